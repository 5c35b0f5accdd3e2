"""Scenario files and overrides: one-line messages naming the key, the value and the range."""

import pytest

from visnav.scenarios.schema import ScenarioError, builtin_names, load_scenario, to_toml, validate


def test_builtins_load():
    assert "palace-landing" in builtin_names()
    for name in builtin_names():
        assert load_scenario(name).run.name == name


def test_override_applies_and_round_trips():
    sc = load_scenario("palace-landing", ["sensors.imu.delay_s=0.043", "world.surface=grass"], seed=9)
    assert sc.sensors.imu.delay_s == 0.043 and sc.world.surface == "grass" and sc.run.seed == 9
    import tomllib

    again = validate(tomllib.loads(to_toml(sc)))
    assert again == sc


@pytest.mark.parametrize(
    "override, fragments",
    [
        ("sensors.imu.dely_s=0.1", ["unknown scenario key 'sensors.imu.dely_s'", "delay_s"]),
        ("sensors.imu.delay_s=-1", ["'sensors.imu.delay_s'", "-1", ">= 0", "<= 1.0"]),
        ("world.surface=mud", ["'world.surface'", "mud", "'concrete'", "'grass'"]),
        ("mission.glide_slope_deg=5", ["'mission.glide_slope_deg'", ">= 20"]),
        ("bogus=1", ["unknown scenario key 'bogus'", "mission"]),
    ],
)
def test_bad_keys_give_one_line(override, fragments):
    with pytest.raises(ScenarioError) as ei:
        load_scenario("palace-landing", [override])
    msg = str(ei.value)
    assert "\n" not in msg
    for f in fragments:
        assert f in msg


def test_unknown_scenario_and_missing_file():
    with pytest.raises(ScenarioError, match="palace-landing"):
        load_scenario("no-such-scenario")
    with pytest.raises(ScenarioError, match="not found: /nonexistent/x.toml"):
        load_scenario("/nonexistent/x.toml")
