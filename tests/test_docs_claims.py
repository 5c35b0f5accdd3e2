"""The docs' claims checked against the code where they can be (issue #32 item 12): every `visnav ...` command
line in README.md and docs/*.md (fenced blocks and inline code) names a command that exists, uses only options
that command's --help lists, names built-in scenarios that exist, and sets (--set / --grid) keys with values the
scenario accepts. A renamed option or key makes this fail instead of leaving the docs wrong."""

from __future__ import annotations

import re
import shlex
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: commands whose first argument is a scenario (built-in name or .toml)
SCENARIO_ARG = ("run", "montecarlo", "keys", "record", "faults", "margins")


def _command_lines(text: str) -> list[str]:
    """`visnav ...` command lines: fenced code (with its backslash continuations) and inline code spans."""
    out: list[str] = []
    fenced = False
    pending = ""
    for line in text.splitlines():
        if line.strip().startswith("```"):
            fenced, pending = not fenced, ""
            continue
        if fenced:
            s = pending + line.strip()
            if s.endswith("\\"):
                pending = s[:-1] + " "
                continue
            pending = ""
            s = re.sub(r"^\$\s*", "", s)
            if s.startswith("visnav "):
                out.append(" ".join(s.split("  #")[0].split(" # ")[0].split()))
        else:
            out += [m.strip() for m in re.findall(r"`(visnav [^`]+)`", line)]
    return out


def _claims() -> list[tuple[str, str]]:
    """(file, one command) for every command of every line (``a && b``, ``a; b`` and ``a | b`` are two)."""
    return [(p.relative_to(ROOT).as_posix(), part.strip()) for p in DOCS for c in _command_lines(p.read_text())
            for part in re.split(r"&&|;|\|", c) if part.strip().startswith("visnav ")]


@lru_cache(maxsize=None)
def _commands() -> dict:
    import typer

    from visnav.cli import app

    return typer.main.get_command(app).commands


def _words(cmd: str) -> list[str]:
    try:
        return shlex.split(cmd)
    except ValueError:  # an unclosed quote in prose: the plain words
        return cmd.split()


CLAIMS = _claims()


def test_the_docs_have_commands_to_check():
    assert len(CLAIMS) > 60 and {c.split()[1] for _, c in CLAIMS} >= {"run", "replay", "bridge", "montecarlo"}


@pytest.mark.parametrize("where, cmd", CLAIMS)
def test_a_documented_command_exists_and_takes_its_options(where, cmd):
    words = _words(cmd)
    name = words[1]
    if name.startswith("-"):
        assert name in ("--version", "--help"), f"{where}: {cmd}"
        return
    if not re.fullmatch(r"[a-z][a-z-]*", name):  # a placeholder (visnav COMMAND): nothing to check
        return
    commands = _commands()
    assert name in commands, f"{where}: `visnav {name}` is not a command (known: {', '.join(sorted(commands))})"
    opts = {o for p in commands[name].params for o in (*p.opts, *p.secondary_opts)} | {"--help"}
    used = [w.split("=")[0] for w in words[2:] if w.startswith("--") and re.fullmatch(r"--[a-z][a-z0-9-]*(=.*)?", w)]
    unknown = [o for o in used if o not in opts]
    assert not unknown, f"{where}: `{cmd}`: {', '.join(unknown)} not in `visnav {name} --help`"


def _scenario_claims():
    out = []
    for where, cmd in CLAIMS:
        words = _words(cmd)
        if len(words) > 2 and words[1] in SCENARIO_ARG and re.fullmatch(r"[a-z][a-z0-9-]+", words[2]):
            sets = [words[i + 1] for i, w in enumerate(words[:-1]) if w == "--set"]
            grids = [words[i + 1] for i, w in enumerate(words[:-1]) if w == "--grid"]
            out.append((where, words[2], tuple(sets), tuple(grids)))
    return out


@pytest.mark.parametrize("where, scenario, sets, grids", _scenario_claims())
def test_a_documented_scenario_and_its_keys_exist(where, scenario, sets, grids):
    from visnav.scenarios.schema import ScenarioError, builtin_names, load_scenario

    assert scenario in builtin_names(), f"{where}: no built-in scenario {scenario!r}"
    if any(re.search(r"[A-Z]{2,}|\.\.\.|=[A-Z]+$", s) for s in sets + grids):  # a placeholder (KEY=VALUE, k=X)
        return
    try:
        load_scenario(scenario, list(sets) + [f"{g.split('=')[0]}={g.split('=')[1].split(',')[0]}" for g in grids])
    except ScenarioError as exc:
        pytest.fail(f"{where}: `{scenario}` with {list(sets) + list(grids)}: {exc}")


def test_the_extractor_sees_fenced_continuations_and_inline_code():
    text = "x `visnav run a --seed 2` y\n```\n$ visnav montecarlo b -n 2 \\\n  --grid k=1,2   # c\n```\nvisnav prose\n"
    assert _command_lines(text) == ["visnav run a --seed 2", "visnav montecarlo b -n 2 --grid k=1,2"]


def test_a_wrong_claim_is_caught():
    with pytest.raises(AssertionError, match="--sed not in `visnav run --help`"):
        test_a_documented_command_exists_and_takes_its_options("x.md", "visnav run palace-landing --sed 3")
    with pytest.raises(AssertionError, match="`visnav rn` is not a command"):
        test_a_documented_command_exists_and_takes_its_options("x.md", "visnav rn palace-landing")
    with pytest.raises(pytest.fail.Exception, match="run.durration_s"):
        test_a_documented_scenario_and_its_keys_exist("x.md", "palace-landing", ("run.durration_s=3",), ())
    with pytest.raises(pytest.fail.Exception, match="navigation.mpe.atitude_delay_s"):
        test_a_documented_scenario_key_exists("x.md", "navigation.mpe.atitude_delay_s")
    test_a_documented_scenario_key_exists("x.md", "navigation.mpe.attitude_delay_s")


def test_every_command_has_a_help_page():
    from typer.testing import CliRunner

    from visnav.cli import app

    for name in _commands():
        r = CliRunner().invoke(app, [name, "--help"])
        assert r.exit_code == 0 and "Usage:" in r.stdout and r.exception is None, (name, r.output)


#: dotted names in the docs that are code, not scenario keys: an object's attribute (where it says so)
NOT_KEYS = {"vehicle.state": "a vehicle model's state (docs/architecture.md, the truth history)",
            "world.wind": "the world object's wind (docs/integrity.md, the gust fault)",
            "control.frd": "python-control's frequency response data (docs/analysis.md)",
            "control.stability_margins": "python-control's margins (docs/analysis.md)"}


def _key_claims() -> list[tuple[str, str]]:
    pat = r"`((?:run|world|vehicle|navigation|sensors|control|mission)\.[a-z0-9_.]+)(?:\s*=\s*[^`]*)?`"
    return [(p.relative_to(ROOT).as_posix(), k) for p in DOCS for k in re.findall(pat, p.read_text())]


@lru_cache(maxsize=None)
def _known_keys() -> frozenset:
    from visnav.scenarios.keys import settable_keys
    from visnav.scenarios.roles import LEGACY, MOVED
    from visnav.scenarios.schema import builtin_names, load_scenario

    keys = {r["key"] for n in builtin_names() for r in settable_keys(load_scenario(n))}
    keys |= {old for pairs in LEGACY.values() for old, _ in pairs}  # the old layout the docs explain
    keys |= {old for pairs in MOVED.values() for old, _ in pairs}  # ... and the [mission] keys before issue #31
    return frozenset(keys)


def test_the_docs_have_keys_to_check():
    assert len(_key_claims()) > 50


@pytest.mark.parametrize("where, key", sorted(set(_key_claims())))
def test_a_documented_scenario_key_exists(where, key):
    import importlib

    known = _known_keys()
    if key in known or any(k.startswith(key + ".") or key.startswith(k + ".") for k in known) or key in NOT_KEYS:
        return
    module, _, attr = f"visnav.{key}".rpartition(".")  # a code path (navigation.integrity.same_image)
    try:
        assert hasattr(importlib.import_module(module), attr)
    except (ImportError, AssertionError):
        pytest.fail(f"{where}: `{key}` is neither a scenario key (visnav keys SCENARIO) nor a name in the code")
