"""World content under [world.<thing>], controller gains under [control.<system>] (issue #31 item 4): the layout
before it still loads to the same scenario, and each old key says its new name once, as a warning line."""

from __future__ import annotations

from pathlib import Path

import pytest

from visnav.scenarios import roles
from visnav.scenarios.base import ScenarioError
from visnav.scenarios.schema import builtin_names, load_scenario, to_toml

from tests.test_scenario_roles import with_changes_since

#: the built-ins that had world content or gains under [mission], as they were before the move
BEFORE = Path(__file__).parent / "data" / "scenarios_before_world_control"


@pytest.fixture(autouse=True)
def _fresh_messages():
    roles._SAID.clear()  # each old key is named once per process: start each test without the earlier ones
    yield
    roles._SAID.clear()


@pytest.mark.parametrize("old", sorted(BEFORE.glob("*.toml")), ids=lambda p: p.stem)
def test_old_layout_file_gives_the_same_scenario_and_names_the_new_keys(old, capsys):
    sc = load_scenario(str(old))
    err = capsys.readouterr().err
    sc = with_changes_since(sc, old.stem)
    assert sc == load_scenario(old.stem) and to_toml(sc) == to_toml(load_scenario(old.stem))
    lines = err.splitlines()
    assert lines and all(line.startswith("warning: mission.") and " is now " in line for line in lines)
    assert len(lines) == len(set(lines))  # one line per key
    for line in lines:  # each names a key that exists where it says, with the old key's value
        old_key, new_key = line.removeprefix("warning: ").split(" is now ")
        assert roles.moved_key(old_key, sc.mission.type) == new_key
    assert capsys.readouterr().err == ""  # the new layout says nothing
    load_scenario(str(old))
    assert capsys.readouterr().err == ""  # and the same old keys are not named twice in one process


def test_builtins_are_in_the_new_layout(capsys):
    for name in builtin_names():
        load_scenario(name)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("name, old, new, value", [
    ("deck-static", "mission.deck.motion", "world.deck.motion", "moving"),
    ("deck-moving", "mission.guidance.k_rho", "control.deck.k_rho", 0.4),
    ("condor-orbit", "mission.control.orbit.logic", "control.condor.orbit.logic", "original"),
    ("condor-orbit", "mission.control.orbit.switch_time_s", "mission.orbit.switch_time_s", 20.0),
    ("condor-orbit", "mission.control.kp_phi", "control.condor.kp_phi", 1.5),
    ("condor-orbit", "mission.target.north_m", "world.tent.north_m", 10.0),
    ("mav-geolocation", "mission.control.l1_m", "control.mav.l1_m", 40.0),
    ("mav-geolocation", "mission.control.altitude_m", "mission.altitude_m", 90.0),
    ("mav-geolocation", "mission.target.click_sigma_px", "mission.click_sigma_px", 5.0),
    ("mav-geolocation", "mission.map.rural_size_m", "world.geo_map.rural_size_m", 300.0),
    ("witas-homing", "mission.map.pond", "world.witas_map.pond", False),
    ("pad-landing", "mission.pad.shadow", "world.pad.shadow", True),
    ("pfcm-spiral", "mission.roll_compensator", "control.pfcm.roll_compensator", False),
])
def test_set_with_the_old_key_sets_the_new_one_and_says_so(name, old, new, value, capsys):
    text = str(value).lower() if isinstance(value, bool) else repr(value).replace("'", '"')
    a = load_scenario(name, [f"{old}={text}"])
    assert capsys.readouterr().err == f"warning: {old} is now {new}\n"
    b = load_scenario(name, [f"{new}={text}"])
    assert a == b and a != load_scenario(name)
    node = a
    for p in new.split("."):
        node = getattr(node, p)
    assert node == value


def test_cli_run_with_the_old_key_warns_and_runs(tmp_path):
    from typer.testing import CliRunner

    from visnav.cli import app

    r = CliRunner().invoke(app, ["run", "deck-static", "--set", "mission.deck.motion=moving", "--set",
                                 "run.duration_s=0.05", "--out", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    assert "mission.deck.motion is now world.deck.motion" in r.output and "Traceback" not in r.output
    assert 'motion = "moving"' in (tmp_path / "r" / "scenario.toml").read_text()


@pytest.mark.parametrize("name, key, message", [
    ("palace-landing", "world.deck.motion=moving", "world.deck does not apply to mission.type 'palace' (its world "
     "sections: none)"),
    ("mav-geolocation", "world.tent.north_m=3", "world.tent does not apply to mission.type 'mav-geolocation' (its "
     "world sections: world.geo_map, world.truck)"),
    ("deck-static", "control.condor.kp_phi=1", "control.condor does not apply to mission.type 'deck' (its control "
     "sections: control.deck)"),
    ("deck-static", "mission.guidance.landing_point_m=[0.5, 0.0, 0.0]", "must lie on the 0.6 m deck plate of "
     "world.deck"),
])
def test_another_systems_section_is_one_line(name, key, message):
    with pytest.raises(ScenarioError) as e:
        load_scenario(name, [key])
    assert message in str(e.value) and "\n" not in str(e.value)


def test_a_system_without_sections_of_its_own_writes_none():
    """The R-MAX's PALACE missions have no [world.<thing>] or [control.<system>]: their resolved scenario.toml (and
    so scenario_hash, the resume key of a campaign) is what it was before the sections existed."""
    text = to_toml(load_scenario("palace-landing"))
    assert "[control" not in text and "[world." not in text and "[world]" in text
    assert "[control.pfcm]" in to_toml(load_scenario("pfcm-spiral"))
