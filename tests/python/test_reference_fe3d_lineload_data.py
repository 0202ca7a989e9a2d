"""The committed 3-D line load across the face (scenarios/reference/<scene>.reference_fe3d.lineload.csv,
reference_fe/README.md "3-D line load") holds what `python -m reference_fe lineload3d` checked
when it wrote them, read here without reference_fe's code:

* force balance: at every torque and position the integral of the line load over the face and
  the loaded teeth (the bins' forces at the finest binning) equals the total normal force
  T / r_b1 within FORCE_TOLERANCE (frictionless: a contact force on the line of action has the
  lever arm r_b1; a tooth in tip-corner contact off the path has another, and carries little);
  the bins' moments about gear 1's axis add up to the torque within 1e-4 (equilibrium);
* every binning is the same forces: a bin's force is at most the sum of its finer bins' (a
  vector sum), and the line load is the force over the bin width;
* the JSON beside it records the same checks and the binning.
"""
from __future__ import annotations

import csv
import json
import math
import pathlib
from collections import defaultdict

import pytest
from conftest import REPO

REFERENCE = REPO / "scenarios" / "reference"
FILES = sorted(REFERENCE.glob("*.reference_fe3d.lineload.csv"))
# set A (and its crowned variant): r_b1 = m z cos(20 deg) / 2, 57 teeth of module 2.6 mm
BASE_RADIUS = 0.0026 * 57 * math.cos(math.radians(20.0)) / 2
FACE_WIDTH = 0.023
FORCE_TOLERANCE = 5e-3   # measured worst +0.24 %: reference_fe/README.md, "3-D line load"


def rows(path: pathlib.Path) -> list[dict]:
    with path.open() as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def test_there_is_data():
    assert any(p.name.startswith("paper_setA_lead_crowned") for p in FILES)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_committed_line_load_balances_the_torque(path):
    by_case = defaultdict(list)
    for r in rows(path):
        by_case[(int(r["bins"]), float(r["torque_Nm"]), int(r["position"]))].append(r)
    counts = sorted({k[0] for k in by_case})
    finest = counts[-1]
    torques = sorted({k[1] for k in by_case})
    assert len(torques) == 2 and len(by_case) == len(counts) * 2 * 8
    for (bins, torque, k), cells in by_case.items():
        assert {int(c["bin"]) for c in cells} == set(range(bins)), (bins, torque, k)
        for c in cells:
            width = float(c["z_high_m"]) - float(c["z_low_m"])
            assert width == pytest.approx(FACE_WIDTH / bins, rel=1e-9)
            assert float(c["line_load_N_per_m"]) == pytest.approx(float(c["force_N"]) / width,
                                                                  rel=1e-12)
        moment = sum(float(c["moment_Nm"]) for c in cells)
        assert abs(moment) == pytest.approx(torque, rel=1e-4), (bins, torque, k)
        if bins == finest:
            force = sum(float(c["force_N"]) for c in cells)
            assert force == pytest.approx(torque / BASE_RADIUS, rel=FORCE_TOLERANCE), (torque, k)
    for (bins, torque, k), cells in by_case.items():   # coarser bins: vector sums of finer ones
        fine = by_case[(finest, torque, k)]
        merge = finest // bins
        for c in cells:
            parts = [float(f["force_N"]) for f in fine if f["tooth"] == c["tooth"]
                     and int(f["bin"]) // merge == int(c["bin"])]
            assert float(c["force_N"]) <= sum(parts) * (1 + 1e-9)
            assert float(c["force_N"]) >= sum(parts) * (1 - 1e-3)   # nearly parallel forces


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_provenance_records_the_checks(path):
    record = json.loads(path.with_suffix(".json").read_text())
    checks = record["checks"]
    assert checks["moment_sum_vs_torque_max_rel"] <= 1e-4
    assert abs(checks["force_sum_vs_T_over_rb1_worst_rel"]) <= FORCE_TOLERANCE
    assert record["binning"]["layers"] == max(int(r["bins"]) for r in rows(path))
    assert record["ccx_version"] and record["command"].startswith("python -m reference_fe lineload3d")
