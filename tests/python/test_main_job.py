"""The main job end to end on the default scene: its figures agree with the geometry."""
from __future__ import annotations

import csv
import pathlib

import numpy as np
import pytest

from gearmesh.main_job import run_main
from gearmesh.scene import load_scene

SCENES = pathlib.Path(__file__).resolve().parents[2] / "scenarios"


def read(path):
    with open(path) as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def test_set_b_scene_fmu_carries_its_crowning(fmu_path, tmp_path):
    """The scene FMU starts at the scene's values: set B's crowning lowers the force at a pose
    near the start of the path compared with set A at the same rigid approach."""
    from gearmesh.fmu_driver import GearMeshFMU
    from gearmesh.scene_fmu import build_scene_fmu
    forces = {}
    for name in ("paper_setA_3U4U", "paper_setB_P1P2"):
        scene = load_scene(SCENES / f"{name}.toml")
        fmu = build_scene_fmu(fmu_path, scene.parameters, scene.resources, tmp_path / f"{name}.fmu")
        with GearMeshFMU(fmu) as inst:
            crowning = inst.get(["gear2.profile_crowning"])["gear2.profile_crowning"]
            rb2 = inst.get(["gear2.base_diameter"])["gear2.base_diameter"] / 2
            inst.step({"gear1.phi": 0.0, "gear2.phi": 8e-6 / rb2})  # TE = 8 um, pitch point
            forces[name] = (crowning, inst.get(["mesh.normal_force"])["mesh.normal_force"])
    assert forces["paper_setA_3U4U"][0] == 0.0
    assert forces["paper_setB_P1P2"][0] == pytest.approx(10e-6)
    assert forces["paper_setB_P1P2"][1] < forces["paper_setA_3U4U"][1]


def test_main_job_on_set_a(fmu_path, tmp_path):
    scene = load_scene(SCENES / "paper_setA_3U4U.toml")
    report = run_main([scene], fmu_path, tmp_path)
    text = report.read_text()
    assert "paper_setA_3U4U" in text
    folder = tmp_path / scene.name
    for name in ("engagement_sweep.csv", "revolution.csv", "engagement_sweep.png",
                 "revolution.png"):
        assert (folder / name).stat().st_size > 0
    rev = read(folder / "revolution.csv")
    assert rev["mesh.normal_force"].min() > 0  # a rigid approach always loads some pair
    assert set(np.unique(rev["mesh.pairs_in_contact"])) <= {1.0, 2.0, 3.0}
    sweep = read(folder / "engagement_sweep.csv")
    assert sweep["mesh.normal_force"][sweep["mesh.flank"] == 0].max() == 0.0
    assert (np.diff(sweep["mesh.normal_force"][sweep["mesh.flank"] == 1]) >= 0).all()
    loaded = read(folder / "loaded_te.csv")
    means = [loaded["mesh.te"][loaded["torque"] == t].mean() for t in (50.0, 200.0, 350.0)]
    assert 0 < means[0] < means[1] < means[2]  # the loaded TE grows with the torque
    assert "order 57" in text and "order 114" in text


def test_main_job_friction_sweep_of_set_b(fmu_path, tmp_path):
    """Set B's friction sweep (the paper's Figure 8): friction moves the first mesh order far
    more at 350 N m than at 50 N m."""
    scene = load_scene(SCENES / "paper_setB_P1P2.toml")
    run_main([scene], fmu_path, tmp_path)
    rows = read(tmp_path / scene.name / "friction_sweep.csv")
    assert set(rows["mu"]) == {0.30, 0.35, 0.40}

    def spread(torque):
        sel = rows["torque_Nm"] == torque
        return np.ptp(rows["order1_m"][sel])

    assert spread(350.0) > 5 * spread(50.0)
    assert (tmp_path / scene.name / "friction_sweep.png").stat().st_size > 0
