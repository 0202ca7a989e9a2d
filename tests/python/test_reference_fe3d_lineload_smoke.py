"""Smoke test of the 3-D line load across the face (reference_fe/lineload3d.py): set A with 5 um
of lead crowning as 3-D sectors at a coarse mesh (level -2, 3 element layers), the pitch-point
position (one tooth pair on the path), 150 and 350 N m in one ccx run, gear 1's slave surface
split per tooth and layer.

Checks, each able to fail:

* the layers' contact moments about gear 1's axis add up to the torque (1e-4) and their forces
  to T / r_b1 (1e-3: one pair on the line of action); a layer missing from the deck or the
  parser, or forces in the wrong unit, fail here;
* the crowning puts the load at mid-face: the middle layer's line load above the end layers'
  (measured 2026-11-25: 1.66 / 1.42 times the face average at 150 / 350 N m), the two end layers
  alike within 2 % (the model is symmetric about mid-face; measured 0.7 %);
* the bins: 3 layers give 3 and 1 bins, the single bin is the face average T / (r_b1 b).
"""
from __future__ import annotations

import math
import tempfile

import pytest


from reference_fe import lineload3d, model3d, scene  # noqa: E402
from conftest import REPO

pytestmark = pytest.mark.usefixtures("ccx_installed")


def test_crowned_line_load_at_the_pitch_point():
    spec = scene.load(REPO / "scenarios" / "paper_setA_lead_crowned.toml", dims=3)
    model = lineload3d.lineload_model(spec, layers=3, level=-2)
    torques = [150.0, 350.0]
    with tempfile.TemporaryDirectory() as wd:
        r = model.solve_position(model3d.Case3D(), 0, 8, torques, wd)
    rb1, b = model.pair.g1.rb, model.pair.g1.b
    checks = lineload3d.check("smoke", [r], rb1, {})
    print(checks)
    assert checks["moment_sum_vs_torque_max_rel"] <= 1e-4
    assert abs(checks["force_sum_vs_T_over_rb1_worst_rel"]) <= 1e-3
    assert lineload3d.binnings(3) == [3, 1]
    for ti, T in enumerate(torques):
        bins = lineload3d.bin_loads(r.layer_force_N[ti], 3, 3, b)
        q = max((v[1] for v in bins.values()), key=lambda q: q.sum())
        average = T / rb1 / b
        print(f"{T:g} N m: line load per layer {q.round(0)} N/m, face average {average:.0f}")
        assert q[1] > 1.1 * max(q[0], q[2])
        assert q[0] == pytest.approx(q[2], rel=2e-2)
        whole = lineload3d.bin_loads(r.layer_force_N[ti], 3, 1, b)
        top, tooth, _ = lineload3d.peak(whole)
        assert top == pytest.approx(average, rel=1e-3) and tooth == "0"
    assert all(math.isfinite(t) and t > 0 for t in r.te)
