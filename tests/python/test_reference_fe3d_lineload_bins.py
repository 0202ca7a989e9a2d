"""The reduction of reference_fe/lineload3d.py (no ccx): per-layer contact forces of a tooth into
bins across the face, the peak, the checks that refuse an unbalanced run, the bin-size
sensitivity and the layer study, on made-up forces whose answers are known."""
from __future__ import annotations

import math

import pytest


from reference_fe import lineload3d  # noqa: E402
from reference_fe.analysis import PositionResult  # noqa: E402

RB1 = 0.07
B = 0.02


def layers(forces, direction=(0.6, 0.8, 0.0)):
    """layer -> [fx, fy, fz, mz] for normal forces along `direction` with lever arm RB1."""
    return {str(j): [f * direction[0], f * direction[1], f * direction[2], f * RB1]
            for j, f in enumerate(forces)}


def result(position, per_torque, torques=(150.0,)):
    """A PositionResult whose gear-1 tooth "0" carries per_torque[i] (layer -> force)."""
    return PositionResult(position=position, n_positions=8, dphi1=0.0, te=[1e-6] * len(torques),
                          torques=list(torques), wall_s=1.0, max_rss_MiB=1.0,
                          layer_force_N=[{"0": t} if t else {} for t in per_torque])


def test_binnings_and_bins():
    assert lineload3d.binnings(10) == [10, 5, 2, 1]
    assert lineload3d.binnings(3) == [3, 1]
    teeth = {"0": layers([100, 300, 500, 100]), "56": layers([0, 50, 50, 0])}
    bins = lineload3d.bin_loads(teeth, 4, 2, B)
    force, q, moment = bins["0"]
    assert force == pytest.approx([400, 600]) and q == pytest.approx([400 / 0.01, 600 / 0.01])
    assert moment == pytest.approx([400 * RB1, 600 * RB1])
    assert lineload3d.peak(bins) == (pytest.approx(6e4), "0", 1)
    assert lineload3d.peak(lineload3d.bin_loads(teeth, 4, 4, B)) == (pytest.approx(1e5), "0", 2)
    with pytest.raises(ValueError, match="3 bins do not divide 4 layers"):
        lineload3d.bin_loads(teeth, 4, 3, B)


def test_bins_add_forces_as_vectors():
    """Two layers pushing in different directions: the bin's force is the vector sum."""
    teeth = {"0": {"0": [100.0, 0.0, 0.0, 0.0], "1": [0.0, 100.0, 0.0, 0.0]}}
    force, _, _ = lineload3d.bin_loads(teeth, 2, 1, B)["0"]
    assert force == pytest.approx([100 * math.sqrt(2)])


def test_checks_refuse_unbalanced_runs():
    T = 150.0
    balanced = layers([T / RB1 / 4] * 4)
    checks = lineload3d.check("s", [result(0, [balanced])], RB1, {(T, 0, 8): 1e-6 / 1.01})
    assert checks["moment_sum_vs_torque_max_rel"] == pytest.approx(0, abs=1e-12)
    assert checks["force_sum_vs_T_over_rb1_worst_rel"] == pytest.approx(0, abs=1e-12)
    assert checks["te_vs_committed_base_rel"]["max"] == pytest.approx(0.01)
    short = layers([T / RB1 / 4] * 3)                    # a layer's force lost
    with pytest.raises(RuntimeError, match="moments miss the torque"):
        lineload3d.check("s", [result(0, [short])], RB1, {})
    tilted = {k: [v[0] * 1.01, v[1] * 1.01, v[2], v[3]] for k, v in balanced.items()}
    with pytest.raises(RuntimeError, match="forces miss T / r_b1"):
        lineload3d.check("s", [result(0, [tilted])], RB1, {})
    with pytest.raises(RuntimeError, match="no per-layer contact forces"):
        lineload3d.check("s", [result(0, [{}])], RB1, {})


def test_summary_sensitivity_and_layer_study():
    T = 150.0
    crowned = layers([50, 200, 250, 300, 250, 200])      # 6 layers, peak in layer 3
    flat = layers([150] * 6)
    res = [result(0, [crowned]), result(1, [flat])]
    summary = lineload3d.summarize(res, [T], 6, B, RB1)
    by_bins = {s["bins"]: s for s in summary}
    assert sorted(by_bins) == [1, 2, 3, 6]
    assert by_bins[6]["peak_N_per_m"] == pytest.approx(300 / (B / 6))
    assert by_bins[6]["at"] == {"position": 0, "peak_N_per_m": pytest.approx(300 / (B / 6)),
                                "tooth": "0", "bin": 3}
    assert by_bins[3]["peak_N_per_m"] == pytest.approx(550 / (B / 3))
    sens, = lineload3d.sensitivity(summary, 6)
    assert sens["change"] == pytest.approx(550 / 2 / 300 - 1)
    assert lineload3d.sensitivity(summary, 3) == []
    # 12 layers of the crowned case, each layer split evenly: the same bins, change 0
    fine = layers([f / 2 for f in (50, 200, 250, 300, 250, 200) for _ in (0, 1)])
    rows = lineload3d.layer_study(res, [result(0, [fine])], [T], 6, 12, B)
    assert [r["bins"] for r in rows] == [[6, 6], [3, 3], [2, 2], [1, 1], [6, 12]]
    assert all(r["change"] == pytest.approx(0, abs=1e-12) for r in rows[:4])
    assert rows[4]["change"] == pytest.approx(0)          # halves of a layer: the same peak
    sharp = layers([f * s for f in (50, 200, 250, 300, 250, 200) for s in (0.4, 0.6)])
    rows = lineload3d.layer_study(res, [result(0, [sharp])], [T], 6, 12, B)
    assert rows[4]["peaks_N_per_m"][1] == pytest.approx(0.6 * 300 / (B / 12))
    assert rows[4]["change"] == pytest.approx(0.2)
