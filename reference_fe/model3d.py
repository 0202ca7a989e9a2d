"""The 3-D contact model of a scene's pair: sectors of both gears as C3D20R hexahedra (mesh3d),
solved position by position exactly as the 2-D model (analysis.Model: placement, engagement,
one load step per torque, TE = r_b1 times gear 1's rotation past the rigid-body angle).

What differs from 2-D:

* the bodies are sectors (the fine teeth and whole teeth each side filling `sector_deg`, rim
  down to the bore) or, at `sector_deg` 360, the whole gears with their bodies (web, hub,
  lightening holes: mesh3d.section_whole), extruded over
  the face width, twisted into helicoids for a helical pair (gear 1 right hand, gear 2 left:
  an external pair has opposite hands; frictionless, the TE of the mirror pair is the same),
  lead crowning mapped onto the flanks;
* the held nodes (the sector's bore and its two radial cut faces, mesh3d): gear 2's clamped in
  x, y, z; gear 1's turn rigidly with the rotation node (the 2-D *EQUATION u_x = -theta y,
  u_y = theta x) and u_z = 0; the end faces are free;
* a first step holds gear 1 at its placement (engagement 2 um, see Model3D.engage) so that the
  contact exists before the torque is applied (ccx.write_deck);
* the unloaded TE that places gear 1 is the smallest over the face width (101 sections) of the
  2-D unloaded TE of the section (turned by the helix) plus both lead gaps there;
* isotropic 3-D elasticity: there is no plane strain / plane stress choice.

Positions: gear 1 turned by k (2 pi / z1) / n from position 0 (flank A of tooth 0 of both gears
touching at the pitch point in the mid-face section); for a helical pair this is one
transverse base pitch, the period of its TE.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import analysis, ccx, mesh3d
from .geometry import Pair
from .scene import PairSpec, SceneError

CODE_VERSION = 1   # bump when the mesh or deck of the 3-D model changes (cache key)


@dataclass
class Case3D(analysis.Case):
    model: str = "solid_3d"
    element: str = "C3D20R"


class Model3D(analysis.Model):
    """Both sectors of a scene at one refinement level (meshed once, placed per position)."""

    # initial closure: CalculiX's surface-to-surface contact facets the quadratic master faces
    # into flat triangles, whose sag on the flank (s^2 / (8 rho), s the node spacing, rho the
    # involute's curvature radius: 0.1-0.3 um here) hides a 0.3 um closure (no contact found)
    engage = 2.0e-6

    def __init__(self, spec: PairSpec, level: int = 0, sector_deg: float = 120.0,
                 size: mesh3d.Size3D | None = None, hold_cuts: bool = True,
                 split_layers: bool = False):
        if spec.gear1.face_width != spec.gear2.face_width:
            raise SceneError("the 3-D reference needs equal face widths (aligned mid-faces)")
        if spec.helix_angle and (spec.gear1.mod.any() or spec.gear2.mod.any()):
            raise SceneError("profile modifications on a helical pair: not implemented in the "
                             "3-D reference (the offset would be transverse, not normal)")
        self.spec = spec
        self.pair = Pair(spec)
        self.level = level
        pr = self.pair
        self.size = size or mesh3d.default_size(spec.module, pr.g1.b, level,
                                                     math.radians(sector_deg))
        self.beta_b = math.asin(math.sin(spec.helix_angle) * math.cos(spec.pressure_angle))
        self.spread = pr.g1.b / 2 * math.tan(self.beta_b)      # roll distance, mid to end
        f1, f2 = analysis.fine_teeth(pr, self.spread)
        self.m1 = mesh3d.build(pr.g1, self.size, f1, +1, self.beta_b, hold_cuts)
        self.m2 = mesh3d.build(pr.g2, self.size, f2, -1, self.beta_b, hold_cuts)
        # split_layers: gear 1's slave surfaces per tooth and element layer, the contact force
        # per layer printed (lineload3d.py); the deck's contact pairs differ, so its own runs
        self.m1.split_layers = split_layers
        self.cache_tag = (f"3d-v{CODE_VERSION}" + ("" if hold_cuts else "-free-cuts")
                          + ("-layers" if split_layers else ""))
        self.whole = mesh3d.is_whole(self.size)
        if self.whole:
            self.cache_tag += "-whole-v2"   # v2: the far teeth's mid-side nodes straightened
        self.variant = ("helical" if spec.helix_angle else "spur") + (
            "_lead_crowned" if (spec.gear1.mod.lead_crowning or spec.gear2.mod.lead_crowning)
            else "") + ("_whole" if self.whole else "")

    def stats(self) -> dict:
        return {"gear1": self.m1.stats, "gear2": self.m2.stats,
                "size_m": mesh3d.size_dict(self.size)}

    def materials(self, case):
        return [ccx.Material(self.pair.g1.E, self.pair.g1.nu),
                ccx.Material(self.pair.g2.E, self.pair.g2.nu)]

    def element(self, case) -> str:
        return case.element

    def thickness(self):
        return None

    def unloaded_te(self, dphi1: float) -> float:
        pr = self.pair
        g1, g2 = pr.g1, pr.g2
        best = math.inf
        for z in np.linspace(-g1.b / 2, g1.b / 2, 101):
            te = pr.unloaded_te(dphi1 + z * math.tan(g1.beta) / g1.r)
            te += float(mesh3d.lead_gap(g1, z) + mesh3d.lead_gap(g2, z))
            best = min(best, te)
        return best
