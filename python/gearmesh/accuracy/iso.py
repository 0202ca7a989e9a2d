"""The stiffness a user would take from ISO 6336-1 for levels 0 and 1 (docs/model.md, "Stiffness levels"):

* level 0: the mean mesh stiffness c_gamma_alpha = c'(0.75 eps_alpha + 0.25) per unit face width,
  with the level-2 model's own c': the peak of its mesh.stiffness per unit face width in the
  single-contact zone (plain mode, micro-geometry removed; the single pair passes mid-path, u =
  0.5, where the level-2 curve peaks at c'). Not the mean of mesh.stiffness over a pitch: a
  loaded pair's tip edge beyond the path adds stiffness there that ISO's c_gamma_alpha leaves out
  (0.3 N/(mm um) on set A at 0.2 um approach, growing with the approach);
* level 1: the level-2 curve as a stiffness table (scenarios/user_stiffness_example.txt gives the
  format): the single-pair stiffness c'(1 - kappa (2u - 1)^2) over the path (u = 0 at its start,
  1 at its end), kappa = 0.75 (1 - 1/eps_alpha), c' = c_gamma_alpha / (0.75 eps_alpha + 0.25),
  over gear 1's roll angle (both constants as level 2 computes them: docs/model.md, "Stiffness levels").
"""
from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass

import numpy as np

from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.prescribed_motion import pair_kinematics

# Micro-geometry and excitation parameters, set to "none" for the run that reads c'.
_MICRO = ("profile_crowning", "tip_relief", "root_relief", "profile_slope", "lead_crowning",
          "helix_slope", "end_relief")
APPROACH = 0.2e-6  # m: any approach loads the single pair; its stiffness is linear at level 2
POSITIONS = 400    # per pitch: the parabola's top is flat, a sample within 1/400 pitch of u = 0.5
                   # is within kappa (2/400 / eps_alpha)^2 < 1e-5 of c'
TABLE_ROWS = 41    # over the path of contact


@dataclass(frozen=True)
class IsoStiffness:
    c_gamma_alpha: float    # N/m per m of face width (SI of model.user_stiffness)
    c_prime: float          # N/m per m, single-pair peak
    contact_ratio: float
    roll_start: float       # rad, gear 1's roll angle at the start of the path of contact
    roll_end: float         # rad, at its end (gear 1's tip)

    def table_text(self, rows: int = TABLE_ROWS) -> str:
        """The level-2 curve in the stiffness-table format (deg, N/(mm um))."""
        if rows < 2:
            raise ValueError(f"table rows = {rows}; allowed: >= 2")
        kappa = 0.75 * (1 - 1 / self.contact_ratio)
        lines = ["gearmesh-stiffness-table 1",
                 "# written by gearmesh.accuracy.iso: ISO 6336-1 method B single-pair stiffness "
                 "of the level-2 model over gear 1's roll angle",
                 f"# c_gamma_alpha = {self.c_gamma_alpha / 1e9:.6g} N/(mm um), c' = "
                 f"{self.c_prime / 1e9:.6g} N/(mm um), eps_alpha = {self.contact_ratio:.6g}",
                 "# roll angle deg   stiffness N/(mm um)"]
        for u in np.linspace(0.0, 1.0, rows):
            roll = self.roll_start + u * (self.roll_end - self.roll_start)
            k = self.c_prime * (1 - kappa * (2 * u - 1) ** 2)
            lines.append(f"{math.degrees(roll):.9g} {k / 1e9:.9g}")
        return "\n".join(lines) + "\n"


def face_overlap(values: dict) -> float:
    """The axial overlap of the two face widths, m."""
    lo = max(values[f"gear{i}.axial_offset"] - values[f"gear{i}.face_width"] / 2 for i in (1, 2))
    hi = min(values[f"gear{i}.axial_offset"] + values[f"gear{i}.face_width"] / 2 for i in (1, 2))
    return hi - lo


class NotApplicable(ValueError):
    """The pair is not an external spur pair: levels 0 and 1 have no ISO input here."""


def iso_stiffness(fmu_path, start_values: dict | None = None) -> IsoStiffness:
    """c_gamma_alpha, c', eps_alpha and the path's roll angles of the pair in `fmu_path` (with
    `start_values` set on top of its own). External spur pairs only (the table's roll angle is
    gear 1's; a helical pair's level-2 mean is per transverse line, not needed here)."""
    params = dict(start_values or {})
    params.update({"model.stiffness": 2, "model.quasi_static": False, "model.stiffness_table": "",
                   "model.te_table": "", "model.friction_coefficient": 0.0})
    for i in (1, 2):
        params.update({f"gear{i}.{m}": 0.0 for m in _MICRO})
        params[f"gear{i}.deviations"] = ""
    with GearMeshFMU(fmu_path, params, instance_name="iso_stiffness") as fmu:
        g = fmu.get(["pair.internal", "pair.helix_angle", "pair.center_distance",
                     "geometry.operating_pressure_angle", "geometry.contact_ratio",
                     "gear1.teeth", "gear1.tip_diameter_used", "gear2.tip_diameter_used",
                     *(f"gear{i}.{n}" for i in (1, 2)
                       for n in ("face_width", "axial_offset"))])
        if g["pair.internal"] or g["pair.helix_angle"] != 0.0:
            raise NotApplicable("levels 0 and 1 from ISO: external spur pairs only "
                             f"(pair.internal = {bool(g['pair.internal'])}, pair.helix_angle = "
                             f"{g['pair.helix_angle']:g} rad; allowed: false, 0)")
        kin = pair_kinematics(fmu)
        pitch = 2 * math.pi / g["gear1.teeth"]
        single = []
        for phi1 in np.arange(POSITIONS) * pitch / POSITIONS:
            fmu.step({"gear1.phi": phi1, "gear2.phi": kin.phi2(APPROACH, phi1)})
            out = fmu.get(["mesh.stiffness", "mesh.pairs_in_contact"])
            if out["mesh.pairs_in_contact"] == 1:
                single.append(out["mesh.stiffness"])
    eps = g["geometry.contact_ratio"]
    if not single or eps >= 2:
        raise ValueError(f"geometry.contact_ratio = {eps:.4g}: no single-contact zone to read c' "
                         "from; allowed: contact ratio < 2")
    c_prime = max(single) / face_overlap(g)
    r_a1, r_a2 = g["gear1.tip_diameter_used"] / 2, g["gear2.tip_diameter_used"] / 2
    line = g["pair.center_distance"] * math.sin(g["geometry.operating_pressure_angle"])
    start = (line - math.sqrt(r_a2 ** 2 - kin.r_b2 ** 2)) / kin.r_b1
    end = math.sqrt(r_a1 ** 2 - kin.r_b1 ** 2) / kin.r_b1
    return IsoStiffness(c_prime * (0.75 * eps + 0.25), c_prime, eps, start, end)


def write_table(iso: IsoStiffness, path: pathlib.Path) -> pathlib.Path:
    path = pathlib.Path(path)
    path.write_text(iso.table_text())
    return path
