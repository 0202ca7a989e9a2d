"""The main job: for each default scene, the engagement sweep (backlash, flank A and B) and a
revolution at a fixed approach (single/double contact), with CSV tables, plots and a report."""
from __future__ import annotations

import csv
import math
import pathlib
import sys

import numpy as np

from gearmesh import main_levels
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.prescribed_motion import (GEOMETRY, engagement_sweep, loaded_te_sweep,
                                       mesh_order_amplitudes, revolution_at_approach)
from gearmesh.scene import Scene
from gearmesh.scene_fmu import build_scene_fmu

RUN_DEFAULTS = {"approach_um": 10e-6, "points_per_pitch": 40, "sweep_margin_um": 20e-6,
                "sweep_points": 401, "torques_Nm": [], "speed_rpm": 10 * 2 * math.pi / 60,
                "te_pitches": 3, "friction_sweep": []}


def write_table(path: pathlib.Path, columns: dict) -> None:
    names = list(columns)
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for row in zip(*(columns[n] for n in names)):
            writer.writerow([f"{v:.9g}" for v in row])


def plot(path: pathlib.Path, x, ys: dict, xlabel: str, ylabel: str, title: str) -> None:
    """ys: label -> y over x, or label -> (x, y) for a curve with its own abscissae."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for label, y in ys.items():
        xs, y = y if isinstance(y, tuple) else (x, y)
        ax.plot(xs, y, label=label)
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    ax.grid(True, alpha=0.3)
    if len(ys) > 1:
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_scene(scene: Scene, generic_fmu: pathlib.Path, out: pathlib.Path) -> str:
    """Build the scene's FMU (its start values and resources only), run it; returns the
    scene's markdown section."""
    run = {**RUN_DEFAULTS, **scene.run}
    levels = main_levels.levels(scene, run)  # the first: the level of every run below
    levels, left_out = main_levels.without_unbuildable_fe(scene, levels)
    if left_out:
        print(f"gearmesh main: {scene.name}: {left_out}", file=sys.stderr)
    # level 5: the gears' compliance databases (built once, cached) as resources
    at_level = {level: main_levels.scene_at_level(scene, level) for level in levels}
    scene = at_level[levels[0]]
    folder = out / scene.name
    folder.mkdir(parents=True, exist_ok=True)
    fmus = {level: build_scene_fmu(generic_fmu, s.parameters, s.resources,
                                   folder / (f"{scene.name}.fmu" if level == levels[0]
                                             else f"{scene.name}.level{level}.fmu"))
            for level, s in at_level.items()}
    fmu_path = fmus[levels[0]]
    with GearMeshFMU(fmu_path, instance_name=scene.name) as fmu:
        geo = fmu.get(GEOMETRY)
        j_bt = geo["geometry.backlash"]
        margin = run["sweep_margin_um"]
        sweep = engagement_sweep(fmu, -j_bt - margin, margin, run["sweep_points"])
        warnings = list(fmu.warnings)
    with GearMeshFMU(fmu_path, instance_name=scene.name) as fmu:
        rev = revolution_at_approach(fmu, run["approach_um"], run["points_per_pitch"],
                                     progress=f"{scene.name}: revolution")
    loaded_by_level = {}
    swept = fmus if run["torques_Nm"] else {}  # the loaded TE per level
    for level, path in swept.items():
        with GearMeshFMU(path, {"model.quasi_static": True}, instance_name=scene.name) as fmu:
            loaded_by_level[level] = loaded_te_sweep(
                fmu, run["torques_Nm"], run["speed_rpm"], run["te_pitches"],
                run["points_per_pitch"], progress=f"{scene.name}: loaded TE, level {level}")
        write_table(folder / ("loaded_te.csv" if level == levels[0]
                              else f"loaded_te_level{level}.csv"), loaded_by_level[level])
    loaded = loaded_by_level.get(levels[0])
    # friction sweep (the paper's Figures 7-8): mesh orders over torque for each mu
    friction_rows = []
    for mu in run["friction_sweep"]:
        params = {"model.quasi_static": True, "model.friction_coefficient": mu}
        with GearMeshFMU(fmu_path, params, instance_name=scene.name) as fmu:
            sweep_mu = loaded_te_sweep(fmu, run["torques_Nm"], run["speed_rpm"], run["te_pitches"],
                                       run["points_per_pitch"], progress=f"{scene.name}: mu {mu:g}")
        for torque in run["torques_Nm"]:
            te = sweep_mu["mesh.te"][sweep_mu["torque"] == torque]
            orders = mesh_order_amplitudes(te, run["te_pitches"])
            friction_rows.append({"mu": mu, "torque_Nm": torque, "mean_te_m": te.mean(),
                                  "order1_m": orders[1], "order2_m": orders[2]})
    if friction_rows:
        write_table(folder / "friction_sweep.csv",
                    {k: np.array([r[k] for r in friction_rows]) for k in friction_rows[0]})
    write_table(folder / "engagement_sweep.csv", sweep)
    write_table(folder / "revolution.csv", rev)
    te_um = sweep["mesh.te"] * 1e6
    plot(folder / "engagement_sweep.png", te_um, {"normal force": sweep["mesh.normal_force"]},
         "TE (um)", "normal force (N)", f"{scene.name}: flank B | backlash | flank A")
    plot(folder / "revolution.png", np.degrees(rev["gear1.phi"]),
         {"normal force": rev["mesh.normal_force"]}, "gear 1 angle (deg)", "normal force (N)",
         f"{scene.name}: TE held at {run['approach_um'] * 1e6:g} um")

    # Figures read off the runs, set against the geometry.
    # Flank B closes where its (linear, level 0) force line meets zero.
    loaded_b = sweep["mesh.flank"] == 2
    if loaded_b.sum() >= 2:
        slope, intercept = np.polyfit(sweep["mesh.te"][loaded_b], sweep["mesh.normal_force"][loaded_b], 1)
        backlash_seen = intercept / slope
    else:
        backlash_seen = math.nan
    pairs = rev["mesh.pairs_in_contact"]
    eps = geo["geometry.contact_ratio"]
    approach_um = run["approach_um"] * 1e6
    lines = [
        f"## {scene.name}",
        "",
        scene.description,
        "",
        *([f"**{left_out}**", ""] if left_out else []),
        "| quantity | from the geometry | seen in the run |",
        "|---|---|---|",
        f"| transverse backlash j_bt (um) | {j_bt * 1e6:.3f} | "
        f"{backlash_seen * 1e6:.3f} (zero of the flank-B force line) |",
        f"| share of poses with 2 or more loaded pairs at a rigid approach of {approach_um:g} um "
        f"| eps_alpha - 1 = {eps - 1:.4f} (flank contact alone) | {np.mean(pairs >= 2):.4f} |",
        f"| share of poses with 3 loaded pairs (tip-edge contact outside the path) | 0 | "
        f"{np.mean(pairs >= 3):.4f} |",
        "",
        f"Operating pressure angle {math.degrees(geo['geometry.operating_pressure_angle']):.4f} deg,"
        f" base pitch {geo['geometry.base_pitch'] * 1e3:.5f} mm, contact ratio {eps:.4f}.",
        "",
        f"The scene's FMU, with its start values and resources: `{scene.name}/{scene.name}.fmu`.",
        "",
        f"![engagement]({scene.name}/engagement_sweep.png)",
        f"![revolution]({scene.name}/revolution.png)",
        "",
    ]
    if loaded is not None:
        z1 = scene.parameters.get("gear1.teeth", 57)
        mu = scene.parameters.get("model.friction_coefficient", 0.0)
        lines += [f"Loaded TE (quasi-static, mu = {mu:g}, {run['te_pitches']} pitches at "
                  f"{run['speed_rpm'] * 60 / (2 * math.pi):g} rpm) at stiffness level "
                  f"{' and '.join(map(str, levels))}:", "",
                  f"| level | load on gear 2 (N m) | mean TE (um) | peak-to-peak (um) | order {z1} (um) | "
                  f"order {2 * z1} (um) |", "|---|---|---|---|---|---|"]
        summaries = {level: main_levels.loaded_summary(sweep_l, run["torques_Nm"],
                                                       run["te_pitches"])
                     for level, sweep_l in loaded_by_level.items()}
        for level, summary in summaries.items():
            for torque, v in summary.items():
                lines.append(f"| {level} | {torque:g} | {v['mean'] * 1e6:.3f} | "
                             f"{v['pp'] * 1e6:.3f} | {v['order1'] * 1e6:.4f} | "
                             f"{v['order2'] * 1e6:.4f} |")
        lines.append("")
        curves = {f"{torque:g} N m": loaded["mesh.te"][loaded["torque"] == torque] * 1e6
                  for torque in run["torques_Nm"]}
        angle = np.degrees(loaded["gear1.phi"][loaded["torque"] == run["torques_Nm"][0]])
        plot(folder / "loaded_te.png", angle, curves, "gear 1 angle (deg)", "TE (um)",
             f"{scene.name}: loaded TE")
        torques = np.array(run["torques_Nm"], dtype=float)
        orders = {}
        for n in (1, 2):
            orders[f"order {n * z1}"] = [
                mesh_order_amplitudes(loaded["mesh.te"][loaded["torque"] == t],
                                      run["te_pitches"])[n] * 1e6 for t in torques]
        plot(folder / "mesh_orders.png", torques, orders, "load on gear 2 (N m)", "amplitude (um)",
             f"{scene.name}: mesh orders of the loaded TE")
        lines += ["", f"![loaded TE]({scene.name}/loaded_te.png)",
                  f"![mesh orders]({scene.name}/mesh_orders.png)", ""]
        reference_dir = scene.path.parent / "reference"
        accuracy, _ = main_levels.accuracy_lines(scene.name, fmus, reference_dir)
        lines += accuracy
        crowned = any(scene.parameters.get(f"gear{i}.profile_crowning", 0) for i in (1, 2))
        if crowned:
            lines += main_levels.figure7_lines(scene.name, summaries, mu, reference_dir)
    if friction_rows:
        z1 = scene.parameters.get("gear1.teeth", 57)
        torques = np.array(run["torques_Nm"], dtype=float)
        curves = {}
        for mu in run["friction_sweep"]:
            rows = [r for r in friction_rows if r["mu"] == mu]
            curves[f"mu {mu:g}, order {z1}"] = [r["order1_m"] * 1e6 for r in rows]
            curves[f"mu {mu:g}, order {2 * z1}"] = [r["order2_m"] * 1e6 for r in rows]
        plot(folder / "friction_sweep.png", torques, curves, "load on gear 2 (N m)", "amplitude (um)",
             f"{scene.name}: friction effect on the mesh orders")
        lines += [f"Friction sweep (mu = {', '.join(f'{m:g}' for m in run['friction_sweep'])}): "
                  f"`{scene.name}/friction_sweep.csv`", "",
                  f"![friction sweep]({scene.name}/friction_sweep.png)", ""]
    if warnings:
        lines += ["Warnings of the FMU:", ""] + [f"* {w}" for w in warnings] + [""]
    if scene.assumptions:
        lines += ["Assumptions of the scene:", ""] + [f"* {a}" for a in scene.assumptions] + [""]
    return "\n".join(lines)


def run_main(scenes: list[Scene], fmu_path: pathlib.Path, out: pathlib.Path,
             trains: list[pathlib.Path] = ()) -> pathlib.Path:
    out.mkdir(parents=True, exist_ok=True)
    sections = [run_scene(s, fmu_path, out) for s in scenes]
    if trains:
        from gearmesh.train_report import section

        sections += [section(t, fmu_path, out) for t in trains]
    from gearmesh.stability.suite import main_job_section

    sections.append(main_job_section(fmu_path, out))
    report = out / "report.md"
    report.write_text("# GearMesh main job\n\n" + "\n".join(sections), encoding="utf-8")
    return report
