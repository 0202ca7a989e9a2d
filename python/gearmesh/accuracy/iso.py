"""The stiffness a user would take from ISO 6336-1 for levels 0 and 1 (docs/model.md, "Stiffness levels"),
read from the FMU's calculated parameters (the core's ISO 6336-1 method B, core/src/stiffness_iso.hpp):

* level 0: the mean mesh stiffness c_gamma_alpha = c'(0.75 eps_alpha + 0.25) per unit face width
  (iso.mesh_stiffness), or the single stiffness c' (iso.single_stiffness), both load-corrected by
  model.rated_line_load as level 2 uses them;
* level 1: the level-2 curve as a stiffness table (scenarios/user_stiffness_example.txt gives the
  format): the single-pair stiffness c'(1 - kappa (2u - 1)^2) over the path (u = 0 at its start,
  1 at its end: geometry.path_start and geometry.path_end over gear 1's base radius), kappa =
  0.75 (1 - 1/eps_alpha), over gear 1's roll angle (both constants as level 2 computes them:
  docs/model.md, "Stiffness levels").
"""
from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass

import numpy as np

from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.levels import Level
from gearmesh.param_ranges import parameter_use

TABLE_ROWS = 41    # over the path of contact


@dataclass(frozen=True)
class IsoStiffness:
    c_gamma_alpha: float    # N/m per m of face width (SI of model.user_stiffness)
    c_prime: float          # N/m per m, ISO's single stiffness c' (level 2's single-pair peak)
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


class NotApplicable(ValueError):
    """The pair is not an external spur pair, or ISO's method B has no stiffness for it: levels 0
    and 1 have no ISO input here."""


def iso_stiffness(fmu_path, start_values: dict | None = None) -> IsoStiffness:
    """c_gamma_alpha, c', eps_alpha and the path's roll angles of the pair in `fmu_path` (with
    `start_values` set on top of its own), as the FMU calculates them at initialization. External
    spur pairs only (the table's roll angle is gear 1's; a helical pair's level-2 mean is per
    transverse line, not needed here)."""
    # level 0 with no file accepts every pair; the values do not depend on the level
    files = {name: "" for name, use in parameter_use(fmu_path).items() if use.file}
    params = {**(start_values or {}), **files, "model.stiffness": int(Level.USER_CONSTANT), "model.quasi_static": False}
    with GearMeshFMU(fmu_path, params, instance_name="iso_stiffness") as fmu:
        g = fmu.get(["pair.internal", "pair.helix_angle", "geometry.contact_ratio", "gear1.base_diameter",
                     "geometry.path_start", "geometry.path_end", "iso.single_stiffness", "iso.mesh_stiffness"])
    if g["pair.internal"] or g["pair.helix_angle"] != 0.0:
        raise NotApplicable("levels 0 and 1 from ISO: external spur pairs only "
                            f"(pair.internal = {bool(g['pair.internal'])}, pair.helix_angle = "
                            f"{g['pair.helix_angle']:g} rad; allowed: false, 0)")
    if not g["iso.single_stiffness"] > 0:
        raise NotApplicable("levels 0 and 1 from ISO: iso.single_stiffness = 0 (ISO 6336-1 method B's "
                            "regression gives no positive q'_min for these profile shifts)")
    r_b1 = g["gear1.base_diameter"] / 2
    return IsoStiffness(g["iso.mesh_stiffness"], g["iso.single_stiffness"], g["geometry.contact_ratio"],
                        g["geometry.path_start"] / r_b1, g["geometry.path_end"] / r_b1)


def write_table(iso: IsoStiffness, path: pathlib.Path) -> pathlib.Path:
    path = pathlib.Path(path)
    path.write_text(iso.table_text())
    return path
