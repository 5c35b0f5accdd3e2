"""Issue 13: a key that does not apply to the scenario's mission is an error, not silently ignored; every
built-in scenario and every resolved scenario.toml still loads; `visnav keys` lists only the keys that apply."""

from __future__ import annotations

import sys

import pytest
from typer.testing import CliRunner

from visnav.cli import app
from visnav.scenarios import roles
from visnav.scenarios.keys import settable_keys
from visnav.scenarios.schema import (NOT_APPLICABLE, ScenarioError, builtin_names, load_scenario, not_applicable,
                                     to_toml, validate)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

REJECTED = [  # (scenario, override, what the one line must say)
    ("deck-static", "sensors.imu.delay_s=0.1",
     "scenario deck-static: sensors.imu.delay_s does not apply to mission.type 'deck' (sensors.imu is kind "
     "'multirotor-imu'; allowed keys here: accel_noise_mps2, gyro_noise_rad_s, attitude_noise_deg, "
     "ahrs_leveled_on_accel, rate_hz, accel_bias_mps2, gyro_bias_deg_s, accel_bias_walk_mps2_sqrt_s, gyro_bias_walk_deg_s_sqrt_s)"),
    ("deck-moving", "world.wind_speed_mps=8", "world.wind_speed_mps does not apply to mission.type 'deck'"),
    ("deck-static", "vehicle.yaw_deg=30", "(vehicle is kind 'multirotor'"),
    ("deck-static", "navigation.accel_noise=1", "(navigation is kind 'deck'"),
    ("condor-orbit", "world.surface=grass", "world.surface does not apply to mission.type 'condor'"),
    ("condor-orbit", "sensors.sonar.rate_hz=3", "sensors.sonar does not apply to mission.type 'condor' (its sensors: "
     "camera, gimbal, baro, link, ahrs, imu, pitot, compass, gps)"),
    ("mav-geolocation", "vehicle.yaw_deg=10", "(vehicle is kind 'mav'"),
    ("witas-homing", "navigation.mpe.rate_hz=5", "(navigation is kind 'witas'"),
    ("witas-homing", "sensors.baro.t_measured_c=10", "its navigator makes no eq. 2.1 temperature correction"),
    ("pad-landing", "sensors.gps.rate_hz=5", "sensors.gps does not apply to mission.type 'pad-landing'"),
    ("pad-landing", "sensors.imu.rate_hz=200", "navigation.gyro_hz"),
    ("pfcm-segment", "navigation.tracker.template_px=31", "no camera, no tracker"),
    # the layout before issue #13: an R-MAX section of an old file that the system does not fly
    ("deck-static", "mission.filter.gate=20", None),
]

ACCEPTED = [  # keys these missions do read
    ("condor-orbit", "world.wind_speed_mps=6", lambda sc: sc.world.wind_speed_mps == 6),
    ("mav-geolocation", "world.turbulence=none", lambda sc: sc.world.turbulence == "none"),
    ("pad-landing", "sensors.imu.accel_noise=0.05", lambda sc: sc.sensors.imu.accel_noise == 0.05),
    ("pad-landing", "world.field_size_m=30", lambda sc: sc.world.field_size_m == 30),
    ("witas-homing", "sensors.gps.sigma_m=2", lambda sc: sc.sensors.gps.sigma_m == 2),
    ("pfcm-segment", "navigation.accel_noise=0.5", lambda sc: sc.navigation.accel_noise == 0.5),
    ("palace-landing", "sensors.imu.delay_s=0.043", lambda sc: sc.sensors.imu.delay_s == 0.043),
    ("deck-static", "sensors.imu.gyro_noise_rad_s=0.01", lambda sc: sc.sensors.imu.gyro_noise_rad_s == 0.01),
    ("deck-static", "mission.imu.gyro_noise_rad_s=0.01", lambda sc: sc.sensors.imu.gyro_noise_rad_s == 0.01),
    ("condor-orbit", "sensors.gps.sigma_m=3", lambda sc: sc.sensors.gps.sigma_m == 3),
    ("witas-homing", "sensors.camera.delay_s=0.02", lambda sc: sc.sensors.camera.delay_s == 0.02),
]


@pytest.mark.parametrize("name,override,message", REJECTED)
def test_a_key_the_mission_ignores_is_one_clear_error(name, override, message):
    if message is None:  # an old-layout key: translated, and then an old R-MAX key off its default fails
        assert load_scenario(name, [override]).navigation.gate == 20
        with pytest.raises(ScenarioError, match=r"sensors\.imu\.delay_s does not apply .*kind 'multirotor-imu'"):
            load_scenario(name, [override, "sensors.imu.delay_s=0.1"])
        return
    with pytest.raises(ScenarioError, match="does not apply") as e:
        load_scenario(name, [override])
    assert message in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("name,override,check", ACCEPTED)
def test_a_key_the_mission_reads_is_accepted(name, override, check):
    assert check(load_scenario(name, [override]))


@pytest.mark.parametrize("name", builtin_names())
def test_builtins_and_their_resolved_scenario_toml_still_load(name):
    sc = load_scenario(name)
    again = validate(tomllib.loads(to_toml(sc)))  # a run directory's scenario.toml: every key, at its value
    assert to_toml(again) == to_toml(sc)
    kind = sc.mission.type
    keys = [r["key"] for r in settable_keys(sc)]
    assert all(not_applicable(k, kind) is None for k in keys)
    assert keys and all(k.split(".")[0] in ("run", "mission", "world", "vehicle", "sensors", "navigation", "control",
                                                        "faults") for k in keys)
    # the world of a system: its own [world.<thing>] sections (roles.WORLD), and the shared keys it reads
    own = {k.split(".")[1] for k in keys if k.startswith("world.") and k.count(".") > 1}
    assert own == set(roles.WORLD.get(kind, ()))
    assert {k.split(".")[1] for k in keys if k.startswith("control.")} == set(roles.CONTROL.get(kind, ()))
    shared = [k for k in keys if k.startswith("world.") and k.count(".") == 1]
    if kind == "deck":
        assert not shared and "world.deck.motion" in keys and "control.deck.k_rho" in keys
        assert "sensors.imu.gyro_noise_rad_s" in keys and "sensors.imu.delay_s" not in keys
        assert "navigation.gate" in keys and "vehicle.mass_kg" in keys
    if kind in ("condor", "mav-geolocation"):
        assert shared == ["world.wind_speed_mps", "world.wind_from_deg", "world.turbulence"]
    if kind == "palace":
        assert "sensors.imu.delay_s" in keys and "navigation.mpe.rate_hz" in keys


def test_every_rule_names_a_key_of_the_schema():
    for kind, rules in NOT_APPLICABLE.items():
        sc = load_scenario({"deck": "deck-static", "condor": "condor-orbit", "mav-geolocation": "mav-geolocation",
                            "witas-homing": "witas-homing", "pad-landing": "pad-landing",
                            "pfcm": "pfcm-segment"}[kind])
        assert sc.mission.type == kind
        for prefix, keep, _ in rules:
            node = sc
            for p in prefix.split("."):
                node = getattr(node, p)  # (sensors.<name>: the named sensor)  # AttributeError: a rule for a key that does not exist
            for k in keep:
                getattr(node, k)


def test_the_cli_says_it_in_one_line():
    r = CliRunner().invoke(app, ["run", "deck-static", "--set", "sensors.imu.delay_s=0.1"])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "sensors.imu.delay_s does not apply to mission.type 'deck' (sensors.imu is kind 'multirotor-imu'" in r.output
