# visnav: `make run` runs the default scenario, `make test` runs the tests (each sets up .venv first).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
SCENARIO ?= palace-landing
ARGS ?=

.PHONY: run test test-all bench install clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,fast]'
	@touch $(STAMP)

install: $(STAMP)

run: $(STAMP)
	$(BIN)/visnav run $(SCENARIO) $(ARGS)

# the wall-clock-paced tests (MAVLink bridge, SIL, signals) run after the parallel suite, alone
test: $(STAMP)
	$(BIN)/python -m pytest -n 2 -q -m "not slow and not realtime"
	$(BIN)/python -m pytest -q -m "realtime and not slow"

test-all: $(STAMP)
	$(BIN)/python -m pytest -n 2 -q -m "not realtime"
	$(BIN)/python -m pytest -q -m "realtime"

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

clean:
	rm -rf $(VENV) runs .pytest_cache
