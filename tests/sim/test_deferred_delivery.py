"""The loop delivers a frame still rendering later (in order, before anything reads the navigator): the run is
the run of a loop that waits for every frame when it is due, to the last bit (app/loop.py, issue #19)."""

import time

import numpy as np
import pytest

from visnav.navigation.palace import PalaceNavigator
from visnav.scenarios.schema import load_scenario
from visnav.sensors.camera import CameraRenderer
from visnav.app.loop import Simulation
from visnav.app.schedule import SensorSchedule

SHORT = ["mission.start_height_m=14", "mission.settle_s=1"]


@pytest.fixture
def slow_render(monkeypatch):
    """Every frame takes 15 ms more on the render thread: it is never done when it falls due."""
    execute = CameraRenderer.execute  # (the render worker's part of a frame)

    def slow(self, *a):
        img = execute(self, *a)
        time.sleep(0.015)
        return img

    monkeypatch.setattr(CameraRenderer, "execute", slow)


def _run(sets, defer: bool, monkeypatch=None):
    sim = Simulation(load_scenario("palace-landing", SHORT + sets, seed=2))
    sim.defer_deliveries = defer
    waited = []
    if monkeypatch is not None:
        drain = SensorSchedule._drain

        def counting(self, wait):
            waited.append(len(self._backlog))
            return drain(self, wait)

        monkeypatch.setattr(SensorSchedule, "_drain", counting)
    return sim.run(), waited


def test_deferred_deliveries_give_the_same_run(slow_render, monkeypatch):
    # frames at 5 Hz: a frame's delivery waits past the next mission and controller step (10 Hz), which must
    # see it delivered (at 10 Hz the next frame's sampling settles the backlog first)
    sets = ["run.duration_s=8", "navigation.mpe.rate_hz=5"]
    late, waited = _run(sets, True, monkeypatch)
    monkeypatch.undo()
    now, _ = _run(sets, False)
    assert sum(1 for n in waited if n) >= 20  # the frames did wait in the backlog
    assert late.error is None and now.error is None
    assert late.log.streams() == now.log.streams()
    for s in now.log.streams():
        a, b = late.log.get(s), now.log.get(s)
        assert a.keys() == b.keys(), s
        for k in a:
            same = list(a[k]) == list(b[k]) if b[k].dtype == object else np.array_equal(a[k], b[k], equal_nan=True)
            assert same, f"{s}.{k}"
    assert len(now.log.get("tracker")["t"]) >= 20  # frames were tracked


def _backlog_at_sampling(sim, monkeypatch) -> list[int]:
    """The frames still waiting in the loop's backlog each time the camera is sampled."""
    from visnav.sensors.camera import Camera, PendingFrame

    seen = []
    sample_async = Camera.sample_async

    def spy(self, *a, **k):
        seen.append(sum(isinstance(m, PendingFrame) for _, m in sim.schedule._backlog))
        return sample_async(self, *a, **k)

    monkeypatch.setattr(Camera, "sample_async", spy)
    return seen


def test_a_truth_only_camera_renders_while_the_frame_before_is_delivered(slow_render, monkeypatch):
    """At 10 Hz the mission reads the navigator at the next frame's instant: the palace camera (a function of the
    truth under a gate that reads the mission's mode only) is sampled before the frame still rendering is
    delivered, and the run is still, to the last bit, the run of the loop that waits for every frame."""
    sets = ["run.duration_s=6"]
    sim = Simulation(load_scenario("palace-landing", SHORT + sets, seed=2))
    seen = _backlog_at_sampling(sim, monkeypatch)
    late = sim.run()
    monkeypatch.undo()
    now, _ = _run(sets, False)
    assert late.error is None and now.error is None
    assert sum(1 for n in seen if n) >= 20  # frames were sampled with the one before still in the backlog
    for s in now.log.streams():
        a, b = late.log.get(s), now.log.get(s)
        for k in b:
            same = list(a[k]) == list(b[k]) if b[k].dtype == object else np.array_equal(a[k], b[k], equal_nan=True)
            assert same, f"{s}.{k}"


def test_a_gate_that_reads_the_navigator_is_asked_after_the_backlog_is_delivered(slow_render, monkeypatch):
    """A gate not marked ``mode_gate`` may read what the deliveries change: the loop delivers first."""
    sim = Simulation(load_scenario("palace-landing", SHORT + ["run.duration_s=3"], seed=2))
    mission = sim.mission
    sim.parts.routing.gates["camera"] = lambda t: mission.camera_wanted(t)  # (an unmarked gate)
    seen = _backlog_at_sampling(sim, monkeypatch)
    assert sim.run().error is None
    assert len(seen) >= 20 and not any(seen)


def test_a_navigator_error_names_the_step_its_measurement_was_due_at(slow_render, monkeypatch):
    update = PalaceNavigator.update

    def failing(self, m):
        if type(m).__name__ == "Frame" and m.t >= 3.0:
            raise RuntimeError("tracker fell over")
        return update(self, m)

    monkeypatch.setattr(PalaceNavigator, "update", failing)
    late, _ = _run(["run.duration_s=8"], True)
    now, _ = _run(["run.duration_s=8"], False)
    assert now.error is not None and "tracker fell over" in now.error
    assert late.error == now.error  # "RuntimeError at t=3.03s: ..." (the frame of t = 3.0 s, 30 ms latency)
    assert late.log.get("truth")["t"][-1] == now.log.get("truth")["t"][-1]


def test_the_switch_interval_is_short_while_frames_render_and_restored_after(monkeypatch):
    """The render worker takes the GIL back after each OpenCV call: during the run the interpreter hands it over
    within ``RENDER_SWITCH_INTERVAL_S``; after the run (or an error) the process has its own setting back."""
    import sys

    from visnav.app import schedule

    seen = []
    execute = CameraRenderer.execute  # (the worker's part of a frame)

    def spy(self, *a):
        seen.append(sys.getswitchinterval())
        return execute(self, *a)

    monkeypatch.setattr(CameraRenderer, "execute", spy)
    before = sys.getswitchinterval()
    res, _ = _run(["run.duration_s=1"], True)
    assert res.error is None and seen and max(seen) <= schedule.RENDER_SWITCH_INTERVAL_S < before
    assert sys.getswitchinterval() == before


def test_a_wrapped_navigator_gets_each_measurement_at_its_step():
    """``visnav record`` logs the loop step of each delivery and ``--sil`` forwards it in wall-clock time: with a
    navigator wrapper the loop does not defer."""
    sc = load_scenario("palace-landing", SHORT + ["run.duration_s=1"], seed=2)
    assert Simulation(sc).defer_deliveries
    assert not Simulation(sc, navigator_wrapper=lambda nav: nav).defer_deliveries


@pytest.mark.parametrize("scenario, sets", [
    ("palace-landing", SHORT + ["run.duration_s=6"]),
    ("witas-homing", ["run.duration_s=14"]),  # GPS lost at 8 s: the vision navigator takes the frames
])
def test_frames_rendered_on_the_loops_thread_give_the_same_run(scenario, sets, monkeypatch):
    """``render_thread = False`` (a campaign that runs a simulation per core) renders each frame when it is taken,
    on the loop's thread, with no prework and no deferred delivery: the run is the threaded run to the last bit."""
    from visnav.sensors.camera import Camera

    runs, on_worker = [], []
    sample_async = Camera.sample_async
    monkeypatch.setattr(Camera, "sample_async", lambda *a, **k: on_worker.append(1) or sample_async(*a, **k))
    for threaded in (True, False):
        on_worker.clear()
        sim = Simulation(load_scenario(scenario, sets, seed=3))
        sim.render_thread = threaded
        runs.append(sim.run())
        assert runs[-1].error is None
        assert (len(on_worker) >= 20) if threaded else not on_worker
    a, b = runs
    assert a.log.streams() == b.log.streams()
    for s in a.log.streams():
        for k, v in a.log.get(s).items():
            w = b.log.get(s)[k]
            same = list(v) == list(w) if v.dtype == object else np.array_equal(v, w, equal_nan=True)
            assert same, f"{s}.{k}"
    frames_used = {"palace-landing": "tracker", "witas-homing": "odometry"}[scenario]
    assert len(a.log.get(frames_used)["t"]) >= 20  # frames were rendered and used


def test_a_sensor_whose_latency_changes_is_read_after_each_sample():
    """A sensor whose clock jumped (``sensors/faults``: stamp + jump, latency - jump) arrives when its unjumped
    sample would: the schedule reads ``latency_s`` after each sample, not once at set-up."""
    from visnav.measurements import RangeSample

    class Jumpy:
        rate_hz, phase_s = 10.0, 0.0

        def __init__(self):
            self.latency_s = 0.05

        def sample(self, t, truth=None, world=None):
            jump = 0.2 if 0.25 < t < 0.55 else 0.0
            self.latency_s = 0.05 - jump
            return RangeSample(t=t + jump, range=1.0, sensor="laser", beam_offset=0.0)

    sched = SensorSchedule(0.01)
    sched.open({"laser": Jumpy()}, {}, None, None, None, on_grid=False, render_thread=False, defer=False)
    got = []
    for k in range(80):
        t = k * 0.01
        sched.sample(k, t)
        while sched.due(t):
            got.append((round(t, 6), sched.pop().t))
    sent = [(0.1 * k, 0.1 * k + (0.2 if 0.25 < 0.1 * k < 0.55 else 0.0)) for k in range(8)]
    assert [stamp for _, stamp in got] == pytest.approx([stamp for _, stamp in sent])  # in order, stamps jumped
    for (arrived, _), (taken, _) in zip(got, sent):  # each when the unjumped one would arrive (the next step)
        assert taken + 0.05 - 1e-9 <= arrived <= taken + 0.05 + 0.01 + 1e-9
