"""The committed per-tooth contact forces (scenarios/reference/<scene>.reference_fe.pairs.csv,
reference_fe/README.md, "Load share and peak line load") hold what `python -m reference_fe pairs`
checked when it wrote them, read here without reference_fe's code: at every model, torque and
position the teeth's moments about gear 1's axis add up to the torque; the teeth's forces times
gear 1's base radius add up to it too within 1 % (frictionless: a force on the line of action
has the lever arm r_b1; a tooth in tip-corner contact off the path has another, and carries
little); every position has its TE within 1 % of the committed te.csv."""
from __future__ import annotations

import csv
import pathlib
from collections import defaultdict

import pytest
from conftest import REPO

REFERENCE = REPO / "scenarios" / "reference"
FILES = sorted(REFERENCE.glob("*.reference_fe.pairs.csv"))
# set A, set B: base radius r_b1 = m z cos(20 deg) / 2 (both 57 teeth of module 2.6 mm)
BASE_RADIUS = {"paper_setA_3U4U": 0.0026 * 57 * 0.9396926207859084 / 2,
               "paper_setB_P1P2": 0.0026 * 57 * 0.9396926207859084 / 2}


def rows(path: pathlib.Path) -> list[dict]:
    with path.open() as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def test_there_is_data():
    assert any(p.name.startswith("paper_setA_3U4U") for p in FILES)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_committed_pairs_are_in_equilibrium_and_match_the_te(path):
    scene = path.name.split(".")[0]
    by_case = defaultdict(list)
    for r in rows(path):
        by_case[(r["model"], float(r["torque_Nm"]), int(r["position"]))].append(r)
    te = {(r["model"], float(r["torque_Nm"]), int(r["position"])): float(r["te_m"])
          for r in rows(REFERENCE / f"{scene}.reference_fe.te.csv") if r["mesh_level"] == "0"}
    assert len(by_case) == 2 * 4 * 20
    rb1 = BASE_RADIUS[scene]
    for key, teeth in by_case.items():
        torque = key[1]
        moment = sum(float(t["moment_Nm"]) for t in teeth)
        assert abs(moment) == pytest.approx(torque, rel=1e-4), key
        lever = sum(float(t["force_N"]) for t in teeth) * rb1
        assert lever == pytest.approx(torque, rel=1e-2), key  # measured: within 0.23 %
        assert float(teeth[0]["te_m"]) == pytest.approx(te[key], rel=1e-2), key
