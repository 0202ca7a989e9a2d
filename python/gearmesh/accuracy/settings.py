"""The settings `gearmesh accuracy` compares: stiffness level x slices (x coupled teeth at level
5, and level 5's FE variants: the mesh coarse/default/fine and the flank-grid density), and where
level 5's compliance databases come from (the cache of gearmesh.compliance; they are built only
with --build-databases)."""
from __future__ import annotations

import dataclasses
import json
import pathlib
from dataclasses import dataclass

from gearmesh import compliance
from gearmesh.param_ranges import fmu_ranges
from gearmesh.scene import Scene

SLICES = (1, 3, 10, 20, 40)
COUPLED = (0, 1, 2, 3)
# quick: a CI ledger (docs/validation.md): levels 2, 3, 4 at 10 slices, the reference's lowest
# and highest torque, and level 4 without its tooth coupling (L4 s10 c0) beside it
QUICK_LEVELS = (2, 3, 4)
QUICK_SLICES = (10,)
# level5: the CI ledger of the FE level: level 5 at 10 slices and the scene's coupled teeth, its
# [fe] mesh (no variants), every reference torque; the databases are built when missing (about
# 10 s and 1 GiB per distinct gear at the default mesh)
LEVEL5_SLICES = 10
PRESETS = ("quick", "level5", "full")
# Level 0's constant (model.user_stiffness, one tooth pair per unit face width) as a user would
# take it from ISO 6336-1: the mean mesh stiffness c_gamma_alpha, or the single stiffness c' that
# docs/model.md ("Contact detection", slices) names as the parameter's meaning.
LEVEL0_CONSTANTS = ("c_ga", "c'")
# Level 5's FE variants, as [fe] keys over the scene's own (docs/validation.md, "FE variants"):
# the mesh one step coarser and finer than compliance_tool's default 8 x 4 x 3 (profile x width
# x fillet elements; the flank grid is the flank's nodes, (2 p + 1) x (2 w + 1), so it follows),
# and the flank grid loaded at 70 % and 50 % (the paper's reduced grid: the other columns from
# the reduction space of the loaded ones). Each at 10 slices and the scene's coupled teeth.
FE_VARIANTS: dict[str, dict] = {
    "mesh-coarse": {"profile_elements": 6, "width_elements": 3, "fillet_elements": 2},
    "mesh-fine": {"profile_elements": 12, "width_elements": 6, "fillet_elements": 4},
    "grid-70%": {"load_fraction": 0.7},
    "grid-50%": {"load_fraction": 0.5},
}
FE_VARIANT_SLICES = 10
DEFAULT_COUPLED = 2  # the FMU's default model.coupled_teeth


@dataclass(frozen=True)
class Setting:
    level: int
    slices: int
    coupled: int | None = None  # levels 4 (tooth coupling) and 5; None: the scene's
    constant: str | None = None  # level 0 only: one of LEVEL0_CONSTANTS
    fe: str | None = None        # level 5 only: one of FE_VARIANTS (None: the scene's [fe])

    @property
    def label(self) -> str:
        level = f"L0({self.constant})" if self.constant else f"L{self.level}"
        text = f"{level} s{self.slices}"
        text = text if self.coupled is None else f"{text} c{self.coupled}"
        return text if self.fe is None else f"{text} {self.fe}"

    def parameters(self) -> dict:
        out = {"model.stiffness": self.level, "model.slices": self.slices}
        if self.coupled is not None:
            out["model.coupled_teeth"] = self.coupled
        return out


def settings(preset: str, level5_coupled: tuple[int, ...] = (),
             fe_variants: tuple[str, ...] = (), variant_coupled: int = DEFAULT_COUPLED) -> list[Setting]:
    """The preset's settings; level 5 only with the coupled-teeth values and FE variants that
    have databases."""
    if preset == "quick":
        return ([Setting(level, s) for level in QUICK_LEVELS for s in QUICK_SLICES] +
                [Setting(4, s, 0) for s in QUICK_SLICES])
    if preset == "level5":
        return [Setting(5, LEVEL5_SLICES, c) for c in level5_coupled]
    if preset != "full":
        raise ValueError(f"--settings {preset}: unknown; allowed: {', '.join(PRESETS)}")
    out = [Setting(0, s, constant=c) for c in LEVEL0_CONSTANTS for s in SLICES]
    out += [Setting(level, s) for level in range(1, 5) for s in SLICES]
    out += [Setting(5, s, c) for c in level5_coupled for s in SLICES]
    out += [Setting(5, FE_VARIANT_SLICES, variant_coupled, fe=v) for v in fe_variants]
    return out


def torques(preset: str, reference_torques: list[float]) -> list[float]:
    """The reference's torques (quick: its lowest and highest)."""
    ordered = sorted(reference_torques)
    return sorted({ordered[0], ordered[-1]}) if preset == "quick" else ordered


def scene_coupled(scene: Scene) -> int:
    """The scene's coupled teeth (the FMU's default where it sets none)."""
    return int(scene.parameters.get("model.coupled_teeth", DEFAULT_COUPLED))


def level5_scene(scene: Scene, coupled: int, fe: str | None = None) -> Scene:
    """The scene at level 5 with `coupled` teeth and FE variant `fe` over its [fe] keys: what
    the cache key of its databases is made of."""
    if fe is not None and fe not in FE_VARIANTS:
        raise ValueError(f"FE variant {fe!r}: unknown; allowed: {', '.join(FE_VARIANTS)}")
    parameters = {**scene.parameters, "model.stiffness": 5, "model.coupled_teeth": coupled}
    for i in (1, 2):
        parameters.pop(f"gear{i}.compliance", None)
    parameters.pop("model.stiffness_table", None)
    fe_keys = {**scene.fe, **(FE_VARIANTS[fe] if fe else {})}
    return dataclasses.replace(scene, parameters=parameters, fe=fe_keys)


def cached_databases(scene: Scene, coupled: int, fmu: pathlib.Path, tool: pathlib.Path | None = None,
                     cache: pathlib.Path | None = None,
                     fe: str | None = None) -> dict[int, pathlib.Path] | None:
    """Both gears' cached databases of FE variant `fe` that serve `coupled` teeth (built for
    `coupled` or more, up to the FMU's max of model.coupled_teeth: a database for n coupled
    teeth serves any model.coupled_teeth <= n), or None."""
    tool = pathlib.Path(tool or compliance.default_tool())
    cache = pathlib.Path(cache or compliance.default_cache())
    if not tool.is_file() or not cache.is_dir():
        return None
    most = int(fmu_ranges(fmu)["model.coupled_teeth"].hi)
    for built_for in range(coupled, most + 1):
        at = level5_scene(scene, built_for, fe)
        paths = {i: cache / f"{compliance.cache_key(at, i, tool)}.gcdb" for i in (1, 2)}
        if all(p.is_file() for p in paths.values()):
            return paths
    return None


@dataclass(frozen=True)
class DatabaseCost:
    build_s: float    # wall time of compliance_tool over the distinct databases, s
    peak_MiB: float   # the largest peak resident memory of those builds, MiB


def database_cost(paths: dict[int, pathlib.Path]) -> DatabaseCost | None:
    """What the databases cost to build, from the cache's record next to each (<key>.json,
    gearmesh.compliance); None when a record is missing. Equal gears share one database."""
    seconds, peak = 0.0, 0.0
    for path in dict.fromkeys(paths.values()):
        meta = pathlib.Path(path).with_suffix(".json")
        if not meta.is_file():
            return None
        summary = json.loads(meta.read_text()).get("summary", {})
        if "total_s" not in summary or "peak_rss_MiB" not in summary:
            return None
        seconds += float(summary["total_s"])
        peak = max(peak, float(summary["peak_rss_MiB"]))
    return DatabaseCost(seconds, peak)
