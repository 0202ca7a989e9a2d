"""Loaded transmission error of a scene's spur pair by CalculiX, over positions in one pitch.

Position k of n: gear 1 turned dphi1 = k (2 pi / z1) / n from position 0, where flank A of
tooth 0 of both gears touches at the pitch point (unloaded, unmodified), gear 2 turned
conjugately (-dphi1 z1 / z2) and clamped at its bore. Gear 1 is placed turned a further
theta0 = (unloaded TE + engage) / r_b1 (so that the contact is closed from the first iteration),
then the torques are applied one step each. TE = r_b1 (theta0 + theta_FE): gear 1's rotation
past the rigid-body kinematic angle along the line of action, positive = approach on flank A,
the product's sign convention (repository docs/fmi.md, "Variables"; with gear 2 held, its
TE = r_b1 phi1 + r_b2 phi2 reduces to r_b1 times gear 1's extra rotation).
"""
from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import tempfile
from dataclasses import asdict, dataclass, field

import numpy as np

from . import ccx, mesh
from .geometry import Pair
from .scene import PairSpec

MODELS = ("plane_strain", "plane_stress")
DEFAULT_PENALTY = 1.0e16   # Pa/m: 0.06 um overclosure at 600 MPa contact pressure
ENGAGE = 0.3e-6            # m, initial closure past the first touch


@dataclass
class Case:
    model: str = "plane_strain"
    level: int = 0                     # mesh refinement level (sizes / 2^level)
    penalty: float = DEFAULT_PENALTY   # Pa/m
    friction: float = 0.0              # Coulomb mu (0: frictionless)
    element: str = "CPE6"              # CPE6 (plane stress by the equivalent material) / CPS6

    def key(self) -> str:
        return f"{self.model}|L{self.level}|K{self.penalty:.3g}|mu{self.friction:g}|{self.element}"


@dataclass
class PositionResult:
    position: int
    n_positions: int
    dphi1: float
    te: list[float]             # m, one per torque
    torques: list[float]
    wall_s: float
    max_rss_MiB: float
    iterations_note: str = ""
    # per torque: gear 1's contact tooth (index mod z) -> |contact force| (N) and its moment
    # about gear 1's axis (N m; the moments add up to the torque)
    pair_force_N: list = field(default_factory=list)
    pair_moment_Nm: list = field(default_factory=list)
    # 3-D with per-layer slave surfaces (lineload3d.py), per torque: gear 1's contact tooth ->
    # element layer -> [fx, fy, fz] (N) of the contact force on that layer's faces and its
    # moment about gear 1's axis (N m) as a fourth entry (JSON keys are text)
    layer_force_N: list = field(default_factory=list)


# How far past the path of contact's ends a tooth pair gets contact surfaces, as a fraction of the
# base pitch (`run --contact-margin`): tip-corner contact under load extends the path. An
# internal pair's flanks conform, so its corner gaps grow slowly past the path's end and its
# contact reaches farther than an external pair's (the 21/62 ring at 100 N m: 0.18 p_b and
# beyond; set A at 350 N m: none past 0.15 p_b). contact_set_check names the positions where a
# left-out tooth's rigid corner gap is below the solved TE.
CONTACT_MARGIN = 0.15


def fine_teeth(pair: Pair, spread: float = 0.0,
               margin: float = CONTACT_MARGIN) -> tuple[list[int], list[int]]:
    """Teeth that can touch while gear 1 turns one pitch from position 0 (pairs within the
    path of contact, extended by `margin` base pitches at both ends for tip-corner contact under
    load): gear 1's tooth j meshes gear 2's tooth -j (an internal ring's +j). spread (m): the
    roll distance by which the pair's contact moves either way across the face (helical:
    b/2 tan beta_b; spur 0)."""
    js = []
    ext = margin * pair.pb
    for j in range(-8, 9):
        lo = pair.rho_pitch1 + pair.g1.rb * j * pair.g1.tau - spread
        hi = lo + pair.pb + 2 * spread
        if hi >= pair.rho_sap1 - ext and lo <= pair.rho_tip1 + ext:
            js.append(j)
    return js, (list(js) if getattr(pair, "internal", False) else [-j for j in js])


def contact_set_check(pair: Pair, teeth: list[int], results, spread: float = 0.0) -> list[dict]:
    """The positions where a tooth pair left out of the contact set (the next one at either
    end of `teeth`, gear 1's, signed) could have touched: its tip corner's rigid gap
    (Pair.tip_corner_gap, in the transverse section; a helical pair's sections at the face ends
    stand `spread` of roll either way, so the smallest of the three) below the solved TE at the
    top torque. The other pairs' loads, a body's twist among them, may still carry it clear
    (rerun with a larger margin to know); an empty list: none could."""
    out = []
    shifts = (0.0, -spread / pair.g1.rb, spread / pair.g1.rb) if spread else (0.0,)
    for r in results:
        te = max(r.te)
        for j, leaving in ((max(teeth) + 1, True), (min(teeth) - 1, False)):
            g = min(pair.tip_corner_gap(r.dphi1 + d, j, leaving) for d in shifts)
            if g < te:
                out.append({"position": r.position, "tooth_gear1": j,
                            "end": "leaving" if leaving else "entering",
                            "corner_gap_m": g, "te_m": te})
    return out


def place(m, phi: float, cx: float):
    """A copy of the mesh turned by phi about its axis and moved to (cx, 0) (3-D: z kept)."""
    out = copy.copy(m)
    c, s = math.cos(phi), math.sin(phi)
    x, y = m.nodes[:, 0], m.nodes[:, 1]
    out.nodes = np.column_stack([c * x - s * y + cx, s * x + c * y, *m.nodes[:, 2:].T])
    return out


class Model:
    """The two meshed gears of a scene at one refinement level (meshed once, placed per
    position)."""

    def __init__(self, spec: PairSpec, level: int, size: mesh.MeshSize | None = None,
                 margin: float = CONTACT_MARGIN):
        self.spec = spec
        self.pair = Pair(spec)
        self.level = level
        self.size = size or mesh.default_size(spec.module, level)
        self.margin = margin
        f1, f2 = fine_teeth(self.pair, margin=margin)
        self.m1 = mesh.build(self.pair.g1, self.size, f1)
        self.m2 = mesh.build(self.pair.g2, self.size, f2)

    def stats(self) -> dict:
        return {"gear1": self.m1.stats, "gear2": self.m2.stats,
                "size_m": asdict(self.size), "fine_teeth_gear1": self.m1.contact_teeth,
                "fine_teeth_gear2": self.m2.contact_teeth, "contact_margin_pb": self.margin}

    def materials(self, case: Case):
        mats = [ccx.Material(self.pair.g1.E, self.pair.g1.nu),
                ccx.Material(self.pair.g2.E, self.pair.g2.nu)]
        if case.model == "plane_stress" and case.element == "CPE6":
            mats = [ccx.plane_stress_equivalent(m) for m in mats]
        return mats

    engage = ENGAGE   # m, initial closure past the first touch

    def unloaded_te(self, dphi1: float) -> float:
        return self.pair.unloaded_te(dphi1)

    def thickness(self):
        """Section thickness of the plane elements: the face width."""
        return self.pair.g1.b

    def element(self, case: Case) -> str:
        if case.element == "CPS6" and case.model != "plane_stress":
            raise ValueError("CPS6 is plane stress")
        return case.element

    def solve_position(self, case: Case, k: int, n: int, torques, workdir) -> PositionResult:
        pr = self.pair
        dphi = k * pr.g1.tau / n
        phi1, phi2 = pr.rotations(dphi)
        te0 = self.unloaded_te(dphi)
        if not math.isfinite(te0):
            raise RuntimeError(f"position {k}: no tooth pair on the path of contact")
        theta0 = (te0 + self.engage) / pr.g1.rb
        b1 = place(self.m1, phi1 + theta0, 0.0)
        b2 = place(self.m2, phi2, pr.a)
        os.makedirs(workdir, exist_ok=True)
        ccx.write_deck(os.path.join(workdir, "gears.inp"), [b1, b2], self.thickness(),
                       self.materials(case), list(torques), case.penalty,
                       friction=case.friction, element=self.element(case))
        res = ccx.run(workdir)
        ends = {}
        for t, rot in res.rotations:        # the last increment of step s ends at time s
            s = round(t)
            if abs(t - s) < 1e-6 and s >= 1:
                ends[s] = rot
        pre = ccx.pre_steps([b1, b2])
        if res.returncode != 0 or len(ends) != len(torques) + pre:
            raise RuntimeError(f"ccx failed at position {k} (exit {res.returncode}, "
                               f"{len(ends)}/{len(torques) + pre} steps):\n{res.log_tail}")
        te = [float(pr.g1.rb * (theta0 + ends[s + 1 + pre])) for s in range(len(torques))]
        step_ends = [s + 1 + pre for s in range(len(torques))]
        forces, moments = pair_totals(res.contact, step_ends)
        return PositionResult(position=k, n_positions=n, dphi1=float(dphi), te=te,
                              torques=list(torques), wall_s=res.wall_s,
                              max_rss_MiB=res.max_rss_MiB, pair_force_N=forces,
                              pair_moment_Nm=moments,
                              layer_force_N=layer_totals(res.contact_layers, step_ends))


def pair_totals(contact, step_ends: list[int]) -> tuple[list[dict], list[dict]]:
    """Per step end: gear-1 tooth -> |contact force| and -> moment about gear 1's axis, from
    the last print of each step (ccx.parse_contact_totals; JSON keys are the tooth as text)."""
    forces, moments = [], []
    for s in step_ends:
        at = [c for c in contact if abs(c[0] - s) < 1e-6]
        last = {tooth: (f, mz) for _, tooth, f, mz in at}
        forces.append({str(t): f for t, (f, _) in sorted(last.items())})
        moments.append({str(t): mz for t, (_, mz) in sorted(last.items())})
    return forces, moments


def layer_totals(contact_layers, step_ends: list[int]) -> list[dict]:
    """Per step end: tooth -> layer -> [fx, fy, fz, mz] from the last print of each step
    (ccx.parse_contact_layers); [] per step without per-layer surfaces."""
    out = []
    for s in step_ends:
        last: dict = {}
        for t, tooth, layer, f, mz in contact_layers:
            if abs(t - s) < 1e-6:
                last.setdefault(str(tooth), {})[str(layer)] = [*f, mz]
        out.append({t: dict(sorted(v.items(), key=lambda kv: int(kv[0])))
                    for t, v in sorted(last.items(), key=lambda kv: int(kv[0]))})
    return out


def orders(te: np.ndarray, count: int = 3) -> list[float]:
    """Amplitudes of mesh orders 1..count of TE sampled at n equidistant positions over one
    pitch (periodic, end point excluded): 2 |X_k| / n of numpy's FFT."""
    X = np.fft.rfft(np.asarray(te))
    n = len(te)
    return [float(2 * abs(X[k]) / n) if k < len(X) else float("nan")
            for k in range(1, count + 1)]


def summary(positions: list[PositionResult], torque_index: int) -> dict:
    te = np.array([p.te[torque_index] for p in sorted(positions, key=lambda p: p.position)])
    full = len(te) == positions[0].n_positions
    out = {"n_positions": len(te), "mean_te_m": float(te.mean()),
           "pp_te_m": float(te.max() - te.min())}
    o = orders(te) if full else [float("nan")] * 3
    out.update({f"order{k}_m": o[k - 1] for k in (1, 2, 3)})
    return out


def cache_key(spec: PairSpec, model: Model, case: Case, k: int, n: int, torques) -> str:
    """A run is redone only if something that changes its deck changed (a model may add a
    `cache_tag`: its variant and code version)."""
    d = {"scene": open(spec.path, "rb").read().decode(), "case": case.key(),
         "size": asdict(model.size), "k": k, "n": n, "torques": list(torques), "version": 2}
    if getattr(model, "cache_tag", None):
        d["tag"] = model.cache_tag
    if getattr(model, "margin", CONTACT_MARGIN) != CONTACT_MARGIN:
        d["contact_margin"] = model.margin
    blob = json.dumps(d, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def run_case(spec: PairSpec, model: Model, case: Case, positions, n: int, torques,
             cache_dir: str | None = None, log=print) -> list[PositionResult]:
    """Solve the given positions (indices of n) of one case, reusing cached runs."""
    cache_dir = cache_dir or os.path.join(tempfile.gettempdir(), "reference_fe_cache")
    os.makedirs(cache_dir, exist_ok=True)
    out = []
    for k in positions:
        key = cache_key(spec, model, case, k, n, torques)
        path = os.path.join(cache_dir, key + ".json")
        if os.path.exists(path):
            with open(path) as f:
                out.append(PositionResult(**json.load(f)))
            continue
        with tempfile.TemporaryDirectory(prefix="reference_fe_") as wd:
            r = model.solve_position(case, k, n, torques, wd)
        with open(path, "w") as f:
            json.dump(asdict(r), f)
        log(f"{spec.name} {case.key()} position {k}/{n}: TE "
            + " ".join(f"{t * 1e6:.3f}" for t in r.te) + f" um, {r.wall_s:.1f} s, "
            f"{r.max_rss_MiB:.0f} MiB")
        out.append(r)
    return out
