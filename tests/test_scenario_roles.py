"""Configuration by role (issue #13): every built-in scenario's resolved configuration round-trips in role form
and builds; every key ``visnav keys`` printed before the role layout still works through its translation
(roles.LEGACY) to the same value, or fails naming the new key; a key that does not apply fails in one line."""

import json
from pathlib import Path

import pytest

from visnav.scenarios import roles
from visnav.scenarios.base import ScenarioError
from visnav.scenarios.schema import Scenario, builtin_names, load_scenario, to_toml, validate

try:
    import tomllib
except ImportError:  # pragma: no cover
    import tomli as tomllib

# `visnav keys SCEN --json` (key, value) of every built-in scenario at 0d4066d, before the role layout
KEYS_BEFORE = json.loads((Path(__file__).parent / "data" / "keys_before_roles.json").read_text())
#: built-in scenarios added after the snapshots were taken (nothing to compare them with)
ADDED_SINCE = {"mav-geolocation-pingwing"}
#: the built-ins' own settings changed after the snapshots were taken, as ``--set`` overrides on a snapshot
CHANGED_SINCE = {
    # issue 30 round 18: a deck at rest is level to 1 deg, the level update's sigma hypot(1, 0.1 AHRS)
    "deck-static": {"world.deck.level_error_deg": 1.0, "navigation.level_deck_sigma_deg": 1.0},
}


def with_changes_since(sc, name: str):
    """``sc`` (a snapshot's scenario) with the settings its built-in changed since (``CHANGED_SINCE``)."""
    for key, value in CHANGED_SINCE.get(name, {}).items():
        *path, leaf = key.split(".")
        obj = sc
        for p in path:
            obj = obj[p] if isinstance(obj, dict) else getattr(obj, p)
        setattr(obj, leaf, value)
    return sc


def _leaves(sc):
    return {".".join(p): v for p, v in roles._leaves(sc.model_dump(mode="json"))}


@pytest.mark.parametrize("name", builtin_names())
def test_resolved_round_trip_and_build(name):
    from visnav.app.missions import BuildContext, build  # noqa: F401

    sc = load_scenario(name)
    text = to_toml(sc)
    data = tomllib.loads(text)
    assert not roles.is_legacy(data)
    assert data["vehicle"]["kind"] == roles.SUITES[sc.mission.type]["vehicle"]["kind"]
    assert all("kind" in s for s in data["sensors"].values())
    again = validate(data)
    assert again == sc and to_toml(again) == text
    from visnav.app.loop import Simulation

    Simulation(again)  # the builder assembles every part from the role sections


@pytest.mark.parametrize("name", sorted(KEYS_BEFORE))
def test_every_key_printed_before_still_works(name):
    """Each old key set to the value it had resolves to the same scenario; through the translation the new key
    holds that value; the keys of a system's sensor that it never read fail naming the sensor."""
    sc = load_scenario(name)
    new = _leaves(sc)
    t = sc.mission.type
    for key, value in KEYS_BEFORE[name]:
        nk = roles.legacy_key(key, t)
        nk = key if nk is None else nk
        nk = roles.moved_key(nk, t) or nk  # world content and gains out of [mission] (issue #31)
        text = json.dumps(value)
        if key.startswith("mission.compass."):  # WITAS: the compass is a sensor present or not
            assert "compass" not in sc.sensors and key.replace("mission.compass.", "") in ("enabled", "rate_hz",
                                                                                             "sigma_deg", "bias_deg")
            continue
        if nk not in new:  # a key main accepted and never read (the geo-location MAV's GPS and compass)
            assert key in roles.LEGACY_UNREAD[t], key
            assert load_scenario(name, [f"{key}={text}"]) == sc  # at its old default (an old scenario.toml)
            with pytest.raises(ScenarioError, match=rf"^scenario {name}: {key} does not apply"):
                load_scenario(name, [f"{key}={2 * value}"])
            continue
        assert new[nk] == value, (key, nk)
        if value is None:  # no TOML spelling of "none" for --set
            continue
        assert load_scenario(name, [f"{key}={text}"]) == sc, key


def test_old_layout_sets_the_new_key():
    a = load_scenario("deck-static", ["mission.filter.gate=20", "mission.camera.focal_px=400", "mission.imu.rate_hz=50"])
    b = load_scenario("deck-static", ["navigation.gate=20", "sensors.camera.focal_px=400", "sensors.imu.rate_hz=50"])
    assert a == b and a.navigation.gate == 20 and a.sensors.camera.focal_px == 400
    c = load_scenario("condor-orbit", ["mission.gps_noise_m=3", "mission.altimeter.noise_m=0.5",
                                       "mission.sensors.gps.velocity_noise_mps=0.2", "mission.vision.method=thesis"])
    assert (c.sensors.gps.sigma_m, c.sensors.baro.sigma_m, c.sensors.gps.velocity_sigma_mps) == (3, 0.5, 0.2)
    assert c.navigation.vision.method == "thesis"
    w = load_scenario("witas-homing", ["mission.compass.enabled=true", "mission.compass.sigma_deg=2"])
    assert (w.sensors.compass.noise_deg, w.sensors.compass.bias_deg) == (2.0, 0.5)
    p = load_scenario("pad-landing", ["mission.pantilt.servo_gain=4", "mission.filter.gyro_hz=100"])
    assert p.sensors.camera.pantilt.servo_gain == 4 and p.navigation.gyro_hz == 100


def test_old_resolved_file_loads(tmp_path):
    """A scenario.toml of a run directory written before the role layout (every R-MAX section at its default,
    the devices under mission) gives the same scenario."""
    old = {"run": {"name": "x", "seed": 3}, "vehicle": {"model": "rmax", "yaw_deg": 0.0},
           "sensors": {"imu": {"delay_s": 0.0}, "camera": {"focal_px": 1073.0}},
           "navigation": {"accel_noise": 0.3},
           "mission": {"type": "deck", "filter": {"init": "truth"}, "vehicle": {"mass_kg": 2.0}}}
    sc = validate(old)
    assert sc.navigation.init == "truth" and sc.vehicle.mass_kg == 2.0 and sc.vehicle.kind == "multirotor"
    old["sensors"]["imu"]["delay_s"] = 0.1
    with pytest.raises(ScenarioError, match=r"^sensors\.imu\.delay_s does not apply to mission\.type 'deck'"):
        validate(old)


@pytest.mark.parametrize("name, override, message", [
    ("deck-static", "sensors.imu.delay_s=0.1", "scenario deck-static: sensors.imu.delay_s does not apply to "
     "mission.type 'deck' (sensors.imu is kind 'multirotor-imu'"),
    ("deck-static", "sensors.sonar.rate_hz=5", "scenario deck-static: sensors.sonar does not apply to mission.type "
     "'deck' (its sensors: imu, camera)"),
    ("deck-static", "vehicle.kind=rmax", "vehicle.kind 'rmax' does not fit mission.type 'deck'"),
    ("mav-geolocation", "mission.sensors.gps.rate_hz=2", "mission.sensors.gps.rate_hz does not apply to mission.type "
     "'mav-geolocation' (its simulation never read it"),
    ("mav-geolocation", "sensors.gps.rate_hz=2", "sensors.gps does not apply to mission.type 'mav-geolocation'"),
    ("pfcm-segment", "sensors.camera.noise_sigma=5", "sensors.camera.noise_sigma does not apply to mission.type 'pfcm'"),
    ("witas-homing", "sensors.laser.rate_hz=5", "sensors.laser does not apply to mission.type 'witas-homing'"),
])
def test_key_that_does_not_apply_is_one_line(name, override, message):
    with pytest.raises(ScenarioError) as e:
        load_scenario(name, [override])
    assert message in str(e.value) and "\n" not in str(e.value)


def test_cli_one_line(tmp_path):
    from typer.testing import CliRunner

    from visnav.cli import app

    r = CliRunner().invoke(app, ["run", "deck-static", "--set", "sensors.imu.delay_s=0.1", "--out", str(tmp_path / "r")])
    assert r.exit_code != 0 and "Traceback" not in r.output
    assert "sensors.imu.delay_s" in r.output and "deck-static" in r.output


def test_default_scenario_is_palace():
    sc = Scenario()
    assert (sc.vehicle.kind, sc.navigation.kind, list(sc.sensors)) == ("rmax", "palace",
                                                                       ["imu", "gps", "laser", "sonar", "camera"])


# every built-in's resolved scenario as main wrote it into scenario.toml before the role layout (None dropped)
RESOLVED_BEFORE = json.loads((Path(__file__).parent / "data" / "resolved_before_roles.json").read_text())


@pytest.mark.parametrize("name", sorted(RESOLVED_BEFORE))
def test_old_run_folder_scenario_gives_the_same_scenario(name):
    """`visnav metrics RUN_DIR` of a run made before the role layout reads the same configuration."""
    assert roles.is_legacy(RESOLVED_BEFORE[name])
    assert with_changes_since(validate(RESOLVED_BEFORE[name]), name) == load_scenario(name)


def test_the_snapshots_cover_every_builtin_but_the_ones_added_since():
    """The snapshot tests run over the scenarios the snapshots hold: every other built-in is listed as added since."""
    assert set(builtin_names()) == set(KEYS_BEFORE) | ADDED_SINCE == set(RESOLVED_BEFORE) | ADDED_SINCE
    assert not ADDED_SINCE & set(KEYS_BEFORE)
