"""The one registry of navigators by name: the closed loop (``app/missions.py``), ``visnav replay`` and
``visnav bridge`` all build a navigator here, from a scenario's configuration.

``make_navigator(name, sc, recorder, camera=..., mount=..., reference=..., **parts)`` builds it; what is not
given comes from the scenario (the camera of ``[sensors.camera]`` or of the mission, the WITAS reference
map degraded from the scenario's ground). A caller that has its own (a recording's ``camera.yaml``, a
``--map``, the simulation's pan-tilt unit) passes it. Adding a navigator (deck, CONDOR) is one
``NavigatorSpec`` in ``NAVIGATORS`` (its estimate's frame and, when it is not a ``NavEstimate``, how to log it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from visnav.measurements import FRAMES
from visnav.sim.clock import rate_divisor
from dataclasses import replace
import importlib


@dataclass(frozen=True)
class NavigatorSpec:
    scenario: str  # the built-in scenario whose configuration it takes by default
    mission_types: tuple[str, ...]  # scenario mission types that fly it
    needs: tuple[str, ...]  # recording streams a replay needs
    camera: Callable  # camera(sc) -> (PinholeCamera, mount) of the scenario
    camera_hz: Callable  # camera_hz(sc) -> frames per second it consumes
    build: Callable  # build(sc, recorder, camera, mount, **parts) -> navigator
    frame: str = FRAMES["ned"]  # the frame of its estimate (``Estimate.frame``'s text: the TUM header of a replay)
    estimate_row: Callable | None = None  # estimate -> dict(position, velocity, euler, source, valid); None: NavEstimate
    color_frames: bool = False  # it takes RGB frames (else 8-bit gray)
    finish: Callable | None = None  # finish(nav, log): what the navigator logs at the end of a run (replay)
    truth: Callable | None = None  # truth(log) -> truth.csv columns of what it estimates (default: the vehicle's)
    streams: str = ""  # "module:NAME" of its loop's stream table (units of a replay's log.h5), "": the registered ones
    # the loop logs the step's own estimate (the first asked at a time: the one its health and HPL were assessed with),
    # not one asked again after the mission's step (CONDOR's source switch, issue #30); else the last asked
    log_first_estimate: bool = False


def rmax_camera(sc):
    """The R-MAX loop's camera (``[sensors.camera]``): pinhole model and fixed depressed mount."""
    from visnav.geometry.camera import PinholeCamera
    from visnav.geometry.mounts import FixedMount

    c = sc.sensors.camera
    return (PinholeCamera.ideal(c.width, c.height, c.focal_px),
            FixedMount.depressed(c.depression_deg, lever_arm=tuple(c.lever_arm_m)))


def _rmax_camera_hz(sc) -> float:
    c = sc.sensors.camera  # every decimation-th captured frame is processed (sensors/camera.Camera)
    return c.capture_hz / max(1, int(round(c.capture_hz / sc.navigation.mpe.rate_hz)))


def _palace(sc, recorder, camera, mount, **_):
    from visnav.navigation.palace import PalaceNavigator

    return PalaceNavigator(sc.navigation, camera, mount, recorder=recorder)


def _witas(sc, recorder, camera, mount, reference=None, **_):
    from visnav.navigation.witas import WitasNavigator
    from visnav.world.witas_map import make_ground, mission_rngs, reference_map

    cfg = sc.mission
    if reference is None:  # the same degraded map as the closed loop's
        reference = reference_map(sc.world.witas_map, make_ground(cfg.path, sc.world.witas_map, sc.run.seed,
                                                                   sc.sensors.camera)[0])
    return WitasNavigator(sc.navigation, camera.K, mount, reference, recorder=recorder, rng=mission_rngs(sc.run.seed)[4])


def _pad_camera(sc):
    from visnav.geometry.camera import PinholeCamera

    cc = sc.sensors.camera
    return PinholeCamera.ideal(cc.width, cc.height, cc.focal_px), None  # the mount is the pan-tilt unit


def _pad(sc, recorder, camera, mount, ptu=None, layout=None, **_):
    from visnav.geometry.pad import PadLayout
    from visnav.navigation.pad import PadNavigator
    from visnav.vision.pad import PadDetector

    if ptu is None:
        raise ValueError("the pad navigator needs its pan-tilt unit (ptu): it points the camera; replay and bridge "
                         "of the pad landing need pan-tilt frames and a pan-tilt link (not there yet)")
    pc, fc = sc.world.pad, sc.navigation
    layout = layout or PadLayout(tuple(pc.legs_m), tuple(pc.ring_ratio), tuple(pc.inner_ratio))
    detector = PadDetector(layout, camera.K, sigma_floor_px=fc.sigma_floor_px, cov_inflation=fc.cov_inflation)
    return PadNavigator(fc, detector, ptu, recorder=recorder)


def _deck_camera(sc):
    """The deck vehicle's LED camera (``sensors.camera``): intrinsics with eq. 5.6-5.7 distortion, fixed mount
    (T_cam: body -> camera, so R_cam_to_body = T_cam^T; lever arm = the camera position rho)."""
    from visnav.geometry.mounts import FixedMount

    c = sc.sensors.camera
    return c.pinhole(), FixedMount(c.rotation().T, tuple(c.position_m))


def _deck_frame_interval(sc) -> float:
    """The interval between the frames the deck loop delivers (a whole number of dynamics steps)."""
    return rate_divisor(sc.sensors.camera.rate_hz, sc.run.dt_s) * sc.run.dt_s


def _deck(sc, recorder, camera, mount, **_):
    """``DeckNavigator`` tuned from ``navigation`` (``DeckNavConfig.from_mission``); the camera's intrinsics,
    distortion and mount are the ones given (a recording's camera.yaml) when they are."""

    from visnav.estimation.deck import CameraGeometry
    from visnav.navigation.deck import DeckNavConfig, DeckNavigator

    cfg = DeckNavConfig.from_mission(sc, _deck_frame_interval(sc))
    if mount is None:
        raise ValueError("the deck navigator needs the camera's mount (R_cam_to_body and lever_arm_m in camera.yaml)")
    cfg = replace(cfg, camera=camera, cam=CameraGeometry(rho=np.asarray(mount.lever_arm, float),
                                                         T_cam=np.asarray(mount.R_cam_to_body, float).T))
    return DeckNavigator(cfg, recorder=recorder)


def _deck_row(e) -> dict:
    """The deck estimate's relative state: deck origin relative to the vehicle (body FRD), deck -> vehicle Euler
    angles, the relative velocity seen from the vehicle (the loop's ``estimate`` stream)."""
    x = e.state
    return {"position": x[0:3], "euler": x[3:6], "velocity": x[6:9], "source": "deck", "valid": e.valid}


def _condor_camera(sc):
    from visnav.sensors.condor_camera import condor_camera

    c = sc.sensors.camera  # on the gimbal: no fixed mount (camera_attitude.csv, pan.csv)
    return condor_camera(c.width_px, c.height_px, c.hfov_deg, c.k1, c.k2, c.crop_dx_px, c.crop_dy_px), None


def _condor(sc, recorder, camera, mount, **_):
    from visnav.app.condor_parts import build_navigator

    if sc.mission.experiment != "orbit":
        raise ValueError(f"the condor navigator flies the orbit experiment; this scenario's is "
                         f"{sc.mission.experiment!r}")
    return build_navigator(sc, camera)


def _geolocation_camera(sc):
    from visnav.app.geoloc_parts import mav_camera

    return mav_camera(sc.sensors.camera), None  # on the pitch-roll gimbal: no fixed mount


def _geolocation(sc, recorder, camera, mount, reference=None, **_):
    """``GeolocationNavigator`` of ``navigation`` (kind geolocation); the reference image given (``--map``) or, for a
    simulated recording, the closed loop's (the mission's map, degraded)."""
    from visnav.app.geoloc_parts import build_navigator, mission_reference
    from visnav.world.rural import mission_map

    if reference is None:
        reference = mission_reference(sc.world.geo_map, mission_map(sc.world.geo_map), sc.run.seed)
    return build_navigator(sc, reference, camera)


def _target_row(e) -> dict:
    """A ``TargetEstimate``: the target on the ground (down 0), NED world."""
    p = np.asarray(e.position, float)
    return {"position": np.array([p[0], p[1], 0.0]), "velocity": np.full(3, np.nan), "euler": np.zeros(3),
            "source": e.method, "valid": e.valid}


def _geolocation_finish(nav, log) -> None:
    from visnav.app.geoloc_parts import log_samples

    log_samples(log.record, nav)


def _target_truth(log) -> dict | None:
    """truth.csv of a geo-location flight: the true target (what its navigator estimates) at the log's 10 Hz."""
    tg, tr = log.get("target"), log.get("truth")
    if not tg or not tr:
        return None
    p = np.asarray(tg["position"], float).reshape(-1)
    n = len(tr["t"])
    return {"t_s": np.asarray(tr["t"], float), "n_m": np.full(n, p[0]), "e_m": np.full(n, p[1]), "d_m": np.zeros(n)}


def _vo(sc, recorder, camera, mount, **_):
    """Frame-only visual odometry of a photo survey (navigation/vo.py); the scenario is not used."""
    from visnav.navigation.vo import VONavigator

    return VONavigator(camera, recorder=recorder, mount=mount)


NAVIGATORS: dict[str, NavigatorSpec] = {
    "palace": NavigatorSpec("palace-landing", ("palace", "hover", "pfcm"), ("imu", "attitude", "gps"), rmax_camera,
                            _rmax_camera_hz, _palace),
    "witas": NavigatorSpec("witas-homing", ("witas-homing",), ("imu", "attitude", "gps", "baro", "frames"),
                           rmax_camera, lambda sc: float(sc.navigation.odometry_hz), _witas),
    "pad": NavigatorSpec("pad-landing", ("pad-landing",), ("imu", "attitude", "frames"), _pad_camera,
                         lambda sc: float(sc.sensors.camera.rate_hz), _pad),
    "deck": NavigatorSpec("deck-moving", ("deck",), ("imu", "attitude", "frames"), _deck_camera,
                          lambda sc: 1.0 / _deck_frame_interval(sc), _deck,
                          frame=FRAMES["deck_body"],
                          estimate_row=_deck_row, streams="visnav.sim.streams:DECK_STREAMS"),
    "condor": NavigatorSpec("condor-orbit", ("condor",), ("imu", "attitude", "gps", "baro", "magnetometer", "airspeed",
                                                          "camera_attitude", "pan", "frames", "click"),
                            _condor_camera, lambda sc: float(sc.sensors.camera.frame_hz), _condor, color_frames=True,
                            streams="visnav.sim.streams:CONDOR_STREAMS", log_first_estimate=True),
    "geolocation": NavigatorSpec("mav-geolocation", ("mav-geolocation",), ("telemetry", "frames", "click"),
                                 _geolocation_camera, lambda sc: float(sc.sensors.camera.frame_hz), _geolocation,
                                 frame=FRAMES["target_ned"], estimate_row=_target_row,
                                 finish=_geolocation_finish, truth=_target_truth,
                                 streams="visnav.sim.streams:GEOLOC_STREAMS"),
    "vo": NavigatorSpec("witas-homing", (), ("frames", "gps"), rmax_camera, lambda sc: 0.2, _vo),
}


def stream_table(s: NavigatorSpec) -> dict | None:
    """The stream table of a navigator's loop (``NavigatorSpec.streams``), None when it has none of its own."""

    if not s.streams:
        return None
    module, attr = s.streams.split(":")
    return getattr(importlib.import_module(module), attr)


def spec(name: str) -> NavigatorSpec:
    if name not in NAVIGATORS:
        raise ValueError(f"unknown navigator {name!r}; known: {', '.join(sorted(NAVIGATORS))}")
    return NAVIGATORS[name]


def navigator_for(mission_type: str) -> str:
    """The registered navigator a mission type flies with."""
    for name, s in NAVIGATORS.items():
        if mission_type in s.mission_types:
            return name
    known = "; ".join(f"{n}: {', '.join(s.mission_types)}" for n, s in NAVIGATORS.items())
    raise ValueError(f"mission.type {mission_type!r} has no registered navigator (registered: {known})")


def make_navigator(name: str, sc, recorder=None, camera=None, mount=None, **parts):
    """The navigator ``name`` configured by Scenario ``sc``; ``camera``/``mount`` default to the scenario's."""
    s = spec(name)
    if camera is None:
        camera, default_mount = s.camera(sc)
        mount = mount if mount is not None else default_mount
    return s.build(sc, recorder or (lambda *a, **k: None), camera, mount, **parts)
