"""The FMI 3.0 co-simulation FMU (build/GearMesh-fmi3.fmu) beside the FMI 2.0 one: one build makes
both from the same variable table (modelDescription/variables.h), the same model and core, and
the shared instance layer (fmu_src/fmi_instance.c) behind fmi3_functions.c. Checked through
FMPy's FMI 3 support: its validation (schema and rules), the same variables, outputs bit for
bit the 2.0 FMU's in every mode, FMU state, directional and adjoint derivatives, and the
refusals of what FMI 3.0 offers and this FMU does not."""
from __future__ import annotations

import ctypes
import pathlib
import zipfile
from xml.etree import ElementTree

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu
from conftest import REPO



# The three modes, each with inputs that load the mesh (one per mode, held over 10 ms in 1 ms steps).
CASES = {
    "plain": {"gear1.omega": 100.0, "gear2.omega": -100.0, "gear2.phi": 1e-4, "model.damping": 2e3,
              "model.friction_coefficient": 0.05},
    "quasi-static": {"model.quasi_static": True, "mesh.load_torque": 200.0, "gear1.omega": 100.0},
    "large-step": {"model.dynamics": 1, "gear1.torque": 151.0, "gear2.torque": 150.0,
                   "gear1.shaft_stiffness": 2e4, "gear1.shaft_damping": 10.0, "gear1.shaft_omega": 10.0},
}


def test_fmpy_validates_it(fmu3_path):
    """FMPy's validation of an FMI 3.0 FMU (the XML schema and the rules: one independent
    variable, unique value references, legal causality/variability/initial, units, the model
    structure) finds nothing."""
    assert validate_fmu(str(fmu3_path)) == []


STRUCTURAL = {"model.slices", "dynamics.mesh_orders"}  # FMI 3.0: UInt64 structural parameters (the arrays' dimensions)
ARRAYS = ["mesh.slice_position", "mesh.line_load", "mesh.pair_force", "mesh.pair_share", "mesh.pair_position",
          "mesh.pair_approach", "mesh.te_orders", "mesh.te_order_phases", "mesh.normal_force_orders",
          "mesh.normal_force_order_phases"]


def xml_bounds(fmu: pathlib.Path, name: str) -> tuple[str | None, str | None]:
    """The min and max attributes of variable `name` in the FMU's modelDescription.xml."""
    with zipfile.ZipFile(fmu) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    element = next(e for e in root.find("ModelVariables") if e.get("name") == name)
    return element.get("min"), element.get("max")


def test_same_variables_as_fmi2(fmu_path, fmu3_path):
    """Every variable of the 2.0 FMU with its value reference, causality, variability, type (Real
    as Float64, Integer as Int32; model.slices and dynamics.mesh_orders UInt64 structural parameters), unit, start, min
    and max; plus the independent variable `time` after them, and after it the arrays; the same
    GUID as instantiation token."""
    md2, md3 = read_model_description(str(fmu_path)), read_model_description(str(fmu3_path))
    assert md3.fmiVersion == "3.0" and md3.instantiationToken == md2.guid
    v3 = {v.name: v for v in md3.modelVariables}
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
    for v in md2.modelVariables:
        w = v3.pop(v.name)
        # FMI 3.0: the unit and display unit through the variable's declared type
        unit = w.declaredType.unit if w.declaredType else w.unit
        display = w.declaredType.displayUnit if w.declaredType else w.displayUnit
        causality, kind = ("structuralParameter", "UInt64") if v.name in STRUCTURAL else (v.causality, types[v.type])
        bounds = (w.min, w.max) if v.name not in STRUCTURAL else xml_bounds(fmu3_path, v.name)  # FMPy reads none
        assert (w.valueReference, w.causality, w.variability, w.type, unit, display, *bounds) == \
            (v.valueReference, causality, v.variability, kind, v.unit, v.displayUnit, v.min, v.max), v.name
        assert str(w.start) == str(v.start), v.name
    assert list(v3) == ["time", *ARRAYS] and v3["time"].causality == "independent"
    assert v3["time"].valueReference == len(md2.modelVariables)
    assert [v3[a].valueReference for a in ARRAYS] == list(range(len(md2.modelVariables) + 1,
                                                                len(md2.modelVariables) + 1 + len(ARRAYS)))
    output_arrays = [a for a in ARRAYS if v3[a].causality == "output"]
    assert len(md3.outputs) == len(md2.outputs) + len(output_arrays)
    assert len(md3.initialUnknowns) == len(md2.initialUnknowns) + len(ARRAYS)


@pytest.mark.parametrize("mode", list(CASES))
def test_outputs_bit_for_bit_the_fmi2_fmus(fmu_path, fmu3_path, mode):
    """FMPy's simulate_fmu on both FMUs with the same start values: every Real, Integer and
    Boolean output identical at every communication point."""
    md2 = read_model_description(str(fmu_path))
    outputs = [v.name for v in md2.modelVariables if v.causality == "output"]
    runs = [simulate_fmu(str(p), start_values=CASES[mode], stop_time=0.01, output_interval=1e-3, output=outputs)
            for p in (fmu_path, fmu3_path)]
    assert len(runs[0]) == len(runs[1]) == 11
    for name in outputs:
        assert np.array_equal(runs[0][name], runs[1][name]), name
    assert np.ptp(runs[1]["mesh.normal_force"]) > 0 or runs[1]["mesh.normal_force"][-1] > 0  # a loaded mesh


class Pair:
    """The 2.0 and the 3.0 FMU, instantiated and initialized alike."""

    def __init__(self, fmu_path, fmu3_path, start: dict):
        self.md2, self.md3 = read_model_description(str(fmu_path)), read_model_description(str(fmu3_path))
        self.vr = {v.name: v.valueReference for v in self.md2.modelVariables}
        self.types = {v.name: v.type for v in self.md2.modelVariables}
        self.f2 = FMU2Slave(guid=self.md2.guid, unzipDirectory=extract(str(fmu_path)), modelIdentifier="GearMesh",
                            instanceName="two")
        self.f3 = FMU3Slave(guid=self.md3.instantiationToken, unzipDirectory=extract(str(fmu3_path)),
                            modelIdentifier="GearMesh", instanceName="three")
        self.messages: list[str] = []
        self.f2.instantiate()
        self.f3.instantiate(logMessage=self._log)
        self.f2.setupExperiment(startTime=0.0)
        self.set(start)
        self.f2.enterInitializationMode()
        self.f3.enterInitializationMode(startTime=0.0)
        self.f2.exitInitializationMode()
        self.f3.exitInitializationMode()
        self.t = 0.0

    def _log(self, env, status, category, message):
        self.messages.append(message.decode())

    def set(self, values: dict):
        for name, x in values.items():
            kind = self.types[name]
            if kind == "Real":
                self.f2.setReal([self.vr[name]], [x])
                self.f3.setFloat64([self.vr[name]], [x])
            elif kind == "Boolean":
                self.f2.setBoolean([self.vr[name]], [x])
                self.f3.setBoolean([self.vr[name]], [x])
            else:
                self.f2.setInteger([self.vr[name]], [x])
                if name in STRUCTURAL:
                    self.f3.setUInt64([self.vr[name]], [x])
                else:
                    self.f3.setInt32([self.vr[name]], [x])

    def step(self, h=1e-3):
        self.f2.doStep(self.t, h)
        self.f3.doStep(self.t, h)
        self.t += h

    def reals(self, names):
        refs = [self.vr[n] for n in names]
        return self.f2.getReal(refs), self.f3.getFloat64(refs)

    def free(self):
        for f in (self.f2, self.f3):
            f.terminate()
            f.freeInstance()


def test_state_and_derivatives_as_fmi2(fmu_path, fmu3_path):
    """The large-step mode: FMU state taken, serialized, deserialized and set gives the same next
    step in both; directional derivatives (partials at the point, and with
    dynamics.step_sensitivities the step's) are the 2.0 FMU's bit for bit; the adjoint is the
    transpose of the directional derivative's matrix; `time` reads the instance's time."""
    start = {**CASES["large-step"], "dynamics.step_sensitivities": True, "gear2.uy": 1e-6}
    p = Pair(fmu_path, fmu3_path, start)
    try:
        for _ in range(3):
            p.step()
        names = ["mesh.te", "gear1.mz", "gear1.speed", "gear2.angle", "gear1.shaft_torque"]
        s2, s3 = p.f2.getFMUstate(), p.f3.getFMUState()
        b2, b3 = p.f2.serializeFMUstate(s2), p.f3.serializeFMUState(s3)
        p.step()
        after = p.reals(names)
        assert after[0] == after[1]
        p.f2.setFMUstate(p.f2.deSerializeFMUstate(b2))
        p.f3.setFMUState(p.f3.deserializeFMUState(b3))
        p.t -= 1e-3
        p.step()
        assert p.reals(names) == after
        assert p.f3.getFloat64([len(p.md2.modelVariables)]) == [pytest.approx(p.t, abs=1e-15)]
        knowns = ["gear1.torque", "gear2.torque", "gear1.shaft_omega"]
        refs_u, refs_k = [p.vr[n] for n in names], [p.vr[n] for n in knowns]
        for k in refs_k:
            d2 = p.f2.getDirectionalDerivative(refs_u, [k], [1.0])
            d3 = p.f3.getDirectionalDerivative(refs_u, [k], [1.0])
            assert d2 == d3 and any(d3), k
        seed = [0.3, -1.0, 2.0, 0.5, 1e-3]
        jac = np.array([p.f3.getDirectionalDerivative(refs_u, [k], [1.0]) for k in refs_k]).T  # unknowns x knowns
        # FMI 3.0: the seed has the unknowns' length, the result the knowns' (v^T J)
        adjoint = p.f3.getAdjointDerivative(refs_u, refs_k, seed, nSensitivity=len(refs_k))
        assert np.allclose(adjoint, np.array(seed) @ jac, rtol=1e-14, atol=0)
        p.f2.freeFMUstate(s2)
        p.f3.freeFMUState(s3)
    finally:
        p.free()


def test_what_fmi3_offers_and_this_fmu_does_not_is_refused(fmu3_path):
    """Event mode asked at instantiation, a value reference of a type the FMU has none of, an
    array length that is not the scalars', setting the independent variable, event-mode and
    clock functions: each refused with an error naming it, the instance usable afterwards."""
    md = read_model_description(str(fmu3_path))
    directory = extract(str(fmu3_path))
    messages: list[str] = []

    def log(env, status, category, message):
        messages.append(message.decode())

    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=directory, modelIdentifier="GearMesh",
                  instanceName="refusals")
    with pytest.raises(Exception):
        f.instantiate(eventModeUsed=True, logMessage=log)
    assert any("no event mode" in m for m in messages)
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=directory, modelIdentifier="GearMesh",
                  instanceName="refusals")
    f.instantiate(logMessage=log)
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    te = next(v.valueReference for v in md.modelVariables if v.name == "mesh.te")
    time_vr = next(v.valueReference for v in md.modelVariables if v.name == "time")
    for call, expected in [(lambda: f.getFloat32([te]), "not a variable of type Float32"),
                           (lambda: f.fmi3GetFloat64(f.component, (ctypes.c_uint32 * 1)(te), 1,
                                                     (ctypes.c_double * 2)(), 2), "whose values number 1"),
                           (lambda: f.setFloat64([time_vr], [1.0]), "independent variable"),
                           (lambda: f.enterEventMode(), "no event mode")]:
        messages.clear()
        with pytest.raises(FMICallException):
            call()
        assert any(expected in m for m in messages), (expected, messages)
    f.doStep(0.0, 1e-3)  # still usable
    assert f.getFloat64([time_vr]) == [pytest.approx(1e-3)]
    f.terminate()
    f.freeInstance()


def test_intermediate_update_offers_the_mesh_signal_inside_a_long_step(fmu3_path):
    """Intermediate update (providesIntermediateUpdate="true"): in the large-step mode at 10 ms
    communication steps, the callback comes after each internal step with the TE and the mesh
    moment readable at that time (intermediateUpdate="true"), so a master records the mesh
    signal at full rate: at 3000 rpm (set A meshes at 2.85 kHz) at least 10 samples per mesh
    period, in increasing time up to each step's end, where they are the step's outputs. They lie
    on the run of the same FMU stepped at 1e-5 s (its TE interpolated at the sample times) within
    the integration's error, which converges with dynamics.tolerance: at 1e-8 m (the default)
    within 0.15 um (measured 0.12 um, median 0.023 um, of a 3.7 um swing), at 1e-9 m within
    0.03 um and at most 0.3 of that (measured 0.022 um). Reading a variable without intermediate
    values (energy.kinetic) inside the callback is an error naming it."""
    md = read_model_description(str(fmu3_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    w = 3000 * 2 * np.pi / 60

    def run(h, n, tolerance, record):
        start = {"model.dynamics": 1, "dynamics.tolerance": tolerance, "gear1.omega": w, "gear2.omega": -w,
                 "gear1.shaft_stiffness": 2e4, "gear1.shaft_damping": 10.0, "gear1.shaft_omega": w,
                 "gear2.torque": 200.0}
        f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(fmu3_path)), modelIdentifier="GearMesh",
                      instanceName=f"run{h}")
        samples, refused = [], []

        def update(env, t, set_requested, get_allowed, finished, can_return_early, early, early_time):
            assert get_allowed and not set_requested
            samples.append((t, *f.getFloat64([vr["mesh.te"], vr["gear1.mz"]])))
            if record == "wrong":
                try:
                    f.getFloat64([vr["energy.kinetic"]])
                except FMICallException as exc:
                    refused.append(exc)

        f.instantiate(intermediateUpdate=update if record else None)
        for name, x in start.items():
            (f.setInt32 if name == "model.dynamics" else f.setFloat64)([vr[name]], [x])
        f.enterInitializationMode(startTime=0.0)
        f.exitInitializationMode()
        points = []
        t = 0.0
        for k in range(n):
            f.setFloat64([vr["gear1.shaft_phi"]], [w * t])
            f.doStep(t, h)
            t = (k + 1) * h
            points.append((t, *f.getFloat64([vr["mesh.te"], vr["gear1.mz"]])))
        f.terminate()
        f.freeInstance()
        return (refused if record == "wrong" else samples), points

    gaps = {}
    for tolerance in (1e-8, 1e-9):
        samples, points = run(1e-2, 2, tolerance, "samples")
        times = np.array([s[0] for s in samples])
        assert np.all(np.diff(times) > 0) and times[-1] == pytest.approx(0.02, abs=1e-15)
        assert len(samples) >= 10 * 0.02 * w / (2 * np.pi) * 57
        for t_end, te, mz in points:  # the last sample of each step is the step's outputs
            last = [s for s in samples if abs(s[0] - t_end) < 1e-12]
            assert last and last[-1][1:] == (te, mz)
        fine = run(1e-5, 2000, tolerance, None)[1]
        ft, fte = np.array([p[0] for p in fine]), np.array([p[1] for p in fine])
        inside = times > ft[0]
        gap = np.abs(np.array([s[1] for s in samples])[inside] - np.interp(times[inside], ft, fte))
        gaps[tolerance] = gap.max()
        print(f"tolerance {tolerance:g} m: {len(samples)} samples in 20 ms at 10 ms steps, gap to the 1e-5 s run "
              f"largest {gap.max() * 1e6:.4f} um, median {np.median(gap) * 1e6:.4f} um; TE swing "
              f"{np.ptp(fte[len(fte) // 2:]) * 1e6:.3f} um")
    assert gaps[1e-8] <= 0.15e-6
    assert gaps[1e-9] <= 0.03e-6 and gaps[1e-9] <= 0.3 * gaps[1e-8]
    refused = run(1e-2, 1, 1e-8, "wrong")[0]
    assert refused and all(exc.status == 3 for exc in refused)  # fmi3Error at every internal step


@pytest.mark.parametrize("mode", [None, "large_step"])
def test_scene_fmus_of_both_versions_agree(fmu_path, fmu3_path, tmp_path, mode):
    """`gearmesh fmu SCENE --fmi3` makes set A's scene FMU as FMI 3.0 from GearMesh-fmi3.fmu: the
    same interface (the same names, causalities and start values), FMPy's validation finds
    nothing, and FMPy's simulate_fmu gives every output of the 2.0 scene FMU bit for bit (the
    scene as it is, and a copy in the large-step mode driven through the drive port)."""
    from gearmesh import fmu_command
    from gearmesh.scene import load_scene
    from gearmesh.scene_fmu import model_variables

    scene_file = REPO / "scenarios" / "paper_setA_3U4U.toml"
    if mode:
        scene_file = tmp_path / "setA_large_step.toml"
        scene_file.write_text((REPO / "scenarios" / "paper_setA_3U4U.toml").read_text()
                              + f'\n[fmu]\nmode = "{mode}"\n')
    scene = load_scene(scene_file, fmu_path)
    fmus = {}
    for version, generic in (("2", fmu_path), ("3", fmu3_path)):
        out = tmp_path / f"setA{version}.fmu"
        fmu_command.write_scene_fmu(scene, pathlib.Path(generic), out)
        fmus[version] = out
    assert validate_fmu(str(fmus["3"])) == []
    import zipfile
    mds = {v: model_variables(zipfile.ZipFile(p).read("modelDescription.xml").decode()) for v, p in fmus.items()}
    assert mds["2"] == mds["3"]
    outputs = [n for n, (_, causality, _) in mds["2"].items() if causality == "output"]
    if mode:
        w = 3000 * 2 * np.pi / 60
        start = {"drive.shaft_omega": w, "load.torque": -200.0, "gear1.omega": w, "gear2.omega": -w}
        stop, interval = 0.02, 1e-3
    else:
        start = {"gear1.omega": 100.0, "gear2.omega": -100.0, "gear2.phi": 1e-4}
        stop, interval = 0.01, 1e-3
    runs = [simulate_fmu(str(fmus[v]), start_values=start, stop_time=stop, output_interval=interval, output=outputs)
            for v in ("2", "3")]
    for name in outputs:
        assert np.array_equal(runs[0][name], runs[1][name]), name
    assert np.max(np.abs(runs[1]["mesh.normal_force"])) > 0


@pytest.mark.parametrize("train_scene", ["two_stage_reducer", "planetary_3_planets"])
def test_train_fmus_of_both_versions_agree(fmu_path, fmu3_path, tmp_path, train_scene):
    """`gearmesh train-fmu TRAIN --fmi3` makes the train's FMU as FMI 3.0 around the FMI 3.0 train
    binary (GearTrain3.so): FMPy's validation finds nothing, it lists the 2.0 train FMU's
    variables (with `time` after them), and under FMPy's simulate_fmu, its motor driven and its
    output braked, every output equals the 2.0 FMU's bit for bit."""
    from gearmesh import train_fmu
    from gearmesh.scene_fmu import model_variables

    scene = REPO / "scenarios" / "trains" / f"{train_scene}.toml"
    fmus = {"2": train_fmu.build_train_fmu(scene, tmp_path / "train2.fmu", fmu_path),
            "3": train_fmu.build_train_fmu(scene, tmp_path / "train3.fmu", fmu3_path, fmi3=True)}
    assert validate_fmu(str(fmus["3"])) == []
    mds = {v: model_variables(zipfile.ZipFile(p).read("modelDescription.xml").decode()) for v, p in fmus.items()}
    assert mds["2"] == mds["3"]
    md2 = read_model_description(str(fmus["2"]))
    inputs = {v.name for v in md2.modelVariables if v.causality == "input"}
    outputs = [v.name for v in md2.modelVariables if v.causality == "output"]
    drive = next(n for n in ("motor.far_omega", "sun.torque") if n in inputs)
    brake = next(n for n in ("output.torque", "carrier.torque") if n in inputs)
    start = {drive: 100.0, brake: -150.0}
    runs = [simulate_fmu(str(p), start_values=start, stop_time=0.02, output_interval=1e-3, output=outputs)
            for p in fmus.values()]
    for name in outputs:
        assert np.array_equal(runs[0][name], runs[1][name]), name
    moving = [n for n in outputs if n.endswith(".speed")]
    assert max(np.max(np.abs(runs[1][n])) for n in moving) > 1.0  # the train turned
