"""python -m reference_fe run SCENE [SCENE ...] --out DIR: the 2-D FE reference of each scene
(python -m reference_fe run3d ...: the 3-D cases, run3d.py; lineload3d ...: the 3-D contact line
load across the face, lineload3d.py).

Per scene it writes DIR/<scene>.reference_fe.te.csv (TE per case, torque and position),
DIR/<scene>.reference_fe.summary.csv (mean, peak-to-peak, mesh orders 1-3 per case and torque)
and DIR/<scene>.reference_fe.json (provenance, mesh statistics, the mesh-convergence and
penalty studies, wall time and peak memory). Finished ccx runs are cached (--cache), so an
interrupted generation resumes where it stopped. Regenerate only on purpose.
"""
from __future__ import annotations

import argparse
import csv
import pathlib
import time

import numpy as np

from . import analysis, lineload3d, pairs, run3d, scene
from .report import THREADS, _changes, _cost, _g, provenance, write_provenance


def run_scene(path, out_dir, n, models, torques, study_every, study_models, friction, cache,
              penalty_factor, log, margin=analysis.CONTACT_MARGIN):
    spec = scene.load(path)
    t_start = time.time()
    base_model = analysis.Model(spec, 0, margin=margin)
    cases = {}   # label -> (Case, results)
    for model in models:
        case = analysis.Case(model=model, friction=friction)
        cases[f"{model}"] = (case, analysis.run_case(spec, base_model, case, range(n), n, torques,
                                                     cache, log))
    studies = {}
    fine_model = coarse_model = None
    subset = list(range(0, n, study_every)) if study_every else []
    for model in (study_models if subset else []):
        case0, res0 = cases[model]
        base_sub = [r for r in res0 if r.position in subset]
        stiff = analysis.Case(model=model, friction=friction,
                              penalty=analysis.DEFAULT_PENALTY * penalty_factor)
        res_k = analysis.run_case(spec, base_model, stiff, subset, n, torques, cache, log)
        if fine_model is None:
            fine_model = analysis.Model(spec, 1, margin=margin)
            coarse_model = analysis.Model(spec, -1, margin=margin)
        coarse = analysis.Case(model=model, level=-1, friction=friction)
        res_c = analysis.run_case(spec, coarse_model, coarse, subset, n, torques, cache, log)
        fine = analysis.Case(model=model, level=1, friction=friction)
        res_f = analysis.run_case(spec, fine_model, fine, subset, n, torques, cache, log)
        studies[model] = {
            "positions": subset,
            "mesh_convergence": {"levels": [-1, 0, 1],
                                 "changes_level0_to_1": _changes(base_sub, res_f, torques),
                                 "changes_level-1_to_0": _changes(res_c, base_sub, torques),
                                 "cost_level1": _cost(res_f), "cost_level-1": _cost(res_c)},
            "penalty": {"penalties_Pa_per_m": [case0.penalty, stiff.penalty],
                        "changes": _changes(base_sub, res_k, torques),
                        "cost_stiff": _cost(res_k)},
        }
    stem = f"{spec.name}.reference_fe"
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / f"{stem}.te.csv", "w", newline="") as f:
        f.write(f"# FE reference TE of {pathlib.Path(path).name}: python -m reference_fe run "
                "(reference_fe/README.md); regenerate only on purpose\n")
        w = csv.writer(f)
        w.writerow(["scene", "model", "mesh_level", "penalty_Pa_per_m", "friction", "torque_Nm",
                    "position", "n_positions", "gear1_angle_rad", "te_m"])
        for label, (case, res) in cases.items():
            for r in sorted(res, key=lambda r: r.position):
                for T, te in zip(r.torques, r.te):
                    w.writerow([spec.name, case.model, case.level, f"{case.penalty:.3g}",
                                case.friction, f"{T:g}", r.position, r.n_positions,
                                _g(r.dphi1), _g(te)])
    summaries = []
    with open(out_dir / f"{stem}.summary.csv", "w", newline="") as f:
        f.write("# per case and torque: mean, peak-to-peak and mesh orders 1-3 (amplitude) of "
                "the TE over one pitch\n")
        w = csv.writer(f)
        w.writerow(["scene", "model", "mesh_level", "penalty_Pa_per_m", "friction", "torque_Nm",
                    "n_positions", "mean_te_m", "pp_te_m", "order1_m", "order2_m", "order3_m"])
        for label, (case, res) in cases.items():
            for ti, T in enumerate(torques):
                s = analysis.summary(res, ti)
                summaries.append({"model": case.model, "torque_Nm": T, **s})
                w.writerow([spec.name, case.model, case.level, f"{case.penalty:.3g}",
                            case.friction, f"{T:g}", s["n_positions"], _g(s["mean_te_m"]),
                            _g(s["pp_te_m"]), _g(s["order1_m"]), _g(s["order2_m"]),
                            _g(s["order3_m"])])
    pr = base_model.pair
    teeth = analysis.fine_teeth(pr, margin=margin)[0]   # signed (the mesh holds them modulo z)
    contact_check = {label: analysis.contact_set_check(pr, teeth, res)
                     for label, (case, res) in cases.items()}
    for label, flagged in contact_check.items():
        for f in flagged:
            log(f"WARNING {spec.name} {label} position {f['position']}: the {f['end']} tooth "
                f"{f['tooth_gear1']}, left out of the contact set, has a corner gap of "
                f"{f['corner_gap_m'] * 1e6:.2f} um below the TE {f['te_m'] * 1e6:.2f} um: rerun "
                "with a larger --contact-margin to know whether it carries")
    prov = {
        **provenance(spec.name, path),
        "model": {
            "description": "2-D, both complete gears to the bore, CPE6 (plane stress by the "
                           "equivalent plane-strain material), gear 2's bore clamped, gear 1's "
                           "bore rigidly turning about its axis with the torque, "
                           "surface-to-surface penalty contact, linear pressure-overclosure"
                           + ("; gear 2 an internal ring from its teeth out to its outer "
                              "diameter, clamped there (bore_diameters_m: the ring's outer "
                              "diameter), its flank B in contact with the pinion's flank A"
                              if pr.internal else ""),
            "internal": pr.internal,
            "friction": friction,
            "penalty_Pa_per_m": analysis.DEFAULT_PENALTY,
            "engage_m": analysis.ENGAGE,
            "positions": n,
            "position_0": "flank A of tooth 0 of both gears touching at the pitch point "
                          "(unloaded, unmodified); gear1_angle_rad = gear 1's turn from there",
            "te": "r_b1 times gear 1's rotation past the rigid-body kinematic angle, "
                  "positive = approach on flank A",
            "bore_diameters_m": [2 * pr.g1.bore, 2 * pr.g2.bore],
            "base_radius_gear1_m": pr.g1.rb,
            "contact_ratio": pr.eps_alpha,
        },
        "mesh": {"level0": base_model.stats(),
                 "level1": fine_model.stats() if fine_model else None,
                 "level-1": coarse_model.stats() if coarse_model else None},
        "summary": summaries,
        "contact_set_check": contact_check,
        "studies": studies,
        "cost": {label: _cost(res) for label, (case, res) in cases.items()},
        "elapsed_s_this_invocation": time.time() - t_start,
        "threads": THREADS,
    }
    write_provenance(out_dir / f"{stem}.json", prov)
    log(f"wrote {out_dir / stem}.te.csv, .summary.csv, .json")


def _read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def compare(summary_csv, product_csv, teeth1: int, log=print):
    """The product's TE curve (columns torque_Nm, gear1_phi_rad, te_m over whole pitches,
    e.g. scenarios/<scene>.reference_te.csv) against the FE band: mean, p-p and mesh orders
    1-3 per torque, and the product's value relative to plane strain and plane stress."""
    fe = {}
    for r in _read_csv(summary_csv):
        if int(r["mesh_level"]) == 0:
            fe[(r["model"], float(r["torque_Nm"]))] = r
    prod = {}
    for r in _read_csv(product_csv):
        prod.setdefault(float(r["torque_Nm"]), []).append(
            (float(r["gear1_phi_rad"]), float(r["te_m"])))
    tau = 2 * np.pi / teeth1
    rows = []
    for T in sorted(prod):
        pts = sorted(prod[T])
        te = np.array([t for _, t in pts])
        pitches = round((pts[-1][0] - pts[0][0] + (pts[1][0] - pts[0][0])) / tau)
        X = np.fft.rfft(te)
        ours = {"mean_te_m": te.mean(), "pp_te_m": te.max() - te.min()}
        ours.update({f"order{k}_m": 2 * abs(X[k * pitches]) / len(te) for k in (1, 2, 3)})
        for q in ("mean_te_m", "pp_te_m", "order1_m", "order2_m", "order3_m"):
            band = [float(fe[(m, T)][q]) for m in analysis.MODELS if (m, T) in fe]
            if len(band) != 2:
                continue
            lo, hi = min(band), max(band)
            v = ours[q]
            where = "inside" if lo <= v <= hi else ("below" if v < lo else "above")
            rows.append((T, q, v, band[0], band[1], where))
            log(f"{T:6g} N m {q:10s} product {v * 1e6:8.4f} um  FE plane strain "
                f"{band[0] * 1e6:8.4f}  plane stress {band[1] * 1e6:8.4f}  -> {where} "
                f"({(v / band[0] - 1) * 100:+.1f} % / {(v / band[1] - 1) * 100:+.1f} %)")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m reference_fe")
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="TE of scene(s) by CalculiX, with the studies")
    r.add_argument("scenes", nargs="+")
    r.add_argument("--out", required=True)
    r.add_argument("--positions", type=int, default=20, help="positions per pitch (>= 20)")
    r.add_argument("--models", default="plane_strain,plane_stress")
    r.add_argument("--torques", default="50,150,250,350", help="N m")
    r.add_argument("--study-every", type=int, default=5,
                   help="convergence/penalty studies at every k-th position (0: none)")
    r.add_argument("--study-models", default="plane_strain,plane_stress")
    r.add_argument("--penalty-factor", type=float, default=10.0)
    r.add_argument("--friction", type=float, default=0.0, help="Coulomb mu (0: frictionless)")
    r.add_argument("--cache", default=None, help="directory of finished runs (default: temp)")
    r.add_argument("--contact-margin", type=float, default=analysis.CONTACT_MARGIN,
                   help="tooth pairs get contact surfaces this many base pitches past the path "
                        "of contact's ends (default %(default)s)")
    run3d.add_parser(sub)
    lineload3d.add_parser(sub)
    pairs.add_parser(sub)
    c = sub.add_parser("compare", help="a product TE curve against the FE band")
    c.add_argument("summary_csv", help="<scene>.reference_fe.summary.csv")
    c.add_argument("product_csv", help="torque_Nm, gear1_phi_rad, te_m over whole pitches")
    c.add_argument("--teeth1", type=int, required=True, help="gear 1's tooth count")
    a = ap.parse_args(argv)

    def log(msg):
        print(time.strftime("%H:%M:%S"), msg, flush=True)
    if a.cmd in ("run3d", "sector3d"):
        run3d.main(a, log)
        return
    if a.cmd == "lineload3d":
        lineload3d.main(a, log)
        return
    if a.cmd == "pairs":
        pairs.main(a, log)
        return
    if a.cmd == "compare":
        compare(a.summary_csv, a.product_csv, a.teeth1)
        return
    torques = [float(t) for t in a.torques.split(",")]
    models = a.models.split(",")
    for m in models + a.study_models.split(","):
        if m not in analysis.MODELS:
            ap.error(f"--models: {m!r}; allowed: {', '.join(analysis.MODELS)}")
    if not (0 <= a.contact_margin <= 2):
        ap.error(f"--contact-margin {a.contact_margin}; allowed: 0 .. 2 (base pitches)")
    for s in a.scenes:
        run_scene(s, a.out, a.positions, models, torques, a.study_every,
                  [m for m in a.study_models.split(",") if m in models], a.friction, a.cache,
                  a.penalty_factor, log, margin=a.contact_margin)


if __name__ == "__main__":
    main()
