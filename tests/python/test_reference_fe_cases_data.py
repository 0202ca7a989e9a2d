"""The committed CalculiX references of set B in 3-D, the internal ring (2-D), the lightweight
body (3-D, whole gears) and the sector study (reference_fe/README.md), read without
reference_fe's code: each summary is the mean, p-p and mesh orders 1-3 of its own per-position
file; the convergence figures stay those the README states; and checks from outside the model:
plane stress softer than plane strain everywhere, whole gears softer than held sectors, the
3-D sectors against the committed 2-D band at the same positions. A file regenerated with
another mesh, a corrupted or mismatched file, or a model change that moved the references
fails here."""
from __future__ import annotations

import csv
import json
import math
import pathlib

import numpy as np
import pytest
from conftest import REPO

REF = REPO / "scenarios" / "reference"


def rows(path: pathlib.Path) -> list[dict]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


def base_curves(stem: str) -> dict[tuple[str, float], np.ndarray]:
    """(model, torque) -> TE at positions 0..n-1 of the base case (3-D: the case "base" at its
    own mesh level; 2-D: mesh level 0)."""
    out: dict = {}
    for r in rows(REF / f"{stem}.te.csv"):
        if r.get("case", "base") != "base" or ("case" not in r and r["mesh_level"] != "0"):
            continue
        out.setdefault((r["model"], float(r["torque_Nm"])), {})[int(r["position"])] = float(r["te_m"])
    curves = {}
    for key, by in out.items():
        n = len(by)
        assert sorted(by) == list(range(n)), (stem, key)
        curves[key] = np.array([by[k] for k in range(n)])
    return curves


@pytest.mark.parametrize("stem", ["paper_setB_P1P2.reference_fe3d", "internal_ring_fe.reference_fe",
                                  "lightweight_vs_solid_fe.reference_fe3d"])
def test_summary_is_its_per_position_file(stem):
    """mean, p-p and the amplitudes 2|X_k|/n of mesh orders 1-3 of the per-position TE."""
    curves = base_curves(stem)
    summary = [r for r in rows(REF / f"{stem}.summary.csv") if r.get("case", "base") == "base"]
    assert {(r["model"], float(r["torque_Nm"])) for r in summary} == set(curves)
    for r in summary:
        te = curves[(r["model"], float(r["torque_Nm"]))]
        assert int(r["n_positions"]) == len(te) >= 8
        X = np.fft.rfft(te)
        want = {"mean_te_m": te.mean(), "pp_te_m": te.max() - te.min(),
                **{f"order{k}_m": 2 * abs(X[k]) / len(te) for k in (1, 2, 3)}}
        for col, v in want.items():
            assert float(r[col]) == pytest.approx(v, rel=1e-9, abs=1e-15), (stem, col)
        assert np.all(te > 0)


def study(stem: str, label: str) -> dict:
    """A 3-D study's relative change of the TE at its position, per torque."""
    j = json.loads((REF / f"{stem}.json").read_text())
    return {c["torque_Nm"]: c["mean_change"] for c in j["studies"][label]["changes"]}


def test_set_b_3d_convergence_and_the_2d_band():
    """Set B in 3-D (120 deg sectors): the mesh study at position 0 as the README states it
    (level 0 -> +1: +3.8 % at 150 N m, +0.7 % at 350 N m; -1 -> 0 within 11 %), and at the
    positions both files share, the 3-D TE 0.85-0.95 of the committed 2-D plane strain TE:
    stiffer, as set A's 3-D sectors are (0.83-0.90, the held cut faces), and the same at
    every position within 4 points (a 3-D model of another pair, load or position would not)."""
    stem = "paper_setB_P1P2.reference_fe3d"
    fine = study(stem, "mesh+1")
    assert abs(fine[150.0]) < 0.05 and abs(fine[350.0]) < 0.01
    assert all(abs(v) < 0.11 for v in study(stem, "mesh-1").values())
    c3 = base_curves(stem)
    c2 = base_curves("paper_setB_P1P2.reference_fe")
    for T in (150.0, 350.0):
        ratio = [c3[("3d_spur", T)][k] / c2[("plane_strain", T)][k * 20 // 8] for k in (0, 2, 4, 6)]
        assert 0.85 < min(ratio) and max(ratio) < 0.95, (T, ratio)
        assert max(ratio) - min(ratio) < 0.04, (T, ratio)


def test_ring_2d_band_and_convergence():
    """The internal ring (2-D): plane stress softer than plane strain at every position and
    torque (E' < E: the band is ordered everywhere, as the equivalence requires); the mesh and
    penalty studies as the README states them (level 0 -> 1: mean within 0.2 %, p-p within 0.4 %
    of the mean; penalty x10: mean -0.8 to -1.0 %); at mid-pitch (two pairs on the path, no
    tip-corner contact) the TE nearly linear in the torque (20 -> 100 N m: exponent 0.9-1.02,
    bending linear, Hertz slightly sub-linear)."""
    stem = "internal_ring_fe.reference_fe"
    c = base_curves(stem)
    for T in (20.0, 50.0, 100.0):
        assert np.all(c[("plane_stress", T)] > c[("plane_strain", T)]), T
    n = math.log(c[("plane_strain", 100.0)][10] / c[("plane_strain", 20.0)][10]) / math.log(5.0)
    assert 0.9 < n < 1.02, n
    s = json.loads((REF / f"{stem}.json").read_text())["studies"]["plane_strain"]
    for ch in s["mesh_convergence"]["changes_level0_to_1"]:
        assert abs(ch["mean_change"]) < 0.002 and abs(ch["pp_change_of_mean"]) < 0.004, ch
    for ch in s["penalty"]["changes"]:
        assert -0.011 < ch["mean_change"] < -0.007, ch
    assert json.loads((REF / f"{stem}.json").read_text())["model"]["internal"] is True


def test_sector_study_whole_gears_are_softer():
    """Set A's sector study: at each of its positions and torques the whole gears' TE exceeds the
    120 deg sectors' (held cut faces stiffen a sector; a whole gear has none), and the
    difference is a body compliance, so nearly proportional to the torque (difference / torque
    equal at both torques within 10 %); the sector rows reproduce the committed run3d base
    within 0.5 % (the same model, but the slave surface now split per tooth, README)."""
    data = rows(REF / "paper_setA_3U4U.reference_fe3d.sector.csv")
    te = {(float(r["sector_deg"]), float(r["torque_Nm"]), int(r["position"])): float(r["te_m"])
          for r in data}
    positions = sorted({k for _, _, k in te})
    base = base_curves("paper_setA_3U4U.reference_fe3d")
    for k in positions:
        d = {T: te[(360.0, T, k)] - te[(120.0, T, k)] for T in (150.0, 350.0)}
        assert d[150.0] > 0 and d[350.0] > 0, (k, d)
        assert d[350.0] / 350.0 == pytest.approx(d[150.0] / 150.0, rel=0.10), (k, d)
        for T in (150.0, 350.0):
            assert te[(120.0, T, k)] == pytest.approx(base[("3d_spur", T)][k], rel=0.005)


def test_lightweight_whole_gears():
    """The lightweight body (whole gears, web 6 mm of 23 mm, 19 holes): the model of whole
    gears (no sector bias); the TE linear in the torque at every position (100 -> 300 N m:
    exponent 0.95-1.02; the web's bending and twist are linear, and they dominate); at the pitch
    point more than 1.5 x as compliant per N m as set A's whole solid gears (the sector study's
    run; the same teeth, a web instead of a disc); the mesh study at position 0 as the README
    states it (level -1 against -2: -2.1 / -1.9 %, against 0: +1.0 / +0.7 %, so converging
    from below)."""
    stem = "lightweight_vs_solid_fe.reference_fe3d"
    c = base_curves(stem)
    (model,) = {m for m, _ in c}
    assert model == "3d_spur_whole"
    n = np.log(c[(model, 300.0)] / c[(model, 100.0)]) / math.log(3.0)
    assert np.all((0.95 < n) & (n < 1.02)), n
    sector = {(float(r["sector_deg"]), float(r["torque_Nm"]), int(r["position"])): float(r["te_m"])
              for r in rows(REF / "paper_setA_3U4U.reference_fe3d.sector.csv")}
    assert c[(model, 100.0)][0] / 100.0 > 1.5 * sector[(360.0, 150.0, 0)] / 150.0
    coarse, fine = study(stem, "mesh-1"), study(stem, "mesh+1")
    assert all(-0.03 < v < -0.01 for v in coarse.values()), coarse
    assert all(0.005 < v < 0.015 for v in fine.values()), fine
