"""python -m reference_fe run3d SCENE[:T1,T2] ... --out DIR: the 3-D FE reference of each scene.

Per scene (model3d: sectors of both gears, C3D20R), it solves

* case `base`: mesh level 0, sectors of 120 deg, penalty 1e16 Pa/m, at n positions
  over one (transverse) base pitch, the scene's two torques as load steps of one ccx run;
* at the study positions: `mesh-1` and `mesh+1` (every size / sqrt(2)^L, layers * sqrt(2)^L),
  `penalty_x10`, and `sector240` (sectors of 240 deg: the sector-size error);

and writes DIR/<scene>.reference_fe3d.te.csv (every run, a `case` column), .summary.csv (mean,
p-p, orders 1-3 of the base case) and .json (provenance, mesh statistics, the studies' relative
changes, wall time and peak memory). Finished ccx runs are cached (--cache) so an interrupted
generation resumes. Frictionless. Regenerate only on purpose.
"""
from __future__ import annotations

import csv
import pathlib
import time

from . import analysis, model3d, scene
from .report import THREADS, _changes, _cost, _g, provenance, write_provenance

SECTOR_DEG = 120.0     # the base sector (--sector-deg; 360: whole gears); studies 240, 360 deg
WHOLE_DEG = 360.0
STUDIES = (("mesh-1", {"level": -1}), ("penalty_x10", {"penalty_factor": 10.0}),
           ("sector240", {"sector_deg": 240.0}), ("mesh+1", {"level": 1}),
           ("whole", {"sector_deg": WHOLE_DEG}))


def parse_scene_arg(arg: str, default_torques):
    """SCENE or SCENE:T1,T2 (N m)."""
    if ":" in arg and not pathlib.Path(arg).exists():
        path, t = arg.rsplit(":", 1)
        return path, [float(x) for x in t.split(",")]
    return arg, list(default_torques)


def run_scene(path, torques, out_dir, n, study_positions, studies, cache, log,
              sector_deg=SECTOR_DEG, level=0):
    spec = scene.load(path, dims=3)
    t_start = time.time()
    models = {}

    def model(lv=level, sector=sector_deg):
        if (lv, sector) not in models:
            models[(lv, sector)] = model3d.Model3D(spec, lv, sector)
        return models[(lv, sector)]

    base_model = model()
    base_case = model3d.Case3D(level=level)
    runs = {"base": (base_model, base_case,
                     analysis.run_case(spec, base_model, base_case, range(n), n, torques,
                                       cache, log))}
    study_out = {}
    for label, opts in STUDIES:
        if label not in studies or not study_positions:
            continue
        m = model(level + opts.get("level", 0), opts.get("sector_deg", sector_deg))
        case = model3d.Case3D(level=level + opts.get("level", 0),
                              penalty=analysis.DEFAULT_PENALTY * opts.get("penalty_factor", 1.0))
        res = analysis.run_case(spec, m, case, study_positions, n, torques, cache, log)
        runs[label] = (m, case, res)
        base_sub = [r for r in runs["base"][2] if r.position in study_positions]
        study_out[label] = {"positions": list(study_positions), "options": opts,
                            "changes": _changes(base_sub, res, torques), "cost": _cost(res)}
    if "mesh-1" in study_out:   # level -1 -> 0 as well (the change of the base from coarse)
        c = runs["mesh-1"][2]
        base_sub = [r for r in runs["base"][2] if r.position in study_positions]
        study_out["mesh-1"]["changes_level-1_to_0"] = _changes(c, base_sub, torques)

    stem = f"{spec.name}.reference_fe3d"
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    variant = base_model.variant
    with open(out_dir / f"{stem}.te.csv", "w", newline="") as f:
        f.write(f"# 3-D FE reference TE of {pathlib.Path(path).name}: python -m reference_fe "
                "run3d (reference_fe/README.md, '3-D cases'); regenerate only on purpose\n")
        w = csv.writer(f)
        w.writerow(["scene", "model", "case", "mesh_level", "sector_teeth_gear1", "sector_teeth_gear2",
                    "penalty_Pa_per_m", "friction", "torque_Nm", "position", "n_positions",
                    "gear1_angle_rad", "te_m"])
        for label, (m, case, res) in runs.items():
            for r in sorted(res, key=lambda r: r.position):
                for T, te in zip(r.torques, r.te):
                    w.writerow([spec.name, f"3d_{variant}", label, case.level,
                                len(m.m1.sector_teeth), len(m.m2.sector_teeth), f"{case.penalty:.3g}", case.friction,
                                f"{T:g}", r.position, r.n_positions, _g(r.dphi1), _g(te)])
    summaries = []
    with open(out_dir / f"{stem}.summary.csv", "w", newline="") as f:
        f.write("# base case per torque: mean, peak-to-peak and mesh orders 1-3 (amplitude) of "
                "the TE over one (transverse) base pitch\n")
        w = csv.writer(f)
        w.writerow(["scene", "model", "case", "mesh_level", "sector_teeth_gear1", "sector_teeth_gear2",
                    "penalty_Pa_per_m", "friction", "torque_Nm", "n_positions", "mean_te_m",
                    "pp_te_m", "order1_m", "order2_m", "order3_m"])
        m, case, res = runs["base"]
        for ti, T in enumerate(torques):
            s = analysis.summary(res, ti)
            summaries.append({"model": f"3d_{variant}", "case": "base", "torque_Nm": T, **s})
            w.writerow([spec.name, f"3d_{variant}", "base", case.level, len(m.m1.sector_teeth),
                        len(m.m2.sector_teeth),
                        f"{case.penalty:.3g}", case.friction, f"{T:g}", s["n_positions"],
                        _g(s["mean_te_m"]), _g(s["pp_te_m"]), _g(s["order1_m"]),
                        _g(s["order2_m"]), _g(s["order3_m"])])
    pr = base_model.pair
    teeth = analysis.fine_teeth(pr, base_model.spread)[0]
    contact_check = analysis.contact_set_check(pr, teeth, runs["base"][2], base_model.spread)
    for f in contact_check:
        log(f"WARNING {spec.name} position {f['position']}: the {f['end']} tooth "
            f"{f['tooth_gear1']}, left out of the contact set, has a corner gap of "
            f"{f['corner_gap_m'] * 1e6:.2f} um below the TE {f['te_m'] * 1e6:.2f} um (a body's "
            "twist may carry it clear)")
    prov = {
        **provenance(spec.name, path),
        "model": {
            "description": ("3-D whole gears with their bodies (web, hub, lightening holes), "
                            if base_model.whole else
                            f"3-D sectors of both gears ({sector_deg:g} deg, rim to the bore), ")
                           + "C3D20R hexahedra (C3D15 wedges where the section mesh kept a "
                           "triangle) extruded over the face width, helicoids by twisting the "
                           "sections, lead crowning mapped onto the flanks; bore and radial cut "
                           "faces of gear 2 clamped, of gear 1 turning rigidly with the torque "
                           "(u_z = 0); surface-to-surface penalty contact, linear "
                           "pressure-overclosure, frictionless (reference_fe/model3d.py, "
                           "mesh3d.py)",
            "sector_deg": sector_deg,
            "bodies": [spec.gear1.body.__dict__, spec.gear2.body.__dict__],
            "variant": variant,
            "helix_angle_rad": spec.helix_angle,
            "lead_crowning_m": [spec.gear1.mod.lead_crowning, spec.gear2.mod.lead_crowning],
            "friction": 0.0,
            "penalty_Pa_per_m": analysis.DEFAULT_PENALTY,
            "engage_m": base_model.engage,
            "positions": n,
            "torques_Nm": list(torques),
            "position_0": "flank A of tooth 0 of both gears touching at the pitch point in the "
                          "mid-face section (unloaded, unmodified); gear1_angle_rad = gear 1's "
                          "turn from there; n positions over one transverse base pitch",
            "te": "r_b1 times gear 1's rotation past the rigid-body kinematic angle, "
                  "positive = approach on flank A",
            "bore_diameters_m": [2 * pr.g1.bore, 2 * pr.g2.bore],
            "base_radius_gear1_m": pr.g1.rb,
            "transverse_contact_ratio": pr.eps_alpha,
        },
        "mesh": {f"level{lv}_sector{sd:g}deg": m.stats() for (lv, sd), m in models.items()},
        "summary": summaries,
        "contact_set_check": contact_check,
        "studies": study_out,
        "cost": {label: _cost(res) for label, (m, case, res) in runs.items()},
        "elapsed_s_this_invocation": time.time() - t_start,
        "threads": THREADS,
    }
    write_provenance(out_dir / f"{stem}.json", prov)
    log(f"wrote {out_dir / stem}.te.csv, .summary.csv, .json")


def add_scene_arguments(p):
    """The arguments of the 3-D commands (run3d, lineload3d): scenes with torques, --out,
    --positions, --torques, --cache."""
    p.add_argument("scenes", nargs="+", help="SCENE or SCENE:T1,T2 (torques, N m)")
    p.add_argument("--out", required=True)
    p.add_argument("--positions", type=int, default=8, help="positions per base pitch")
    p.add_argument("--torques", default="150,350", help="N m, for scenes without :T1,T2")
    p.add_argument("--cache", default=None, help="directory of finished runs (default: temp)")


def add_parser(sub):
    r = sub.add_parser("run3d", help="3-D TE of scene(s) by CalculiX, with the studies")
    add_scene_arguments(r)
    r.add_argument("--study-positions", default="0",
                   help="positions of the studies (comma separated; empty: none)")
    r.add_argument("--studies", default=",".join(s for s, _ in STUDIES if s != "whole"))
    r.add_argument("--level", type=int, default=0,
                   help="the base model's mesh level (the mesh studies are relative to it)")
    r.add_argument("--sector-deg", type=float, default=SECTOR_DEG,
                   help="the base model's sectors (360: whole gears, the only choice for webs "
                        "and holes)")
    s = sub.add_parser("sector3d", help="the sector bias of the 3-D TE: sectors against whole "
                                        "gears at a few positions")
    add_scene_arguments(s)
    s.add_argument("--at", default="0", help="positions (comma separated)")
    s.add_argument("--sectors", default="120,360", help="sector angles, deg (360: whole gears)")
    return r


def main(a, log):
    default = [float(t) for t in a.torques.split(",")]
    if a.cmd == "sector3d":
        for arg in a.scenes:
            path, torques = parse_scene_arg(arg, default)
            run_sector_study(path, torques, a.out, a.positions,
                             [int(k) for k in a.at.split(",")],
                             [float(x) for x in a.sectors.split(",")], a.cache, log)
        return
    study_positions = [int(k) for k in a.study_positions.split(",") if k.strip()]
    studies = [s for s in a.studies.split(",") if s]
    for s in studies:
        if s not in dict(STUDIES):
            raise SystemExit(f"--studies: {s!r}; allowed: {', '.join(x for x, _ in STUDIES)}")
    for arg in a.scenes:
        path, torques = parse_scene_arg(arg, default)
        run_scene(path, torques, a.out, a.positions, study_positions, studies, a.cache, log,
                  a.sector_deg, a.level)


def run_sector_study(path, torques, out_dir, n, positions, sectors, cache, log):
    """The TE of the same positions with sectors of each angle (held cut faces; 360: whole
    gears, no cuts) at mesh level 0: DIR/<scene>.reference_fe3d.sector.csv (every run) and
    .json (provenance, each sector's TE relative to the whole gears', the cost)."""
    spec = scene.load(path, dims=3)
    t_start = time.time()
    res, models = {}, {}
    for sd in sectors:
        models[sd] = model3d.Model3D(spec, 0, sd)
        res[sd] = analysis.run_case(spec, models[sd], model3d.Case3D(), positions, n, torques,
                                    cache, log)
    stem = f"{spec.name}.reference_fe3d.sector"
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / f"{stem}.csv", "w", newline="") as f:
        f.write(f"# 3-D FE TE of {pathlib.Path(path).name} with sectors against whole gears: "
                "python -m reference_fe sector3d (reference_fe/README.md, '3-D cases'); "
                "regenerate only on purpose\n")
        w = csv.writer(f)
        w.writerow(["scene", "sector_deg", "whole", "sector_teeth_gear1", "sector_teeth_gear2",
                    "torque_Nm", "position", "n_positions", "gear1_angle_rad", "te_m"])
        for sd in sectors:
            m = models[sd]
            for r in sorted(res[sd], key=lambda r: r.position):
                for T, te in zip(r.torques, r.te):
                    w.writerow([spec.name, f"{sd:g}", int(m.whole), len(m.m1.sector_teeth),
                                len(m.m2.sector_teeth), f"{T:g}", r.position, r.n_positions,
                                _g(r.dphi1), _g(te)])
    ref = max(sectors)
    ratios = {}
    for sd in sectors:
        by = {r.position: r for r in res[sd]}
        ref_by = {r.position: r for r in res[ref]}
        ratios[f"{sd:g}"] = {str(k): {f"{T:g}": by[k].te[i] / ref_by[k].te[i]
                                      for i, T in enumerate(torques)} for k in positions}
    prov = {
        **provenance(spec.name, path),
        "model": {"description": "run3d's base model (level 0, penalty 1e16 Pa/m, "
                                 "frictionless) with sectors of each angle (held cut faces) "
                                 "and whole gears (360 deg, no cuts)",
                  "sectors_deg": sectors, "positions": positions, "n_positions": n,
                  "torques_Nm": list(torques)},
        "mesh": {f"sector{sd:g}deg": m.stats() for sd, m in models.items()},
        "te_ratio_to_largest": ratios,
        "cost": {f"sector{sd:g}deg": _cost(r) for sd, r in res.items()},
        "elapsed_s_this_invocation": time.time() - t_start,
        "threads": THREADS,
    }
    write_provenance(out_dir / f"{stem}.json", prov)
    log(f"wrote {out_dir / stem}.csv, .json")
