"""When each sensor samples and when its measurements reach the loop (``app/loop.py``): the sensors' sampling
instants, the latency queue, and the frames rendered on a worker thread while the loop steps on.

Each measurement is stamped with the instant it describes and waits in a heap until ``t + latency_s``. A
sensor that renders (``sample_async``: a camera whose latency is at least one step) renders on a second
thread (``render_thread``), with the navigator's ``frame_prework`` run there right after the image; the
interpreter's switch interval is shortened while that thread runs (``RENDER_SWITCH_INTERVAL_S``) and restored
by ``close``. Where the navigator alone takes the measurements (``deferred``), a frame still rendering when it
falls due, and everything due after it, wait in a backlog, in order, until the frame is done or something
reads the navigator (``settle``): the navigator gets the same measurements in the same order and every reader
sees it as a loop that waits for each frame would; only the wall-clock instant of ``update`` moves.
"""

from __future__ import annotations

import heapq
import itertools
import sys
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from typing import Callable

from visnav.sensors.camera import PendingFrame
from visnav.sim.clock import rate_divisor

#: the interpreter's switch interval while frames render on the worker thread [s]: the worker takes the GIL back
#: after each of a frame's ~5 OpenCV calls while the loop runs Python on the other core; a palace frame
#: replayed beside a busy thread waited ~0.65 ms for it at 0.1 ms, ~0.3 ms at 10-30 us (BENCHMARKS.md, speed
#: round 5)
RENDER_SWITCH_INTERVAL_S = 2e-5


class SensorSchedule:
    """The loop's measurement path: ``open`` before the first step, ``sample``, ``due`` / ``pop`` (or
    ``deliver_deferred``) and ``settle`` each step, ``close`` after the last."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.due_at: float | None = None  # the step a measurement delivered late from the backlog was due at
        self._queue: list = []  # (t due, sequence, measurement)
        self._seq = itertools.count()
        self._backlog: deque = deque()  # (t due at, measurement) waiting for a frame still rendering
        self._pool: ThreadPoolExecutor | None = None
        self._switch_interval: float | None = None
        self._own: list = []  # [period, next instant, sample function]: sensors sampled at their own instants
        self._grid: list = []  # [divisor, offset, sample function]: sensors sampled on the dynamics grid
        self.deferred = False
        self._nav = None  # the navigator the backlog goes to

    # ------------------------------------------------------------------------------------ set-up
    def open(self, sensors: dict, gates: dict, truth, world, nav, on_grid: bool, render_thread: bool,
             defer: bool) -> None:
        """The render thread (where a sensor renders and ``render_thread``) and each sensor's sampling instants:
        at its own instants (truth interpolated between dynamics steps, so the rate need not divide the step)
        or on the dynamics grid (``on_grid``), from its ``phase_s`` on. A gated sensor (a camera) samples only
        while its gate wants it. ``defer``: the navigator alone takes the deliveries (``deliver_deferred``)."""
        dt = self.dt
        if render_thread and any(hasattr(s, "sample_async") and s.latency_s >= dt for s in sensors.values()):
            self._pool = ThreadPoolExecutor(1)
            # the worker takes the GIL back after each OpenCV call; while the loop runs Python it would wait for
            # the interpreter's switch interval (5 ms) each time, so a frame of ~3 ms CPU would take tens of ms
            self._switch_interval = sys.getswitchinterval()
            sys.setswitchinterval(min(self._switch_interval, RENDER_SWITCH_INTERVAL_S))
        self.deferred = defer and self._pool is not None
        self._nav = nav
        for name, s in sensors.items():
            fn = self._sampler(s, gates.get(name), truth, world, nav)
            phase = getattr(s, "phase_s", 0.0)  # the first sample's instant
            if on_grid:
                self._grid.append([rate_divisor(s.rate_hz, dt), int(round(phase / dt)), fn])
            else:
                self._own.append([1.0 / s.rate_hz, phase, fn])

    def _sampler(self, s, gate, truth, world, nav) -> Callable[[float], None]:
        """``fn(t)``: sensor ``s`` sampled at ``t`` (rendered on the worker where it renders) into the queue."""
        rendered = self._pool is not None and hasattr(s, "sample_async") and s.latency_s >= self.dt
        prework = getattr(nav, "frame_prework", None) if rendered else None
        pool = self._pool
        if prework is not None:  # the navigator's work on the image, on the render thread ahead of delivery
            sample = lambda t: s.sample_async(t, truth, world, pool, then=prework())  # noqa: E731
        elif rendered:
            sample = lambda t: s.sample_async(t, truth, world, pool)  # noqa: E731
        else:
            sample = lambda t: s.sample(t, truth, world)  # noqa: E731
        emit = self.emit
        # the latency is read after each sample: a sensor whose clock jumped (``sensors/faults``) stamps the sample
        # ahead and shortens its latency by as much, so it arrives when the unjumped one would
        # a gate reads the mission, a navigator's prework its state now, a pan-tilt camera the head the navigator
        # points: what was due before is delivered first. A camera that reads nothing but the truth and the world
        # (``samples_truth_only``), under no gate or one that reads only the mission's mode
        # (``mission/base.mode_gate``), is sampled without it: its frame renders while the loop delivers the one
        # before (the navigator gets the same measurements in the same order)
        independent = (prework is None and getattr(s, "samples_truth_only", False)
                       and (gate is None or not getattr(gate, "reads_deliveries", True)))
        if (gate is not None or rendered) and not independent:
            def fn(t):
                if self._backlog:
                    self.settle()
                if gate is None or gate(t):
                    emit(sample(t), s.latency_s)
        elif gate is not None:
            def fn(t):
                if gate(t):
                    emit(sample(t), s.latency_s)
        else:
            fn = lambda t: emit(sample(t), s.latency_s)  # noqa: E731
        return fn

    def close(self) -> None:
        """The render thread stopped and the interpreter's switch interval restored."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            sys.setswitchinterval(self._switch_interval)

    # ------------------------------------------------------------------------------------ each step
    def sample(self, k: int, t: float) -> None:
        """Every sensor due by step ``k`` (at ``t``) sampled, its measurements queued."""
        for item in self._own:
            while item[1] <= t + 1e-9:
                item[2](item[1])
                item[1] += item[0]
        for d, off, fn in self._grid:
            if k % d == off:
                fn(t)

    def emit(self, m, latency: float) -> None:
        """``m`` (None, a measurement or a tuple of them: IMU + attitude) delivered at ``m.t + latency``."""
        if m is None:
            return
        if isinstance(m, tuple):
            for x in m:
                self.emit(x, latency)
            return
        heapq.heappush(self._queue, (m.t + latency, next(self._seq), m))

    def push(self, t_due: float, m) -> None:
        """``m`` delivered at ``t_due`` (a radius fix back over the uplink)."""
        heapq.heappush(self._queue, (t_due, next(self._seq), m))

    def due(self, t: float) -> bool:
        """Something is due by ``t``."""
        q = self._queue
        return bool(q) and q[0][0] <= t + 1e-9

    def pop(self):
        """The next measurement due (waiting for it where it is a frame still rendering)."""
        m = heapq.heappop(self._queue)[2]
        return m.result() if isinstance(m, PendingFrame) else m

    @property
    def waiting(self) -> bool:
        """Deliveries wait in the backlog for a frame still rendering."""
        return bool(self._backlog)

    def deliver_deferred(self, t: float) -> None:
        """Everything due by ``t`` to the navigator without waiting on the render thread: a frame still rendering when
        it is due, and everything due after it, wait in the backlog (in delivery order) and go to it once
        the frame is done or when something reads the navigator (``settle``)."""
        q, backlog, nav = self._queue, self._backlog, self._nav
        while q and q[0][0] <= t + 1e-9:
            m = heapq.heappop(q)[2]
            if backlog or (isinstance(m, PendingFrame) and not m.done()):
                backlog.append((t, m))
            else:
                nav.update(m.result() if isinstance(m, PendingFrame) else m)
        if backlog:
            self._drain(wait=False)

    def _drain(self, wait: bool) -> None:
        """Deliver the backlog in order; a frame still rendering stops it unless ``wait``. While a measurement is
        delivered ``due_at`` is the step it was due at (an error names that step, as without the wait)."""
        backlog, nav, before = self._backlog, self._nav, self.due_at
        while backlog:
            t, m = backlog[0]
            if isinstance(m, PendingFrame):
                if not (wait or m.done()):
                    break
                self.due_at = t
                m = m.result()
            backlog.popleft()
            self.due_at = t
            nav.update(m)
        self.due_at = before  # (None, or the step of an error raised by an earlier delivery)

    def settle(self) -> None:
        """Everything due so far delivered (waiting for the frames still rendering): before anything reads the
        navigator or the mission; a part that reads the navigator outside the loop's stages calls it first
        (``rmax_parts.Touchdown``)."""
        if self._backlog:
            self._drain(wait=True)
