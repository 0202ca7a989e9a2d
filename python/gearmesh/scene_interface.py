"""The interface of a scene FMU: which of the generic FMU's variables it lists
(docs/fmi.md, "Scene interfaces").

* torsional: the spins in (angles and speeds, and what the scene's modes add: gear 2's load in
  the quasi-static mode; in the large-step mode the drive and load ports, gear 1's and gear 2's
  torques and shaft ends each in its gear's own sense of rotation, so that a drive +T and a
  brake -T load the mesh); the gear torques, TE, mesh force, flank in contact and the losses out
  (and in the large-step mode the ports' spins and shaft torques and the energy account);
* planar: torsional plus the gear centres' in-plane motion in (ux, uy, vx, vy) and the in-plane
  contact forces out (fx, fy);
* full: every variable of the generic FMU (the ports and the housing-frame gear<i>.torque,
  .shaft_phi, .shaft_omega, .angle, .speed, .shaft_torque, all about +z).

Arrays (the load across the face: mesh.line_load, mesh.pair_force, ...) and further outputs are
listed when the scene names them in [fmu] outputs: FMI 3.0 as arrays, FMI 2.0 as their elements,
Real scalars named name[i] or name[i,j] (1-based, row-major).

Parameters the scene sets are not listed (the binary reads them from the scene's start values
file in resources/) unless named tunable; those it leaves at the FMU's defaults stay parameters
where the scene's level and modes read them. Calculated parameters stay listed. A hidden input
keeps its start value (the scene's mounting, else 0). The binary and its value references are
the generic FMU's, so a listed variable behaves exactly as in the full FMU.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping

from gearmesh.param_ranges import Use

INTERFACES = ("torsional", "planar", "full")
MODES = ("prescribed", "quasi_static", "large_step")  # scene [fmu] mode -> the FMU's switches
MODE_PARAMETERS = {"prescribed": {"model.quasi_static": False, "model.dynamics": 0},
                   "quasi_static": {"model.quasi_static": True, "model.dynamics": 0},
                   "large_step": {"model.quasi_static": False, "model.dynamics": 1}}

GEARS = (1, 2)
# inputs each mode reads (the large-step mode: the spins are its initial state)
MODE_INPUTS = {
    "prescribed": [f"gear{i}.{x}" for i in GEARS for x in ("phi", "omega")],
    "quasi_static": ["gear1.phi", "gear1.omega", "gear2.omega", "mesh.load_torque"],
    "large_step": [f"gear{i}.{x}" for i in GEARS for x in ("phi", "omega")]
    + [f"{p}.{x}" for p in ("drive", "load") for x in ("torque", "shaft_phi", "shaft_omega")],
}
# the large-step mode's energy account (docs/dynamics.md, "Energy account"): a master checks with it
# that the integration inside the FMU neither makes nor loses more energy than it reports
ENERGY_OUTPUTS = [f"energy.{x}" for x in ("kinetic", "elastic", "initial", "work_in", "work_out", "friction",
                                          "damping", "parametric", "residual")]
# the mesh orders over whole mesh cycles (docs/dynamics.md, "Mesh orders")
MESH_ORDERS = [f"mesh.{s}_order{k}{x}" for s in ("te", "normal_force") for k in (1, 2, 3) for x in ("", "_phase")] \
    + ["mesh.order_cycles"]
MODE_OUTPUTS = {"prescribed": [], "quasi_static": [],
                "large_step": [f"{p}.{x}" for p in ("drive", "load")
                               for x in ("angle", "speed", "shaft_torque", "shaft_torque_mean")]
                + ENERGY_OUTPUTS + MESH_ORDERS}
# the step means (over a large step: what a 1-10 ms master should record instead of point samples
# of a kHz mesh signal; docs/guide/fmu.md)
STEP_MEANS = ["mesh.te_mean", "mesh.te_min", "mesh.te_max", "mesh.te_rms", "mesh.normal_force_mean"]
TORSIONAL_OUTPUTS = ["gear1.mz", "gear2.mz", "mesh.te", "mesh.te_angle", "mesh.normal_force",
                     "mesh.flank", "mesh.friction_power", "mesh.damping_power", "gear1.mz_mean",
                     "gear2.mz_mean", *STEP_MEANS]
PLANAR_INPUTS = [f"gear{i}.{x}" for i in GEARS for x in ("ux", "uy", "vx", "vy")]
PLANAR_OUTPUTS = [f"gear{i}.{x}" for i in GEARS for x in ("fx", "fy", "fx_mean", "fy_mean")]
OUT_OF_PLANE_INPUTS = [f"gear{i}.{x}" for i in GEARS for x in ("uz", "rx", "ry")]  # misalignment



class InterfaceError(ValueError):
    """An interface, mode or tunable name that the scene FMU cannot have; the message names it."""


def default_interface(fixed: Mapping[str, object], bearing_motion: Iterable[int] = ()) -> str:
    """full when the scene is misaligned (a tilt or axial offset of a centre), planar when a
    gear's bearings move, else torsional."""
    if any(fixed.get(name, 0) for name in OUT_OF_PLANE_INPUTS):
        return "full"
    return "planar" if tuple(bearing_motion) else "torsional"


def scene_modes(fixed: Mapping[str, object]) -> list[str]:
    """The modes the scene FMU can run in: the one its parameters fix, else all three."""
    quasi, dynamics = fixed.get("model.quasi_static"), fixed.get("model.dynamics")
    return [m for m, p in MODE_PARAMETERS.items()
            if (quasi is None or quasi == p["model.quasi_static"])
            and (dynamics is None or dynamics == p["model.dynamics"])]


def listed_variables(variables: Mapping[str, str], fixed: Mapping[str, object], interface: str,
                     tunable: Iterable[str] = (), outputs: Iterable[str] = (), arrays: Iterable[str] = (),
                     use: Mapping[str, Use] | None = None) -> set[str]:
    """The names the scene FMU lists. `variables`: name -> causality of the generic FMU's
    variables and arrays; `fixed`: what the scene sets (name -> value); `tunable`: set parameters
    kept listed; `outputs`: outputs and arrays listed besides the interface's; `arrays`: which of
    `variables` are arrays (listed only when named in `outputs`); `use`: what reads each parameter
    (param_ranges.parameter_use of the generic FMU)."""
    use = use or {}
    if interface not in INTERFACES:
        raise InterfaceError(f"interface {interface!r}: allowed: {', '.join(INTERFACES)}")
    tunable, asked, arrays = set(tunable), set(outputs), set(arrays)
    for name in sorted(tunable):
        if variables.get(name) != "parameter":
            raise InterfaceError(f"tunable {name!r}: not a parameter of the FMU; allowed: a "
                                 "parameter name such as model.friction_coefficient")
    for name in sorted(asked):
        if variables.get(name) != "output" and name not in arrays:
            raise InterfaceError(f"output {name!r}: not an output or array of the FMU; allowed: an output "
                                 f"name such as mesh.max_line_load, or an array: {', '.join(sorted(arrays))}")
    if interface == "full":
        return (set(variables) - arrays) | asked
    modes = scene_modes(fixed)
    if not modes:
        raise InterfaceError("model.quasi_static = true with model.dynamics = 1: no such mode; "
                             f"allowed modes: {', '.join(MODES)}")
    inputs = {n for m in modes for n in MODE_INPUTS[m]}
    outputs = set(TORSIONAL_OUTPUTS) | {n for m in modes for n in MODE_OUTPUTS[m]}
    if interface == "planar":
        inputs |= set(PLANAR_INPUTS)
        outputs |= set(PLANAR_OUTPUTS)
    wanted = {"input": inputs, "output": outputs}
    listed = set()
    for name, causality in variables.items():
        if name in arrays:
            keep = name in asked
        elif causality == "output" and name in asked:
            keep = True
        elif causality in wanted:
            keep = name in wanted[causality]
        elif causality == "parameter":
            keep = name in tunable or (name not in fixed and use.get(name, Use()).read(fixed.get("model.stiffness"),
                                                                                          modes))
        else:  # calculated parameters: the pair's geometry, always shown
            keep = True
        if keep:
            listed.add(name)
    missing = (inputs | outputs) - set(variables)
    if missing:
        raise InterfaceError(f"{sorted(missing)[0]}: no such variable in the generic FMU (a "
                             "scene_interface table out of step with modelDescription/variables.h)")
    return listed


def restrict_model_description(xml: str, listed: set[str]) -> str:
    """modelDescription.xml with only the `listed` ScalarVariables, the ModelStructure indices
    renumbered and dependencies on variables no longer listed dropped (their values are now
    constants of the scene). FMI 3.0: the same by value reference (nothing renumbered), the
    independent variable kept."""
    root = ET.fromstring(xml)
    if root.get("fmiVersion", "").startswith("3"):
        return _restrict_fmi3(root, listed)
    variables = root.find("ModelVariables")
    new_index, kept = {}, []
    for old, sv in enumerate(variables.findall("ScalarVariable"), start=1):
        if sv.get("name") in listed:
            kept.append(sv)
            new_index[old] = len(kept)
    arrays = {a.get("name"): a for a in root.iterfind("VendorAnnotations/Tool[@name='GearMesh arrays']/Arrays/Array")
              if a.get("name") in listed}
    elements = _array_elements(variables, arrays)
    unknown = listed - {sv.get("name") for sv in kept} - set(arrays)
    if unknown:
        raise InterfaceError(f"{sorted(unknown)[0]}: no such variable in modelDescription.xml")
    index_of_vr = {int(sv.get("valueReference")): new_index[old]
                   for old, sv in enumerate(variables.findall("ScalarVariable"), start=1) if old in new_index}
    variables.clear()
    for n, sv in enumerate(kept, start=1):
        variables.append(ET.Comment(f" index {n} "))
        variables.append(sv)
    for n, (sv, _) in enumerate(elements, start=len(kept) + 1):
        variables.append(ET.Comment(f" index {n} "))
        variables.append(sv)
    structure = root.find("ModelStructure")
    for section in list(structure):
        for unknown_el in list(section):
            index = new_index.get(int(unknown_el.get("index")))
            if index is None:
                section.remove(unknown_el)
                continue
            unknown_el.set("index", str(index))
            _renumber_dependencies(unknown_el, new_index)
    _add_element_unknowns(structure, elements, len(kept), index_of_vr)
    for section in list(structure):
        if len(section) == 0:
            structure.remove(section)
    for path, tag in (("Tool[@name='GearMesh']/Ranges", "Range"),  # the listed variables' only
                      ("Tool[@name='GearMesh.parameters']/Parameters", "Parameter")):
        for group in root.findall("VendorAnnotations/" + path):
            for el in group.findall(tag):
                if el.get("variable") not in listed:
                    group.remove(el)
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _array_elements(variables: ET.Element, arrays: Mapping[str, ET.Element]) -> list[tuple[ET.Element, ET.Element]]:
    """FMI 2.0: the ScalarVariables of the listed arrays' elements (name[i] or name[i,j], 1-based,
    row-major; value reference elementBase + index), each with its array's annotation, at the
    structural parameters' start values (the scene's)."""
    starts = {sv.get("name"): sv[0].get("start") for sv in variables.findall("ScalarVariable")}
    out = []
    for name, a in arrays.items():
        dims = [int(d) if d.isdigit() else int(starts[d]) for d in a.get("dimensions").split()]
        indices = [(i,) for i in range(dims[0])] if len(dims) == 1 else \
            [(i, j) for i in range(dims[0]) for j in range(dims[1])]
        for flat, index in enumerate(indices):
            sv = ET.Element("ScalarVariable", {
                "name": f"{name}[{','.join(str(i + 1) for i in index)}]",
                "valueReference": str(int(a.get("elementBase")) + flat),
                "description": a.get("description"), "causality": a.get("causality"),
                "variability": a.get("variability"), "initial": a.get("initial")})
            real = ET.SubElement(sv, "Real")
            for attribute in ("unit", "displayUnit"):
                if a.get(attribute):
                    real.set(attribute, a.get(attribute))
            out.append((sv, a))
    return out


def _add_element_unknowns(structure: ET.Element, elements: list[tuple[ET.Element, ET.Element]], first: int,
                          index_of_vr: Mapping[int, int]) -> None:
    """FMI 2.0 <Outputs> and <InitialUnknowns> of the array elements (indices after `first`), their
    knowns from the annotation's value references, those still listed, in index order."""
    def section(tag: str, before: tuple[str, ...]) -> ET.Element:
        found = structure.find(tag)
        if found is None:
            found = ET.Element(tag)
            at = next((i for i, s in enumerate(structure) if s.tag in before), len(structure))
            structure.insert(at, found)
        return found

    def add(to: ET.Element, index: int, refs: str) -> None:
        deps = sorted(index_of_vr[int(r)] for r in refs.split() if int(r) in index_of_vr)
        ET.SubElement(to, "Unknown", {"index": str(index), "dependencies": " ".join(map(str, deps)),
                                      "dependenciesKind": " ".join(["dependent"] * len(deps))})

    for n, (sv, a) in enumerate(elements, start=first + 1):
        if a.get("causality") == "output":
            add(section("Outputs", ("Derivatives", "InitialUnknowns")), n, a.get("dependencies"))
        add(section("InitialUnknowns", ()), n, a.get("initialDependencies"))


def _restrict_fmi3(root: ET.Element, listed: set[str]) -> str:
    variables = root.find("ModelVariables")
    kept = [el for el in variables if el.get("name") in listed or el.get("causality") == "independent"]
    unknown = listed - {el.get("name") for el in kept}
    if unknown:
        raise InterfaceError(f"{sorted(unknown)[0]}: no such variable in modelDescription.xml")
    refs = {el.get("valueReference") for el in kept}
    # an array's dimension whose structural parameter the scene fixes (and no longer lists) is that
    # parameter's start value
    starts = {el.get("valueReference"): el.get("start") for el in variables}
    for el in kept:
        for dim in el.findall("Dimension"):
            if dim.get("valueReference") is not None and dim.get("valueReference") not in refs:
                dim.set("start", starts[dim.attrib.pop("valueReference")])
    variables.clear()
    variables.extend(kept)
    structure = root.find("ModelStructure")
    for unknown_el in list(structure):
        if unknown_el.get("valueReference") not in refs:
            structure.remove(unknown_el)
            continue
        deps, kinds = (unknown_el.get("dependencies") or "").split(), (unknown_el.get("dependenciesKind") or "").split()
        pairs = [(d, k) for d, k in zip(deps, kinds or [None] * len(deps)) if d in refs]
        if unknown_el.get("dependencies") is not None:
            unknown_el.set("dependencies", " ".join(d for d, _ in pairs))
            if kinds:
                unknown_el.set("dependenciesKind", " ".join(k for _, k in pairs))
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _renumber_dependencies(unknown: ET.Element, new_index: Mapping[int, int]) -> None:
    deps = unknown.get("dependencies")
    if deps is None:  # absent: depends on every known; stays so
        return
    kinds = (unknown.get("dependenciesKind") or "").split()
    pairs = [(new_index[int(d)], k) for d, k in zip(deps.split(), kinds or [None] * len(deps.split()))
             if int(d) in new_index]
    unknown.set("dependencies", " ".join(str(d) for d, _ in pairs))
    if kinds:
        unknown.set("dependenciesKind", " ".join(k for _, k in pairs))
