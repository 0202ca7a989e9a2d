"""The settings `gearmesh accuracy` compares: stiffness level x slices (x coupled teeth at level
5), and where level 5's compliance databases come from (the cache of gearmesh.compliance only:
this command never runs compliance_tool)."""
from __future__ import annotations

import dataclasses
import pathlib
from dataclasses import dataclass

from gearmesh import compliance
from gearmesh.param_ranges import fmu_ranges
from gearmesh.scene import Scene

SLICES = (1, 3, 10, 20, 40)
COUPLED = (0, 1, 2, 3)
# quick: the CI ledger (docs/validation.md): levels 2, 3, 4 at 10 slices, the reference's lowest
# and highest torque
QUICK_LEVELS = (2, 3, 4)
QUICK_SLICES = (10,)
PRESETS = ("quick", "full")
# Level 0's constant (model.user_stiffness, one tooth pair per unit face width) as a user would
# take it from ISO 6336-1: the mean mesh stiffness c_gamma_alpha, or the single stiffness c' that
# docs/model.md ("Contact detection", slices) names as the parameter's meaning.
LEVEL0_CONSTANTS = ("c_ga", "c'")


@dataclass(frozen=True)
class Setting:
    level: int
    slices: int
    coupled: int | None = None  # level 5 only
    constant: str | None = None  # level 0 only: one of LEVEL0_CONSTANTS

    @property
    def label(self) -> str:
        level = f"L0({self.constant})" if self.constant else f"L{self.level}"
        text = f"{level} s{self.slices}"
        return text if self.coupled is None else f"{text} c{self.coupled}"

    def parameters(self) -> dict:
        out = {"model.stiffness": self.level, "model.slices": self.slices}
        if self.coupled is not None:
            out["model.coupled_teeth"] = self.coupled
        return out


def settings(preset: str, level5_coupled: tuple[int, ...] = ()) -> list[Setting]:
    """The preset's settings; level 5 only with the coupled-teeth values that have databases."""
    if preset == "quick":
        return [Setting(level, s) for level in QUICK_LEVELS for s in QUICK_SLICES]
    if preset != "full":
        raise ValueError(f"--settings {preset}: unknown; allowed: {', '.join(PRESETS)}")
    out = [Setting(0, s, constant=c) for c in LEVEL0_CONSTANTS for s in SLICES]
    out += [Setting(level, s) for level in range(1, 5) for s in SLICES]
    out += [Setting(5, s, c) for c in level5_coupled for s in SLICES]
    return out


def torques(preset: str, reference_torques: list[float]) -> list[float]:
    """The reference's torques (quick: its lowest and highest)."""
    ordered = sorted(reference_torques)
    return ordered if preset == "full" else sorted({ordered[0], ordered[-1]})


def level5_scene(scene: Scene, coupled: int) -> Scene:
    """The scene at level 5 with `coupled` teeth: what the cache key of its databases is made of."""
    parameters = {**scene.parameters, "model.stiffness": 5, "model.coupled_teeth": coupled}
    for i in (1, 2):
        parameters.pop(f"gear{i}.compliance", None)
    parameters.pop("model.stiffness_table", None)
    return dataclasses.replace(scene, parameters=parameters)


def cached_databases(scene: Scene, coupled: int, fmu: pathlib.Path, tool: pathlib.Path | None = None,
                     cache: pathlib.Path | None = None) -> dict[int, pathlib.Path] | None:
    """Both gears' cached databases that serve `coupled` teeth (built for `coupled` or more, up
    to the FMU's max of model.coupled_teeth: a database for n coupled teeth serves any
    model.coupled_teeth <= n), or None."""
    tool = pathlib.Path(tool or compliance.default_tool())
    cache = pathlib.Path(cache or compliance.default_cache())
    if not tool.is_file() or not cache.is_dir():
        return None
    most = int(fmu_ranges(fmu)["model.coupled_teeth"].hi)
    for built_for in range(coupled, most + 1):
        at = level5_scene(scene, built_for)
        paths = {i: cache / f"{compliance.cache_key(at, i, tool)}.gcdb" for i in (1, 2)}
        if all(p.is_file() for p in paths.values()):
            return paths
    return None
