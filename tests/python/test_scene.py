"""Scene validation: one schema, errors that name the key, the value and the allowed range."""
from __future__ import annotations

import pytest

from gearmesh.scene import SceneError, load_scene, parse_scene
from conftest import REPO

SCENES = REPO / "scenarios"


def test_paper_set_a_converts_units_to_si():
    s = load_scene(SCENES / "paper_setA_3U4U.toml")
    assert s.parameters["pair.center_distance"] == pytest.approx(0.150)
    assert s.parameters["pair.normal_module"] == pytest.approx(0.0026)
    assert s.parameters["pair.pressure_angle"] == pytest.approx(0.3490658503988659)
    assert s.parameters["gear1.youngs_modulus"] == pytest.approx(210e9)
    assert s.parameters["model.stiffness"] == 4
    assert s.parameters["model.friction_coefficient"] == pytest.approx(0.4)
    assert s.parameters["model.friction_velocity"] == pytest.approx(1e-5)
    assert s.run["torques_Nm"] == [50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0]
    assert s.run["speed_rpm"] == pytest.approx(10 * 2 * 3.141592653589793 / 60)
    assert s.parameters["gear2.teeth"] == 57
    assert s.run["approach_um"] == pytest.approx(10e-6)
    assert s.assumptions


@pytest.mark.parametrize("text, words", [
    ("[pair]\ncenter_distance_m = 0.15\n", ["pair.center_distance_m", "unknown key",
                                            "center_distance_mm"]),
    ("[pair]\ncenter_distance_mm = -3\n", ["pair.center_distance_mm", "-3", "allowed range"]),
    ("[gear1]\nteeth = 20.5\n", ["gear1.teeth", "whole number"]),
    ("[gear3]\nteeth = 20\n", ["[gear3]", "unknown section"]),
    ("[pair]\ninternal = 1\n", ["pair.internal", "true or false"]),
    ("[model]\nslices = 0\n", ["model.slices", "allowed range [1, 200]"]),
    ("[run]\nspeed = 3\n", ["run.speed", "unknown key"]),
    ("[run]\ntorques_Nm = [50, \"x\"]\n", ["run.torques_Nm[1]", "expected a number"]),
    ("[model]\nfriction_coefficient = 3\n", ["model.friction_coefficient", "allowed range"]),
    ("[pair]\npressure_angle_deg = nan\n", ["pair.pressure_angle_deg", "allowed range"]),
    ("[pair\n", ["not valid TOML"]),
])
def test_bad_scenes_are_named(text, words):
    with pytest.raises(SceneError) as err:
        parse_scene(text)
    for w in words:
        assert w in str(err.value)


def test_micro_geometry_keys_and_deviation_files(tmp_path):
    dev = tmp_path / "p1.txt"
    dev.write_text((SCENES / "deviations_example.txt").read_text())
    s = parse_scene('[gear1]\nprofile_crowning_um = 5\ntip_relief_length_mm = 2\n'
                    'tip_relief_parabolic = true\ndeviations_file = "p1.txt"\n',
                    tmp_path / "scene.toml")
    assert s.parameters["gear1.profile_crowning"] == pytest.approx(5e-6)
    assert s.parameters["gear1.tip_relief_length"] == pytest.approx(2e-3)
    assert s.parameters["gear1.tip_relief_parabolic"] is True
    name = s.parameters["gear1.deviations"]
    assert s.resources[name] == dev.resolve()
    with pytest.raises(SceneError, match="gear2.deviations_file.*no such file"):
        parse_scene('[gear2]\ndeviations_file = "missing.txt"\n', tmp_path / "scene.toml")
    with pytest.raises(SceneError, match="gear1.profile_crowning_um.*allowed range"):
        parse_scene('[gear1]\nprofile_crowning_um = -1\n', tmp_path / "scene.toml")


def test_paper_set_b_has_the_papers_crowning():
    s = load_scene(SCENES / "paper_setB_P1P2.toml")
    assert s.parameters["gear1.profile_crowning"] == pytest.approx(5e-6)
    assert s.parameters["gear2.profile_crowning"] == pytest.approx(10e-6)


def test_fe_scenes_parse_with_their_bodies():
    """The FE-level scenes: level 5, body tables in mm, and set A's FE scene has set A's gears."""
    plain = load_scene(SCENES / "paper_setA_3U4U.toml")
    fe = load_scene(SCENES / "fe" / "paper_setA_3U4U_fe.toml")
    assert fe.parameters["model.stiffness"] == 5 and fe.parameters["model.coupled_teeth"] == 2
    assert fe.bodies == {1: {"bore_diameter_mm": 50.0}, 2: {"bore_diameter_mm": 50.0}}
    same = {k: v for k, v in plain.parameters.items() if k != "model.stiffness"}
    assert {k: fe.parameters[k] for k in same} == same
    light = load_scene(SCENES / "fe" / "lightweight_vs_solid_fe.toml")
    assert light.bodies[1]["holes"] == 19 and light.bodies[1]["web_thickness_mm"] == 6.0
    ring = load_scene(SCENES / "fe" / "internal_ring_fe.toml")
    assert ring.parameters["pair.internal"] is True and "ring_outer_diameter_mm" in ring.bodies[2]
    helical = load_scene(SCENES / "fe" / "helical_fe.toml")
    assert helical.fe == {"profile_elements": 6, "width_elements": 8}
    for s in (fe, light, ring, helical):
        assert s.description and s.assumptions


def test_a_scene_without_a_level_runs_at_the_fmus_default(fmu_path):
    """A scene that sets no [model] stiffness_level runs where the FMU would: at model.stiffness's
    start value in the FMU's modelDescription.xml (read here with xml.etree), not at level 0;
    a scene that sets one keeps its own."""
    import zipfile
    import xml.etree.ElementTree as ET

    with zipfile.ZipFile(fmu_path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    start = next(sv[0].get("start") for sv in root.iter("ScalarVariable") if sv.get("name") == "model.stiffness")
    text = (REPO / "scenarios" / "paper_setA_3U4U.toml").read_text()
    bare = "\n".join(line for line in text.splitlines() if not line.startswith("stiffness_level"))
    assert "stiffness_level" not in bare
    assert parse_scene(bare, fmu=fmu_path).level == int(start) == 4
    assert parse_scene(bare.replace("[model]", "[model]\nstiffness_level = 2"), fmu=fmu_path).level == 2
