"""Micro-geometry through the FMU: the gear<i> modification parameters, String parameters and the
deviation file in resources/, the FMU state with strings, and the scene FMU (gearmesh.scene_fmu).

Forces are checked with prescribed spin angles at level 0, the user-constant stiffness (LEVEL0, set
explicitly: the defaults are level 4 with 10 slices), where a slice of width b/n in contact carries
k' (b/n) (approach - gap) (docs/physics.md §3), and the gaps follow the formulas of
core/src/microgeometry.hpp, written again here from that comment.
"""
from __future__ import annotations

import ctypes
import math
import struct
import zipfile
from ctypes import byref, create_string_buffer

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import fmi2CoSimulation, fmi2String, fmi2ValueReference
from fmpy.validation import validate_fmu

from gearmesh.scene_fmu import START_VALUES, build_scene_fmu

import test_fmu_conformance as conformance
from test_fmu_conformance import LEVEL0, Instance, assert_error
from conftest import REPO


K_PRIME = 1.5e10  # N/m^2, the default user stiffness per unit face width
FACE = 0.023      # m, the default face width
KB = K_PRIME * FACE
TE = 1e-6         # m, approach on flank A
AMOUNTS = ["profile_crowning", "tip_relief", "root_relief", "profile_slope", "lead_crowning",
           "helix_slope", "end_relief"]
LENGTHS = ["tip_relief_length", "root_relief_length", "end_relief_length"]
SHAPES = ["tip_relief_parabolic", "root_relief_parabolic"]
PITCH_FILE = "gearmesh-deviations 1\nteeth 57\npitch 5 A 2.0\npitch 6 A -2.0\n"  # tooth 5 flank A +2 um
CORRUPT_FILE = "gearmesh-deviations 1\nteeth 57\npitch 5 A two\n"





@pytest.fixture(scope="module")
def resources(tmp_path_factory):
    """Deviation files to put into scene FMUs."""
    d = tmp_path_factory.mktemp("deviations")
    (d / "pitch.txt").write_text(PITCH_FILE)
    (d / "corrupt.txt").write_text(CORRUPT_FILE)
    return {"pitch ü.txt": d / "pitch.txt", "measured/corrupt.txt": d / "corrupt.txt",
            "example.txt": REPO / "scenarios" / "deviations_example.txt"}


def scene(fmu_path, tmp_path, parameters, resources, name="scène dir ü"):
    """Build a scene FMU and extract it into a directory whose path has a space and UTF-8."""
    out = build_scene_fmu(fmu_path, parameters, resources, tmp_path / "scene.fmu")
    directory = tmp_path / name
    extract(str(out), str(directory))
    return out, directory, read_model_description(str(out))


class Pair:
    """Roll positions of the default spur pair (docs/physics.md §0, 1) from the FMU's calculated parameters:
    at phi_1 = 0 tooth 0 of gear 1 touches at the pitch point; turning gear 1 by +phi_1 moves its
    contact point by r_b1 phi_1 towards its tip, and tooth k takes the place of tooth 0 at
    phi_1 - 2 pi k / z1 (the deviation file's numbering)."""

    def __init__(self, inst: Instance):
        g = {n: inst.get(n) for n in (
            "gear1.base_diameter", "gear2.base_diameter", "gear1.tip_diameter_used", "gear2.tip_diameter_used",
            "geometry.operating_pressure_angle", "pair.center_distance", "geometry.base_pitch",
            "geometry.backlash", "gear1.teeth", "gear1.profile_shift", "pair.pressure_angle")}
        self.rb1, self.rb2 = g["gear1.base_diameter"] / 2, g["gear2.base_diameter"] / 2
        self.alpha_w = g["geometry.operating_pressure_angle"]
        rho_a1 = math.sqrt(g["gear1.tip_diameter_used"] ** 2 - g["gear1.base_diameter"] ** 2) / 2
        rho_a2 = math.sqrt(g["gear2.tip_diameter_used"] ** 2 - g["gear2.base_diameter"] ** 2) / 2
        self.rho_sap1 = g["pair.center_distance"] * math.sin(self.alpha_w) - rho_a2
        self.length = rho_a1 - self.rho_sap1  # active profile of either gear = path of contact
        self.pb = g["geometry.base_pitch"]
        self.j = g["geometry.backlash"]
        self.tau = 2 * math.pi / g["gear1.teeth"]
        # half tooth angle of gear 1 at its base circle, ISO 21771 (spur, no allowance):
        # eta_b = s/d + inv(alpha), s/d = (pi/2 + 2 x tan alpha)/z
        inv = lambda a: math.tan(a) - a  # noqa: E731
        alpha, z, x = g["pair.pressure_angle"], g["gear1.teeth"], g["gear1.profile_shift"]
        eta_b = (math.pi / 2 + 2 * x * math.tan(alpha)) / z + inv(alpha)
        self.theta0 = inv(self.alpha_w) - eta_b  # tests/core/test_evaluate.cpp ForwardBackwardMirrorSymmetry

    def phi1(self, s: float, tooth: int = 0) -> float:
        """Gear-1 angle with `tooth` touching at distance s from gear 1's start of active profile."""
        return (self.rho_sap1 + s) / self.rb1 - math.tan(self.alpha_w) - tooth * self.tau

    def pose(self, phi1: float, te: float) -> dict:
        return {"gear1.phi": phi1, "gear2.phi": (te - self.rb1 * phi1) / self.rb2}

    def mirror(self, phi1: float, te: float) -> dict:
        """The flank-B pose that mirrors the flank-A pose (phi1, te)."""
        return self.pose(-phi1 - 2 * self.theta0, -te - self.j)

    def pairs(self, s: float) -> list[float]:
        """Distances from gear 1's start of active profile of the pairs in contact."""
        return [t for t in (s - self.pb, s, s + self.pb) if 0 <= t <= self.length]


class Stepper:
    """Prescribed poses, one communication step each, outputs after the step."""

    def __init__(self, inst: Instance):
        self.inst, self.t = inst, 0.0

    def __call__(self, inputs: dict, names=("mesh.normal_force",)):
        self.inst.set(inputs)
        self.inst.slave.doStep(self.t, 1e-3)
        self.t += 1e-3
        out = [self.inst.get(n) for n in names]
        return out[0] if len(out) == 1 else out


def initialized(new, params=None, **kwargs) -> tuple[Instance, Stepper]:
    inst = new(**kwargs)
    inst.initialize(params or {})
    return inst, Stepper(inst)


def gap(mod: dict, s: float, y: float, length: float, b: float = FACE) -> float:
    """Material removed at (s, y) of one flank (microgeometry.hpp): s from the start of active
    profile towards the tip, y from mid-face."""
    m = {k: 0.0 for k in AMOUNTS + LENGTHS} | {k: False for k in SHAPES} | mod
    g = m["profile_crowning"] * (2 * s / length - 1) ** 2 + m["profile_slope"] * (s / length - 0.5)
    if m["tip_relief"] and s > length - m["tip_relief_length"]:
        g += m["tip_relief"] * ((s - (length - m["tip_relief_length"])) / m["tip_relief_length"]) ** (
            2 if m["tip_relief_parabolic"] else 1)
    if m["root_relief"] and s < m["root_relief_length"]:
        g += m["root_relief"] * ((m["root_relief_length"] - s) / m["root_relief_length"]) ** (
            2 if m["root_relief_parabolic"] else 1)
    g += m["lead_crowning"] * (2 * y / b) ** 2 + m["helix_slope"] * y / b
    if m["end_relief"] and abs(y) > b / 2 - m["end_relief_length"]:
        g += m["end_relief"] * (abs(y) - (b / 2 - m["end_relief_length"])) / m["end_relief_length"]
    return g


# ---- the parameters ----------------------------------------------------------------------------

def test_microgeometry_parameters_are_declared(md):
    svs = {v.name: v for v in md.modelVariables}
    for i in (1, 2):
        for field in AMOUNTS + LENGTHS + SHAPES:
            v = svs[f"gear{i}.{field}"]
            assert (v.causality, v.variability, v.initial) == ("parameter", "fixed", "exact"), v.name
            assert "flank A and flank B" in v.description, v.name
            if field in SHAPES:
                assert v.type == "Boolean" and v.start == "false", v.name
            else:
                assert v.type == "Real" and float(v.start) == 0.0 and v.unit == "m", v.name
                assert v.displayUnit == ("mm" if field in LENGTHS else "um"), v.name
        v = svs[f"gear{i}.deviations"]
        assert (v.type, v.causality, v.variability, v.start) == ("String", "parameter", "fixed", "")
        assert "resources/" in v.description


def test_microgeometry_parameters_are_settable_before_initialization(new):
    values = {"profile_crowning": 1e-6, "tip_relief": 4e-6, "tip_relief_length": 2e-3, "tip_relief_parabolic": True,
              "root_relief": 3e-6, "root_relief_length": 1.5e-3, "root_relief_parabolic": True,
              "profile_slope": -2e-6, "lead_crowning": 5e-6, "helix_slope": 1e-6, "end_relief": 6e-6,
              "end_relief_length": 2e-3}
    inst = new()
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({f"gear{i}.{k}": (x * i if not isinstance(x, bool) else x) for k, x in values.items() for i in (1, 2)})
    inst.slave.enterInitializationMode()
    inst.set({"gear2.profile_slope": 7e-6})  # also in Initialization Mode
    for k, x in values.items():
        assert inst.get(f"gear1.{k}") == x
        assert inst.get(f"gear2.{k}") == (7e-6 if k == "profile_slope" else x * 2 if not isinstance(x, bool) else x)
    inst.set(conformance.drive(0.0))
    inst.slave.exitInitializationMode()  # the core accepts them
    assert_error(inst.slave.setReal, [inst.vr("gear1.profile_crowning")], [2e-6])  # fixed
    assert "gear1.profile_crowning" in inst.log.messages("logStatusError")[-1]


def test_invalid_modification_is_named_and_can_be_fixed(new):
    inst = new()
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({"gear2.tip_relief": 5e-6})  # a relief without its length
    inst.slave.enterInitializationMode()
    assert_error(inst.slave.exitInitializationMode)
    assert "gear2.tip_relief" in inst.log.messages("logStatusError")[-1]
    inst.set({"gear2.tip_relief_length": 1e-3})
    inst.slave.exitInitializationMode()


def test_profile_crowning_lowers_the_force_near_the_start_of_the_path(new):
    plain, step_plain = initialized(new)
    crowned, step_crowned = initialized(new, {"gear1.profile_crowning": 0.5e-6})
    pair = Pair(plain)
    for s in (0.0, 0.02 * pair.length, 0.1 * pair.length):
        pose = pair.pose(pair.phi1(s), TE)
        assert step_crowned(pose) < step_plain(pose) - 0.1e-6 * KB
    mid = pair.pose(pair.phi1(pair.length / 2), TE)  # no crowning in the middle of the profile
    assert step_crowned(mid) == pytest.approx(step_plain(mid), rel=1e-8)


PROFILE_CASES = [{"profile_crowning": 0.5e-6}, {"tip_relief": 2e-6, "tip_relief_length": 2e-3},
                 {"tip_relief": 2e-6, "tip_relief_length": 2e-3, "tip_relief_parabolic": True},
                 {"root_relief": 2e-6, "root_relief_length": 2e-3},
                 {"root_relief": 2e-6, "root_relief_length": 2e-3, "root_relief_parabolic": True},
                 {"profile_slope": 1e-6}, {"profile_slope": -1e-6}]
LEAD_CASES = [{"lead_crowning": 2e-6}, {"helix_slope": 4e-6}, {"end_relief": 2e-6, "end_relief_length": 3e-3}]


@pytest.mark.parametrize("gear", [1, 2])
@pytest.mark.parametrize("mod", PROFILE_CASES + LEAD_CASES, ids=lambda m: "+".join(m))
def test_each_parameter_acts_as_its_formula(new, gear, mod):
    """Every parameter reaches its own field in SI units: forces against the gap formulas, on
    gear 1 (s from its start of active profile) or gear 2 (s2 = L - s on the same pair)."""
    slices = 8 if mod.keys() & {"lead_crowning", "helix_slope", "end_relief"} else 1
    inst, step = initialized(new, {**LEVEL0, "model.slices": slices,
                                   **{f"gear{gear}.{k}": x for k, x in mod.items()}})
    pair = Pair(inst)
    ys = [(k + 0.5) * FACE / slices - FACE / 2 for k in range(slices)]
    for frac in (0.01, 0.08, 0.3, 0.5, 0.7, 0.92, 0.99):
        s = frac * pair.length
        expected = 0.0
        for s1 in pair.pairs(s):
            sg = s1 if gear == 1 else pair.length - s1
            expected += sum(KB / slices * max(0.0, TE - gap(mod, sg, y, pair.length)) for y in ys)
        force = step(pair.pose(pair.phi1(s), TE))
        # the core takes the gap midway between the flanks: TE/2 off the line, a few 1e-9 m of gap
        assert force == pytest.approx(expected, abs=3e-9 * KB), (frac, force, expected)


def test_flank_b_gets_the_modification_of_flank_a(new):
    mod = {"gear1.profile_crowning": 0.5e-6, "gear1.tip_relief": 1e-6, "gear1.tip_relief_length": 2e-3,
           "gear2.root_relief": 1.5e-6, "gear2.root_relief_length": 3e-3, "gear2.root_relief_parabolic": True}
    plain, step_plain = initialized(new)
    crowned, step = initialized(new, mod)
    pair = Pair(plain)
    names = ("mesh.normal_force", "mesh.flank", "mesh.pairs_in_contact")
    for s in (0.01 * pair.length, 0.2 * pair.length, 0.5 * pair.length, 0.97 * pair.length):
        phi1 = pair.phi1(s)
        a_plain, b_plain = step_plain(pair.pose(phi1, TE), names), step_plain(pair.mirror(phi1, TE), names)
        assert a_plain[0] == pytest.approx(b_plain[0], rel=1e-9)  # the mirror pose itself
        a, b = step(pair.pose(phi1, TE), names), step(pair.mirror(phi1, TE), names)
        assert (a[1], b[1]) == (1, 2) and a[2] == b[2]
        assert b[0] == pytest.approx(a[0], rel=1e-9), s
        if s != 0.5 * pair.length:
            assert a[0] < a_plain[0] - 0.1e-6 * KB  # and the modification acts


# ---- String parameters -------------------------------------------------------------------------

def test_string_get_and_set(new):
    inst = new()
    s = inst.slave
    vr = [inst.vr("gear1.deviations"), inst.vr("gear2.deviations")]
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    assert s.getString(vr) == [b"", b""]
    value = create_string_buffer("a b ü.txt".encode(), size=64)
    values = (fmi2String * 2)(ctypes.cast(value, fmi2String), b"second.txt")
    s.fmi2SetString(s.component, (fmi2ValueReference * 2)(*vr), 2, values)
    value.value = b"overwritten"  # the FMU owns a copy
    assert s.getString(vr) == ["a b ü.txt".encode(), b"second.txt"]
    s.setString(vr[:1], [""])
    assert s.getString(vr) == [b"", b"second.txt"]

    assert_error(s.setString, vr[:1], [None])  # NULL is not ""
    assert "gear1.deviations" in inst.log.messages("logStatusError")[-1]
    assert_error(s.setString, vr, ["fine.txt", None])  # a refused call sets nothing
    assert s.getString(vr) == [b"", b"second.txt"]
    assert_error(s.setString, [inst.vr("gear1.face_width")], ["x"])
    assert_error(s.getString, [inst.vr("gear1.face_width")])
    assert_error(s.setReal, vr[:1], [1.0])
    s.setString(vr, ["", ""])
    s.exitInitializationMode()
    assert_error(s.setString, vr[:1], ["late.txt"])  # fixed parameter
    assert "fixed parameter" in inst.log.messages("logStatusError")[-1]
    assert s.getString(vr) == [b"", b""]


# ---- deviation files in resources/ -------------------------------------------------------------

def test_pitch_deviation_from_resources(new, fmu_path, tmp_path, resources):
    """+2 um of pitch deviation on flank A of gear 1's tooth 5 is 2 um more approach when that
    tooth is in single contact, k b 2 um more force; no other tooth changes."""
    _, directory, md = scene(fmu_path, tmp_path, {}, resources)
    assert " " in str(directory) and "ü" in str(directory)
    inst, step = initialized(new, {**LEVEL0, "gear1.deviations": "pitch ü.txt"}, directory=directory,
                             model_description=md)
    pair = Pair(inst)
    mid = pair.length / 2  # single contact
    names = ("mesh.normal_force", "mesh.pairs_in_contact")
    for tooth, extra in ((0, 0.0), (4, 0.0), (5, 2e-6), (6, 0.0), (52, 0.0)):
        force, pairs = step(pair.pose(pair.phi1(mid, tooth), TE), names)
        assert pairs == 1
        assert force == pytest.approx(KB * (TE + extra), rel=1e-9), tooth


def test_example_deviation_file(new, fmu_path, tmp_path, resources):
    """scenarios/deviations_example.txt on gear 1: pitch +3/+2 um on teeth 5/6, and the measured
    grid of tooth 0 at mid-face (the single slice), interpolated along the roll distance."""
    _, directory, md = scene(fmu_path, tmp_path, {"gear1.deviations": "example.txt"}, resources)
    inst, step = initialized(new, LEVEL0, directory=directory, model_description=md)
    pair = Pair(inst)
    s = pair.length / 2
    for tooth, extra in ((5, 3e-6), (6, 2e-6), (7, 0.0), (4, 0.0)):
        assert step(pair.pose(pair.phi1(s, tooth), TE)) == pytest.approx(KB * (TE + extra), rel=1e-9), tooth
    roll_mm = [21.5, 24.5, 27.5, 30.5, 33.5, 34.3]
    mid_face_um = [0.0, 0.5, 1.0, 1.5, 2.0, 1.5]
    measured = 1e-6 * np.interp((pair.rho_sap1 + s) * 1e3, roll_mm, mid_face_um)  # + = material added
    assert step(pair.pose(pair.phi1(s), TE)) == pytest.approx(KB * (TE + measured), rel=1e-4)


@pytest.mark.parametrize("gear, bad, says", [
    (1, "missing.txt", "cannot open"),
    (2, "../pitch ü.txt", '".." component'),
    (1, "measured/../../pitch ü.txt", '".." component'),
    (1, "/etc/hostname", "absolute path"),
    (2, "measured\\corrupt.txt", "backslash"),
    (1, "measured/corrupt.txt", ":3:"),  # the core names the file and the line
])
def test_bad_deviation_file_is_named_and_can_be_fixed(new, fmu_path, tmp_path, resources, gear, bad, says):
    _, directory, md = scene(fmu_path, tmp_path, {}, resources)
    inst = new(directory=directory, model_description=md)
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({f"gear{gear}.deviations": bad})
    inst.slave.enterInitializationMode()
    assert_error(inst.slave.exitInitializationMode)
    message = inst.log.messages("logStatusError")[-1]
    assert f"gear{gear}.deviations" in message and says in message, message
    assert_error(inst.slave.getReal, [inst.vr("geometry.contact_ratio")])  # same on a get
    inst.set({f"gear{gear}.deviations": "pitch ü.txt"})  # fix it and go on
    inst.set(conformance.drive(0.0))
    inst.slave.exitInitializationMode()
    conformance.run(inst, 2)


def test_deviation_file_without_resource_location(new, md):
    inst = new(instantiate=False)
    c = inst.slave.fmi2Instantiate(b"r", fmi2CoSimulation, md.guid.encode(), None, byref(inst.log.callbacks), 0, 0)
    assert c is not None
    inst.slave.component = c
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({"gear2.deviations": "pitch.txt"})
    inst.slave.enterInitializationMode()
    assert_error(inst.slave.exitInitializationMode)
    message = inst.log.messages("logStatusError")[-1]
    assert "gear2.deviations" in message and "resource location" in message, message
    inst.set({"gear2.deviations": ""})
    inst.slave.exitInitializationMode()


# ---- FMU state with strings --------------------------------------------------------------------

def test_state_round_trip_with_a_deviation_file(new, fmu_path, tmp_path, resources):
    _, directory, md = scene(fmu_path, tmp_path, {}, resources)
    a, step_a = initialized(new, {"gear1.deviations": "pitch ü.txt"}, directory=directory, model_description=md)
    pair = Pair(a)
    poses = [pair.pose(pair.phi1(pair.length / 2, 5) - 0.1 + 0.02 * k, 2e-6) for k in range(10)]
    for pose in poses[:5]:
        step_a(pose)
    blob = a.slave.serializeFMUstate(a.slave.getFMUstate())
    t_state = step_a.t
    assert struct.unpack_from("<I", blob, 8)[0] == 3  # state format 3: with strings and a checksum
    after = []
    for pose in poses[5:]:
        step_a(pose)
        after.append(a.outputs())
    forces = {o[conformance.OUTPUTS_REAL.index("mesh.normal_force")] for o in after}
    assert max(forces) > KB * 2e-6 * 1.5  # tooth 5, 2 um proud, went through the mesh

    b = new(directory=directory, model_description=md, name="b")  # fresh: gear1.deviations = ""
    b.slave.setFMUstate(b.slave.deSerializeFMUstate(blob))
    assert b.get("gear1.deviations") == "pitch ü.txt"
    step_b = Stepper(b)
    step_b.t = t_state
    replay = []
    for pose in poses[5:]:
        step_b(pose)
        replay.append(b.outputs())
    assert replay == after  # bit for bit

    generic = new(name="generic")  # no such file in its resources: refused, instance unchanged
    generic.slave.setupExperiment(startTime=0.0)
    generic.slave.enterInitializationMode()
    assert_error(generic.slave.setFMUstate, generic.slave.deSerializeFMUstate(blob))
    assert "gear1.deviations" in generic.log.messages("logStatusError")[-1]
    assert generic.get("gear1.deviations") == ""


# ---- the scene FMU -----------------------------------------------------------------------------

def test_scene_fmu_starts_at_its_values(new, fmu_path, md, tmp_path, resources):
    params = {"gear1.profile_crowning": 5e-6, "gear1.deviations": "pitch ü.txt", "model.slices": 3,
              "gear2.tip_relief_parabolic": True}
    out, directory, scene_md = scene(fmu_path, tmp_path, params, resources)
    assert validate_fmu(str(out)) == []
    assert scene_md.guid == md.guid  # the same binary
    with zipfile.ZipFile(out) as z:
        names = set(z.namelist())
        assert {"resources/pitch ü.txt", "resources/measured/corrupt.txt", f"resources/{START_VALUES}",
                "binaries/linux64/GearMesh.so"} <= names
        assert z.read("binaries/linux64/GearMesh.so") == zipfile.ZipFile(fmu_path).read("binaries/linux64/GearMesh.so")
    starts = {v.name: v.start for v in scene_md.modelVariables}
    assert starts["gear1.profile_crowning"] == "5e-06" and starts["gear1.deviations"] == "pitch ü.txt"
    assert starts["model.slices"] == "3" and starts["gear2.tip_relief_parabolic"] == "true"
    generic_starts = {v.name: v.start for v in md.modelVariables}
    assert {k for k in starts if starts[k] != generic_starts[k]} == set(params)

    inst = new(directory=directory, model_description=scene_md, logging_on=True)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    for v in scene_md.modelVariables:  # the binary starts at the XML's start values
        if v.start is not None:
            want = {"Real": float, "Integer": int, "Boolean": lambda s: s == "true", "String": str}[v.type](v.start)
            assert inst.get(v.name) == want, v.name
    inst.slave.exitInitializationMode()
    assert any(START_VALUES in m for m in inst.log.messages("logEvents"))

    # evaluates as the generic FMU (with the same resources) with the same values set
    _, plain_dir, plain_md = scene(fmu_path, tmp_path / "plain", {}, resources, name="plain")
    reference, step_ref = initialized(new, params, directory=plain_dir, model_description=plain_md)
    scene_step = Stepper(inst)
    pair = Pair(reference)
    for frac, tooth in ((0.02, 0), (0.5, 5), (0.5, 0), (0.9, 5)):
        pose = pair.pose(pair.phi1(frac * pair.length, tooth), TE)
        scene_step(pose)
        step_ref(pose)
        assert inst.outputs() == reference.outputs()
    inst.slave.reset()  # back to the scene's start values
    inst.slave.enterInitializationMode()
    assert inst.get("gear1.profile_crowning") == 5e-6 and inst.get("gear1.deviations") == "pitch ü.txt"

    result = simulate_fmu(str(out), stop_time=2e-3, output_interval=1e-3,
                          start_values={"gear1.phi": 1e-4, "gear1.omega": 1.0})
    assert all(math.isfinite(x) for x in result["mesh.normal_force"])

    # a scene FMU built on a scene FMU keeps what it had
    again = build_scene_fmu(out, {"gear1.profile_crowning": 1e-6}, {}, tmp_path / "again.fmu")
    starts = {v.name: v.start for v in read_model_description(str(again)).modelVariables}
    assert (starts["gear1.profile_crowning"], starts["gear1.deviations"], starts["model.slices"]) == (
        "1e-06", "pitch ü.txt", "3")
    assert validate_fmu(str(again)) == []


@pytest.mark.parametrize("parameters, files, says", [
    ({"gear1.no_such": 1.0}, {}, "no such FMU variable"),
    ({"gear1.fx": 1.0}, {}, "only parameters and inputs"),
    ({"gear1.teeth": 1.5}, {}, "type Integer"),
    ({"gear1.profile_crowning": math.nan}, {}, "type Real"),
    ({"pair.internal": 1}, {}, "type Boolean"),
    ({"gear1.deviations": 3}, {}, "type String"),
    ({"gear1.deviations": "absent.txt"}, {}, "no such file"),
    ({"gear1.deviations": "../x.txt"}, {}, "inside resources/"),
    ({}, {"../x.txt": "pitch ü.txt"}, "inside resources/"),
    ({}, {START_VALUES: "pitch ü.txt"}, "reserved"),
])
def test_scene_fmu_refuses_what_the_fmu_would_refuse(fmu_path, tmp_path, resources, parameters, files, says):
    out = tmp_path / "bad.fmu"
    with pytest.raises(ValueError, match=says):
        build_scene_fmu(fmu_path, parameters, {k: resources[v] for k, v in files.items()}, out)
    assert not out.exists() and not list(tmp_path.iterdir())


@pytest.mark.parametrize("text, says", [
    ("gearmesh-start-values 2\n", ':1: the first line must be "gearmesh-start-values 1"'),
    ("gearmesh-start-values 1\n# comment\ngear1.profile_crowning 5,0e-6\n", ":3: gear1.profile_crowning = 5,0e-6"),
    ("gearmesh-start-values 1\ngear1.profile_crowning inf\n", ":2: gear1.profile_crowning = inf"),
    ("gearmesh-start-values 1\ngear1.teeth 3000000000\n", ":2: gear1.teeth = 3000000000"),
    ("gearmesh-start-values 1\npair.internal 1\n", ":2: pair.internal = 1: a Boolean is true or false"),
    ('gearmesh-start-values 1\ngear1.deviations "a\\x"\n', ":2: gear1.deviations: a String value"),
    ("gearmesh-start-values 1\ngear1.deviations a.txt\n", ":2: gear1.deviations: a String value"),
    ("gearmesh-start-values 1\ngear1.fx 1\n", ":2: gear1.fx: only parameters and inputs"),
    ("gearmesh-start-values 1\ngear3.teeth 1\n", ":2: gear3.teeth: no variable of that name"),
    ("gearmesh-start-values 1\nmodel.slices 2\nmodel.slices 3\n", ":3: model.slices: given twice"),
])
def test_malformed_start_values_refuse_instantiation(new, fmu_path, tmp_path, text, says):
    """A scene FMU whose start values file was edited by hand: fmi2Instantiate fails and says
    where; the generic start values are never silently used instead."""
    _, directory, md = scene(fmu_path, tmp_path, {"model.slices": 2}, {})
    (directory / "resources" / START_VALUES).write_text(text)
    inst = new(directory=directory, model_description=md, instantiate=False)
    with pytest.raises(Exception, match="Failed to instantiate"):
        inst.slave.instantiate(callbacks=inst.log.callbacks)
    assert f"fmi2Instantiate: resources/{START_VALUES}{says}" in inst.log.text(), inst.log.text()
