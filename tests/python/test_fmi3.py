"""The FMI 3.0 co-simulation FMU (build/GearMesh-fmi3.fmu) beside the FMI 2.0 one: one build makes
both from the same variable table (modelDescription/variables.h), the same model and core, and
the shared instance layer (fmu_src/fmi_instance.c) behind fmi3_functions.c. Checked through
FMPy's FMI 3 support: its validation (schema and rules), the same variables, outputs bit for
bit the 2.0 FMU's in every mode, FMU state, directional and adjoint derivatives, and the
refusals of what FMI 3.0 offers and this FMU does not."""
from __future__ import annotations

import ctypes
import os
import pathlib

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def fmu3_path(fmu_path) -> pathlib.Path:
    """GearMesh-fmi3.fmu beside the 2.0 FMU (GEARMESH_FMU3 overrides)."""
    path = pathlib.Path(os.environ.get("GEARMESH_FMU3", pathlib.Path(fmu_path).with_name("GearMesh-fmi3.fmu")))
    if not path.is_file():
        pytest.fail(f"{path} not found: build the 'fmu3' target first (tools/run-tests does)")
    return path


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


def test_same_variables_as_fmi2(fmu_path, fmu3_path):
    """Every variable of the 2.0 FMU with its value reference, causality, variability, type (Real
    as Float64, Integer as Int32), unit, start, min and max; plus the independent variable `time`
    after them; the same GUID as instantiation token."""
    md2, md3 = read_model_description(str(fmu_path)), read_model_description(str(fmu3_path))
    assert md3.fmiVersion == "3.0" and md3.instantiationToken == md2.guid
    v3 = {v.name: v for v in md3.modelVariables}
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
    for v in md2.modelVariables:
        w = v3.pop(v.name)
        # FMI 3.0: the unit and display unit through the variable's declared type
        unit = w.declaredType.unit if w.declaredType else w.unit
        display = w.declaredType.displayUnit if w.declaredType else w.displayUnit
        assert (w.valueReference, w.causality, w.variability, w.type, unit, display, w.min, w.max) == \
            (v.valueReference, v.causality, v.variability, types[v.type], v.unit, v.displayUnit, v.min, v.max), v.name
        assert str(w.start) == str(v.start), v.name
    assert list(v3) == ["time"] and v3["time"].causality == "independent"
    assert v3["time"].valueReference == len(md2.modelVariables)
    assert len(md3.outputs) == len(md2.outputs) and len(md3.initialUnknowns) == len(md2.initialUnknowns)


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
                                                     (ctypes.c_double * 2)(), 2), "no variable is an array"),
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
