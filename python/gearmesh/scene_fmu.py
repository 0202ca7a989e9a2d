"""The FMU of a scene: the generic GearMesh.fmu plus only the resources and start values that the
scene needs (docs/design.md, "What a user does", step 3).

The binary and the GUID stay those of the generic FMU. The scene's start values are written
twice, from one dict: as the start attributes in modelDescription.xml (what importers show and
validate) and in resources/gearmesh-start-values.txt, which the binary reads at fmi2Instantiate
(fmu_src/values.h gives the format), so that the FMU starts at them without anybody setting them.
"""
from __future__ import annotations

import math
import numbers
import os
import pathlib
import re
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from xml.sax.saxutils import escape

from gearmesh.scene_interface import restrict_model_description

START_VALUES = "gearmesh-start-values.txt"  # under resources/, read by the binary
_MAGIC = "gearmesh-start-values 1"
# String parameters whose value is the name of a file inside resources/.
_RESOURCE_PARAMETERS = (".deviations", ".compliance", "model.stiffness_table", "model.te_table")

Value = float | int | bool | str


def build_scene_fmu(generic_fmu: pathlib.Path, parameters: Mapping[str, Value],
                    resources: Mapping[str, pathlib.Path], out: pathlib.Path,
                    listed: set[str] | None = None) -> pathlib.Path:
    """Write `out`: `generic_fmu` with `resources` (name inside resources/ -> local file) added
    and the start values of `parameters` (FMU variable name -> value, SI units as in the FMU)
    replaced. Raises ValueError naming the bad parameter or resource; `out` is then untouched.

    Parameters and inputs can be given (they are the variables with start values); a String
    parameter that names a resource (gear<i>.deviations, gear<i>.compliance, model.stiffness_table,
    model.te_table)
    must name one of the scene FMU's resources. Building from a scene FMU adds to its resources
    and start values. `listed` (default: all) names the variables modelDescription.xml keeps
    (gearmesh.scene_interface); the others keep their start values, from the start values file."""
    generic_fmu, out = pathlib.Path(generic_fmu), pathlib.Path(out)
    with zipfile.ZipFile(generic_fmu) as z:
        entries = {info.filename: (info, z.read(info)) for info in z.infolist()}
    if "modelDescription.xml" not in entries:
        raise ValueError(f"{generic_fmu}: no modelDescription.xml; not an FMU")
    xml = entries["modelDescription.xml"][1].decode("utf-8")
    variables = model_variables(xml)

    added = {}
    for name, path in resources.items():
        _check_resource_name(name, f"resource {name!r}")
        if name == START_VALUES:
            raise ValueError(f"resource {name!r}: the name is reserved for the scene's start values")
        if not pathlib.Path(path).is_file():
            raise ValueError(f"resource {name!r}: {path} is not a file")
        added["resources/" + name] = pathlib.Path(path).read_bytes()
    have = {n[len("resources/"):] for n in list(entries) + list(added) if n.startswith("resources/")}

    start_entry = "resources/" + START_VALUES
    starts = _parse_start_values(entries[start_entry][1].decode("utf-8")) if start_entry in entries else {}
    for name, value in parameters.items():
        starts[name] = _start_text(name, value, variables, have)

    for name, text in starts.items():
        xml = _replace_start(xml, name, text, variables[name][0])
    if listed is not None:
        xml = restrict_model_description(xml, listed)
    _check_starts(xml, starts)

    lines = [_MAGIC, "# written by gearmesh.scene_fmu; modelDescription.xml states the same start values"]
    lines += [f"{name} {text}" for name, text in starts.items()]
    files = {**{n: data for n, (_, data) in entries.items()}, **added,
             "modelDescription.xml": xml.encode("utf-8")}
    if starts:
        files[start_entry] = ("\n".join(lines) + "\n").encode("utf-8")

    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=out.name + ".", dir=out.parent)
    os.close(fd)
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for name, data in files.items():
                info = entries[name][0] if name in entries else zipfile.ZipInfo(name, (1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                z.writestr(info, data)
        os.replace(tmp, out)
    except BaseException:
        pathlib.Path(tmp).unlink(missing_ok=True)
        raise
    return out


# FMI 3.0's variable elements and the FMI 2.0 types they stand for (generate_model_description --fmi3:
# a structural parameter, an Integer of the table, is a UInt64)
FMI3_TYPES = {"Float64": "Real", "Int32": "Integer", "UInt64": "Integer", "Boolean": "Boolean", "String": "String"}


def is_fmi3(xml: str) -> bool:
    return ET.fromstring(xml).get("fmiVersion", "").startswith("3")


@dataclass(frozen=True)
class ArrayVariable:
    """An array the FMU offers (modelDescription/variables.h, GM_FMU_ARRAYS): FMI 3.0 declares it
    with its <Dimension>s, FMI 2.0 in <Tool name="GearMesh arrays">, whose element scalars a scene
    FMU lists (value reference element_base + row-major index)."""
    name: str
    causality: str
    variability: str
    initial: str
    unit: str
    display_unit: str
    dimensions: tuple[str, ...]  # each a length or the structural parameter's name
    description: str
    element_base: int = 0  # FMI 2.0
    dependencies: tuple[int, ...] = ()  # FMI 2.0: the knowns' value references at a communication point
    initial_dependencies: tuple[int, ...] = ()  # ... and at initialization


def array_variables(xml: str) -> dict[str, ArrayVariable]:
    """name -> ArrayVariable of every array the FMU offers (FMI 2.0 or 3.0)."""
    root = ET.fromstring(xml)
    out = {}
    if root.get("fmiVersion", "").startswith("3"):
        by_vr = {el.get("valueReference"): el.get("name") for el in root.find("ModelVariables")}
        types = {t.get("name"): t for t in root.iter("Float64Type")}
        for el in root.find("ModelVariables"):
            dims = el.findall("Dimension")
            if not dims:
                continue
            typ = types.get(el.get("declaredType"), el)
            out[el.get("name")] = ArrayVariable(
                el.get("name"), el.get("causality", "local"), el.get("variability", "continuous"),
                el.get("initial", ""), typ.get("unit", ""), typ.get("displayUnit", ""),
                tuple(d.get("start") or by_vr[d.get("valueReference")] for d in dims), el.get("description", ""))
        return out
    for el in root.iterfind("VendorAnnotations/Tool[@name='GearMesh arrays']/Arrays/Array"):
        out[el.get("name")] = ArrayVariable(
            el.get("name"), el.get("causality"), el.get("variability"), el.get("initial"), el.get("unit", ""),
            el.get("displayUnit", ""), tuple(el.get("dimensions").split()), el.get("description", ""),
            int(el.get("elementBase")), tuple(int(v) for v in el.get("dependencies").split()),
            tuple(int(v) for v in el.get("initialDependencies").split()))
    return out


def model_variables(xml: str) -> dict[str, tuple[str, str, str | None]]:
    """name -> (type, causality, start) of every variable (FMI 2.0 or 3.0; the type as FMI 2.0
    names it; FMI 3.0's independent variable left out; an array once by its name, whose FMI 2.0
    element scalars, name[i,j], a scene FMU lists)."""
    root = ET.fromstring(xml)
    out = {}
    if root.get("fmiVersion", "").startswith("3"):
        for el in root.find("ModelVariables"):
            if el.get("causality") == "independent":
                continue
            start = el.find("Start").get("value") if el.tag == "String" and el.find("Start") is not None \
                else el.get("start")
            causality = el.get("causality", "local")
            out[el.get("name")] = (FMI3_TYPES[el.tag], "parameter" if causality == "structuralParameter" else causality,
                                   start)
        return out
    for sv in root.iter("ScalarVariable"):
        typ = sv[0]  # the type element
        name = sv.get("name").split("[")[0] if int(sv.get("valueReference")) >= ELEMENT_VR_BASE else sv.get("name")
        out[name] = (typ.tag, sv.get("causality", "local"), typ.get("start"))
    return out


ELEMENT_VR_BASE = 0x40000000  # fmu_src/model.h, MODEL_ELEMENT_VR: an array element's value reference


def _check_resource_name(name: str, what: str) -> None:
    """The rules of the binary (core_params.c, resolve_resource): inside resources/."""
    if not name or name.startswith("/") or "\\" in name or ".." in name.split("/") or name.endswith("/"):
        raise ValueError(f"{what}: must name a file inside resources/ (relative, '/' separators, no '..', "
                         "no backslashes)")


def _start_text(name: str, value: Value, variables: dict, have: set[str]) -> str:
    """The start value as written in the start values file (and, unquoted, in the XML)."""
    if name not in variables:
        raise ValueError(f"{name}: no such FMU variable")
    typ, causality, _ = variables[name]
    if causality not in ("parameter", "input"):
        raise ValueError(f"{name}: is {causality}; only parameters and inputs have start values")
    bad = ValueError(f"{name} = {value!r}: not a value of type {typ}")
    if typ == "Real":
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
            raise bad
        return repr(float(value))  # shortest text that reads back to the same double
    if typ == "Integer":
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not -2**31 <= value < 2**31:
            raise bad
        return str(int(value))
    if typ == "Boolean":
        if not isinstance(value, bool):
            raise bad
        return "true" if value else "false"
    if not isinstance(value, str) or any(ord(ch) < 0x20 for ch in value):
        raise bad
    if value and name.endswith(_RESOURCE_PARAMETERS):
        _check_resource_name(value, f"{name} = {value!r}")
        if value not in have:
            raise ValueError(f"{name} = {value!r}: no such file in the scene FMU's resources/")
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _xml_value(text: str) -> str:
    """The start attribute's value for a start-file value text (strings unquoted)."""
    if text.startswith('"'):
        return re.sub(r'\\(["\\])', r"\1", text[1:-1])
    return text


def _replace_start(xml: str, name: str, text: str, typ: str) -> str:
    """Replace the start attribute of one variable, leaving the rest of the file as it is."""
    attribute = escape(_xml_value(text), {'"': "&quot;"})
    quoted = re.escape(escape(name, {'"': "&quot;"}))
    if is_fmi3(xml):  # the start on the variable's own element, a String's in its <Start>
        tag = "(?:" + "|".join(k for k, v in FMI3_TYPES.items() if v == typ) + ")"
        pattern = re.compile(r'(<String\s+name="' + quoted + r'"[^>]*>\s*<Start\s+value=")[^"]*(")' if typ == "String"
                             else r'(<' + tag + r'\s+name="' + quoted + r'"[^>]*?\sstart=")[^"]*(")')
    else:
        pattern = re.compile(r'(<ScalarVariable\s+name="' + quoted
                             + r'"[^>]*>\s*<' + typ + r'\b[^>]*?\sstart=")[^"]*(")')
    xml, n = pattern.subn(lambda m: m.group(1) + attribute + m.group(2), xml)
    if n != 1:
        raise ValueError(f"{name}: modelDescription.xml has no start value to replace")
    return xml


def _check_starts(xml: str, starts: dict[str, str]) -> None:
    variables = model_variables(xml)
    for name, text in starts.items():
        if name in variables and variables[name][2] != _xml_value(text):
            raise ValueError(f"{name}: the start value did not reach modelDescription.xml")


def _parse_start_values(text: str) -> dict[str, str]:
    """name -> value text of an existing start values file (a scene FMU built on)."""
    lines = [line.strip() for line in text.splitlines()]
    lines = [line for line in lines if line and not line.startswith("#")]
    if not lines or lines[0] != _MAGIC:
        raise ValueError(f"resources/{START_VALUES}: not a start values file")
    return dict(line.split(None, 1) for line in lines[1:])
