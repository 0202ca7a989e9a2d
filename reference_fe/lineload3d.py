"""python -m reference_fe lineload3d SCENE[:T1,T2] ... --out DIR: the contact line load across the
face in the 3-D model (reference_fe/README.md, "3-D line load").

The 3-D base model of run3d (model3d: 120 deg sectors, level 0, penalty 1e16 Pa/m,
frictionless, n positions over one base pitch, the torques as load steps of one ccx run) with

* `layers` element layers over the face width (default: the scene's `[model] slices`, the
  product's slices, so that a layer is a product slice: like with like), and
* gear 1's slave surface split per contact tooth and element layer (FLANK1_T<k>_Z<j>), each
  with `*CONTACT PRINT ... CF`: the total contact force on that tooth's faces in that layer,
  i.e. the contact pressure integrated over the layer's part of the flank (ccx's own
  integration of its surface-to-surface contact).

The line load of a tooth in a bin of face width w (one layer, or `merge` adjacent layers) is
|the vector sum of its layers' forces| / w (N/m): the force per unit face length, summed over the
tooth's profile. Per position and torque the peak is the largest over the bins and the teeth;
per torque the largest over the positions. Binnings: every divisor of `layers` (bins of 1, 2, 5,
10 layers for 10 layers), so that a product run with 1, 2, 5 or 10 slices has its like.

Checks (written into the JSON; refused when they fail):
* the layers' moments about gear 1's axis add up to the torque (equilibrium: MOMENT_TOLERANCE);
* the integral of the line load over the face and the teeth (the sum of the bins' forces) equals
  the total normal force T / r_b1 within FORCE_TOLERANCE (a spur pair's contact normal lies on
  the line of action only up to tip-corner contact and the lead crowning's tilt);
and the bin-size sensitivity of the peak (one layer against two), the TE against the committed
run3d base (6 layers; not refused: a different mesh). --study-layers N: the study positions
again with N layers, the peak at the bin counts both share (the mesh across the face) and at
N bins against the base's finest (the bin width).

Writes DIR/<scene>.reference_fe3d.lineload.csv (per binning, torque, position, tooth and bin:
z range, force, moment about gear 1's axis, line load) and DIR/<scene>.reference_fe3d.lineload.json (provenance, mesh,
binning, summary, checks, cost). Regenerate only on purpose.
"""
from __future__ import annotations

import csv
import dataclasses
import math
import pathlib
import time

import numpy as np

from . import analysis, mesh3d, model3d, scene
from .report import THREADS, _cost, _g, provenance, write_provenance
from .run3d import SECTOR_DEG, add_scene_arguments, parse_scene_arg

MOMENT_TOLERANCE = 1e-4  # relative: the layers' contact moments against the torque
# relative: the sum of the layers' forces against T / r_b1; measured on set A crowned (8
# positions, 150 / 350 N m): worst +0.24 % (tip-corner contact off the line of action), mean
# +0.015 %
FORCE_TOLERANCE = 5e-3


def binnings(layers: int) -> list[int]:
    """The bin counts over the face: the divisors of `layers`, most bins first."""
    return [n for n in range(layers, 0, -1) if layers % n == 0]


def bin_loads(teeth: dict, layers: int, bins: int, face_width: float) -> dict:
    """teeth: tooth -> layer -> [fx, fy, fz, mz] (PositionResult.layer_force_N of one torque).
    Returns tooth -> (forces N, line loads N/m, moments about gear 1's axis N m) per bin, bin 0
    at z = -b/2: the vector sum of the bin's layers' forces, its magnitude over the bin's
    width, the sum of their moments."""
    merge = layers // bins
    if merge * bins != layers:
        raise ValueError(f"{bins} bins do not divide {layers} layers")
    width = face_width / bins
    out = {}
    for tooth, by_layer in teeth.items():
        f = np.zeros((layers, 4))
        for j, v in by_layer.items():
            f[int(j)] = v
        f = f.reshape(bins, merge, 4).sum(axis=1)
        force = np.linalg.norm(f[:, :3], axis=1)
        out[tooth] = (force, force / width, f[:, 3])
    return out


def peak(teeth_bins: dict) -> tuple[float, str, int]:
    """(largest line load, its tooth, its bin) over the teeth and bins of bin_loads."""
    best = (-1.0, "", -1)
    for tooth, (_, q, _) in teeth_bins.items():
        j = int(np.argmax(q))
        if q[j] > best[0]:
            best = (float(q[j]), tooth, j)
    return best


def lineload_model(spec, layers: int | None = None, level: int = 0) -> model3d.Model3D:
    """run3d's base model (level 0) with `layers` layers (default: the scene's slices, else the
    mesh default) and gear 1's slave surface split per tooth and layer."""
    size = mesh3d.default_size(spec.module, spec.gear1.face_width, level,
                               math.radians(SECTOR_DEG))
    size = dataclasses.replace(size, layers=layers or spec.slices or size.layers)
    return model3d.Model3D(spec, level, SECTOR_DEG, size=size, split_layers=True)


def _committed_te(path: pathlib.Path) -> dict:
    """(torque, position, n) -> TE of the committed run3d base case; {} without the file."""
    if not path.is_file():
        return {}
    with open(path) as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return {(float(r["torque_Nm"]), int(r["position"]), int(r["n_positions"])):
                float(r["te_m"]) for r in rows if r["case"] == "base"}


def check(name: str, res, rb1: float, committed: dict) -> dict:
    """The equilibrium and force checks over every position and torque (refused beyond the
    tolerances), the worst figures and the TE against the committed base."""
    moment, force, te_diff = [], [], []
    for r in res:
        for T, te, teeth in zip(r.torques, r.te, r.layer_force_N):
            if not teeth:
                raise RuntimeError(f"{name}: position {r.position}: no per-layer contact forces")
            mz = sum(v[3] for layers in teeth.values() for v in layers.values())
            moment.append(abs(abs(mz) - T) / T)
            total = sum(float(np.linalg.norm(v[:3])) for layers in teeth.values()
                        for v in layers.values())
            force.append((total - T / rb1) / (T / rb1))
            key = (T, r.position, r.n_positions)
            if key in committed:
                te_diff.append(te / committed[key] - 1)
    worst_m, worst_f = max(moment), max(force, key=abs)
    if worst_m > MOMENT_TOLERANCE:
        raise RuntimeError(f"{name}: the layers' contact moments miss the torque by "
                           f"{worst_m:.2e} (allowed {MOMENT_TOLERANCE:g})")
    if abs(worst_f) > FORCE_TOLERANCE:
        raise RuntimeError(f"{name}: the layers' contact forces miss T / r_b1 by {worst_f:.2e} "
                           f"(allowed {FORCE_TOLERANCE:g})")
    out = {"moment_sum_vs_torque_max_rel": worst_m, "moment_tolerance": MOMENT_TOLERANCE,
           "force_sum_vs_T_over_rb1_worst_rel": worst_f,
           "force_sum_vs_T_over_rb1_mean_rel": float(np.mean(force)),
           "force_tolerance": FORCE_TOLERANCE,
           "force_sum_note": "sum over teeth and layers of |layer force| (the integral of the "
                             "line load over the face and teeth at the finest binning) against "
                             "T / r_b1"}
    if te_diff:
        out["te_vs_committed_base_rel"] = {"min": min(te_diff), "max": max(te_diff),
                                           "compared": len(te_diff)}
    return out


def summarize(res, torques, layers: int, b: float, rb1: float) -> list[dict]:
    """Per binning and torque: the peak over the positions (its position, tooth and bin) and
    the peak per position; with the face average T / (r_b1 b) for scale."""
    out = []
    for bins in binnings(layers):
        for ti, T in enumerate(torques):
            per_pos = []
            for r in sorted(res, key=lambda r: r.position):
                q, tooth, j = peak(bin_loads(r.layer_force_N[ti], layers, bins, b))
                per_pos.append({"position": r.position, "peak_N_per_m": q, "tooth": tooth,
                                "bin": j})
            top = max(per_pos, key=lambda p: p["peak_N_per_m"])
            out.append({"bins": bins, "bin_width_m": b / bins, "torque_Nm": T,
                        "peak_N_per_m": top["peak_N_per_m"], "at": top,
                        "face_average_N_per_m": T / rb1 / b,
                        "peak_over_face_average": top["peak_N_per_m"] / (T / rb1 / b),
                        "per_position": per_pos})
    return out


def sensitivity(summary: list[dict], layers: int) -> list[dict]:
    """The peak at bins of two layers against bins of one layer, per torque."""
    if layers % 2:
        return []
    one = {s["torque_Nm"]: s["peak_N_per_m"] for s in summary if s["bins"] == layers}
    two = {s["torque_Nm"]: s["peak_N_per_m"] for s in summary if s["bins"] == layers // 2}
    return [{"torque_Nm": T, "bins": [layers, layers // 2], "peaks_N_per_m": [one[T], two[T]],
             "change": two[T] / one[T] - 1} for T in sorted(one)]


def layer_study(base, study, torques, layers: int, study_layers: int, b: float) -> list[dict]:
    """The peak at the study positions with `study_layers` layers against the base's `layers`:
    at every bin count of the base that the study's layers divide into too (the mesh), and the
    study's finest bins (one per study layer) against the base's (the bin width)."""
    out = []
    by_position = {r.position: r for r in base}
    for r in study:
        pairs = [(bins, bins) for bins in binnings(layers) if study_layers % bins == 0]
        for bins0, bins1 in pairs + [(layers, study_layers)]:
            for ti, T in enumerate(torques):
                q0 = peak(bin_loads(by_position[r.position].layer_force_N[ti], layers, bins0,
                                    b))[0]
                q1 = peak(bin_loads(r.layer_force_N[ti], study_layers, bins1, b))[0]
                out.append({"position": r.position, "torque_Nm": T, "bins": [bins0, bins1],
                            "layers": [layers, study_layers], "peaks_N_per_m": [q0, q1],
                            "change": q1 / q0 - 1,
                            "te_m": [by_position[r.position].te[ti], r.te[ti]]})
    return out


def run_scene(path, torques, out_dir, n, layers, cache, log, study_layers=0,
              study_positions=(0,)):
    spec = scene.load(path, dims=3)
    t_start = time.time()
    model = lineload_model(spec, layers)
    layers = model.size.layers
    res = analysis.run_case(spec, model, model3d.Case3D(), range(n), n, torques, cache, log)
    studies = {}
    if study_layers:
        fine = lineload_model(spec, study_layers)
        res_s = analysis.run_case(spec, fine, model3d.Case3D(), study_positions, n, torques,
                                  cache, log)
        studies[f"layers{study_layers}"] = {
            "positions": list(study_positions), "mesh": fine.stats(), "cost": _cost(res_s),
            "peaks": layer_study(res, res_s, torques, layers, study_layers, model.pair.g1.b)}
    pr = model.pair
    b, rb1 = pr.g1.b, pr.g1.rb
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{spec.name}.reference_fe3d"
    checks = check(spec.name, res, rb1, _committed_te(out_dir / f"{stem}.te.csv"))
    summary = summarize(res, torques, layers, b, rb1)
    checks["bin_sensitivity"] = sensitivity(summary, layers)
    with open(out_dir / f"{stem}.lineload.csv", "w", newline="") as f:
        f.write(f"# 3-D FE contact line load across the face of {pathlib.Path(path).name}: "
                "python -m reference_fe lineload3d (reference_fe/README.md, '3-D line load'); "
                "regenerate only on purpose\n")
        w = csv.writer(f)
        w.writerow(["scene", "model", "torque_Nm", "position", "n_positions", "gear1_angle_rad",
                    "te_m", "bins", "bin_width_m", "tooth", "bin", "z_low_m", "z_high_m",
                    "force_N", "moment_Nm", "line_load_N_per_m"])
        for bins in binnings(layers):
            for r in sorted(res, key=lambda r: r.position):
                for ti, T in enumerate(r.torques):
                    for tooth, (force, q, mz) in bin_loads(r.layer_force_N[ti], layers, bins,
                                                           b).items():
                        for j in range(bins):
                            w.writerow([spec.name, f"3d_{model.variant}", f"{T:g}", r.position,
                                        n, _g(r.dphi1), _g(r.te[ti]), bins, _g(b / bins), tooth,
                                        j, _g(-b / 2 + j * b / bins),
                                        _g(-b / 2 + (j + 1) * b / bins), _g(force[j]),
                                        _g(mz[j]), _g(q[j])])
    prov = {
        **provenance(spec.name, path),
        "model": {"description": "run3d's base model (120 deg sectors, mesh level 0, penalty "
                                 "1e16 Pa/m, frictionless) with `layers` element layers over the "
                                 "face and gear 1's slave surface split per contact tooth and "
                                 "layer, *CONTACT PRINT CF per layer (reference_fe/lineload3d.py)",
                  "variant": model.variant, "positions": n, "torques_Nm": list(torques),
                  "face_width_m": b, "base_radius_gear1_m": rb1},
        "binning": {"layers": layers, "layer_width_m": b / layers,
                    "bins": binnings(layers),
                    "z": "from mid-face, bin 0 at z = -b/2; the scene's face width",
                    "line_load": "per tooth and bin: |vector sum of the bin's layer contact "
                                 "forces| / bin width (N/m), summed over the tooth's profile; "
                                 "peak = largest over bins and teeth",
                    "layers_from": "--layers" if layers != spec.slices else "the scene's "
                                   "[model] slices (the product's slice width)"},
        "mesh": model.stats(),
        "summary": summary,
        "checks": checks,
        "studies": studies,
        "cost": _cost(res),
        "elapsed_s_this_invocation": time.time() - t_start,
        "threads": THREADS,
    }
    write_provenance(out_dir / f"{stem}.lineload.json", prov)
    log(f"wrote {out_dir / stem}.lineload.csv, .lineload.json")
    for s in summary:
        log(f"{spec.name} {s['torque_Nm']:g} N m, {s['bins']} bins: peak "
            f"{s['peak_N_per_m']:.4g} N/m ({s['peak_over_face_average']:.3f} x face average) "
            f"at position {s['at']['position']}, tooth {s['at']['tooth']}, bin {s['at']['bin']}")
    log(f"checks: {checks}")
    for label, st in studies.items():
        for row in st["peaks"]:
            log(f"study {label}: position {row['position']}, {row['torque_Nm']:g} N m, "
                f"{row['layers']} layers, {row['bins']} bins: peak {row['peaks_N_per_m'][0]:.4g} -> "
                f"{row['peaks_N_per_m'][1]:.4g} N/m ({100 * row['change']:+.2f} %)")


def add_parser(sub):
    p = sub.add_parser("lineload3d", help="3-D contact line load across the face (CalculiX)")
    add_scene_arguments(p)
    p.add_argument("--layers", type=int, default=0,
                   help="element layers over the face (0: the scene's [model] slices)")
    p.add_argument("--study-layers", type=int, default=0,
                   help="a layer study: this many layers at the study positions (0: none)")
    p.add_argument("--study-positions", default="0", help="positions of the layer study")
    return p


def main(a, log):
    default = [float(t) for t in a.torques.split(",")]
    for arg in a.scenes:
        path, torques = parse_scene_arg(arg, default)
        run_scene(path, torques, a.out, a.positions, a.layers or None, a.cache, log,
                  a.study_layers, [int(k) for k in a.study_positions.split(",") if k.strip()])
