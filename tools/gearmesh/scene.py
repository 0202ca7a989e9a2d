"""Scene files: TOML with the unit in every key name, validated in this one place.

A scene lists only what it uses; every key it omits keeps the FMU's default (the core's
gm_default_params). Each key maps to one FMU parameter with a factor to SI.
"""
from __future__ import annotations

import math
import pathlib
import tomllib
from dataclasses import dataclass, field


class SceneError(ValueError):
    """A scene key has a wrong name, type or value; the message names key, value and range."""


@dataclass(frozen=True)
class Key:
    variable: str        # FMU variable name
    factor: float = 1.0  # scene unit -> SI
    lo: float = -math.inf
    hi: float = math.inf
    kind: type = float   # float, int, bool, str or list (of floats)
    unit: str = ""       # the unit the key's name carries, for messages


DEG = math.pi / 180.0

# section -> key -> Key. Ranges mirror the core's validation; the core checks again.
SCHEMA: dict[str, dict[str, Key]] = {
    "pair": {
        "center_distance_mm": Key("pair.center_distance", 1e-3, 0.1, 20000, unit="mm"),
        "normal_module_mm": Key("pair.normal_module", 1e-3, 0.1, 100, unit="mm"),
        "pressure_angle_deg": Key("pair.pressure_angle", DEG, 10, 35, unit="deg"),
        "helix_angle_deg": Key("pair.helix_angle", DEG, -45, 45, unit="deg"),
        "internal": Key("pair.internal", kind=bool),
        "rack_addendum": Key("pair.rack_addendum", 1.0, 0.5, 2.0, unit="modules"),
        "rack_dedendum": Key("pair.rack_dedendum", 1.0, 0.5, 3.0, unit="modules"),
        "rack_tip_radius": Key("pair.rack_tip_radius", 1.0, 0.0, 1.0, unit="modules"),
    },
    **{
        f"gear{i}": {
            "teeth": Key(f"gear{i}.teeth", 1, 5, 2000, kind=int),
            "profile_shift": Key(f"gear{i}.profile_shift", 1.0, -1.5, 3.0),
            "face_width_mm": Key(f"gear{i}.face_width", 1e-3, 0.01, 2000, unit="mm"),
            "tip_diameter_mm": Key(f"gear{i}.tip_diameter", 1e-3, 0.0, 40000, unit="mm"),
            "thickness_allowance_um": Key(f"gear{i}.thickness_allowance", 1e-6, -50000, 0,
                                          unit="um"),
            "axial_offset_mm": Key(f"gear{i}.axial_offset", 1e-3, -2000, 2000, unit="mm"),
            "youngs_modulus_GPa": Key(f"gear{i}.youngs_modulus", 1e9, 0.1, 10000, unit="GPa"),
            "poisson_ratio": Key(f"gear{i}.poisson_ratio", 1.0, 0.0, 0.499),
            # micro-geometry, both flanks alike (PHYSICS 2; flank-specific: deviations_file)
            "profile_crowning_um": Key(f"gear{i}.profile_crowning", 1e-6, 0, 1000, unit="um"),
            "tip_relief_um": Key(f"gear{i}.tip_relief", 1e-6, 0, 1000, unit="um"),
            "tip_relief_length_mm": Key(f"gear{i}.tip_relief_length", 1e-3, 0, 1000, unit="mm"),
            "tip_relief_parabolic": Key(f"gear{i}.tip_relief_parabolic", kind=bool),
            "root_relief_um": Key(f"gear{i}.root_relief", 1e-6, 0, 1000, unit="um"),
            "root_relief_length_mm": Key(f"gear{i}.root_relief_length", 1e-3, 0, 1000, unit="mm"),
            "root_relief_parabolic": Key(f"gear{i}.root_relief_parabolic", kind=bool),
            "profile_slope_um": Key(f"gear{i}.profile_slope", 1e-6, -1000, 1000, unit="um"),
            "lead_crowning_um": Key(f"gear{i}.lead_crowning", 1e-6, 0, 1000, unit="um"),
            "helix_slope_um": Key(f"gear{i}.helix_slope", 1e-6, -1000, 1000, unit="um"),
            "end_relief_um": Key(f"gear{i}.end_relief", 1e-6, 0, 1000, unit="um"),
            "end_relief_length_mm": Key(f"gear{i}.end_relief_length", 1e-3, 0, 1000, unit="mm"),
            "deviations_file": Key(f"gear{i}.deviations", kind=str),
        }
        for i in (1, 2)
    },
    "model": {
        "stiffness_level": Key("model.stiffness", 1, 0, 5, kind=int),
        "user_stiffness_N_per_mm_um": Key("model.user_stiffness", 1e9, 1e-6, 1e5,
                                          unit="N/(mm um)"),
        "slices": Key("model.slices", 1, 1, 200, kind=int),
        "friction_coefficient": Key("model.friction_coefficient", 1.0, 0.0, 2.0),
        "friction_velocity_mm_per_s": Key("model.friction_velocity", 1e-3, 1e-6, 10000,
                                          unit="mm/s"),
        "damping_Ns_per_m2": Key("model.damping", 1.0, 0.0, 1e9, unit="N s/m^2"),
        "rated_line_load_N_per_mm": Key("model.rated_line_load", 1e3, 0.0, 1e5, unit="N/mm"),
        # user tables (core/src/user_tables.hpp): files next to the scene, shipped in resources/
        "stiffness_table_file": Key("model.stiffness_table", kind=str),  # level 1
        "te_table_file": Key("model.te_table", kind=str),                # any level
    },
}

# Sections that describe the scene or its runs rather than FMU parameters.
META_SECTIONS = {"scene", "run"}
RUN_SCHEMA: dict[str, Key] = {
    "approach_um": Key("", 1e-6, 0.0, 1000, unit="um"),
    "points_per_pitch": Key("", 1, 4, 1000, kind=int),
    "sweep_margin_um": Key("", 1e-6, 0.0, 1000, unit="um"),
    "sweep_points": Key("", 1, 10, 100000, kind=int),
    "torques_Nm": Key("", 1.0, -1e6, 1e6, kind=list, unit="N m"),
    "speed_rpm": Key("", 2 * 3.141592653589793 / 60, -1e5, 1e5, unit="rpm"),
    "te_pitches": Key("", 1, 1, 1000, kind=int),
    "friction_sweep": Key("", 1.0, 0.0, 2.0, kind=list),
}


@dataclass
class Scene:
    name: str
    path: pathlib.Path
    description: str
    assumptions: list[str]
    parameters: dict[str, float | int | bool | str] = field(default_factory=dict)  # FMU name -> SI
    resources: dict[str, pathlib.Path] = field(default_factory=dict)  # name in resources/ -> file
    run: dict[str, float | int] = field(default_factory=dict)                # run key -> SI


def _convert(where: str, key: Key, value):
    if key.kind is list:
        if not isinstance(value, list) or not value:
            raise SceneError(f"{where} = {value!r}: expected a non-empty list of numbers")
        return [_convert(f"{where}[{i}]", Key(key.variable, key.factor, key.lo, key.hi,
                                              unit=key.unit), v) for i, v in enumerate(value)]
    if key.kind is str:
        if not isinstance(value, str) or not value:
            raise SceneError(f"{where} = {value!r}: expected a non-empty file name")
        return value
    if key.kind is bool:
        if not isinstance(value, bool):
            raise SceneError(f"{where} = {value!r}: expected true or false")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"{where} = {value!r}: expected a number")
    if key.kind is int and not isinstance(value, int):
        raise SceneError(f"{where} = {value!r}: expected a whole number")
    if not (math.isfinite(value) and key.lo <= value <= key.hi):
        unit = f" {key.unit}" if key.unit else ""
        raise SceneError(f"{where} = {value!r}{unit}: allowed range [{key.lo:g}, {key.hi:g}]{unit}")
    return value if key.kind is int else value * key.factor


def parse_scene(text: str, path: pathlib.Path | str = "<string>") -> Scene:
    """Validate a scene's TOML text; raise SceneError naming the first bad key."""
    path = pathlib.Path(path)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML: {exc}") from exc
    meta = raw.get("scene", {})
    unknown_meta = set(meta) - {"name", "description", "assumptions"}
    if unknown_meta:
        raise SceneError(f"scene.{sorted(unknown_meta)[0]}: unknown key; allowed: name, "
                         "description, assumptions")
    scene = Scene(name=str(meta.get("name", path.stem)), path=path,
                  description=str(meta.get("description", "")),
                  assumptions=[str(a) for a in meta.get("assumptions", [])])
    for section, body in raw.items():
        if section in META_SECTIONS:
            continue
        if section not in SCHEMA:
            allowed = ", ".join(sorted(set(SCHEMA) | META_SECTIONS))
            raise SceneError(f"[{section}]: unknown section; allowed: {allowed}")
        if not isinstance(body, dict):
            raise SceneError(f"{section}: expected a table")
        for key, value in body.items():
            spec = SCHEMA[section].get(key)
            if spec is None:
                allowed = ", ".join(sorted(SCHEMA[section]))
                raise SceneError(f"{section}.{key}: unknown key; allowed: {allowed}")
            value = _convert(f"{section}.{key}", spec, value)
            if spec.kind is str:  # a file beside the scene, shipped in the FMU's resources/
                source = (path.parent / value).resolve()
                if not source.is_file():
                    raise SceneError(f"{section}.{key} = {value!r}: no such file next to the "
                                     f"scene ({source})")
                name = f"{section}_{source.name}"
                scene.resources[name] = source
                value = name
            scene.parameters[spec.variable] = value
    level = scene.parameters.get("model.stiffness", 0)
    has_table = "model.stiffness_table" in scene.parameters
    if level == 1 and not has_table:
        raise SceneError("model.stiffness_level = 1 (user tables) takes the pair stiffness from "
                         "model.stiffness_table_file; allowed: give that file, or another level")
    if has_table and level != 1:
        raise SceneError(f"model.stiffness_table_file: used at model.stiffness_level = 1 only, "
                         f"this scene has {level}; allowed: level 1, or no stiffness table")
    for key, value in raw.get("run", {}).items():
        spec = RUN_SCHEMA.get(key)
        if spec is None:
            raise SceneError(f"run.{key}: unknown key; allowed: {', '.join(sorted(RUN_SCHEMA))}")
        scene.run[key] = _convert(f"run.{key}", spec, value)
    return scene


def load_scene(path: pathlib.Path | str) -> Scene:
    path = pathlib.Path(path)
    return parse_scene(path.read_text(encoding="utf-8"), path)
