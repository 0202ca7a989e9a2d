"""The stiffness levels (model.stiffness; the core's gm_stiffness_level, one file each in
core/src/level<k>_<name>.hpp): the tooling names a level by this enum, never by its number."""
from __future__ import annotations

from enum import IntEnum


class Level(IntEnum):
    USER_CONSTANT = 0  # one pair stiffness, model.user_stiffness
    USER_TABLE = 1     # the pair stiffness over gear 1's roll angle, model.stiffness_table
    ISO6336 = 2        # ISO 6336-1's c' over the path of contact
    CONTACT_LINE = 3   # ISO's c_gamma_alpha per unit length of contact line
    ANALYTICAL = 4     # both teeth's compliance and the local Hertz law, teeth coupled
    FE = 5             # the gears' compliance databases (compliance_tool)
