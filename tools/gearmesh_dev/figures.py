"""`gearmesh-dev figures`: the pictures of the user docs (docs/img/), each made here from the project's
own outputs, so that they are regenerated, never drawn by hand:

* te_set_a.png: gear set A's loaded TE at stiffness levels 4 and 5 against the CalculiX band of
  the committed FE reference (scenarios/reference/): the pipeline of the main job's error table
  (gearmesh.main_levels.accuracy_lines: the scene at each level, frictionless, at the reference's
  positions and torques, gearmesh.accuracy.sweep), drawn curve by curve;
* schematic.png: set A's pair from the geometry its FMU computes (calculated parameters, and the
  line of action of each flank from the FMU's contact force and moment), frames and signs of
  docs/physics.md §0, and the slices across the face width in the plane of action;
* pareto.png: the committed accuracy ledger (scenarios/reference/ledger_small.csv) drawn by
  gearmesh.accuracy.report.plot (no FE or FMU run);
* stability_map.png: the largest stable step per case and mode (gearmesh.stability's plot) of the
  quick stability suite, run here (about 1.5 min) or read from a table.csv (--stability-table);
* study_histogram.png: a small tolerance study of set A (gearmesh.batch.study on the batch's local
  cluster; finished cases are kept in the work folder and skipped when run again), drawn by
  gearmesh.batch.study_report.plot;
* compliance_mesh.png: the FE mesh compliance_tool builds for set A's gear at the FE level (the
  body of the database that te_set_a.png's level 5 uses), written with --write-mesh and read with
  gmsh.

Intermediate files (scene FMUs, the stability table, the study's cases, the mesh) go to the work
folder (default output/figures/); only the pictures go to the output folder."""
from __future__ import annotations

import csv
import dataclasses
import math
import pathlib
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

import numpy as np

from gearmesh_dev import checkout

REPO = checkout()
DEFAULT_OUT = REPO / "docs" / "img"
DEFAULT_WORK = REPO / "output" / "figures"
SCENE_A = REPO / "scenarios" / "paper_setA_3U4U.toml"
LEDGER = REPO / "scenarios" / "reference" / "ledger_small.csv"
TE_LEVELS = (4, 5)
DPI = 100
# the study of docs/batch.md's example, small: a tilt of gear 2 and gear 1's pitch deviations
STUDY_SAMPLES = ["gear2.rx=normal(0,0.3mrad)", "gear1.pitch_A=normal(0,2um)"]
STUDY_TORQUES = [100.0, 300.0]
STUDY_CASES = 100
STUDY_SEED = 7

# name -> file; the order is the order they are made in
FILES = {"schematic": "schematic.png", "pareto": "pareto.png", "te_set_a": "te_set_a.png",
         "stability_map": "stability_map.png", "study_histogram": "study_histogram.png",
         "compliance_mesh": "compliance_mesh.png", "planetary_sharing": "planetary_sharing.png",
         "planetary_pin_error": "planetary_pin_error.png", "aliasing": "aliasing.png"}
PLANETARY = REPO / "scenarios" / "trains" / "planetary_4_planets.toml"
PLANETARY3 = REPO / "scenarios" / "trains" / "planetary_3_planets.toml"
PIN_ERROR = 3e-6  # m, tangential, on planet 1
PIN_LOAD = 1000.0  # N m on the carrier


@dataclass
class Options:
    fmu: pathlib.Path = REPO / "build" / "GearMesh.fmu"
    work: pathlib.Path = DEFAULT_WORK
    stability_table: pathlib.Path | None = None  # a `gearmesh stability` table.csv to draw
    study_cases: int = STUDY_CASES
    jobs: int = 1                                # the study's local workers


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: pathlib.Path, colours: int = 64) -> None:
    """Save at DPI as a palette PNG (`colours` colours): line drawings stay well under 200 kB."""
    import io

    from PIL import Image

    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=DPI, format="png")
    image = Image.open(buffer).convert("RGB")
    image.quantize(colors=colours, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


# ---------------------------------------------------------------------------------------------
# te_set_a.png


def te_set_a(path: pathlib.Path, opt: Options) -> str:
    """Set A's TE over one pitch at levels 4 and 5 against the plane-stress / plane-strain band."""
    from fmpy import read_model_description

    from gearmesh.accuracy.reference import (curve_error, positions_path, read_positions, read_summary,
                                             summary_path)
    from gearmesh.accuracy.sweep import sweep
    from gearmesh.main_levels import scene_at_level
    from gearmesh.scene import load_scene
    from gearmesh.scene_fmu import build_scene_fmu

    scene = load_scene(SCENE_A, opt.fmu)
    reference_dir = scene.path.parent / "reference"
    ref = read_summary(summary_path(reference_dir, scene.name))
    curves = read_positions(positions_path(reference_dir, scene.name), ref.n_positions)
    folder = opt.work / "te_set_a"
    folder.mkdir(parents=True, exist_ok=True)
    default_coupled = next(v.start for v in read_model_description(str(opt.fmu)).modelVariables
                           if v.name == "model.coupled_teeth")
    te, worst, name = {}, {}, {}
    for level in TE_LEVELS:
        s = scene_at_level(scene, level)
        coupled = int(s.parameters.get("model.coupled_teeth", default_coupled))
        name[level] = (f"level {level} ({'FE databases' if level == 5 else 'analytical'}, "
                       f"±{coupled} coupled teeth, {s.parameters.get('model.slices', 1)} slices)")
        fmu = build_scene_fmu(opt.fmu, s.parameters, s.resources,
                              folder / f"{scene.name}.level{level}.fmu")
        te[level] = sweep(fmu, {}, ref.torques, ref.n_positions, repeats=1).te
        worst[level] = max((curve_error(curves, t, te[level][t]) for t in ref.torques),
                           key=lambda row: abs(row["band_error"]))["band_error"]

    plt = _pyplot()
    x = np.arange(ref.n_positions) / ref.n_positions
    fig, ax = plt.subplots(figsize=(8, 5))
    style = {4: dict(ls="--", marker="o", ms=3, lw=1.2), 5: dict(ls="-", marker="s", ms=3, lw=1.6)}
    for k, torque in enumerate(ref.torques):
        colour = f"C{k}"
        band = np.array([curves[(m, torque)] for m in ref.models]) * 1e6
        ax.fill_between(x, band.min(axis=0), band.max(axis=0), color=colour, alpha=0.22, lw=0)
        for level in TE_LEVELS:
            ax.plot(x, te[level][torque] * 1e6, color=colour, **style[level])
        ax.annotate(f"{torque:g} N m", (x[-1], band[:, -1].mean()), xytext=(6, 0),
                    textcoords="offset points", va="center", fontsize=8, color=colour)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Patch(color="grey", alpha=0.35, label="FE reference band (CalculiX, plane stress "
                     "– plane strain, both gears whole)")]
    handles += [Line2D([], [], color="k", **style[level],
                       label=f"{name[level]}: worst distance to the band "
                       f"{100 * worst[level]:+.1f} %"
                       if worst[level] else f"{name[level]}: inside the band")
                for level in TE_LEVELS]
    ax.legend(handles=handles, fontsize=8, loc="upper left")
    ax.set(xlabel="gear 1 roll angle over one pitch (reference position k / n)",
           ylabel="loaded TE (µm)", xlim=(-0.02, 1.1),
           title=f"Gear set A ({scene.name}): loaded TE, frictionless, against the FE reference")
    ax.title.set_fontsize(10)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return ", ".join(f"level {level} worst {100 * worst[level]:+.1f} %" for level in TE_LEVELS)


# ---------------------------------------------------------------------------------------------
# schematic.png

_PARAMETERS = ["pair.center_distance", "pair.normal_module", "pair.pressure_angle",
               "pair.helix_angle", "pair.internal", "pair.rack_dedendum",
               "geometry.operating_pressure_angle", "geometry.backlash", "geometry.base_pitch",
               "geometry.contact_ratio", "geometry.path_start", "geometry.path_end", "model.slices"]
_GEAR = ["teeth", "profile_shift", "thickness_allowance", "face_width", "axial_offset",
         "base_diameter", "tip_diameter_used", "form_diameter"]


def _inv(alpha: float) -> float:
    return math.tan(alpha) - alpha


@dataclass
class Gear:
    centre: np.ndarray
    z: int
    r_b: float
    r_a: float
    r_f: float       # root radius, from the basic rack (docs/physics.md §1)
    r_form: float
    psi_b: float     # half the tooth's angle at the base circle
    theta0: float    # tooth 0's centre line (polar angle about the centre)
    face: tuple[float, float]


@dataclass
class PairGeometry:
    a: float
    alpha_wt: float
    backlash: float
    base_pitch: float
    contact_ratio: float
    beta_b: float
    slices: int
    gears: tuple[Gear, Gear]
    # flank (1 A, 2 B) -> (unit contact force on gear 1, T1, T2): the line of action from the FMU
    lines: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]
    # the path of contact as roll distances from T1 (docs/physics.md §1): the FMU's
    # geometry.path_start, geometry.path_end
    path: tuple[float, float]

    def drawn_backlash(self) -> float:
        """The gap along flank B's line of action between the drawn teeth (equal to the FMU's
        geometry.backlash when the drawn tooth thickness is the FMU's)."""
        g1, g2 = self.gears
        t1 = self.alpha_wt - (g1.theta0 - g1.psi_b)             # gear 1's lower flank on line B
        t2 = math.pi + self.alpha_wt - (g2.theta0 - g2.psi_b)   # gear 2's upper flank on line B
        return (self.a * math.sin(self.alpha_wt) - g1.r_b * t1 - g2.r_b * t2) % self.base_pitch


def pair_geometry(fmu_path: pathlib.Path, parameters: dict, probe: float = 1e-6) -> PairGeometry:
    """The pair as the FMU sees it: its calculated geometry, and each flank's line of action
    from the contact force and moment on the gears at gear 1's angle 0, TE = +probe (flank A)
    and TE = -backlash - probe (flank B). Tooth thickness and root from docs/physics.md §1; the
    teeth are posed touching on flank A at the pitch point (a pose at TE = 0)."""
    from gearmesh.fmu_driver import GearMeshFMU
    from gearmesh.prescribed_motion import pair_kinematics

    with GearMeshFMU(fmu_path, parameters, instance_name="figures") as fmu:
        g = fmu.get(_PARAMETERS + [f"gear{i}.{n}" for i in (1, 2) for n in _GEAR])
        if g["pair.internal"]:
            raise ValueError("the schematic draws external pairs only")
        kin = pair_kinematics(fmu)
        lines = {}
        for flank, te in ((1, probe), (2, -g["geometry.backlash"] - probe)):
            fmu.step({"gear1.phi": 0.0, "gear2.phi": kin.phi2(te, 0.0)})
            out = fmu.get(["mesh.flank"] + [f"gear{i}.{q}" for i in (1, 2)
                                            for q in ("fx", "fy", "mz")])
            if out["mesh.flank"] != flank:
                raise RuntimeError(f"TE {te:g} m: mesh.flank {out['mesh.flank']}, expected {flank}")
            points = []
            for i, centre in ((1, np.zeros(2)), (2, np.array([g["pair.center_distance"], 0.0]))):
                f = np.array([out[f"gear{i}.fx"], out[f"gear{i}.fy"]])
                n = f / np.linalg.norm(f)
                # the foot of the perpendicular from the centre: lever mz / |F|, sign of mz
                lever = out[f"gear{i}.mz"] / np.linalg.norm(f)
                points.append(centre + lever * np.array([n[1], -n[0]]))
            lines[flank] = (np.array([out["gear1.fx"], out["gear1.fy"]]) /
                            math.hypot(out["gear1.fx"], out["gear1.fy"]), *points)
    a, alpha_wt = g["pair.center_distance"], g["geometry.operating_pressure_angle"]
    m_n, alpha_n, beta = g["pair.normal_module"], g["pair.pressure_angle"], g["pair.helix_angle"]
    m_t, alpha_t = m_n / math.cos(beta), math.atan(math.tan(alpha_n) / math.cos(beta))
    gears = []
    for i, theta_pitch in ((1, 0.0), (2, math.pi)):
        z, x = int(g[f"gear{i}.teeth"]), g[f"gear{i}.profile_shift"]
        x_e = x + g[f"gear{i}.thickness_allowance"] / (2 * m_n * math.tan(alpha_n))
        d = z * m_t
        psi_b = m_t * (math.pi / 2 + 2 * x_e * math.tan(alpha_n)) / d + _inv(alpha_t)
        # flank A ("+" side of the tooth: angle theta + psi_b - inv alpha_r) through the pitch point
        theta0 = theta_pitch + _inv(alpha_wt) - psi_b
        offset, width = g[f"gear{i}.axial_offset"], g[f"gear{i}.face_width"]
        gears.append(Gear(np.array([0.0 if i == 1 else a, 0.0]), z, g[f"gear{i}.base_diameter"] / 2,
                          g[f"gear{i}.tip_diameter_used"] / 2,
                          d / 2 - m_n * (g["pair.rack_dedendum"] - x),
                          g[f"gear{i}.form_diameter"] / 2,
                          psi_b, theta0, (offset - width / 2, offset + width / 2)))
    beta_b = math.asin(math.sin(beta) * math.cos(alpha_n))
    return PairGeometry(a, alpha_wt, g["geometry.backlash"], g["geometry.base_pitch"],
                        g["geometry.contact_ratio"], beta_b, int(g["model.slices"]), tuple(gears),
                        lines, (g["geometry.path_start"], g["geometry.path_end"]))


def gear_outline(gear: Gear, points: int = 12) -> np.ndarray:
    """The gear's closed outline (N x 2): involute flanks from the base or root circle to the tip,
    tip and root arcs; the fillet drawn as a radial line (schematic)."""
    r0 = max(gear.r_b, gear.r_f)
    radii = np.linspace(r0, gear.r_a, points)
    inv_r = np.array([_inv(math.acos(gear.r_b / r)) for r in radii])
    pitch = 2 * math.pi / gear.z
    polar = []
    for k in range(gear.z):
        c = gear.theta0 + k * pitch
        lower = c - gear.psi_b + inv_r   # "-" flank, root to tip
        upper = c + gear.psi_b - inv_r   # "+" flank
        polar += [(gear.r_f, lower[0])] if gear.r_f < r0 else []
        polar += list(zip(radii, lower))
        polar += [(gear.r_a, t) for t in np.linspace(lower[-1], upper[-1], 4)[1:-1]]
        polar += list(zip(radii[::-1], upper[::-1]))
        polar += [(gear.r_f, upper[0])] if gear.r_f < r0 else []
        root_end = c + pitch - gear.psi_b + inv_r[0]
        polar += [(gear.r_f, t) for t in np.linspace(upper[0], root_end, 5)[1:-1]]
    r, t = np.array(polar).T
    xy = np.column_stack([r * np.cos(t), r * np.sin(t)]) + gear.centre
    return np.vstack([xy, xy[:1]])


def _circle(ax, centre, r, **kw):
    t = np.linspace(0, 2 * math.pi, 721)
    ax.plot(centre[0] + r * np.cos(t), centre[1] + r * np.sin(t), **kw)


def _spin(ax, centre, r, label, colour="k"):
    """A counter-clockwise arc (+ spin about +z) below the centre, its arrow head and label."""
    t = np.radians(np.linspace(215, 325, 60))
    x, y = centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)
    ax.plot(x[:-1], y[:-1], color=colour, lw=1.4)
    ax.annotate("", (x[-1], y[-1]), (x[-4], y[-4]),
                arrowprops=dict(arrowstyle="-|>", color=colour, lw=1.4, mutation_scale=12,
                                shrinkA=0, shrinkB=0))
    ax.text(centre[0], centre[1] - 1.15 * r, label, ha="center", va="top", fontsize=9,
            color=colour)


def schematic(path: pathlib.Path, opt: Options, geometry: PairGeometry | None = None) -> str:
    """Set A's pair: whole gears, the mesh zone enlarged, and the slices in the plane of action."""
    if geometry is None:
        from gearmesh.scene import load_scene
        from gearmesh.scene_fmu import build_scene_fmu

        scene = load_scene(SCENE_A, opt.fmu)
        opt.work.mkdir(parents=True, exist_ok=True)
        fmu = build_scene_fmu(opt.fmu, scene.parameters, scene.resources,
                              opt.work / f"{scene.name}.fmu")
        geometry = pair_geometry(fmu, {})
    geo, mm = geometry, 1e3
    g1, g2 = geo.gears
    outlines = [gear_outline(g) * mm for g in geo.gears]
    fills = ("0.86", "#cfe0f0")
    colours = {1: "tab:red", 2: "tab:blue"}   # flank A, flank B
    plt = _pyplot()
    fig, (over, zoom, poa) = plt.subplots(1, 3, figsize=(13, 5.6),
                                          gridspec_kw={"width_ratios": [1.55, 1.05, 0.8]})
    t1a, t2a = geo.lines[1][1] * mm, geo.lines[1][2] * mm
    pitch_point = t1a + (t2a - t1a) * g1.r_b / (g1.r_b + g2.r_b)

    # the whole pair in H
    for k, (gear, outline) in enumerate(zip(geo.gears, outlines)):
        c = gear.centre * mm
        over.fill(*outline.T, color=fills[k], lw=0)
        over.plot(*outline.T, color="0.3", lw=0.3)
        _circle(over, c, gear.r_b * mm, color="0.2", lw=0.8, ls="--")
        over.plot(*c, "k+", ms=8)
        over.text(c[0] - 3, c[1] + 3, f"O{'₁₂'[k]}", ha="right", va="bottom", fontsize=9)
        over.text(c[0], c[1] + 0.5 * gear.r_b * mm, f"gear {k + 1}, z = {gear.z}", ha="center",
                  va="center", fontsize=9)
        _spin(over, c, 0.45 * gear.r_b * mm, f"+φ{'₁₂'[k]} (about +z)")
    for flank, (_, t1, t2) in geo.lines.items():
        over.plot(*np.array([t1, t2]).T * mm, "o-", color=colours[flank], lw=1.2, ms=3,
                  label=f"line of action, flank {'AB'[flank - 1]}")
    for name, point, dx in (("T₁", t1a, -2), ("T₂", t2a, 2)):
        over.text(point[0] + dx, point[1], name, fontsize=9, color=colours[1],
                  ha="right" if dx < 0 else "left", va="center")
    for vec, name in (((1, 0), "x"), ((0, 1), "y")):
        over.annotate("", np.array(vec) * 22, (0, 0), arrowprops=dict(arrowstyle="-|>", lw=1))
        over.text(*(np.array(vec) * 26), name, fontsize=9, ha="center", va="center")
    over.text(-3, -3, "z ⊙", fontsize=9, ha="right", va="top")
    half = 7.0
    over.add_patch(plt.Rectangle(pitch_point - half, 2 * half, 2 * half, fill=False, lw=0.9,
                                 color="k"))
    over.set_aspect("equal")
    over.set_ylim(-95, 88)
    over.set(xlabel="x (mm)", ylabel="y (mm)")
    over.set_title(f"the pair in the housing frame H (z out of the page), a = {geo.a * mm:g} mm,"
                   f"\nα_wt = {math.degrees(geo.alpha_wt):.3f}°, base circles dashed",
                   fontsize=9)
    over.legend(fontsize=8, loc="lower center", ncols=2)

    # the mesh zone (the box)
    for k, (gear, outline) in enumerate(zip(geo.gears, outlines)):
        zoom.fill(*outline.T, color=fills[k], lw=0)
        zoom.plot(*outline.T, color="0.2", lw=0.8)
        for r, ls in ((gear.r_b, "--"), (gear.r_a, ":")):
            _circle(zoom, gear.centre * mm, r * mm, color="0.35", lw=0.7, ls=ls)
    zoom.plot([], [], color="0.35", lw=0.7, ls="--", label="base circles")
    zoom.plot([], [], color="0.35", lw=0.7, ls=":", label="tip circles")
    u = (t2a - t1a) / np.linalg.norm(t2a - t1a)
    start, end = geo.path
    for flank, (_, t1, t2) in geo.lines.items():
        zoom.plot(*np.array([t1, t2]).T * mm, color=colours[flank], lw=0.9)
    zoom.plot(*np.array([t1a + start * mm * u, t1a + end * mm * u]).T, color=colours[1], lw=4,
              alpha=0.45, solid_capstyle="butt",
              label=f"path of contact, flank A (ε_α = {geo.contact_ratio:.3f})")
    force = geo.lines[1][0]
    zoom.annotate("", pitch_point + 2.6 * force, pitch_point,
                  arrowprops=dict(arrowstyle="-|>", color="k", lw=1.6))
    zoom.text(*(pitch_point + 2.8 * force + [0.25, 0.3]), "contact force on\ngear 1, flank A\n"
              "(gear1.fx, gear1.fy)", fontsize=7, va="top")
    # the flanks of tooth 0 of each gear at its operating pitch circle
    inv_w = _inv(geo.alpha_wt)
    labels = ((1, g1, g1.theta0 + g1.psi_b - inv_w, (-5.5, 3.2), "flank A (both gears)"),
              (2, g1, g1.theta0 - g1.psi_b + inv_w, (-5.5, -1.9), "flank B, gear 1"),
              (2, g2, g2.theta0 - g2.psi_b + inv_w, (1.0, 1.9), "flank B, gear 2"))
    for flank, gear, angle, offset, text in labels:
        r_w = gear.r_b / math.cos(geo.alpha_wt)
        p = (gear.centre + r_w * np.array([math.cos(angle), math.sin(angle)])) * mm
        zoom.annotate(text, p, p + offset, fontsize=8, color=colours[flank], va="center",
                      arrowprops=dict(arrowstyle="-|>", color="k", lw=0.7, shrinkA=0,
                                      shrinkB=1),
                      bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=1))
    zoom.set_xlim(pitch_point[0] - half, pitch_point[0] + half)
    zoom.set_ylim(pitch_point[1] - half, pitch_point[1] + half)
    zoom.set_aspect("equal")
    zoom.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncols=2)
    zoom.set(xlabel="x (mm)")
    zoom.set_title("the box enlarged: teeth touching on flank A at the\npitch point (TE = 0; "
                   "the fillets drawn radial)", fontsize=9)

    # plane of action: flank A's path of contact x the faces' overlap, the slices
    lo = max(g1.face[0], g2.face[0]) * mm
    hi = min(g1.face[1], g2.face[1]) * mm
    width = hi - lo
    s0, s1, pb = start * mm, end * mm, geo.base_pitch * mm
    double = (geo.contact_ratio - 1) * pb
    poa.add_patch(plt.Rectangle((s0, lo), s1 - s0, width, facecolor="white", edgecolor="k", lw=1))
    for x0 in (s0, s1 - double):
        poa.add_patch(plt.Rectangle((x0, lo), double, width, facecolor=colours[1], alpha=0.1, lw=0))
    for x0, y0, text in ((s0 + double / 2, 0.4, "2 pairs"), ((s0 + s1) / 2, 1.9, "1 pair"),
                         (s1 - double / 2, 0.4, "2 pairs")):
        poa.text(x0, hi + y0, text, ha="center", va="bottom", fontsize=8)
    edges = np.linspace(lo, hi, geo.slices + 1)
    centres = (edges[:-1] + edges[1:]) / 2
    slope = math.tan(geo.beta_b)
    for j, at in enumerate((s0 + 0.35 * pb, s0 + 1.35 * pb)):
        def line(zz, at=at):
            return at + (zz - (lo + hi) / 2) * slope
        poa.plot([line(lo), line(hi)], [lo, hi], color=colours[1], lw=2.2)
        poa.plot(line(edges), edges, "_", color="k", ms=10, mew=1)
        poa.plot(line(centres), centres, "o", color="k", ms=3)
    poa.annotate("", (s0 + 1.35 * pb, lo - 1.2), (s0 + 0.35 * pb, lo - 1.2),
                 arrowprops=dict(arrowstyle="<->", lw=0.8))
    poa.text(s0 + 0.85 * pb, lo - 1.8, f"p_bt = {pb:.3f} mm", ha="center", va="top", fontsize=8)
    poa.set(xlim=(s0 - 1, s1 + 1), ylim=(lo - 4.5, hi + 4), xlabel="roll distance from T₁ (mm)",
            ylabel=f"face coordinate z (mm), overlap {width:g} mm")
    poa.set_title(f"plane of action, flank A: two contact\nlines, {geo.slices} slices each "
                  "(• their centres)", fontsize=9)
    poa.set_aspect("equal")
    fig.text(0.01, 0.015, "TE = r_b1 φ₁ + r_b2 φ₂ along the line of action (docs/physics.md §0). "
             "TE > 0: approach on flank A, which carries the load when gear 1 turns in +φ₁ and "
             f"drives (gear 2 then turns in −φ₂); flank B closes at TE = −j_bt = "
             f"{-geo.backlash * 1e6:.1f} µm.\nDrawn from the FMU's calculated geometry "
             "(gear<i>.base_diameter, tip_diameter_used, geometry.*) and its contact force on "
             "each flank.", fontsize=8, wrap=True, va="bottom")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    _save(fig, path)
    plt.close(fig)
    return (f"backlash drawn {geo.drawn_backlash() * 1e6:.3f} um, FMU "
            f"{geo.backlash * 1e6:.3f} um")


# ---------------------------------------------------------------------------------------------
# pareto.png, stability_map.png, study_histogram.png


def pareto(path: pathlib.Path, opt: Options) -> str:
    """The committed ledger's score against plain-mode µs per setting (accuracy_report.plot)."""
    from gearmesh_dev import ledger as accuracy_ledger
    from gearmesh.accuracy import report as accuracy_report

    made = accuracy_ledger.provenance(LEDGER)
    entries = accuracy_report.per_setting(accuracy_report.read_csv(LEDGER))
    accuracy_report.plot(path, entries)
    return f"{len(entries)} settings of {LEDGER.name} (--settings {made['settings']})"


def read_stability_table(path: pathlib.Path) -> list:
    """The rows of a `gearmesh stability` table.csv (gearmesh.stability.Row)."""
    from gearmesh.stability.suite import Row

    def value(kind, text):
        if kind in ("bool | None",):
            return None if text in ("", "None") else text == "True"
        if kind == "float":
            return float(text)
        if kind == "int":
            return int(text)
        return text

    fields = {f.name: str(f.type) for f in dataclasses.fields(Row)}
    with pathlib.Path(path).open(newline="") as fh:
        return [Row(**{k: value(fields[k], v) for k, v in row.items()})
                for row in csv.DictReader(fh)]


def stability_map(path: pathlib.Path, opt: Options) -> str:
    from gearmesh.stability import suite as stability
    from gearmesh.stability.cases import select
    from gearmesh.stability.runs import MODES

    if opt.stability_table:
        rows, how = read_stability_table(opt.stability_table), f"from {opt.stability_table}"
    else:
        rows = stability.run_suite(opt.fmu, select(None, quick=True), MODES,
                                   stability.QUICK_STEPS)
        summary = stability.write_outputs(rows, opt.work / "stability",
                                          "Stability suite, quick subset (gearmesh-dev figures)")
        how = (f"quick suite run: {summary['passed']} of {summary['runs']} runs pass, table "
               f"{opt.work / 'stability' / 'table.md'}")
    stability.plot_largest_stable(rows, path)
    return how


def study_histogram(path: pathlib.Path, opt: Options) -> str:
    from gearmesh.batch import run as batch, study, study_report
    from gearmesh.scene import load_scene

    scene = load_scene(SCENE_A, opt.fmu)
    folder = opt.work / "study"
    plan = study.plan(scene, STUDY_SAMPLES, opt.study_cases, STUDY_SEED, opt.fmu, folder)
    result = batch.run_batch(study.expand(plan, STUDY_TORQUES), opt.fmu, folder, opt.jobs,
                             report=False)
    if result.errors:
        raise RuntimeError(f"{len(result.errors)} study cases failed: "
                           f"{folder / 'batch_errors.csv'}")
    report = study_report.write(plan, result)
    study_report.plot(path, result.summary_rows)
    return f"{result.ran} cases run, {result.skipped} reused; report {report}"


# ---------------------------------------------------------------------------------------------
# compliance_mesh.png


def _front_face(msh: pathlib.Path) -> tuple[np.ndarray, np.ndarray]:
    """(node xy, triangles) of the mesh's face at the lowest z: the faces of its tetrahedra whose
    corners all lie there."""
    import gmsh

    gmsh.initialize(["-nopopup"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(msh))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, nodes = gmsh.model.mesh.getElements(dim=3)
        per = {t: gmsh.model.mesh.getElementProperties(t)[3] for t in types}
    finally:
        gmsh.finalize()
    xyz = coords.reshape(-1, 3)
    index = np.full(int(tags.max()) + 1, -1)
    index[tags.astype(int)] = np.arange(len(tags))
    faces = []
    for t, n in zip(types, nodes):
        corners = index[n.astype(int).reshape(-1, per[t])[:, :4]]
        z = xyz[:, 2]
        z0, tol = z.min(), 1e-9 * (z.max() - z.min())
        on = np.abs(z[corners] - z0) <= tol
        for face in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
            keep = on[:, face].all(axis=1)
            faces.append(corners[keep][:, face])
    return xyz[:, :2], np.vstack(faces)


def compliance_mesh(path: pathlib.Path, opt: Options) -> str:
    """Gear 1 of set A at the FE level: compliance_tool's mesh (--write-mesh), its front face."""
    from gearmesh import compliance
    from gearmesh.main_levels import DEFAULT_COUPLED
    from gearmesh.scene import load_scene

    scene = load_scene(SCENE_A, opt.fmu)
    parameters = {**scene.parameters, "model.stiffness": 5}
    parameters.setdefault("model.coupled_teeth", DEFAULT_COUPLED)  # as the main job's level 5
    scene5 = dataclasses.replace(scene, parameters=parameters)
    tool = compliance.default_tool()
    folder = opt.work / "compliance_mesh"
    folder.mkdir(parents=True, exist_ok=True)
    msh = folder / f"{scene.name}.gear1.msh"
    with tempfile.TemporaryDirectory() as tmp:
        command = [str(tool), "--scene", str(scene.path),
                   "--out", str(pathlib.Path(tmp) / "g.gcdb"),
                   *compliance.tool_arguments(scene5, 1), "--write-mesh", str(msh)]
        done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"compliance_tool failed (exit {done.returncode}): "
                           f"{done.stderr.strip().splitlines()[-1:]}")
    summary = compliance.parse_summary(done.stdout)
    xy, triangles = _front_face(msh)
    xy = xy * 1e3
    plt = _pyplot()
    fig, (whole, near) = plt.subplots(1, 2, figsize=(11, 5.2),
                                      gridspec_kw={"width_ratios": [1, 1.1]})
    for ax in (whole, near):
        ax.triplot(xy[:, 0], xy[:, 1], triangles, color="0.15", lw=0.15 if ax is whole else 0.3)
        ax.set_aspect("equal")
        ax.set(xlabel="x (mm)", ylabel="y (mm)")
    r = np.hypot(xy[:, 0], xy[:, 1])
    m_n = scene.parameters["pair.normal_module"] * 1e3
    near.set(xlim=(r.max() - 9 * m_n, r.max() + 0.5 * m_n), ylim=(-5.5 * m_n, 5.5 * m_n))
    whole.add_patch(plt.Rectangle((r.max() - 9 * m_n, -5.5 * m_n), 9.5 * m_n, 11 * m_n,
                                  fill=False, color="tab:red", lw=1))
    whole.set_title(f"{scene.name} gear 1: compliance_tool's TET10 mesh, face z = −b/2\n"
                    f"{summary.get('nodes', '?')} nodes, {summary.get('elements', '?')} elements "
                    f"(bore clamped)", fontsize=9)
    near.set_title("loaded tooth 0 (on +x) and its fine neighbours", fontsize=9)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return (f"{summary.get('nodes')} nodes, tool {summary.get('total_s')} s, "
            f"peak {summary.get('peak_rss_MiB')} MiB")


def planetary_sharing(path: pathlib.Path, opt: Options) -> str:
    """The four planets' share of the sun's force over the carrier's angle
    (scenarios/trains/planetary_4_planets.toml through its train FMU): sun driven at 100 rad/s,
    carrier loaded by 100 N m, 0.2 s to settle at 1e-2 s, then 0.02 s sampled every 2e-5 s."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from gearmesh import train_fmu

    opt.work.mkdir(parents=True, exist_ok=True)
    fmu = train_fmu.build_train_fmu(PLANETARY, opt.work / "planetary_4_planets.fmu", opt.fmu)
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier="GearTrain",
                  instanceName="figure")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    zs, zr, ws, load, n = 21, 63, 100.0, 100.0, 4
    wc, twist = ws * zs / (zs + zr), load * zs / (zs + zr) / 1e4
    names = ["sun.omega", "carrier.omega", "motor.far_omega", "carrier.torque", "motor.far_phi"]
    values = [ws, wc, ws, -load, twist]
    for p in range(1, n + 1):  # the planets start at the scene's angles
        names.append(f"planet{p}.omega")
        values.append(wc - (ws - wc))
    f.setReal([vr[x] for x in names], values)
    f.exitInitializationMode()
    t, angle, force = 0.0, [], []
    for h, steps, keep in ((1e-2, 20, False), (2e-5, 1000, True)):
        for _ in range(steps):
            f.setReal([vr["motor.far_phi"], vr["motor.far_omega"], vr["carrier.torque"]], [twist + ws * t, ws, -load])
            f.doStep(t, h)
            t += h
            if keep:
                angle.append(f.getReal([vr["carrier.angle"]])[0])
                force.append(f.getReal([vr[f"sun_planet{p}.normal_force"] for p in range(1, n + 1)]))
    f.terminate()
    f.freeInstance()
    angle, force = np.degrees(np.array(angle)), np.array(force)
    share = force / force.sum(axis=1, keepdims=True)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4))
    for p in range(n):
        ax.plot(angle, share[:, p], label=f"planet {p + 1}: mean {share[:, p].mean():.4f}")
    ax.axhline(1 / n, color="k", lw=0.8, ls="--")
    ax.set(xlabel="carrier angle (deg)", ylabel="share of the sun's force",
           title="Planetary stage 21/21/63, four planets: sequential phasing, equal on average")
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return f"{len(angle)} samples over {angle[-1] - angle[0]:.1f} deg of the carrier"


def planetary_pin_error(path: pathlib.Path, opt: Options) -> str:
    """Quasi-static planet load sharing over a carrier revolution with planet 1's pin 3 µm off
    tangentially (gearmesh.train_report.quasi_static on the planetary scenes, 1000 N m on the
    carrier): three planets with the sun fixed and floating, four planets floating."""
    from gearmesh import train_fmu
    from gearmesh.train_report import quasi_static, sharing

    opt.work.mkdir(parents=True, exist_ok=True)
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), sharey=True)
    cases = ((PLANETARY3, {}, "3 planets, sun fixed"), (PLANETARY3, {"sun.mass": 1.0}, "3 planets, sun floating"),
             (PLANETARY, {"sun.mass": 1.0}, "4 planets, sun floating"))
    factors = []
    for ax, (scene, extra, title) in zip(axes, cases):
        train = train_fmu.load_train(scene)
        fmu = train_fmu.build_train_fmu(scene, opt.work / f"{scene.stem}.fmu", opt.fmu)
        r = quasi_static(fmu, train, load_Nm=PIN_LOAD, points=360,
                         parameters={"planet1.pin_error_tangential": PIN_ERROR, **extra})
        shares = sharing(train, r)
        angle = np.degrees(r["carrier.angle"] - r["carrier.angle"][0])
        sun = [n for n in shares if n.startswith("sun_planet")]
        for n in sun:
            ax.plot(angle, shares[n], label=n.replace("sun_", ""))
        k_gamma = len(sun) * max(shares[n].max() for n in sun)
        factors.append(f"{title}: K_γ {k_gamma:.3f}")
        ax.set(xlabel="carrier angle (deg)", title=f"{title}\nK_γ = {k_gamma:.3f}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    axes[0].set_ylabel("share of the sun's force")
    fig.suptitle(f"Planet 1's pin {PIN_ERROR * 1e6:g} µm off tangentially, {PIN_LOAD:g} N m on the carrier "
                 "(quasi-static)",
                 fontsize=10)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return "; ".join(factors)


# ---------------------------------------------------------------------------------------------
# aliasing.png


def aliasing(path: pathlib.Path, opt: Options) -> str:
    """What a 1 ms master records of set A's TE at 3000 rpm (large-step mode, driven through a
    shaft against 200 N m): the spectrum of its point samples, where the mesh orders at 2.85, 5.7
    and 8.55 kHz fold below 500 Hz, against the FMU's own mesh orders (mesh.te_order<k>) and the
    spectrum of the same run sampled at 100 kHz."""
    from gearmesh.fmu_driver import GearMeshFMU

    w = 3000 * 2 * np.pi / 60
    z1 = 57
    start = {"model.dynamics": 1, "dynamics.tolerance": 1e-9, "gear1.omega": w, "gear2.omega": -w,
             "gear1.shaft_stiffness": 2e4, "gear1.shaft_damping": 10.0, "gear1.shaft_omega": w,
             "gear2.torque": 200.0}
    settle, span = 0.05, 0.2

    def run(h):
        te, orders = [], None
        with GearMeshFMU(opt.fmu, start) as f:
            t = 0.0
            while t < settle + span - 1e-12:
                f.step({"gear1.shaft_phi": w * t}, h)
                t = f.time
                if t > settle + 1e-12:
                    te.append(f.get(["mesh.te"])["mesh.te"])
            orders = f.get([f"mesh.te_order{k}" for k in (1, 2, 3)])
        return np.array(te), orders

    def spectrum(x, h):
        x = x - x.mean()
        amplitude = 2 * np.abs(np.fft.rfft(x * np.hanning(len(x)))) / np.hanning(len(x)).sum()
        return np.fft.rfftfreq(len(x), h), amplitude

    point, orders = run(1e-3)
    fine, _ = run(1e-5)
    mesh = w / (2 * np.pi) * z1
    f_point, a_point = spectrum(point, 1e-3)
    f_fine, a_fine = spectrum(fine, 1e-5)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.8))
    ax.semilogy(f_fine / 1e3, a_fine * 1e6, color="0.6", lw=0.8, label="TE sampled at 100 kHz")
    ax.semilogy(f_point / 1e3, a_point * 1e6, color="C3", lw=1.2, label="TE sampled at 1 kHz (a 1 ms master)")
    ks = [1, 2, 3]
    amps = [orders[f"mesh.te_order{k}"] * 1e6 for k in ks]
    ax.semilogy([k * mesh / 1e3 for k in ks], amps, "o", color="C0", ms=7,
                label="mesh.te_order1-3 (the FMU's mesh orders)")
    folded = [abs(k * mesh - 1000 * round(k * mesh / 1000)) for k in ks]
    ax.text(3.2, 3e-3, "at 1 kHz, mesh orders 1, 2, 3 fold to\n" + ", ".join(f"{fa:.0f}" for fa in folded)
            + " Hz: a line of the full amplitude\nat a frequency the drivetrain does not have",
            fontsize=8, color="C3")
    ax.set(xlabel="frequency (kHz)", ylabel="TE amplitude (µm)", xlim=(0, 9.5), ylim=(1e-4, 5))
    ax.set_title(f"Set A at 3000 rpm (mesh {mesh / 1e3:.2f} kHz), large-step mode: what a 1 ms master sees",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    peak = f_point[1:][np.argmax(a_point[1:])]
    return (f"orders {', '.join(f'{a:.3g}' for a in amps)} um; the 1 kHz samples' largest line at {peak:.0f} Hz "
            f"({a_point[1:].max() * 1e6:.3g} um)")


MAKERS = {"te_set_a": te_set_a, "schematic": schematic, "pareto": pareto,
          "stability_map": stability_map, "study_histogram": study_histogram,
          "compliance_mesh": compliance_mesh, "planetary_sharing": planetary_sharing,
          "planetary_pin_error": planetary_pin_error, "aliasing": aliasing}


def make(out: pathlib.Path = DEFAULT_OUT, only: list[str] | None = None,
         opt: Options | None = None) -> dict[str, tuple[pathlib.Path, float, str]]:
    """The pictures (all, or `only`) into `out`: name -> (file, seconds, note)."""
    opt = opt or Options()
    names = [n for n in FILES if not only or n in only]
    unknown = sorted(set(only or []) - set(FILES))
    if unknown:
        raise ValueError(f"unknown figure(s) {', '.join(unknown)}; allowed: {', '.join(FILES)}")
    out.mkdir(parents=True, exist_ok=True)
    made = {}
    for name in names:
        start = time.perf_counter()
        note = MAKERS[name](out / FILES[name], opt)
        made[name] = (out / FILES[name], time.perf_counter() - start, note)
        print(f"gearmesh-dev figures: {out / FILES[name]} in {made[name][1]:.1f} s ({note})",
              file=sys.stderr, flush=True)
    return made


def main(out: pathlib.Path, only: list[str] | None, opt: Options) -> int:
    """The CLI's `figures` command; 2 on bad input, 1 if a picture could not be made."""
    try:
        made = make(out, only, opt)
    except ValueError as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    for name, (file, seconds, note) in made.items():
        print(f"{file}: {seconds:.1f} s, {file.stat().st_size / 1024:.0f} kB")
    return 0
