"""Where crowned flanks touch, against CalculiX (reference_fe/README.md, "Low load: where crowned
flanks touch"; docs/physics.md §3). Set B is set A with profile crowning (5 / 10 um); at 5 N m
their TE difference at each of 20 positions over a pitch is what the crowning adds to the rigid
approach. The FE's differs from the gap at the involutes' conjugate points by up to 0.33 um
(mid-double contact); the product's (level 4, quasi-static, the generic FMU) matches the FE's
within 0.03 um at every position (measured 0.022 um; 0.006 um at the even positions)."""
from __future__ import annotations

import csv

import numpy as np
import pytest

from conftest import REPO
from reference_fe.geometry import Pair
from reference_fe.scene import load

LOW = REPO / "scenarios" / "reference" / "low_load"


def fe_te(scene: str, torque: float) -> np.ndarray:
    rows = [r for r in csv.DictReader(line for line in open(LOW / f"{scene}.reference_fe.te.csv")
                                      if not line.startswith("#"))
            if float(r["torque_Nm"]) == torque]
    return np.array([float(r["te_m"]) for r in sorted(rows, key=lambda r: int(r["position"]))])


@pytest.fixture(scope="module")
def product(fmu_path, tmp_path_factory):
    from gearmesh.accuracy.sweep import sweep
    from gearmesh.main_levels import scene_at_level
    from gearmesh.scene import load_scene
    from gearmesh.scene_fmu import build_scene_fmu

    folder = tmp_path_factory.mktemp("touch")
    out = {}
    for name in ("paper_setA_3U4U", "paper_setB_P1P2"):
        scene = scene_at_level(load_scene(REPO / "scenarios" / f"{name}.toml"), 4)
        fmu = build_scene_fmu(fmu_path, scene.parameters, scene.resources, folder / f"{name}.fmu")
        out[name] = sweep(fmu, {}, [5.0], 20, repeats=1).te[5.0]
    return out


def test_crowned_flanks_touch_where_the_fe_says(product):
    fe = fe_te("paper_setB_P1P2", 5.0) - fe_te("paper_setA_3U4U", 5.0)
    ours = product["paper_setB_P1P2"] - product["paper_setA_3U4U"]
    assert len(fe) == len(ours) == 20
    assert np.max(np.abs(ours - fe)) < 0.03e-6, (ours - fe) * 1e6
    # the effect is there to see: the conjugate points' gaps miss the FE by 0.33 um mid-double contact
    pair = Pair(load(REPO / "scenarios" / "paper_setB_P1P2.toml"))
    conjugate = np.array([pair.unloaded_te(pair.g1.tau * k / 20) for k in range(20)])
    assert conjugate[10] - fe[10] > 0.25e-6
