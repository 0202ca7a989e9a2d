"""The main job's comparison of stiffness levels on one scene (`[run] levels`, e.g. [5, 4]: the FE
level with level 4 beside it): each level's loaded TE over torque, its error against the
committed FE reference (scenarios/reference/, frictionless; docs/validation.md), and the
paper's Figure-7 remark that with crowning, friction and tooth flexibility acting together the
TE grows monotonically with torque (which level shows it)."""
from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from gearmesh.accuracy.reference import (curve_error, errors, positions_path, read_positions, read_summary,
                                         summary_path)
from gearmesh.accuracy.report import pct
from gearmesh.accuracy.sweep import sweep
from gearmesh.compliance import needs_build, with_databases
from gearmesh.paths import NotFound, Paths
from gearmesh.prescribed_motion import mesh_order_amplitudes
from gearmesh.scene import Scene

ALLOWED_LEVELS = (2, 3, 4, 5)  # levels 0 and 1 need a user constant or table per scene
DEFAULT_COUPLED = 2            # model.coupled_teeth when a scene is taken to level 5


def levels(scene: Scene, run: dict) -> list[int]:
    """[run] levels as whole levels, the scene's own level when absent; the first is the level of
    the engagement sweep and the revolution."""
    own = scene.level
    chosen = run.get("levels") or [own]
    out = []
    for value in chosen:
        if value != int(value) or int(value) not in ALLOWED_LEVELS + (own,):
            raise ValueError(f"{scene.name}: run.levels = {chosen!r}: {value!r} is not allowed; "
                             f"allowed: whole levels among {ALLOWED_LEVELS} or the scene's own "
                             f"({own})")
        if int(value) not in out:
            out.append(int(value))
    return out


def without_unbuildable_fe(scene: Scene, levels: list[int]) -> tuple[list[int], str]:
    """`levels` without level 5 when its compliance databases would have to be built and
    compliance_tool is not found (an installed package carries none: it needs gmsh and CHOLMOD),
    and the note saying so and how to get the tool; unchanged (and no note) otherwise, or when
    level 5 is the only level (its run then fails naming the tool)."""
    if 5 not in levels or len(levels) == 1:
        return levels, ""
    probe = dataclasses.replace(scene, parameters={**scene.parameters, "model.stiffness": 5})
    if not needs_build(probe):
        return levels, ""
    try:
        Paths.resolve().require("compliance_tool")
    except NotFound as exc:
        return [lv for lv in levels if lv != 5], f"level 5 left out: {exc}"
    return levels, ""


def scene_at_level(scene: Scene, level: int) -> Scene:
    """The scene at `level`, with its compliance databases as resources at level 5 (built by
    compliance_tool once and cached, gearmesh.compliance)."""
    parameters = {**scene.parameters, "model.stiffness": level}
    if level == 5:
        parameters.setdefault("model.coupled_teeth", DEFAULT_COUPLED)
    elif level != 4 or parameters.get("model.coupled_teeth", 0) > 3:
        parameters.pop("model.coupled_teeth", None)  # an input of levels 4 (<= 3) and 5 only
    return with_databases(dataclasses.replace(scene, parameters=parameters))


def loaded_summary(loaded: dict, torques, pitches: int) -> dict[float, dict[str, float]]:
    """Per torque of a loaded TE sweep (prescribed_motion.loaded_te_sweep): mean, p-p, orders 1-2."""
    out = {}
    for torque in torques:
        te = loaded["mesh.te"][loaded["torque"] == torque]
        orders = mesh_order_amplitudes(te, pitches)
        out[float(torque)] = {"mean": float(te.mean()), "pp": float(np.ptp(te)),
                              "order1": orders[1], "order2": orders[2]}
    return out


def grows(values) -> bool:
    """Strictly increasing over the torques."""
    return bool(np.all(np.diff(np.asarray(values, float)) > 0))


def figure7_lines(name: str, by_level: dict[int, dict[float, dict]], mu: float,
                  reference_dir: pathlib.Path) -> list[str]:
    """The Figure-7 check: per level, p-p TE and mesh order 1 over torque (the scene's friction),
    and whether each grows monotonically; the reference's frictionless trend beside them."""
    torques = sorted(next(iter(by_level.values())))
    head = " | ".join(f"{t:g}" for t in torques)
    lines = [f"**Does the TE grow monotonically with torque?** (the paper's Figure 7 remark for a "
             f"crowned pair; quasi-static, mu = {mu:g}; p-p TE in µm at each torque in N m)", "",
             f"| level | quantity | {head} | grows monotonically |",
             "|---|---|" + "---|" * len(torques) + "---|"]
    for level, summary in by_level.items():
        for q, label in (("pp", "p-p"), ("order1", "order 1")):
            values = [summary[t][q] for t in torques]
            cells = " | ".join(f"{v * 1e6:.3f}" for v in values)
            lines.append(f"| {level} | {label} | {cells} | {'yes' if grows(values) else 'no'} |")
    path = summary_path(reference_dir, name)
    if path.is_file():
        ref = read_summary(path)
        have = [t for t in torques if ("plane_strain", t) in ref.values]
        if len(have) >= 2:
            values = [ref.values[("plane_strain", t)]["pp"] for t in have]
            lines.append("")
            lines.append("The FE reference (frictionless, plane strain) at "
                         + ", ".join(f"{t:g}" for t in have) + " N m: p-p "
                         + ", ".join(f"{v * 1e6:.3f}" for v in values) + " µm — "
                         + ("grows" if grows(values) else "does not grow") + " with torque.")
    return lines + [""]


def accuracy_lines(name: str, fmus: dict[int, pathlib.Path],
                   reference_dir: pathlib.Path) -> tuple[list[str], list[dict]]:
    """Each level's error against the committed FE reference (frictionless, at the reference's
    positions and torques): the signed distance to the plane-stress/plane-strain band of mean
    TE, p-p TE and mesh order 1. No reference: a line saying so."""
    path = summary_path(reference_dir, name)
    if not path.is_file():
        return [f"No FE reference for {name} ({path.name} in {reference_dir.name}/): "
                "accuracy not assessed.", ""], []
    ref = read_summary(path)
    curves = read_positions(positions_path(reference_dir, name), ref.n_positions)
    rows = []
    for level, fmu in fmus.items():
        result = sweep(fmu, {}, ref.torques, ref.n_positions, repeats=1)
        for torque in ref.torques:
            curve = curve_error(curves, torque, result.te[torque])
            for e in errors(ref, torque, result.summary[torque]) + ([curve] if curve else []):
                rows.append({"level": level, "torque_Nm": torque, **e})
    lines = [f"**Error against the FE reference** (`reference_fe/`, CalculiX, both gears whole, "
             f"frictionless, {ref.n_positions} positions per pitch; distance to the plane-stress / "
             "plane-strain band, 0 inside it; TE curve: the worst distance to the band position "
             "by position; docs/validation.md):", "",
             "| level | torque on gear 1 (N m; the reference's) | mean TE | p-p TE | order 1 | TE curve |",
             "|---|---|---|---|---|---|"]
    for level in fmus:
        for torque in ref.torques:
            cell = {r["quantity"]: r["band_error"] for r in rows
                    if r["level"] == level and r["torque_Nm"] == torque}
            lines.append(f"| {level} | {torque:g} | " + " | ".join(
                pct(cell.get(q, math.nan)) for q in ("mean", "pp", "order1", "curve")) + " |")
    return lines + [""], rows
