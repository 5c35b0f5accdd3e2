"""The R-MAX's parts of the one loop (``app/loop.py``), which its builders (``app/missions.py``, ``witas_parts``,
``pad_parts``) take from ``rmax_parts``: the helicopter model started at the builder's pose and its truth
history, its wind, the trim held while no position solution is in, the actuator sweep, the touchdown, the
streams it logs, its rates and the camera gate."""

from __future__ import annotations

import numpy as np

from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.measurements import VehicleState, YacsCommand
from visnav.navigation.integrity import STATE_CODES
from visnav.sim.clock import rate_divisor
from visnav.sim.parts import Hooks, MissionParts, Routing, Step, Timing, VehicleTruth
from visnav.sim.streams import RMAX_STREAMS
from visnav.vehicles.base import Environment
from visnav.vehicles.rmax import RmaxModel


#: the R-MAX's truth history [s]: the sensors' delays and the navigators' look-ups reach that far back
TRUTH_HORIZON_S = 2.5
#: the R-MAX's mission manager (and position loop, its own rate_hz) and log [Hz]
MISSION_HZ = 10.0


def rmax_vehicle(start_position, start_yaw: float, dt: float) -> RmaxModel:
    """The R-MAX at the builder's start pose, at rest."""
    init = VehicleState(t=0.0, position=np.asarray(start_position, float), velocity=np.zeros(3),
                        euler=np.array([0.0, 0.0, start_yaw]), body_rates=np.zeros(3),
                        specific_force=np.array([0.0, 0.0, -9.81]))
    return RmaxModel(dt=dt, initial=init)


class WindEnvironment:
    """The world's wind at the vehicle, updated at 20 Hz (turbulence bandwidth is a few rad/s), for the
    turbulence at the vehicle's height and airspeed now: ``height()``, ``airspeed()``."""

    def __init__(self, wind, dt: float, height, airspeed, initial=None) -> None:
        self.wind, self.dt = wind, dt  # wind(): the world's wind (a fault may wrap it after the build)
        self.height, self.airspeed = height, airspeed
        self.d = rate_divisor(20.0, dt)
        self.now = self.wind().steady.ned if initial is None else initial
        self._env: Environment | None = None  # Environment(now), built once per new wind

    def __call__(self, k: int, t: float) -> Environment:
        if k % self.d == 0:
            self.now = self.wind().velocity_ned(t, self.d * self.dt, self.height(), self.airspeed())
        env = self._env
        if env is None or env.wind_ned is not self.now:
            env = self._env = Environment(self.now)
        return env


class HoldTrim:
    """The controller, or the trim while no position solution is in (the first GPS fix)."""

    def __init__(self, controller) -> None:
        self.inner, self.rate_hz = controller, controller.rate_hz

    def command(self, t, estimate, reference):
        return self.inner.command(t, estimate, reference) if estimate.valid else YacsCommand(t=t)

    def __getattr__(self, name):
        return getattr(self.inner, name)


class RmaxLogger:
    """The R-MAX streams (``sim/streams.RMAX_STREAMS``): truth, estimate, reference, command, status."""

    def __init__(self, record) -> None:
        self.record = record

    def __call__(self, s) -> None:
        record, truth, est, ref, cmd, health = self.record, s.truth, s.estimate, s.reference, s.command, s.health
        record("truth", s.t, position=truth.position, velocity=truth.velocity, euler=truth.euler,
               body_rates=truth.body_rates)
        record("estimate", s.t, position=est.position, velocity=est.velocity, euler=est.attitude,
               source=est.source, valid=est.valid)
        record("reference", s.t, position=ref.position, velocity=ref.velocity, yaw=ref.yaw)
        record("command", s.t, ail=cmd.ail, ele=cmd.ele, rud=cmd.rud, thr=cmd.thr)
        record("status", s.t, mode=s.mode, source=health.source, coherence=health.coherence,
               mpe_rate_hz=health.mpe_rate_hz, laser_ok=health.laser_ok, tracking=health.tracking,
               rejected_samples=health.rejected_samples, rejected_ranges=health.rejected_ranges,
               integrity=STATE_CODES.get(health.integrity, -1), hpl_m=health.hpl_m, k2=health.consistency_k2)


class Injection:
    """A sweep at the actuator (the loop broken where seed 000 broke it): ``injection(t)`` added to the
    controller's YACS command, logged in ``actuator``."""

    def __init__(self, injection, record) -> None:
        self.injection, self.record = injection, record

    def __call__(self, t: float, cmd):
        d = self.injection(t)
        if d is None:
            return cmd
        applied = YacsCommand(t=t, ail=cmd.ail + d[0], ele=cmd.ele + d[1], rud=cmd.rud + d[2], thr=cmd.thr + d[3])
        self.record("actuator", t, controller=np.array([cmd.ail, cmd.ele, cmd.rud, cmd.thr]),
                    injection=np.asarray(d, float), applied=np.array([applied.ail, applied.ele, applied.rud, applied.thr]))
        return applied


class Touchdown:
    """The skids on the ground (after the first second): the mission is told, the touchdown and the step
    logged, the run ends. It runs every step and reads the navigator only at the touchdown, so it settles
    the loop's deliveries itself there (``settles_itself``: the loop need not settle before every step)."""

    settles_itself = True

    def __init__(self, vehicle, mission, nav, logger, record, step: Step, settle) -> None:
        self.vehicle, self.mission, self.nav, self.logger, self.record = vehicle, mission, nav, logger, record
        self.step, self.settle = step, settle  # the loop's step (what it logged last) and its settle()

    def __call__(self, t: float, t_prev: float) -> bool:
        s = self.vehicle.state
        if not (s.on_ground and t_prev > 1.0):
            return False
        self.settle()
        self.mission.on_touchdown(t)
        self.record("touchdown", t, position=s.position, speed=float(getattr(self.vehicle, "touchdown_speed", np.nan)))
        st = self.step
        self.logger(Step(t, s, self.nav.estimate(t), self.nav.health(t), st.reference, st.command, "landed"))
        return True


def rmax_parts(ctx, *, world, sensors: dict, navigator, mission, controller, metrics, start_position, start_yaw: float,
               camera_model=None, mount=None, injection=None, notes=()) -> MissionParts:
    """A mission flown by the R-MAX: the builder's world, sensors, navigator, mission, position controller and
    metrics with the helicopter at ``start_position`` / ``start_yaw`` (at rest), its truth history, the wind at
    the rotor (``WindEnvironment``), the trim until the first position solution (``HoldTrim``), the touchdown,
    the R-MAX streams at 10 Hz, each sensor at its own instants, the camera gated by ``mission.camera_wanted``
    where both exist; ``injection(t)``: YACS increments added at the actuator (a sweep, ``Injection``)."""
    dt, record = ctx.scenario.run.dt_s, ctx.record
    vehicle = rmax_vehicle(start_position, start_yaw, dt)
    truth = VehicleTruth(vehicle, dt, horizon_s=TRUTH_HORIZON_S)
    truth.advance(0.0)
    logger = RmaxLogger(record)
    # the world's wind at the rotor (read on use: a wind_gust fault wraps world.wind after the build)
    environment = WindEnvironment(lambda: world.wind, dt, lambda: max(truth.latest.height_agl, 0.5),
                                  lambda: float(np.linalg.norm(truth.latest.velocity - world.wind.steady.ned)))
    gates = {"camera": mission.camera_wanted} if "camera" in sensors and hasattr(mission, "camera_wanted") else {}
    return MissionParts(
        world=world, sensors=sensors, navigator=navigator, mission=mission, controller=HoldTrim(controller),
        vehicle=vehicle, truth=truth, logger=logger, metrics=metrics, streams=RMAX_STREAMS,
        timing=Timing(mission_hz=MISSION_HZ, sensor_grid=False),
        hooks=Hooks(environment=environment, actuator=None if injection is None else Injection(injection, record),
                    after_step=Touchdown(vehicle, mission, navigator, logger, record, ctx.step, ctx.settle)),
        routing=Routing(gates=gates), camera_model=camera_model, mount=mount,
        extra_metrics=(integrity_metrics,),  # from the log (issue #18)
        notes=list(notes))
