"""A gear train's FMU: a train scene (TOML: bodies, shafts, meshes, each mesh's element from a pair
scene) written as an FMI 2.0 co-simulation FMU around the train binary (GearTrain.so,
fmu_src/model_train.c). The variables, their value references and the resource files follow
fmu_src/train_variables.h, which this module reads: one source for the binary and the
modelDescription.xml written here.

A train scene::

    [train]
    name = "two_stage"
    [[body]]                      # gears and carriers, in order; "housing" is not a body
    name = "input"
    inertia_kgm2 = 0.02           # or fixed = true (a ring held in the housing)
    [[shaft]]
    name = "drive"
    body = "input"
    other = "port"                # a far end (angle and speed in), or a body's name
    stiffness_Nm_per_rad = 2e4
    damping_Nms_per_rad = 10.0
    [[mesh]]
    name = "stage1"
    scene = "paper_setA_3U4U.toml"  # the element: a pair scene, relative to this file
    gear1 = "input"
    gear2 = "intermediate"
    carrier = "housing"             # or a body carrying the mesh (planetary)
    orientation_deg = 0.0           # from gear 1 to gear 2, in the carrier's frame
    [dynamics]                      # optional: the integrator
    tolerance_m = 1e-8
    [run]                           # optional: the main job's run (gearmesh.train_report)
    port_speed_rpm = 1000.0
    load_body = "output"
    load_Nm = 200.0
"""
from __future__ import annotations

import math
import os
import pathlib
import re
import tomllib
import zipfile
from dataclasses import dataclass, field
from xml.sax.saxutils import escape

from gearmesh.paths import Paths
from gearmesh.scene import SceneError, load_scene
from gearmesh.scene_fmu import START_VALUES, _start_text, model_variables

TRAIN_IDENTIFIER = "GearTrain"  # the train binary's model identifier
SUFFIX = {"linux64": ".so", "win64": ".dll", "darwin64": ".dylib"}  # FMI 2.0 platform -> binary suffix
TRAIN_FILE = "train.txt"
_FIELD = re.compile(r'X\((\d+), "([\w.]+)", (\w+), (\w+), (\w+), "([^"]*)", "([^"]*)"\)')
_DEFINE = re.compile(r"#define (TRAIN_\w+) (\S+)")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


# The keys of a train scene: TOML table -> key -> (type, unit, meaning). load_train refuses others;
# docs/reference/scene-keys.md lists these (gearmesh_dev.reference_docs).
TRAIN_KEYS: dict[str, dict[str, tuple[str, str, str]]] = {
    "train": {"name": ("string", "", "the train's name: the FMU's modelName and default file name")},
    "body": {
        "name": ("string", "", "the body's name; its variables are NAME.inertia, .phi, .omega, .torque, "
                 ".angle, .speed, .holding_torque"),
        "inertia_kgm2": ("float", "kg m²", "inertia about the spin axis, > 0 (a carrier's includes its "
                         "planets' orbital mass)"),
        "fixed": ("bool", "", "held in the housing at angle 0 (a ring); default false"),
        "angle_deg": ("float", "deg", "initial spin angle (the start of NAME.phi): puts the meshes in contact, "
                      "e.g. a planet's teeth; default 0"),
        "mass_kg": ("float", "kg", "a mass lets the body's centre translate in the housing's plane on its bearing "
                    "(a sun or a ring: a body on the housing's axis that carries no mesh); default 0: it does not"),
        "bearing_stiffness_N_per_m": ("float", "N/m", "the bearing's stiffness per axis, with mass_kg; default 0: "
                                      "floating (held by its meshes only)"),
        "bearing_damping_Ns_per_m": ("float", "N s/m", "the bearing's damping per axis, with mass_kg; default 0"),
        "pin_error_tangential_um": ("float", "µm", "a planet's centre off its place in the carrier along the "
                                    "carrier's turning; default 0"),
        "pin_error_radial_um": ("float", "µm", "a planet's centre off its place in the carrier, outwards; default 0"),
    },
    "shaft": {
        "name": ("string", "", "the shaft's name; its variables are NAME.stiffness, .damping, .far_phi, "
                 ".far_omega, .torque"),
        "body": ("string", "", "the body it turns"),
        "other": ("string", "", "the body at its other end, or \"port\": a far end whose angle and speed "
                  "are inputs"),
        "stiffness_Nm_per_rad": ("float", "N m/rad", "torsional stiffness, >= 0"),
        "damping_Nms_per_rad": ("float", "N m s/rad", "torsional damping, >= 0"),
    },
    "mesh": {
        "name": ("string", "", "the mesh's name; its outputs are NAME.te, .normal_force, ..."),
        "scene": ("string", "", "a pair scene (relative to the train scene): the element's parameters; "
                  "levels 0-4 without tables"),
        "gear1": ("string", "", "the body of the element's gear 1"),
        "gear2": ("string", "", "the body of the element's gear 2"),
        "carrier": ("string", "", "the body carrying the mesh (a planetary stage), or \"housing\" (default)"),
        "orientation_deg": ("float", "deg", "direction from gear 1 to gear 2 in the carrier's frame; default 0"),
    },
    "run": {
        "port_speed_rpm": ("float", "rpm", "the main job's run: every port's far end turns at this speed "
                           "(reached over ramp_s from rest)"),
        "ramp_s": ("float", "s", "the run's ramp of the port speed from rest; default 0.2"),
        "load_body": ("string", "", "the run's loaded body"),
        "load_Nm": ("float", "N m", "the run's load on load_body, against its turning (reached over ramp_s)"),
        "duration_s": ("float", "s", "the run's length; default 1"),
        "step_s": ("float", "s", "the run's communication step; default 1e-2"),
    },
    "fmu": {
        "outputs": ("list of strings", "", "the outputs the FMU lists, as name patterns (fnmatch: "
                    "\"sun_planet*.normal_force\", \"carrier.*\", \"energy.*\"); default: every output of every "
                    "member"),
    },
    "static": {
        "held_body": ("string", "", "the main job's quasi-static analysis: the body held at each angle of the "
                      "sweep (default: the body of the first port's shaft)"),
        "sweep_body": ("string", "", "the sweep covers one revolution of this body (default: the run's "
                       "load_body)"),
        "points": ("integer", "", "equilibria over the sweep; default 240"),
    },
    "dynamics": {
        "tolerance_m": ("float", "m", "local error of the rim motion per internal step; default 1e-8"),
        "max_step_s": ("float", "s", "largest internal step; default 1e-3"),
        "min_step_s": ("float", "s", "smallest internal step; default 1e-9"),
    },
}


# The body fields (train_variables.h) a scene key sets (SI after load_train), in train.txt's order.
BODY_EXTRA = ["mass", "bearing_stiffness", "bearing_damping", "pin_error_tangential", "pin_error_radial"]
BODY_KEYS = {"_mass": "mass_kg", "_bearing_stiffness": "bearing_stiffness_N_per_m",
             "_bearing_damping": "bearing_damping_Ns_per_m", "_pin_error_tangential": "pin_error_tangential_um",
             "_pin_error_radial": "pin_error_radial_um"}


@dataclass(frozen=True)
class Field:
    index: int
    name: str
    type: str
    causality: str
    variability: str
    unit: str
    description: str


@dataclass
class Layout:
    """What train_variables.h says: capacities, bases, stride, GUID and each block's fields."""
    defines: dict[str, str]
    blocks: dict[str, list[Field]]

    def value(self, key: str) -> int:
        return int(self.defines[key])


def layout(header: pathlib.Path | None = None) -> Layout:
    """The train FMU's variable layout from fmu_src/train_variables.h (the installed package carries
    a copy; gearmesh.paths)."""
    header = header or Paths.resolve().require("train_header")
    text = header.read_text(encoding="utf-8")
    defines = {m.group(1): m.group(2).strip('"') for m in _DEFINE.finditer(text)}
    blocks = {}
    for block in ("SCALAR", "BODY", "SHAFT", "MESH"):
        start = text.index(f"#define TRAIN_{block}_FIELDS(X)")
        end = text.index("\n\n", start)
        blocks[block] = [Field(int(m.group(1)), *m.groups()[1:]) for m in _FIELD.finditer(text[start:end])]
    return Layout(defines, blocks)


@dataclass
class Train:
    name: str
    bodies: list[dict]
    shafts: list[dict]
    meshes: list[dict]
    dynamics: dict = field(default_factory=dict)
    path: pathlib.Path | None = None
    run: dict = field(default_factory=dict)
    static: dict = field(default_factory=dict)
    outputs: list[str] | None = None  # [fmu] outputs: name patterns of the outputs listed (None: all)

    def held_body(self) -> int:
        """The quasi-static analysis's held body: [static] held_body, else the first port's body."""
        names = [b["name"] for b in self.bodies]
        if "held_body" in self.static:
            return names.index(self.static["held_body"])
        ports = [s["_body"] for s in self.shafts if s["_other"] == -1]
        return ports[0] if ports else next(i for i, b in enumerate(self.bodies) if not b["_fixed"])


def is_train_scene(path: pathlib.Path) -> bool:
    """Whether a scene file is a train scene (it has a [train] table)."""
    try:
        return "train" in tomllib.loads(pathlib.Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False


def _fail(path: pathlib.Path, text: str) -> SceneError:
    return SceneError(f"{path}: {text}")


def load_train(path: pathlib.Path, lay: Layout | None = None) -> Train:
    """Read and check a train scene; errors name the file, the member and what is allowed."""
    lay = lay or layout()
    path = pathlib.Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _fail(path, f"not a TOML file: {exc}") from None
    for table, body in data.items():
        if table not in TRAIN_KEYS:
            raise _fail(path, f"[{table}]: allowed tables: {', '.join(TRAIN_KEYS)}")
        for entry in (body if isinstance(body, list) else [body]):
            if not isinstance(entry, dict):
                raise _fail(path, f"[{table}]: a table of keys")
            for key in entry:
                if key not in TRAIN_KEYS[table]:
                    raise _fail(path, f"[{table}] {key}: allowed keys: {', '.join(TRAIN_KEYS[table])}")
    name = data.get("train", {}).get("name")
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise _fail(path, "[train] name: a name of letters, digits and _ (starting with a letter)")
    bodies, shafts, meshes = data.get("body", []), data.get("shaft", []), data.get("mesh", [])
    caps = {"body": lay.value("TRAIN_MAX_BODIES"), "shaft": lay.value("TRAIN_MAX_SHAFTS"),
            "mesh": lay.value("TRAIN_MAX_MESHES")}
    names: set[str] = set()
    for kind, members in (("body", bodies), ("shaft", shafts), ("mesh", meshes)):
        if not isinstance(members, list) or len(members) > caps[kind]:
            raise _fail(path, f"[[{kind}]]: at most {caps[kind]}")
        for i, m in enumerate(members):
            n = m.get("name") if isinstance(m, dict) else None
            if not isinstance(n, str) or not _NAME.fullmatch(n) or n in names or n in ("housing", "port"):
                raise _fail(path, f"[[{kind}]] {i + 1}: name {n!r}: allowed: a new name of letters, digits "
                            "and _ (not housing or port)")
            names.add(n)
    if not bodies or not meshes:
        raise _fail(path, "a train needs at least one [[body]] and one [[mesh]]")
    index = {b["name"]: i for i, b in enumerate(bodies)}

    def body_of(member: dict, key: str, allowed: tuple[str, ...] = ()) -> int:
        value = member.get(key)
        if value in allowed:
            return -1
        if value not in index:
            raise _fail(path, f"{member['name']}.{key} = {value!r}: allowed: "
                        f"{', '.join([*allowed, *index])}")
        return index[value]

    for b in bodies:
        fixed = b.get("fixed", False)
        inertia = b.get("inertia_kgm2", 0.0 if fixed else None)
        if not isinstance(fixed, bool) or not isinstance(inertia, (int, float)) or \
                not (fixed or (math.isfinite(inertia) and inertia > 0)):
            raise _fail(path, f"{b['name']}: inertia_kgm2 > 0 (finite), or fixed = true")
        b["_inertia"], b["_fixed"] = float(inertia), fixed
        for key, scale in (("mass_kg", 1.0), ("bearing_stiffness_N_per_m", 1.0), ("bearing_damping_Ns_per_m", 1.0),
                           ("pin_error_tangential_um", 1e-6), ("pin_error_radial_um", 1e-6)):
            v = b.get(key, 0.0)
            signed = key.startswith("pin_error")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or \
                    (not signed and v < 0):
                raise _fail(path, f"{b['name']}.{key} = {v!r}: allowed: finite" + ("" if signed else " and >= 0"))
            b["_" + key] = float(v) * scale
        if b["_mass_kg"] == 0 and (b["_bearing_stiffness_N_per_m"] or b["_bearing_damping_Ns_per_m"]):
            raise _fail(path, f"{b['name']}: a bearing stiffness or damping without mass_kg; allowed: mass_kg > 0 "
                        "(the centre translates) or neither")
    for s in shafts:
        s["_body"] = body_of(s, "body")
        s["_other"] = body_of(s, "other", ("port",))
        if s["_other"] == -1 and bodies[s["_body"]].get("fixed", False):
            raise _fail(path, f"{s['name']}: drives {s['body']}, which is fixed; allowed: a port on a body "
                        "that turns")
        for key in ("stiffness_Nm_per_rad", "damping_Nms_per_rad"):
            v = s.get(key, 0.0)
            if not isinstance(v, (int, float)) or not (math.isfinite(v) and v >= 0):
                raise _fail(path, f"{s['name']}.{key} = {v!r}: allowed: finite and >= 0")
    for m in meshes:
        m["_gear"] = (body_of(m, "gear1"), body_of(m, "gear2"))
        m["_carrier"] = body_of(m, "carrier", ("housing",)) if "carrier" in m else -1
        scene = m.get("scene")
        if not isinstance(scene, str):
            raise _fail(path, f"{m['name']}.scene: a pair scene file (relative to the train scene)")
        m["_scene"] = (path.parent / scene).resolve()
        angle = m.get("orientation_deg", 0.0)
        if not isinstance(angle, (int, float)) or not math.isfinite(angle):
            raise _fail(path, f"{m['name']}.orientation_deg = {angle!r}: allowed: finite")
        m["_orientation"] = math.radians(angle)
    for b in bodies:
        angle = b.get("angle_deg", 0.0)
        if not isinstance(angle, (int, float)) or not math.isfinite(angle) or (b["_fixed"] and angle != 0):
            raise _fail(path, f"{b['name']}.angle_deg = {angle!r}: allowed: finite (0 for a fixed body)")
        b["_angle"] = math.radians(angle)
    run = data.get("run", {})
    if run and run.get("load_body", bodies[0]["name"]) not in index:
        raise _fail(path, f"[run] load_body = {run.get('load_body')!r}: allowed: {', '.join(index)}")
    static = data.get("static", {})
    for key in ("held_body", "sweep_body"):
        if key in static and static[key] not in index:
            raise _fail(path, f"[static] {key} = {static[key]!r}: allowed: {', '.join(index)}")
    if "held_body" in static and bodies[index[static["held_body"]]]["_fixed"]:
        raise _fail(path, f"[static] held_body = {static['held_body']!r} is fixed; allowed: a body that turns")
    points = static.get("points", 240)
    if isinstance(points, bool) or not isinstance(points, int) or not 2 <= points <= 100000:
        raise _fail(path, f"[static] points = {points!r}: allowed: an integer in [2, 100000]")
    outputs = data.get("fmu", {}).get("outputs")
    if outputs is not None and (not isinstance(outputs, list) or not outputs or
                                not all(isinstance(o, str) and o for o in outputs)):
        raise _fail(path, f"[fmu] outputs = {outputs!r}: allowed: a list of name patterns, e.g. "
                    "[\"sun_planet*.normal_force\", \"carrier.speed\"]")
    return Train(name, bodies, shafts, meshes, data.get("dynamics", {}), path, run, static, outputs)


def _scalar_start(train: Train) -> dict[int, float]:
    d = train.dynamics
    return {1: float(d.get("tolerance_m", 1e-8)), 2: float(d.get("max_step_s", 1e-3)),
            3: float(d.get("min_step_s", 1e-9)), 15: 0, 16: train.held_body() + 1, 17: 0.0}


def model_description(train: Train, lay: Layout, fmi3: bool = False) -> str:
    """The train FMU's modelDescription.xml: the scalars, then each member's fields under its name
    (FMI 3.0: the same variables and value references, plus `time` after the table)."""
    stride = lay.value("TRAIN_STRIDE")
    rows: list[tuple[int, str, Field, float | None]] = []
    starts = _scalar_start(train)
    for f in lay.blocks["SCALAR"]:
        rows.append((f.index, f.name, f, starts.get(f.index)))
    for block, members, base in (("BODY", train.bodies, "TRAIN_BODY_BASE"),
                                 ("SHAFT", train.shafts, "TRAIN_SHAFT_BASE"),
                                 ("MESH", train.meshes, "TRAIN_MESH_BASE")):
        for i, member in enumerate(members):
            for f in lay.blocks[block]:
                start = None
                if f.causality in ("parameter", "input"):
                    start = 0.0
                    if block == "BODY" and f.name == "inertia":
                        start = member["_inertia"]
                    if block == "BODY" and f.name == "phi":
                        start = member["_angle"]
                    if block == "BODY" and "_" + f.name in BODY_KEYS:
                        start = member["_" + BODY_KEYS["_" + f.name]]
                    if block == "SHAFT" and f.name == "stiffness":
                        start = float(member.get("stiffness_Nm_per_rad", 0.0))
                    if block == "SHAFT" and f.name == "damping":
                        start = float(member.get("damping_Nms_per_rad", 0.0))
                rows.append((lay.value(base) + i * stride + f.index, f"{member['name']}.{f.name}", f, start))
    if train.outputs is not None:  # only the outputs the scene asks for
        import fnmatch

        for pattern in train.outputs:
            if not any(f.causality == "output" and fnmatch.fnmatchcase(name, pattern) for _, name, f, _ in rows):
                raise _fail(train.path, f"[fmu] outputs: {pattern!r} names no output; allowed: patterns of "
                            "outputs such as sun_planet*.normal_force, carrier.speed, energy.*")
        rows = [row for row in rows if row[2].causality != "output" or
                any(fnmatch.fnmatchcase(row[1], pattern) for pattern in train.outputs)]
    if fmi3:
        return _model_description3(train, lay, rows)
    units = sorted({f.unit for _, _, f, _ in rows if f.unit})
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" modelName="{escape(train.name)}" '
             f'guid="{lay.defines["TRAIN_GUID"]}" generationTool="gearmesh train-fmu" '
             'variableNamingConvention="structured" numberOfEventIndicators="0">',
             '  <CoSimulation modelIdentifier="GearTrain" canHandleVariableCommunicationStepSize="true" '
             'canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="false"/>',
             "  <UnitDefinitions>", *[f'    <Unit name="{escape(u)}"/>' for u in units], "  </UnitDefinitions>",
             "  <LogCategories>",
             *[f'    <Category name="{c}"/>' for c in
               ("logEvents", "logStatusWarning", "logStatusError", "logStatusFatal", "logAll")],
             "  </LogCategories>", "  <ModelVariables>"]
    outputs = []
    for k, (vr, name, f, start) in enumerate(rows, start=1):
        attrs = (f'name="{escape(name)}" valueReference="{vr}" causality="{f.causality}" '
                 f'variability="{f.variability}" description="{escape(f.description)}"')
        unit = f' unit="{escape(f.unit)}"' if f.unit and f.type == "Real" else ""
        start_attr = f' start="{repr(float(start)) if f.type == "Real" else int(start)}"' if start is not None else ""
        lines.append(f"    <ScalarVariable {attrs}><{f.type}{unit}{start_attr}/></ScalarVariable>")
        if f.causality == "output":
            outputs.append(k)
    lines += ["  </ModelVariables>", "  <ModelStructure>", "    <Outputs>",
              # the outputs are the train's state: no input acts on them at a communication point
              *[f'      <Unknown index="{k}" dependencies=""/>' for k in outputs],
              "    </Outputs>", "    <InitialUnknowns>",
              # at initialization they follow from the initial inputs and the parameters
              *[f'      <Unknown index="{k}"/>' for k in outputs],
              "    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}


def _model_description3(train: Train, lay: Layout, rows: list) -> str:
    """FMI 3.0 (fmu_src/fmi3_functions.c over model_train.c): Real as Float64, Integer as Int32,
    units through <TypeDefinitions> as GearMesh-fmi3.fmu declares them; no intermediate update."""
    units = sorted({f.unit for _, _, f, _ in rows if f.unit and f.type == "Real"})
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="3.0" modelName="{escape(train.name)}" '
             f'instantiationToken="{lay.defines["TRAIN_GUID"]}" generationTool="gearmesh train-fmu" '
             'variableNamingConvention="structured">',
             '  <CoSimulation modelIdentifier="GearTrain" canHandleVariableCommunicationStepSize="true" '
             'canGetAndSetFMUState="true" canSerializeFMUState="true" providesDirectionalDerivatives="false" '
             'providesIntermediateUpdate="false" hasEventMode="false"/>',
             "  <UnitDefinitions>", *[f'    <Unit name="{escape(u)}"/>' for u in units], '    <Unit name="s"/>',
             "  </UnitDefinitions>", "  <TypeDefinitions>",
             *[f'    <Float64Type name="{escape(u)}" unit="{escape(u)}"/>' for u in units],
             '    <Float64Type name="s" unit="s"/>', "  </TypeDefinitions>",
             "  <LogCategories>",
             *[f'    <Category name="{c}"/>' for c in
               ("logEvents", "logStatusWarning", "logStatusError", "logStatusFatal", "logAll")],
             "  </LogCategories>", "  <ModelVariables>"]
    outputs = []
    for vr, name, f, start in rows:
        attrs = (f'name="{escape(name)}" valueReference="{vr}" causality="{f.causality}" '
                 f'variability="{f.variability}" description="{escape(f.description)}"')
        typed = f' declaredType="{escape(f.unit)}"' if f.unit and f.type == "Real" else ""
        start_attr = ""
        if start is not None:
            start_attr = f' start="{repr(float(start)) if f.type == "Real" else int(start)}"'
        elif f.causality != "input":
            attrs += ' initial="calculated"'
        lines.append(f"    <{FMI3_TYPES[f.type]} {attrs}{typed}{start_attr}/>")
        if f.causality == "output":
            outputs.append(vr)
    lines += [f'    <Float64 name="time" valueReference="{lay.value("TRAIN_TIME_VR")}" causality="independent" '
              'variability="continuous" declaredType="s" description="simulation time"/>',
              "  </ModelVariables>", "  <ModelStructure>",
              # the outputs are the train's state: no input acts on them at a communication point
              *[f'    <Output valueReference="{vr}" dependencies=""/>' for vr in outputs],
              # at initialization they follow from the initial inputs and the parameters
              *[f'    <InitialUnknown valueReference="{vr}"/>' for vr in outputs],
              "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def kinematic_speeds(train: Train, scenes: list, lead: int, strict: bool = False):
    """Each body's speed per unit speed of body `lead` with rigid teeth and shafts: a mesh on
    carrier c with z1, z2 teeth keeps z1 (w1 - wc) + s z2 (w2 - wc) = 0 (s = +1 external, -1
    internal: the base radii of a pair are in the ratio of its tooth counts), a shaft between
    bodies keeps their speeds equal, a fixed body stands; least squares over the rows (a
    back-to-back loop has one more row than it needs). strict: a ValueError unless they fix every
    speed (else a body the lead does not turn gets 0)."""
    import numpy as np

    n = len(train.bodies)
    rows, rhs = [], []

    def add(entries: dict[int, float], value: float = 0.0) -> None:
        row = np.zeros(n)
        for i, x in entries.items():
            row[i] += x
        rows.append(row)
        rhs.append(value)

    add({lead: 1.0}, 1.0)
    for i, b in enumerate(train.bodies):
        if b["_fixed"]:
            add({i: 1.0})
    for m, sc in zip(train.meshes, scenes):
        p = sc.parameters
        z1, z2 = p.get("gear1.teeth"), p.get("gear2.teeth")
        if not z1 or not z2:
            raise ValueError(f"{m['_scene']}: the tooth counts are needed for the train's ratio")
        s = -1.0 if p.get("pair.internal") else 1.0
        (g1, g2), c = m["_gear"], m["_carrier"]
        row = {g1: float(z1)}
        row[g2] = row.get(g2, 0.0) + s * z2
        if c >= 0:
            row[c] = row.get(c, 0.0) - (z1 + s * z2)
        add(row)
    for sh in train.shafts:
        if sh["_other"] >= 0:
            add({sh["_body"]: 1.0, sh["_other"]: -1.0})
    a, b = np.array(rows), np.array(rhs)
    speed = np.linalg.lstsq(a, b, rcond=None)[0]
    if strict and (np.linalg.matrix_rank(a) < n or not np.allclose(a @ speed, b, atol=1e-9)):
        raise ValueError(f"{train.path}: the train's kinematics have no single solution")
    return speed


def own_senses(train: Train, scenes: list) -> list[int]:
    """Each body's own sense of rotation about +z (+1 or -1): the sign of its speed when the body of
    the first port (else the first free body) turns forwards (kinematic_speeds); +1 for a body
    the input does not turn (a fixed one)."""
    return [-1 if w < -1e-9 else 1 for w in kinematic_speeds(train, scenes, train.held_body())]


def planet_groups(train: Train) -> dict[str, list[str]]:
    """The meshes that share a load in parallel: those of one pair scene on one carrier (a planetary
    stage's sun meshes, its ring meshes), by "<scene file> on <carrier>"; each mesh's
    <mesh>.planet_share is its share of its group's normal force."""
    groups: dict[str, list[str]] = {}
    for m in train.meshes:
        if m["_carrier"] >= 0:
            groups.setdefault(f"{m['_scene'].name} on {train.bodies[m['_carrier']]['name']}", []).append(m["name"])
    return {k: v for k, v in groups.items() if len(v) > 1}


def train_text(train: Train, senses: list[int] | None = None) -> str:
    group = {n: k for k, members in enumerate(planet_groups(train).values(), start=1) for n in members}
    senses = senses or [1] * len(train.bodies)
    lines = ["gearmesh-train 1"]
    for b, sense in zip(train.bodies, senses):
        extra = " ".join(repr(b["_" + BODY_KEYS["_" + f]]) for f in BODY_EXTRA)
        lines.append(f"body {b['name']} {b['_inertia']!r} {int(b['_fixed'])} {b['_angle']!r} {extra} {sense}")
    for s in train.shafts:
        lines.append(f"shaft {s['name']} {s['_body']} {s['_other']} {float(s.get('stiffness_Nm_per_rad', 0.0))!r} "
                     f"{float(s.get('damping_Nms_per_rad', 0.0))!r}")
    for m in train.meshes:
        lines.append(f"mesh {m['name']} {m['_gear'][0]} {m['_gear'][1]} {m['_carrier']} {m['_orientation']!r} "
                     f"{group.get(m['name'], 0)}")
    return "\n".join(lines) + "\n"


def binary(path: pathlib.Path | None = None, fmi3: bool = False) -> pathlib.Path:
    """`path`, else $GEARMESH_TRAIN_BINARY (FMI 3.0: $GEARMESH_TRAIN_BINARY3), else the installed
    package's, else the checkout's build (gearmesh.paths)."""
    if path is not None:
        if not pathlib.Path(path).is_file():
            target = "GearTrain3" if fmi3 else "GearTrain"
            raise FileNotFoundError(f"{path}: the train binary; build it (cmake --build build --target {target})")
        return pathlib.Path(path)
    return Paths.resolve().require("train_binary3" if fmi3 else "train_binary")


def binaries(folder: pathlib.Path | None = None, train_binary: pathlib.Path | None = None) -> dict[str, pathlib.Path]:
    """The FMU's binaries, binaries/<platform>/GearTrain.<suffix> -> file. With a folder of train
    binaries (`folder`; else, unless `train_binary` is given, $GEARMESH_TRAIN_BINARIES), every
    <platform>/GearTrain.<suffix> in it (`gearmesh-dev platforms` writes
    build-platforms/GearTrain/binaries: linux64, win64, darwin64); without one, the linux64
    binary of binary(train_binary)."""
    if folder is None and train_binary is None:
        folder = os.environ.get("GEARMESH_TRAIN_BINARIES")
    if not folder:
        return {f"binaries/linux64/{TRAIN_IDENTIFIER}.so": binary(train_binary)}
    folder = pathlib.Path(folder)
    found = {f"binaries/{platform}/{TRAIN_IDENTIFIER}{suffix}": folder / platform / f"{TRAIN_IDENTIFIER}{suffix}"
             for platform, suffix in SUFFIX.items()}
    found = {name: path for name, path in found.items() if path.is_file()}
    if not found:
        raise FileNotFoundError(f"{folder}: no train binary (<platform>/{TRAIN_IDENTIFIER}.<suffix> for "
                                f"{', '.join(SUFFIX)}); `gearmesh-dev platforms` writes them to "
                                "build-platforms/GearTrain/binaries")
    return found


def check_assembly(train: Train, scenes: list) -> None:
    """The assembly condition of a planetary stage: a planet whose sun mesh points at psi (in the
    carrier's frame) fits both the sun and the ring only where (z_s + z_r) psi / 2 pi is a whole
    number (the sun and the ring then present a tooth space at the same place); a stage that
    breaks it cannot be assembled, and its meshes could not all start in contact."""
    for carrier in {m["_carrier"] for m in train.meshes if m["_carrier"] >= 0}:
        on = [(m, s) for m, s in zip(train.meshes, scenes) if m["_carrier"] == carrier]
        for m, s in on:
            if s.parameters.get("pair.internal"):
                continue
            sun, planet = m["_gear"]
            z_s = s.parameters["gear1.teeth"]
            ring_meshes = [(mr, sr) for mr, sr in on if sr.parameters.get("pair.internal") and mr["_gear"][0] == planet]
            for mr, sr in ring_meshes:
                z_r = sr.parameters["gear2.teeth"]
                turns = (z_s + z_r) * m["_orientation"] / (2 * math.pi)
                if abs(turns - round(turns)) > 1e-6:
                    raise _fail(train.path, f"{m['name']}: a planet at {math.degrees(m['_orientation']):g} deg "
                                f"between a {z_s}-tooth sun and a {z_r}-tooth ring: (z_s + z_r) psi / 360 deg = "
                                f"{turns:.4g} is not a whole number; allowed: psi a multiple of "
                                f"{360 / (z_s + z_r):.6g} deg (the planets cannot be assembled elsewhere)")


def check_geometry(train: Train, scenes: list) -> None:
    """Meshes that can be built together: a planet sits at one radius on its carrier (its meshes
    there, with the sun and with the ring, have one centre distance: for unshifted gears the ring
    has z_s + 2 z_p teeth), and the meshes on the housing form no closed loop (gears meshing in a
    ring lock: a loop is closed by a shaft). A body may carry several gears (an intermediate shaft,
    a stepped planet): the tooth counts of its meshes need not agree. Whether one mesh's gears can
    mesh at its centre distance is the element's own check (the pair scene's)."""
    radius: dict[tuple[int, int], tuple[str, float]] = {}
    for m, s in zip(train.meshes, scenes):
        if m["_carrier"] < 0:
            continue
        a = s.parameters["pair.center_distance"]
        for body in m["_gear"]:
            key = (m["_carrier"], body)
            if key in radius and abs(radius[key][1] - a) > 1e-9:
                raise _fail(train.path, f"{m['name']}: centre distance {a * 1e3:g} mm, but {radius[key][0]} puts "
                            f"{train.bodies[body]['name']} {radius[key][1] * 1e3:g} mm from the axis of "
                            f"{train.bodies[m['_carrier']]['name']}; allowed: the planet's meshes at one centre "
                            "distance (sun + planet = ring - planet)")
            radius.setdefault(key, (m["name"], a))
    parent = list(range(len(train.bodies)))

    def root(b: int) -> int:
        while parent[b] != b:
            b = parent[b]
        return b

    for m in train.meshes:
        if m["_carrier"] >= 0:
            continue
        a, b = (root(x) for x in m["_gear"])
        if a == b:
            raise _fail(train.path, f"{m['name']}: closes a loop of gears meshing on the housing "
                        f"({train.bodies[m['_gear'][0]]['name']} and {train.bodies[m['_gear'][1]]['name']} already "
                        "turn together through other meshes): the gears would lock; allowed: close a loop with a "
                        "shaft (a back-to-back rig)")
        parent[a] = b


def build_train_fmu(train_scene: pathlib.Path, out: pathlib.Path, generic_fmu: pathlib.Path,
                    train_binary: pathlib.Path | None = None,
                    binaries_folder: pathlib.Path | None = None, fmi3: bool = False) -> pathlib.Path:
    """Write the train scene's FMU to out; returns out. Its binaries: binaries(binaries_folder,
    train_binary); FMI 3.0 (fmi3): the FMI 3.0 train binary (GearTrain3.so) for this platform."""
    if fmi3 and binaries_folder is not None:
        raise ValueError("an FMI 3.0 train FMU is built for this platform only: no binaries folder")
    lay = layout()
    train = load_train(train_scene, lay)
    with zipfile.ZipFile(generic_fmu) as z:
        variables = model_variables(z.read("modelDescription.xml").decode("utf-8"))
    scenes = [load_scene(m["_scene"], generic_fmu) for m in train.meshes]
    check_geometry(train, scenes)
    check_assembly(train, scenes)
    libraries = ({"binaries/x86_64-linux/GearTrain.so": binary(train_binary, fmi3=True)} if fmi3  # modelIdentifier
                 else binaries(binaries_folder, train_binary))
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", model_description(train, lay, fmi3))
        for name, library in libraries.items():
            z.write(library, name)
        z.writestr(f"resources/{TRAIN_FILE}", train_text(train, own_senses(train, scenes)))
        for k, (m, scene) in enumerate(zip(train.meshes, scenes), start=1):
            if scene.parameters.get("model.stiffness") == 5:
                from gearmesh.compliance import with_databases

                scene = with_databases(scene, progress=False)  # built by compliance_tool once, cached
            for name, source in scene.resources.items():  # the mesh's files, beside its start values
                z.write(source, f"resources/mesh{k}/{name}")
            text = ["gearmesh-start-values 1"]
            for name, value in scene.parameters.items():
                text.append(f"{name} {_start_text(name, value, variables, set(scene.resources))}")
            z.writestr(f"resources/mesh{k}/{START_VALUES}", "\n".join(text) + "\n")
    return out
