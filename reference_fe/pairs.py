"""python -m reference_fe pairs SCENE [SCENE ...] --out DIR: the load on each of gear 1's contact
teeth in the 2-D base cases (reference_fe/README.md, "Load share and peak line load").

Each ccx deck prints the total contact force on each of gear 1's contact teeth (one slave
surface per tooth, ccx.write_deck) and its moment about gear 1's axis. Per scene it writes
DIR/<scene>.reference_fe.pairs.csv (per model, torque, position and tooth: the force and the
moment; the position's TE beside them) and DIR/<scene>.reference_fe.pairs.json (provenance,
the checks below, cost). Checks, written into the JSON and refused when they fail:
* the teeth's moments add up to the torque (equilibrium of gear 1: within 1e-4);
* where DIR holds the scene's committed TE (<scene>.reference_fe.te.csv of `run`), the TE of
  these runs equals it within TE_TOLERANCE. Not to 1e-15: splitting the slave surface per tooth
  moves ccx's surface-to-surface solution. Measured on set A, both models, 20 positions, 50-350
  N m: the split runs' TE is 0.07-0.69 % larger (mean 0.17 %; the largest at position 17, 50 N m,
  where the second pair takes over), the same at position 10 with ccx's residual tolerance
  tightened from 5e-3 to 1e-5 (so not its convergence); the mesh study's level 0 -> 1 change is
  0.16 % at 50 N m, the band between the two models 6-7 %.
The product compares its mesh.max_load_share with the largest tooth force's share, and that
share of its normal force over the face width with the largest tooth force over the face width
(python/gearmesh/accuracy/reference.py).
"""
from __future__ import annotations

import csv
import pathlib
import time

from . import analysis, scene
from .report import _cost, _g, provenance, write_provenance

MOMENT_TOLERANCE = 1e-4  # relative: the teeth's moments against the torque
TE_TOLERANCE = 1e-2      # relative: against the committed TE of the same case and position


def _committed_te(path: pathlib.Path) -> dict:
    """(model, torque, position, n) -> TE of the base cases (mesh level 0) of a run's te.csv."""
    if not path.is_file():
        return {}
    with open(path) as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return {(r["model"], float(r["torque_Nm"]), int(r["position"]), int(r["n_positions"])):
                float(r["te_m"]) for r in rows if r["mesh_level"] == "0"}


def check(name: str, results: dict, committed: dict) -> dict:
    """The equilibrium and TE checks of the runs (model -> [PositionResult]); raises on a
    failure, else returns the worst figures."""
    worst_moment = worst_te = 0.0
    compared = 0
    for model, res in results.items():
        for r in res:
            for T, te, moments in zip(r.torques, r.te, r.pair_moment_Nm):
                total = abs(sum(moments.values()))
                worst_moment = max(worst_moment, abs(total - T) / T)
                key = (model, T, r.position, r.n_positions)
                if key in committed:
                    worst_te = max(worst_te, abs(te - committed[key]) / abs(committed[key]))
                    compared += 1
    if worst_moment > MOMENT_TOLERANCE:
        raise RuntimeError(f"{name}: the teeth's contact moments miss the torque by "
                           f"{worst_moment:.2e} (allowed {MOMENT_TOLERANCE:g})")
    if worst_te > TE_TOLERANCE:
        raise RuntimeError(f"{name}: TE differs from the committed te.csv by {worst_te:.2e} "
                           f"relative (allowed {TE_TOLERANCE:g})")
    return {"moment_sum_vs_torque_max_rel": worst_moment, "te_vs_committed_max_rel": worst_te,
            "te_compared": compared}


def run_scene(path, out_dir, n, models, torques, cache, log, margin=analysis.CONTACT_MARGIN):
    spec = scene.load(path)
    t_start = time.time()
    model = analysis.Model(spec, 0, margin=margin)
    results = {m: analysis.run_case(spec, model, analysis.Case(model=m), range(n), n, torques,
                                    cache, log) for m in models}
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{spec.name}.reference_fe"
    checks = check(spec.name, results, _committed_te(out_dir / f"{stem}.te.csv"))
    with open(out_dir / f"{stem}.pairs.csv", "w", newline="") as f:
        f.write(f"# contact force per gear-1 tooth of {pathlib.Path(path).name}: python -m "
                "reference_fe pairs (reference_fe/README.md); regenerate only on purpose\n")
        w = csv.writer(f)
        w.writerow(["scene", "model", "torque_Nm", "position", "n_positions", "gear1_angle_rad",
                    "te_m", "tooth", "force_N", "moment_Nm", "line_load_N_per_m"])
        b = model.pair.g1.b  # 2-D: the force spreads evenly over the face width
        for m, res in results.items():
            for r in sorted(res, key=lambda r: r.position):
                for T, te, forces, moments in zip(r.torques, r.te, r.pair_force_N,
                                                  r.pair_moment_Nm):
                    for tooth in forces:
                        w.writerow([spec.name, m, f"{T:g}", r.position, n, _g(r.dphi1), _g(te),
                                    tooth, _g(forces[tooth]), _g(moments[tooth]),
                                    _g(forces[tooth] / b)])
    prov = {**provenance(spec.name, path),
            "model": {"description": "the base cases of `run` (2-D, both complete gears, "
                                     "level 0, default penalty, frictionless) with one slave "
                                     "surface per gear-1 contact tooth; *CONTACT PRINT CF",
                      "face_width_m": model.pair.g1.b, "positions": n, "torques_Nm": torques},
            "checks": checks,
            "cost": {m: _cost(res) for m, res in results.items()},
            "elapsed_s_this_invocation": time.time() - t_start}
    write_provenance(out_dir / f"{stem}.pairs.json", prov)
    log(f"wrote {out_dir / stem}.pairs.csv, .pairs.json ({checks})")


def add_parser(sub):
    p = sub.add_parser("pairs", help="contact force on each of gear 1's contact teeth (2-D)")
    p.add_argument("scenes", nargs="+")
    p.add_argument("--out", required=True)
    p.add_argument("--positions", type=int, default=20)
    p.add_argument("--models", default="plane_strain,plane_stress")
    p.add_argument("--torques", default="50,150,250,350", help="N m")
    p.add_argument("--cache", default=None, help="directory of finished runs (default: temp)")
    p.add_argument("--contact-margin", type=float, default=analysis.CONTACT_MARGIN,
                   help="as `run`'s: the committed te.csv's own (the ring's 0.5)")
    return p


def main(a, log):
    models = a.models.split(",")
    for m in models:
        if m not in analysis.MODELS:
            raise SystemExit(f"--models: {m!r}; allowed: {', '.join(analysis.MODELS)}")
    torques = [float(t) for t in a.torques.split(",")]
    if not (0 <= a.contact_margin <= 2):
        raise SystemExit(f"--contact-margin {a.contact_margin}; allowed: 0 .. 2 (base pitches)")
    for s in a.scenes:
        run_scene(s, a.out, a.positions, models, torques, a.cache, log, margin=a.contact_margin)
