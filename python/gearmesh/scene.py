"""Scene files: TOML with the unit in every key name, validated in this one place.

A scene lists only what it uses; every key it omits keeps the FMU's default (the core's
gm_default_params). Each key maps to one FMU parameter with a factor to SI, and is checked against
that parameter's range as the FMU declares it (its modelDescription.xml's min and max, which the
binary enforces: gearmesh.param_ranges), converted to the key's unit for the message. The rules
between parameters, the level's, the pair geometry and the tilt bound are the core's: the whole set
goes through its check (gm_model_check in the FMU binary), and a scene it refuses fails with the
core's message, in the FMU's names.

The FE level (model.stiffness = 5) adds two kinds of tables that are not FMU parameters but
inputs of compliance_tool (gearmesh.compliance builds each gear's database from them):
[gear1.body] / [gear2.body], the gear body (BODY_SCHEMA), and [fe], the FE discretization
(FE_SCHEMA). Their values stay in the scene's units (mm), as the tool's flags take them. They are
refused at any other level: nothing in a scene is silently unused. A gear without a body table
gets the tool's default body (a solid disc with a bore of 0.4 root radius, the analytical level's).
"""
from __future__ import annotations

import math
import pathlib
import re
import tomllib
from dataclasses import dataclass, field

from gearmesh.levels import Level
from gearmesh.param_ranges import Range, default_fmu, fmi_version, fmu_ranges


class SceneError(ValueError):
    """A scene key has a wrong name, type or value; the message names key, value and range."""


@dataclass(frozen=True)
class Key:
    variable: str        # FMU variable name
    factor: float = 1.0  # scene unit -> SI
    lo: float = -math.inf  # lo, hi: a scene-only key's range (an FMU parameter's is the FMU's)
    hi: float = math.inf
    kind: type = float   # float, int, bool, str or list (of `item`)
    unit: str = ""       # the unit the key's name carries, for messages
    item: type = float   # a list's items: float or int


DEG = math.pi / 180.0

# section -> key -> Key of an FMU parameter; its range is the FMU's (fmu_ranges).
SCHEMA: dict[str, dict[str, Key]] = {
    "pair": {
        "center_distance_mm": Key("pair.center_distance", 1e-3, unit="mm"),
        "normal_module_mm": Key("pair.normal_module", 1e-3, unit="mm"),
        "pressure_angle_deg": Key("pair.pressure_angle", DEG, unit="deg"),
        "helix_angle_deg": Key("pair.helix_angle", DEG, unit="deg"),
        "internal": Key("pair.internal", kind=bool),
        "rack_addendum": Key("pair.rack_addendum", 1.0, unit="modules"),
        "rack_dedendum": Key("pair.rack_dedendum", 1.0, unit="modules"),
        "rack_tip_radius": Key("pair.rack_tip_radius", 1.0, unit="modules"),
    },
    **{
        f"gear{i}": {
            "teeth": Key(f"gear{i}.teeth", 1, kind=int),
            "profile_shift": Key(f"gear{i}.profile_shift", 1.0),
            "face_width_mm": Key(f"gear{i}.face_width", 1e-3, unit="mm"),
            "tip_diameter_mm": Key(f"gear{i}.tip_diameter", 1e-3, unit="mm"),
            "thickness_allowance_um": Key(f"gear{i}.thickness_allowance", 1e-6, unit="um"),
            "axial_offset_mm": Key(f"gear{i}.axial_offset", 1e-3, unit="mm"),
            "youngs_modulus_GPa": Key(f"gear{i}.youngs_modulus", 1e9, unit="GPa"),
            "poisson_ratio": Key(f"gear{i}.poisson_ratio", 1.0),
            # micro-geometry, both flanks alike (docs/physics.md §2; flank-specific: deviations_file)
            "profile_crowning_um": Key(f"gear{i}.profile_crowning", 1e-6, unit="um"),
            "tip_relief_um": Key(f"gear{i}.tip_relief", 1e-6, unit="um"),
            "tip_relief_length_mm": Key(f"gear{i}.tip_relief_length", 1e-3, unit="mm"),
            "tip_relief_parabolic": Key(f"gear{i}.tip_relief_parabolic", kind=bool),
            "root_relief_um": Key(f"gear{i}.root_relief", 1e-6, unit="um"),
            "root_relief_length_mm": Key(f"gear{i}.root_relief_length", 1e-3, unit="mm"),
            "root_relief_parabolic": Key(f"gear{i}.root_relief_parabolic", kind=bool),
            "profile_slope_um": Key(f"gear{i}.profile_slope", 1e-6, unit="um"),
            "lead_crowning_um": Key(f"gear{i}.lead_crowning", 1e-6, unit="um"),
            "helix_slope_um": Key(f"gear{i}.helix_slope", 1e-6, unit="um"),
            "end_relief_um": Key(f"gear{i}.end_relief", 1e-6, unit="um"),
            "end_relief_length_mm": Key(f"gear{i}.end_relief_length", 1e-3, unit="mm"),
            "deviations_file": Key(f"gear{i}.deviations", kind=str),
        }
        for i in (1, 2)
    },
    "model": {
        "stiffness_level": Key("model.stiffness", 1, kind=int),
        "user_stiffness_N_per_mm_um": Key("model.user_stiffness", 1e9, unit="N/(mm um)"),
        "slices": Key("model.slices", 1, kind=int),
        "friction_coefficient": Key("model.friction_coefficient", 1.0),
        "friction_velocity_mm_per_s": Key("model.friction_velocity", 1e-3, unit="mm/s"),
        "damping_Ns_per_m2": Key("model.damping", 1.0, unit="N s/m^2"),
        "rated_line_load_N_per_mm": Key("model.rated_line_load", 1e3, unit="N/mm"),
        # user tables (core/src/user_tables.hpp): files next to the scene, shipped in resources/
        "stiffness_table_file": Key("model.stiffness_table", kind=str),  # level 1
        "te_table_file": Key("model.te_table", kind=str),                # any level
        # FE level: neighbour teeth coupled each side (the databases are built with as many)
        "coupled_teeth": Key("model.coupled_teeth", 1, kind=int),
    },
    # the large-step mode's integration and mesh orders (docs/dynamics.md); inertias, shafts and
    # torques belong to the system model, which sets them through the FMU
    "dynamics": {
        "tolerance_um": Key("dynamics.tolerance", 1e-6, unit="um"),
        "mesh_damping_ratio": Key("dynamics.mesh_damping_ratio", 1.0),
        "mesh_orders": Key("dynamics.mesh_orders", 1, kind=int),
        "order_cycles": Key("dynamics.order_cycles", 1, kind=int),
    },
}

# [gear<i>.body] (FE level): compliance_tool's body options, in mm as the tool's flags
# (Key.variable = the flag). Diameters: the tool checks them against the tooth geometry (root
# circle, ...); here only what needs no geometry (consistency between the keys).
BODY_SCHEMA: dict[str, Key] = {
    "bore_diameter_mm": Key("--bore-diameter-mm", 1.0, 0.01, 40000, unit="mm"),
    "rim_inner_diameter_mm": Key("--rim-inner-diameter-mm", 1.0, 0.01, 40000, unit="mm"),
    "hub_diameter_mm": Key("--hub-diameter-mm", 1.0, 0.01, 40000, unit="mm"),
    "web_thickness_mm": Key("--web-thickness-mm", 1.0, 0.01, 2000, unit="mm"),
    "web_offset_mm": Key("--web-offset-mm", 1.0, -1000, 1000, unit="mm"),
    "holes": Key("--holes", 1, 0, 1000, kind=int),
    "hole_diameter_mm": Key("--hole-diameter-mm", 1.0, 0.01, 40000, unit="mm"),
    "hole_circle_diameter_mm": Key("--hole-circle-diameter-mm", 1.0, 0.01, 40000, unit="mm"),
    "ring_outer_diameter_mm": Key("--ring-outer-diameter-mm", 1.0, 0.01, 80000, unit="mm"),
    "mesh_file": Key("--mesh", kind=str),            # a user mesh instead of the gmsh body
    "compliance_file": Key("", kind=str),            # a prebuilt .gcdb: no build
}
# [fe] (FE level): the discretization of both gears' builds, as compliance_tool's flags.
FE_SCHEMA: dict[str, Key] = {
    "depth_mm": Key("--depth-mm", 1.0, 0.001, 100, unit="mm"),
    "profile_elements": Key("--profile-elements", 1, 1, 200, kind=int),
    "width_elements": Key("--width-elements", 1, 1, 200, kind=int),
    "fillet_elements": Key("--fillet-elements", 1, 1, 200, kind=int),
    "body_size_mm": Key("--body-size-mm", 1.0, 0.01, 1000, unit="mm"),
    "hole_band_size_mm": Key("--hole-band-size-mm", 1.0, 0.01, 1000, unit="mm"),
    "load_fraction": Key("--load-fraction", 1.0, 0.01, 1.0),
}
GEOMETRY_BODY_KEYS = [k for k in BODY_SCHEMA if k not in ("mesh_file", "compliance_file")]
# [gear<i>.mounting]: the centre's static pose in the housing frame (start values of the FMU's
# inputs; a tilt or axial offset is a misalignment) and whether the bearings let it move in the
# plane (the system model then drives gear<i>.ux, .uy: the planar interface).
# The tilt's bound is the core's (its check, _core_check); a centre more than 10 mm off is a different
# pair, not a mounting error.
MOUNTING_SCHEMA: dict[str, Key] = {
    "center_x_um": Key("gear{i}.ux", 1e-6, -1e4, 1e4, unit="um"),
    "center_y_um": Key("gear{i}.uy", 1e-6, -1e4, 1e4, unit="um"),
    "center_z_um": Key("gear{i}.uz", 1e-6, -1e4, 1e4, unit="um"),
    "tilt_x_mrad": Key("gear{i}.rx", 1e-3, unit="mrad"),
    "tilt_y_mrad": Key("gear{i}.ry", 1e-3, unit="mrad"),
    "bearing_motion": Key("", kind=bool),
}
# [fmu]: what `gearmesh fmu` writes (gearmesh.scene_interface; docs/fmi.md, "Scene interfaces")
FMU_INTERFACES = ("torsional", "planar", "full")
FMU_MODES = ("prescribed", "quasi_static", "large_step")

# Sections that describe the scene or its runs rather than FMU parameters.
META_SECTIONS = {"scene", "run", "fe", "fmu"}
RUN_SCHEMA: dict[str, Key] = {
    "approach_um": Key("", 1e-6, 0.0, 1000, unit="um"),
    "points_per_pitch": Key("", 1, 4, 1000, kind=int),
    "sweep_margin_um": Key("", 1e-6, 0.0, 1000, unit="um"),
    "sweep_points": Key("", 1, 10, 100000, kind=int),
    "torques_Nm": Key("", 1.0, -1e6, 1e6, kind=list, unit="N m"),
    "speed_rpm": Key("", 2 * 3.141592653589793 / 60, -1e5, 1e5, unit="rpm"),
    "te_pitches": Key("", 1, 1, 1000, kind=int),
    "friction_sweep": Key("", 1.0, 0.0, 2.0, kind=list),
    "levels": Key("", 1, 0, 5, kind=list, item=int),  # stiffness levels of the main job's loaded TE
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
    # FE level: gear number -> body key -> value (scene units; files as resolved paths)
    bodies: dict[int, dict[str, float | int | pathlib.Path]] = field(default_factory=dict)
    fe: dict[str, float | int] = field(default_factory=dict)                 # [fe] key -> value
    bearing_motion: tuple[int, ...] = ()  # gears whose centres move in the plane ([gear<i>.mounting])
    fmu: dict[str, str | list[str]] = field(default_factory=dict)  # [fmu]: interface, mode, tunable, outputs
    default_level: int = Level.ANALYTICAL  # the FMU's model.stiffness where the scene sets none (load)

    @property
    def level(self) -> int:
        """The stiffness level the scene runs at: its own, else the FMU's default."""
        return int(self.parameters.get("model.stiffness", self.default_level))


def _convert(where: str, key: Key, value, fmu_range: Range | None = None):
    """The value in SI (an int stays an int). A scene-only key is checked against its lo, hi; an
    FMU parameter's against fmu_range, the FMU's range in SI, after conversion as the FMU will."""
    if key.kind is list:
        if not isinstance(value, list) or not value:
            raise SceneError(f"{where} = {_short(value)}: expected a non-empty list of numbers")
        return [_convert(f"{where}[{i}]", Key(key.variable, key.factor, key.lo, key.hi,
                                              kind=key.item, unit=key.unit), v)
                for i, v in enumerate(value)]
    if key.kind is str:
        if not isinstance(value, str) or not value:
            raise SceneError(f"{where} = {_short(value)}: expected a non-empty file name")
        return value
    if key.kind is bool:
        if not isinstance(value, bool):
            raise SceneError(f"{where} = {_short(value)}: expected true or false")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"{where} = {_short(value)}: expected a number")
    if key.kind is int and not isinstance(value, int):
        raise SceneError(f"{where} = {_short(value)}: expected a whole number")
    rng, scale = (fmu_range, key.factor) if fmu_range is not None else (Range(key.lo, key.hi), 1)
    if not rng.contains(_scaled(value, scale)):
        unit = f" {key.unit}" if key.unit else ""
        raise SceneError(f"{where} = {_short(value)}{unit}: allowed range {rng.text(scale)}{unit}")
    return value if key.kind is int else value * key.factor


def _scaled(value: int | float, scale: float) -> int | float:
    """value * scale; an int too large for a float is infinite (outside every range)."""
    try:
        return value if scale == 1 else value * scale
    except OverflowError:
        return math.inf


def parse_scene(text: str, path: pathlib.Path | str = "<string>",
                fmu: pathlib.Path | str | None = None) -> Scene:
    """Validate a scene's TOML text; raise SceneError naming the file (if a path is given) and
    the first bad key, or the line of a syntax error. Nothing else is raised for any text. The
    FMU parameters' ranges are those of `fmu` (default: gearmesh.param_ranges.default_fmu());
    an FMU that is missing or unreadable raises OSError (param_ranges.fmu_ranges)."""
    path = pathlib.Path(path)
    try:
        return _parse_scene(text, path, fmu)
    except SceneError as exc:
        if str(path) == "<string>":
            raise
        raise SceneError(f"{path}: {exc}") from None


def _table(where: str, value) -> dict:
    if not isinstance(value, dict):
        raise SceneError(f"{where} = {_short(value)}: expected a table ([{where}])")
    return value


def _short(value) -> str:
    """repr of a value, cut to a readable length for messages."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _deep_line(text: str, depth: int = 100) -> int:
    """The line where brackets or braces first nest `depth` deep (strings not parsed: a hint)."""
    level = 0
    for i, ch in enumerate(text):
        level += ch in "[{"
        level -= ch in "]}"
        if level >= depth:
            return text.count("\n", 0, i) + 1
    return 1


def _parse_scene(text: str, path: pathlib.Path, fmu) -> Scene:
    if not isinstance(text, str):
        raise SceneError(f"expected the scene as text, got {type(text).__name__}")
    if text.startswith("\ufeff"):  # a UTF-8 byte-order mark (some Windows editors write one)
        text = text[1:]
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"line {_deep_line(text)}: arrays or inline tables nested too deeply "
                         "for the TOML reader; allowed: the flat tables of the scene format") from None
    except ValueError as exc:  # an integer of more than 4300 digits (int's string limit)
        long = re.search(r"[0-9_]{4301,}", text)
        line = text.count("\n", 0, long.start()) + 1 if long else 1
        raise SceneError(f"line {line}: not valid TOML: {exc}") from None
    if not raw:
        raise SceneError("empty scene (no table and no key, line 1); allowed: at least one of "
                         "[scene], [pair], [gear1], [gear2], [model], [run]")
    meta = _table("scene", raw.get("scene", {}))
    unknown_meta = set(meta) - {"name", "description", "assumptions", "resource_root"}
    if unknown_meta:
        raise SceneError(f"scene.{sorted(unknown_meta)[0]}: unknown key; allowed: name, "
                         "description, assumptions, resource_root")
    for key in ("name", "description"):
        if key in meta and not isinstance(meta[key], str):
            raise SceneError(f"scene.{key} = {_short(meta[key])}: expected a string")
    assumptions = meta.get("assumptions", [])
    if not isinstance(assumptions, list) or not all(isinstance(a, str) for a in assumptions):
        raise SceneError(f"scene.assumptions = {_short(assumptions)}: expected a list of strings")
    scene = Scene(name=meta.get("name", path.stem), path=path,
                  description=meta.get("description", ""), assumptions=list(assumptions))
    root = _resource_root(meta, path)
    for section, body in raw.items():
        if section in META_SECTIONS:
            continue
        if section not in SCHEMA:
            allowed = ", ".join(sorted(set(SCHEMA) | META_SECTIONS))
            raise SceneError(f"[{section}]: unknown section; allowed: {allowed}")
        _table(section, body)
        for key, value in body.items():
            if section in ("gear1", "gear2") and key == "body":
                scene.bodies[int(section[-1])] = _parse_body(section, value, path, root)
                continue
            if section in ("gear1", "gear2") and key == "mounting":
                _parse_mounting(scene, int(section[-1]), value)
                continue
            spec = SCHEMA[section].get(key)
            if spec is None:
                allowed = ", ".join(sorted(SCHEMA[section]))
                if section in ("gear1", "gear2"):
                    allowed += f"; and the tables [{section}.body] (FE level), [{section}.mounting]"
                raise SceneError(f"{section}.{key}: unknown key; allowed: {allowed}")
            numeric = spec.kind in (int, float)
            value = _convert(f"{section}.{key}", spec, value,
                             fmu_ranges(fmu).get(spec.variable, Range()) if numeric else None)
            if spec.kind is str:  # a file beside the scene, shipped in the FMU's resources/
                source = _resource_file(f"{section}.{key}", value, path, root)
                name = f"{section}_{source.name}"
                scene.resources[name] = source
                value = name
            scene.parameters[spec.variable] = value
    default = fmu_ranges(fmu).get("model.stiffness", Range()).start
    if default is not None:
        scene.default_level = int(default)
    level = scene.level
    fe = _table("fe", raw.get("fe", {}))
    for key, value in fe.items():
        spec = FE_SCHEMA.get(key)
        if spec is None:
            raise SceneError(f"fe.{key}: unknown key; allowed: {', '.join(sorted(FE_SCHEMA))}")
        scene.fe[key] = _convert(f"fe.{key}", spec, value)
    _check_fe_level(scene, level)
    scene.fmu = _parse_fmu(_table("fmu", raw.get("fmu", {})))
    if "dynamics" in raw and scene.fmu.get("mode", "large_step") != "large_step":
        raise SceneError(f"[dynamics]: read by the large-step mode only, and fmu.mode = {scene.fmu['mode']!r}; "
                         "allowed: fmu.mode = \"large_step\" (or none), or no [dynamics] table")
    for key, value in _table("run", raw.get("run", {})).items():
        spec = RUN_SCHEMA.get(key)
        if spec is None:
            raise SceneError(f"run.{key}: unknown key; allowed: {', '.join(sorted(RUN_SCHEMA))}")
        scene.run[key] = _convert(f"run.{key}", spec, value)
    _core_check(scene, fmu)
    from gearmesh.compliance import ComplianceError, check_bodies

    try:
        check_bodies(scene)
    except ComplianceError as exc:
        raise SceneError(str(exc)) from None
    return scene


def _core_check(scene: Scene, fmu) -> None:
    """The core's rules over the scene's whole parameter set and its inputs' start values (the rules
    between parameters, the level's, the pair geometry, the tilt bound): gm_model_check through the
    FMU binary (gearmesh_check), which reads no file; SceneError with the core's message, the one
    the FMU would give at initialization. A database that compliance_tool is to build stands in as
    a file name."""
    from gearmesh.compliance import needs_build
    from gearmesh.fmu_driver import GearMeshFMU

    path = pathlib.Path(fmu) if fmu is not None else default_fmu()
    if fmi_version(path).startswith("3"):  # the check is the FMI 2.0 binary's
        path = default_fmu()
    values = {**scene.parameters, **{f"gear{i}.compliance": f"gear{i}.gcdb" for i in needs_build(scene)}}
    with GearMeshFMU(path, values, instance_name="scene_check", initialize=False) as instance:
        message = instance.check()
    if message:
        raise SceneError(message)


def _why(exc: Exception) -> str:
    """The reason of an OSError without the (possibly very long) path it repeats."""
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)


def _resource_root(meta: dict, path: pathlib.Path) -> pathlib.Path:
    """The folder every file of the scene must lie in: the scene's own folder, or [scene]
    resource_root (a relative path from the scene's folder to a directory, e.g. "..")."""
    folder = path.parent.resolve()
    if "resource_root" not in meta:
        return folder
    value = meta["resource_root"]
    if not isinstance(value, str) or not value or pathlib.PurePath(value).is_absolute():
        raise SceneError(f"scene.resource_root = {_short(value)}: expected a relative path from "
                         f"the scene's folder ({folder}) to a directory, e.g. \"..\"")
    try:
        root = (folder / value).resolve()
        is_dir = root.is_dir()
    except (OSError, ValueError, RuntimeError) as exc:
        raise SceneError(f"scene.resource_root = {_short(value)}: not a usable path ({_why(exc)}); "
                         "allowed: a directory, relative to the scene's folder") from None
    if not is_dir:
        raise SceneError(f"scene.resource_root = {value!r}: {root} is not a directory; allowed: "
                         "a directory, relative to the scene's folder")
    return root


def _resource_file(where: str, value: str, path: pathlib.Path, root: pathlib.Path) -> pathlib.Path:
    """The resolved path of a file key's value: inside root (symlinks resolved) and a regular
    file, else SceneError naming the key, the resolved path and the rule."""
    try:
        source = (path.parent / value).resolve()
        inside = source.is_relative_to(root)
        exists, regular = source.exists(), source.is_file()
    except (OSError, ValueError, RuntimeError) as exc:  # NUL byte, name too long, symlink loop
        raise SceneError(f"{where} = {_short(value)}: not a usable file name ({_why(exc)}); allowed: "
                         "the name of a regular file inside the scene's folder") from None
    if not inside:
        raise SceneError(f"{where} = {value!r}: resolves to {source}, outside {root}; allowed: a "
                         "file inside the scene's folder (after resolving symlinks), or inside "
                         "[scene] resource_root if the scene sets one")
    if not exists:
        raise SceneError(f"{where} = {value!r}: no such file next to the scene ({source})")
    if not regular:
        raise SceneError(f"{where} = {value!r}: {source} is not a regular file (a directory, "
                         "FIFO, device or socket); allowed: a regular file inside the scene's "
                         "folder")
    return source


def _parse_body(section: str, body, path: pathlib.Path, root: pathlib.Path) -> dict:
    """[gear<i>.body]: keys, ranges and files; how the body's keys fit together and the gear is
    compliance_tool's rule (gearmesh.compliance.check_bodies, at the end of parsing)."""
    where = f"{section}.body"
    _table(where, body)
    out: dict = {}
    for key, value in body.items():
        spec = BODY_SCHEMA.get(key)
        if spec is None:
            raise SceneError(f"{where}.{key}: unknown key; allowed: {', '.join(sorted(BODY_SCHEMA))}")
        value = _convert(f"{where}.{key}", spec, value)
        if spec.kind is str:
            value = _resource_file(f"{where}.{key}", value, path, root)
        out[key] = value
    if "compliance_file" in out and len(out) > 1:
        other = sorted(set(out) - {"compliance_file"})[0]
        raise SceneError(f"{where}.{other}: a prebuilt database (compliance_file) already fixes the "
                         f"body; allowed: compliance_file alone, or the body keys without it")
    if "mesh_file" in out:
        shape = sorted(set(out) & set(GEOMETRY_BODY_KEYS))
        if shape:
            raise SceneError(f"{where}.{shape[0]}: a user mesh (mesh_file) already fixes the body; "
                             "allowed: mesh_file alone, or the body keys without it")

    return out


def _parse_mounting(scene: Scene, gear: int, mounting) -> None:
    """[gear<i>.mounting]: the centre's pose as input start values, and bearing_motion."""
    where = f"gear{gear}.mounting"
    _table(where, mounting)
    for key, value in mounting.items():
        spec = MOUNTING_SCHEMA.get(key)
        if spec is None:
            raise SceneError(f"{where}.{key}: unknown key; allowed: {', '.join(sorted(MOUNTING_SCHEMA))}")
        if key == "bearing_motion":
            if _convert(f"{where}.{key}", spec, value):
                scene.bearing_motion = tuple(sorted({*scene.bearing_motion, gear}))
            continue
        scene.parameters[spec.variable.format(i=gear)] = _convert(f"{where}.{key}", spec, value)


def _parse_fmu(table: dict) -> dict:
    """[fmu]: interface (torsional, planar, full), mode (prescribed, quasi_static, large_step),
    tunable (parameters the scene sets that its FMU keeps listed) and outputs (outputs and arrays
    the FMU lists besides the interface's, e.g. mesh.line_load)."""
    choices = {"interface": FMU_INTERFACES, "mode": FMU_MODES}
    out: dict = {}
    for key, value in table.items():
        if key in choices:
            if value not in choices[key]:
                raise SceneError(f"fmu.{key} = {_short(value)}: allowed: {', '.join(choices[key])}")
            out[key] = value
        elif key in ("tunable", "outputs"):
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                what = "parameter" if key == "tunable" else "output or array"
                raise SceneError(f"fmu.{key} = {_short(value)}: expected a list of FMU {what} names")
            out[key] = list(value)
        else:
            raise SceneError(f"fmu.{key}: unknown key; allowed: interface, mode, tunable, outputs")
    return out


def _check_fe_level(scene: Scene, level: int) -> None:
    """Body and FE tables are inputs of the FE level only; refused elsewhere (nothing unused)."""
    fe_keys = [f"gear{i}.body" for i in sorted(scene.bodies)] + (["fe"] if scene.fe else [])
    coupled = scene.parameters.get("model.coupled_teeth")
    if coupled is not None and level not in (Level.ANALYTICAL, Level.FE):
        raise SceneError(f"model.coupled_teeth: an input of levels 4 and 5 (model.stiffness), "
                         f"this scene has {level}; allowed: level 4 or 5, or leave it out")
    if level != Level.FE:
        if fe_keys:
            raise SceneError(f"{fe_keys[0]}: an input of the FE level (model.stiffness = 5) "
                             f"only, this scene has {level}; allowed: level 5, or leave it out")
        return
    internal = scene.parameters.get("pair.internal", False)
    for i, body in scene.bodies.items():
        if "ring_outer_diameter_mm" in body and not (i == 2 and internal):
            raise SceneError(f"gear{i}.body.ring_outer_diameter_mm: the outer rim of an internal "
                             "ring gear; allowed: gear2 of a pair with pair.internal = true")
    prebuilt = [i for i in (1, 2) if "compliance_file" in scene.bodies.get(i, {})]
    for i in prebuilt:
        source = scene.bodies[i]["compliance_file"]
        name = f"gear{i}_{source.name}"
        scene.resources[name] = source
        scene.parameters[f"gear{i}.compliance"] = name
    if scene.fe and len(prebuilt) == 2:
        raise SceneError(f"fe.{sorted(scene.fe)[0]}: both gears use a prebuilt database "
                         "(compliance_file), nothing is built; allowed: leave [fe] out")


MAX_SCENE_BYTES = 1 << 20  # a scene is a few kB; more is not a scene


def load_scene(path: pathlib.Path | str, fmu: pathlib.Path | str | None = None) -> Scene:
    """Read and validate a scene file against the ranges of `fmu` (parse_scene). A file that is
    not UTF-8 TOML, or not a readable regular file of at most 1 MiB, is a SceneError naming it (a
    UTF-8 byte-order mark is accepted); a missing file is FileNotFoundError."""
    path = pathlib.Path(path)
    if path.exists() and not path.is_file():
        raise SceneError(f"{path}: not a regular file (a directory, FIFO, device or socket); "
                         "allowed: a scene file (TOML)")
    with open(path, "rb") as f:
        data = f.read(MAX_SCENE_BYTES + 1)
    if len(data) > MAX_SCENE_BYTES:
        raise SceneError(f"{path}: larger than {MAX_SCENE_BYTES} bytes; a scene is a small TOML "
                         "file")
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise SceneError(f"{path}: line 1: starts with a UTF-16 byte-order mark; allowed: UTF-8 "
                         "text (save the file as UTF-8)")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise SceneError(f"{path}: line {line}, column {column}: not valid UTF-8 (byte "
                         f"0x{data[exc.start]:02x} at offset {exc.start}: {exc.reason}); allowed: "
                         "UTF-8 text") from None
    if "\x00" in text:
        line = text.count("\n", 0, text.index("\x00")) + 1
        raise SceneError(f"{path}: line {line}: contains a NUL character; a scene is text (TOML)")
    return parse_scene(text, path, fmu)
