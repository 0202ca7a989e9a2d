"""FMU output hashes for behaviour-preserving refactors (the FMU side of output_hashes.cpp): one
SHA-256 per case of every output (Real, Integer) after each of a few communication steps and of
the directional derivative of every Real output along each input, through FMPy, all by name (a
value reference may move), and one of what modelDescription.xml says of each variable
(`canonical`; also GearMesh-fmi3.fmu's beside it). Compared before and after within one build (`diff`), never stored.

    python tests/hash/fmu_hashes.py [GearMesh.fmu] [--skip NAME,NAME...]

--skip leaves the named variables out of the case hashes: the ones a change adds (new calculated
parameters or outputs), so that the others compare with the build before it.
"""
from __future__ import annotations

import hashlib
import shutil
import struct
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

CASES = []
for level in (0, 2, 3, 4):
    for mode in ("prescribed", "quasi_static", "large_step"):
        for friction in (0.0, 0.05):
            for helical in (False, True):
                CASES.append((level, mode, friction, helical))


def run_case(path, unzip, md, level, mode, friction, helical, skip=frozenset()):
    vr = {v.name: v for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="hash")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    reals = {"model.friction_coefficient": friction, "pair.helix_angle": 0.2 if helical else 0.0,
             "pair.center_distance": 0.1531 if helical else 0.150, "model.damping": 1e3}
    ints = {"model.stiffness": level, "model.slices": 5, "model.dynamics": 1 if mode == "large_step" else 0}
    bools = {"model.quasi_static": mode == "quasi_static"}
    fmu.setReal([vr[n].valueReference for n in reals], list(reals.values()))
    fmu.setInteger([vr[n].valueReference for n in ints], list(ints.values()))
    fmu.setBoolean([vr[n].valueReference for n in bools], list(bools.values()))
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    h = hashlib.sha256()
    by_name = sorted((v for v in md.modelVariables if v.name not in skip), key=lambda v: v.name)  # VRs may move
    outputs = [v for v in by_name if v.causality in ("output", "calculatedParameter")]
    real_out = [v.valueReference for v in outputs if v.type == "Real"]
    int_out = [v.valueReference for v in outputs if v.type == "Integer"]
    deriv_out = [v.valueReference for v in outputs if v.type == "Real" and v.causality == "output"]
    inputs = [v.valueReference for v in by_name if v.causality == "input" and v.type == "Real"]
    t, step = 0.0, 1e-4
    rb = 0.5 * 57 * 2.6e-3 * 0.94  # about r_b of set A
    for k in range(6):
        phi1 = 1e-3 + 0.02 * k
        u = {"gear1.phi": phi1, "gear2.phi": -phi1 + 5e-6 / rb,
             "gear1.omega": 100.0, "gear2.omega": -100.0, "mesh.load_torque": 300.0 - 100 * k,
             "gear1.torque": 200.0, "gear2.torque": 200.0, "gear2.ux": 1e-6 * k, "gear1.vy": 1e-3}
        fmu.setReal([vr[n].valueReference for n in u], list(u.values()))
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=step)
        t += step
        h.update(struct.pack(f"{len(real_out)}d", *fmu.getReal(real_out)))
        h.update(struct.pack(f"{len(int_out)}i", *fmu.getInteger(int_out)))
        if mode != "large_step" or k == 5:
            for known in inputs[:: 3 if mode == "large_step" else 1]:
                h.update(struct.pack(f"{len(deriv_out)}d",
                                     *fmu.getDirectionalDerivative(deriv_out, [known], [1.0])))
    fmu.terminate()
    fmu.freeInstance()
    return h.hexdigest()[:16]


def canonical(xml: str) -> str:
    """A hash of what modelDescription.xml says of each variable, by name: its attributes and
    those of its type element (value reference and GUID left out), its ModelStructure entries
    with dependencies by name, the unit definitions and the Ranges annotation; the order of the
    variables and other vendor annotations do not count."""
    root = ET.fromstring(xml)
    variables = root.find("ModelVariables")
    fmi3 = root.get("fmiVersion", "").startswith("3")
    elements = [el for el in variables if (el.tag == "ScalarVariable") or fmi3]
    names = {}
    for n, el in enumerate(elements):
        names[str(n + 1)] = el.get("name")  # FMI 2.0 index
        names["vr" + str(el.get("valueReference"))] = el.get("name")
    rows = []
    for el in elements:
        attrs = {k: v for k, v in el.attrib.items() if k != "valueReference"}
        children = [(c.tag, sorted(c.attrib.items())) for c in el]
        rows.append((el.get("name"), sorted(attrs.items()), children))
    structure = []
    for section in root.find("ModelStructure"):
        for u in ([section] if fmi3 else section):
            key = "vr" + u.get("valueReference") if fmi3 else u.get("index")
            deps = (u.get("dependencies") or "").split()
            kinds = (u.get("dependenciesKind") or "").split()
            dep_names = [names["vr" + d] if fmi3 else names[d] for d in deps]
            structure.append((section.tag if not fmi3 else u.tag, names[key],
                              sorted(zip(dep_names, kinds or [""] * len(deps))), u.get("dependencies") is None))
    units = ET.tostring(root.find("UnitDefinitions")) if root.find("UnitDefinitions") is not None else b""
    ranges = root.find("VendorAnnotations/Tool[@name='GearMesh']")
    if ranges is not None:
        ranges.tail = None
    text = repr((sorted(rows), sorted(structure), units, ET.tostring(ranges) if ranges is not None else b""))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def main() -> int:
    args = sys.argv[1:]
    skip = frozenset()
    if "--skip" in args:
        at = args.index("--skip")
        skip = frozenset(args[at + 1].split(","))
        del args[at:at + 2]
    path = args[0] if args else "build/GearMesh.fmu"
    fmi3 = path.replace("GearMesh.fmu", "GearMesh-fmi3.fmu")
    for label, fmu in (("", path), (" FMI 3.0", fmi3)):
        with zipfile.ZipFile(fmu) as z:
            xml = z.read("modelDescription.xml").decode()
        name = f"modelDescription.xml{label} (canonical)"
        print(f"{name:48s} {canonical(xml)}")
    unzip = tempfile.mkdtemp(prefix="gm-hash-")
    try:
        extract(path, unzip)
        md = read_model_description(path)
        for case in CASES:
            level, mode, friction, helical = case
            name = f"level {level} {mode} friction {friction:g}{' helical' if helical else ''}"
            print(f"{name:48s} {run_case(path, unzip, md, *case, skip=skip)}")
    finally:
        shutil.rmtree(unzip, True)
    print(f"cases: {len(CASES)} FMU settings")
    return 0


if __name__ == "__main__":
    sys.exit(main())
