"""``visnav record``: fly a scenario's closed loop and write what its navigator saw as a recording.

The loop is not rewritten: the navigator is wrapped in ``RecordingNavigator``, a proxy that passes
everything through and logs, with one global sequence number, every ``update(m)`` (the measurement and
the loop time it was delivered at), every mission request (``command(NavCommand)``: its time, name and
arguments; older recordings hold the bespoke methods ``request_tracking``, ``set_source``, ...), every
explicit start (``initialize(NavInit)``) and every ``estimate(t)`` / ``health(t)`` query. ``app/replay.py`` feeds them back
in the same order, which is what makes a replay reproduce the closed loop's estimates exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from visnav.io.recording import RecordingError
from visnav.io.recording_writer import RecordingWriter
from visnav.scenarios.schema import Scenario, to_toml
from visnav.app.missions import RMAX_MISSIONS, make_simulation
from visnav.app.navigators import NAVIGATORS, navigator_for
from visnav.app.runs import OutputDirError, prepare_out_dir
from visnav.io.recording import COMMANDS, STREAMS, TRUTH

#: what a mission may ask a navigator (logged with arguments and replayed); everything else passes through
REQUESTS = frozenset({"request_tracking", "request_tracking_rebase", "set_source", "stop_tracking", "command",
                      "initialize"})


class RecordingNavigator:
    """Transparent proxy around a navigator that logs its inputs into a ``RecordingWriter``."""

    def __init__(self, inner, writer: RecordingWriter, clock: Callable[[], float]):
        self._inner = inner
        self._writer = writer
        self._clock = clock
        self.recording = True

    @property
    def inner(self):
        return self._inner

    def update(self, m) -> None:
        if self.recording:
            self._writer.add(m, self._clock(), self._writer.next_seq())
        self._inner.update(m)

    def estimate(self, t: float, *args, **kwargs):
        if self.recording:
            self._writer.add_command(t, self._writer.next_seq(), "estimate")
        return self._inner.estimate(t, *args, **kwargs)

    def health(self, t: float | None = None):
        if self.recording and t is not None:
            self._writer.add_command(t, self._writer.next_seq(), "health")
        return self._inner.health(t)

    def command(self, request) -> None:
        """A mission's request (``NavCommand``): logged as method ``command`` with its time, name and arguments."""
        if self.recording:
            self._writer.add_command(self._clock(), self._writer.next_seq(), "command",
                                     kwargs={"t": request.t, "name": request.name, "args": request.args})
        return self._inner.command(request)

    def initialize(self, init) -> None:
        """An explicit start (``NavInit``): logged as method ``initialize`` with its fields."""
        if self.recording:
            fields = {k: getattr(init, k) for k in ("t", "source", "position", "velocity", "attitude", "state",
                                                    "covariance")}
            self._writer.add_command(self._clock(), self._writer.next_seq(), "initialize", kwargs=fields)
        return self._inner.initialize(init)

    def __getattr__(self, name):
        attr = getattr(self._inner, name)
        if name not in REQUESTS or not callable(attr):
            return attr

        def call(*args, **kwargs):
            if self.recording:
                self._writer.add_command(self._clock(), self._writer.next_seq(), name, args, kwargs)
            return attr(*args, **kwargs)

        return call


def _drop_summary_queries(writer: RecordingWriter) -> None:
    """Estimate / health queries made after the last delivered sample about an earlier instant (a loop's
    summary at the end of its run, e.g. the geo-location's ``estimate(0.0)``) are not part of the flight:
    a replay, which places queries by their time, would ask them before everything."""
    last = [(r[-1], r[-2]) for rows in writer.rows.values() for r in rows]  # (seq, t_recv)
    if not last:
        return
    seq, t_recv = max(last)
    writer.commands = [c for c in writer.commands
                       if not (c[2] in ("estimate", "health") and c[1] > seq and c[0] < t_recv - 1e-9)]


@dataclass
class RecordResult:
    out_dir: Path
    run: object  # the closed loop's RunResult (its log holds the estimates the replay must reproduce)
    counts: dict


def record(scenario: Scenario, out_dir: str | Path, progress=None, force: bool = False) -> RecordResult:
    """Fly ``scenario`` in its closed loop (the R-MAX loop, the deck loop, the CONDOR orbit, the geo-location flight: the one
    ``app/loop.Simulation`` with the mission's parts) and write the recording to ``out_dir`` (refused when it holds files,
    unless ``force``: then the recording's own files are removed first); returns the closed-loop result beside
    the folder. Ctrl-C stops the flight and the recording keeps what it had (``result.run.interrupted``)."""
    kind = scenario.mission.type
    if kind not in RMAX_MISSIONS:
        name = next((n for n, s in NAVIGATORS.items() if kind in s.mission_types), None)
        if name is None:
            raise RecordingError(f"visnav record: mission.type {kind!r} has no registered navigator "
                                 f"(app/navigators.py) to record for; recordable: the missions of "
                                 f"{', '.join(sorted(NAVIGATORS))}")
        if kind == "condor" and scenario.mission.experiment != "orbit":
            raise RecordingError(f"visnav record: the CONDOR {scenario.mission.experiment!r} experiment has no "
                                 "navigator in the loop; record an orbit (condor-orbit)")
    own = tuple(s.file for s in STREAMS.values()) + (TRUTH.file, COMMANDS.file, "camera.yaml", "scenario.toml")
    try:
        prepare_out_dir(out_dir, force=force, clear=own, kind="a recording")
    except OutputDirError as exc:
        raise RecordingError(str(exc)) from None
    if force:
        for f in Path(out_dir, "frames").glob("*.png"):
            f.unlink()
    writer = RecordingWriter(out_dir)
    proxies: list[RecordingNavigator] = []
    holder: dict = {}

    def clock() -> float:  # the loop time of the current dynamics step (t = k dt, as the loop computes it)
        sim = holder.get("sim")
        if sim is None:  # the loop's set-up (a NavInit sent while the simulation is built): t = 0
            return 0.0
        if getattr(sim, "history", None) is None:  # a loop without a truth history (CONDOR): its step time
            return float(getattr(sim, "_t", 0.0))
        latest = sim.history.latest
        return 0.0 if latest is None else int(round(latest.t / sim.dt)) * sim.dt

    def wrap(nav):
        p = RecordingNavigator(nav, writer, clock)
        proxies.append(p)
        return p

    sim = make_simulation(scenario, navigator_wrapper=wrap)
    holder["sim"] = sim
    result = sim.run(progress=progress)
    for p in proxies:  # the metrics' queries after the flight are not part of it
        p.recording = False
    _drop_summary_queries(writer)
    tr = result.log.get("truth")
    truth = None
    name = navigator_for(kind) if kind not in RMAX_MISSIONS else None
    if name is not None and NAVIGATORS[name].truth is not None:  # what the navigator estimates (the target)
        truth = NAVIGATORS[name].truth(result.log)
    elif tr:
        p, v, e = (np.asarray(tr[k], float).reshape(-1, 3) for k in ("position", "velocity", "euler"))
        truth = {"t_s": tr["t"], "n_m": p[:, 0], "e_m": p[:, 1], "d_m": p[:, 2], "vn_mps": v[:, 0],
                 "ve_mps": v[:, 1], "vd_mps": v[:, 2], "roll_rad": e[:, 0], "pitch_rad": e[:, 1], "yaw_rad": e[:, 2]}
    if kind not in RMAX_MISSIONS:  # the camera the registry builds the navigator with (deck: LED camera; CONDOR: gimbal)
        camera, mount = NAVIGATORS[navigator_for(kind)].camera(scenario)
    else:
        camera, mount = sim.camera_model, sim.mount
    writer.close(camera, mount, 0.0, truth, to_toml(scenario))
    counts = {k: len(v) for k, v in writer.rows.items()} | {"commands": len(writer.commands)}
    return RecordResult(Path(out_dir), result, counts)
