"""The load across the face through both FMU versions (modelDescription/variables.h, GM_FMU_ARRAYS):
FMI 3.0 arrays whose slice dimension is the structural parameter model.slices, FMI 2.0 element
scalars (model.h, MODEL_ELEMENT_VR) that a scene FMU lists when its [fmu] outputs name them.
Checked: the scene FMUs of both versions validate and give the same elements bit for bit; the
elements add up to the scalar outputs (pair forces to mesh.normal_force, a pair's line loads
over the slice width to its force, the largest to mesh.max_line_load); a uniform face at level 0
carries c times the TE; Configuration Mode sets model.slices and the arrays follow; FMU state
restores them; what is not allowed is refused naming it."""
from __future__ import annotations

import pathlib
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu
from conftest import REPO
from test_fmu_conformance import LogCapture

PAIRS = 4  # GM_FMU_LOAD_PAIRS
ELEMENT_BASE = 0x40000000  # model.h, MODEL_ELEMENT_VR
ARRAYS = ["mesh.slice_position", "mesh.line_load", "mesh.pair_force", "mesh.pair_share", "mesh.pair_position",
          "mesh.pair_approach", "mesh.te_orders", "mesh.te_order_phases", "mesh.normal_force_orders",
          "mesh.normal_force_order_phases"]


def element_vr(array: str, index: int) -> int:
    return ELEMENT_BASE + (ARRAYS.index(array) << 20) + index


def scene_fmus(fmu_path, fmu3_path, tmp_path, outputs: list[str], extra: str = ""):
    """Set A's scene with [fmu] outputs, as FMI 2.0 and FMI 3.0 scene FMUs."""
    from gearmesh import fmu_command
    from gearmesh.scene import load_scene

    scene_file = tmp_path / "setA_loads.toml"
    scene_file.write_text((REPO / "scenarios" / "paper_setA_3U4U.toml").read_text() + extra
                          + f"\n[fmu]\noutputs = {outputs!r}\n".replace("'", '"'))
    scene = load_scene(scene_file, fmu_path)
    fmus = {}
    for version, generic in (("2", fmu_path), ("3", fmu3_path)):
        fmus[version] = tmp_path / f"setA{version}.fmu"
        fmu_command.write_scene_fmu(scene, pathlib.Path(generic), fmus[version])
    return scene, fmus


def test_scene_fmus_list_the_asked_arrays_and_agree(fmu_path, fmu3_path, tmp_path):
    """[fmu] outputs = the line load, pair forces and slice positions: FMI 2.0 lists their
    elements (4 x slices line loads named mesh.line_load[k,j]), FMI 3.0 the arrays with the
    scene's slice count as their dimension; FMPy validates both; simulate_fmu gives the same
    values bit for bit; the elements add up to the scalar outputs at every point."""
    scene, fmus = scene_fmus(fmu_path, fmu3_path, tmp_path,
                             ["mesh.line_load", "mesh.pair_force", "mesh.slice_position", "mesh.max_line_load"])
    slices = scene.parameters.get("model.slices", 10)
    for path in fmus.values():
        assert validate_fmu(str(path)) == [], path
    md2, md3 = read_model_description(str(fmus["2"])), read_model_description(str(fmus["3"]))
    names2 = [v.name for v in md2.modelVariables]
    assert f"mesh.line_load[{PAIRS},{slices}]" in names2 and f"mesh.line_load[1,{slices + 1}]" not in names2
    assert "mesh.pair_share[1]" not in names2 and "mesh.max_line_load" in names2  # only what was asked
    v3 = {v.name: v for v in md3.modelVariables}
    assert [int(d.start) for d in v3["mesh.line_load"].dimensions] == [PAIRS, slices]
    assert "mesh.pair_share" not in v3
    start = {"gear1.omega": 100.0, "gear2.omega": -100.0, "gear2.phi": 2e-4}
    names = [f"mesh.line_load[{k},{j}]" for k in range(1, PAIRS + 1) for j in range(1, slices + 1)]
    force_names = [f"mesh.pair_force[{k}]" for k in range(1, PAIRS + 1)]
    run2 = simulate_fmu(str(fmus["2"]), start_values=start, stop_time=0.01, output_interval=1e-3,
                        output=[*names, *force_names, "mesh.normal_force", "mesh.max_line_load"])
    run3 = simulate_fmu(str(fmus["3"]), start_values=start, stop_time=0.01, output_interval=1e-3,
                        output=["mesh.line_load", "mesh.pair_force", "mesh.normal_force"])
    line_load = np.stack([run2[n] for n in names], axis=1).reshape(-1, PAIRS, slices)
    pair_force = np.stack([run2[n] for n in force_names], axis=1)
    assert np.array_equal(line_load, run3["mesh.line_load"])
    assert np.array_equal(pair_force, run3["mesh.pair_force"])
    positions = simulate_fmu(str(fmus["3"]), stop_time=1e-3, output=["mesh.slice_position"])["mesh.slice_position"][0]
    width = np.diff(positions)
    assert np.allclose(width, width[0], rtol=1e-12) and width[0] > 0
    loaded = run2["mesh.normal_force"] > 0
    assert loaded.sum() >= 5
    assert np.allclose(line_load.sum(axis=2) * width[0], pair_force, rtol=1e-12, atol=1e-9)
    assert np.allclose(pair_force.sum(axis=1), run2["mesh.normal_force"], rtol=1e-12)
    assert np.array_equal(line_load.max(axis=(1, 2)), run2["mesh.max_line_load"])


def test_scene_fmus_list_the_mesh_orders_the_scene_asks_for(fmu_path, fmu3_path, tmp_path):
    """A large-step scene with [dynamics] mesh_orders = 6 and [fmu] outputs = the TE's orders:
    FMI 2.0 lists mesh.te_orders[1] ... [6] (not [7]), FMI 3.0 the array with dimension 6; a run
    of both gives the same orders bit for bit, the first three the scalar outputs; a [dynamics]
    table in a scene whose mode is not the large-step one is refused naming the rule."""
    from gearmesh.scene import SceneError, load_scene

    scene, fmus = scene_fmus(fmu_path, fmu3_path, tmp_path, ["mesh.te_orders"],
                             "\n[dynamics]\nmesh_orders = 6\n")
    assert scene.parameters["dynamics.mesh_orders"] == 6
    names2 = [v.name for v in read_model_description(str(fmus["2"])).modelVariables]
    assert "mesh.te_orders[6]" in names2 and "mesh.te_orders[7]" not in names2
    v3 = {v.name: v for v in read_model_description(str(fmus["3"])).modelVariables}
    assert [int(d.start) for d in v3["mesh.te_orders"].dimensions] == [6]
    w = 3000 * 2 * np.pi / 60
    start = {"model.dynamics": 1, "gear1.omega": w, "gear2.omega": -w, "drive.torque": 100.0, "load.torque": -100.0}
    names = [f"mesh.te_order{k}" for k in (1, 2, 3)]
    run2 = simulate_fmu(str(fmus["2"]), start_values=start, stop_time=0.02, output_interval=1e-2,
                        output=[f"mesh.te_orders[{k}]" for k in range(1, 7)] + names)
    run3 = simulate_fmu(str(fmus["3"]), start_values=start, stop_time=0.02, output_interval=1e-2,
                        output=["mesh.te_orders"])
    orders2 = np.stack([run2[f"mesh.te_orders[{k}]"] for k in range(1, 7)], axis=1)
    assert np.array_equal(orders2, run3["mesh.te_orders"]) and orders2[-1, 5] > 0
    assert np.array_equal(orders2[:, :3], np.stack([run2[n] for n in names], axis=1))
    prescribed = tmp_path / "prescribed.toml"
    prescribed.write_text((REPO / "scenarios" / "paper_setA_3U4U.toml").read_text()
                          + '\n[dynamics]\nmesh_orders = 6\n[fmu]\nmode = "prescribed"\n')
    with pytest.raises(SceneError, match=r"\[dynamics\]: read by the large-step mode only"):
        load_scene(prescribed, fmu_path)


def test_unknown_scene_output_is_refused_naming_the_arrays(fmu_path, fmu3_path, tmp_path):
    from gearmesh.scene_interface import InterfaceError

    with pytest.raises(InterfaceError, match="mesh.line_loads.*mesh.line_load"):
        scene_fmus(fmu_path, fmu3_path, tmp_path, ["mesh.line_loads"])


def fmi3_instance(fmu3_path, name="arrays"):
    md = read_model_description(str(fmu3_path))
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(fmu3_path)), modelIdentifier="GearMesh",
                  instanceName=name)
    messages: list[str] = []
    f.instantiate(logMessage=lambda env, status, category, message: messages.append(message.decode()))
    return f, {v.name: v.valueReference for v in md.modelVariables}, messages


def test_configuration_mode_sets_the_slices_and_the_arrays_follow(fmu3_path):
    """model.slices set in Configuration Mode (UInt64): the arrays then have that many columns; at
    level 0 on an aligned spur pair each loaded pair carries c TE over the whole face; a state
    taken and set restores them; Int32 access to model.slices, a UInt64 value of another
    variable, a non-structural parameter in Configuration Mode and a wrong nValues are refused
    naming what, the instance usable after each."""
    f, vr, messages = fmi3_instance(fmu3_path)
    slices, te, c = 7, 4e-6, 2e10
    f.enterConfigurationMode()
    f.setUInt64([vr["model.slices"]], [slices])
    with pytest.raises(FMICallException):
        f.setFloat64([vr["model.user_stiffness"]], [c])
    assert any("Illegal call sequence (instance is in Configuration Mode)" in m for m in messages), messages
    f.exitConfigurationMode()
    with pytest.raises(FMICallException):
        f.setInt32([vr["model.slices"]], [5])
    assert any("structural parameter, of type UInt64" in m for m in messages)
    with pytest.raises(FMICallException):
        f.setUInt64([vr["model.stiffness"]], [1])
    assert any("not a variable of type UInt64" in m for m in messages), messages
    f.setInt32([vr["model.stiffness"]], [0])
    f.setFloat64([vr["model.user_stiffness"]], [c])
    rb2 = 0.5 * 57 * 2.6e-3 * np.cos(np.radians(20)) / np.cos(0)  # set A's gear 2 base radius (spur, m_t = m_n)
    f.setFloat64([vr["gear2.phi"]], [te / rb2])  # gear 1 at 0: the TE is r_b2 phi2 (external pair)
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    assert f.getUInt64([vr["model.slices"]]) == [slices]
    f.doStep(0.0, 1e-3)
    line_load = np.array(f.getFloat64([vr["mesh.line_load"]], nValues=PAIRS * slices)).reshape(PAIRS, slices)
    pairs = int(f.getInt32([vr["mesh.pairs_in_contact"]])[0])
    assert pairs >= 1 and np.all(line_load[pairs:] == 0)
    approach = np.array(f.getFloat64([vr["mesh.pair_approach"]], nValues=PAIRS))
    for k in range(pairs):  # q = c Delta on every slice of a pair
        assert np.allclose(line_load[k], c * approach[k], rtol=1e-12)
    messages.clear()
    with pytest.raises(FMICallException):
        f.getFloat64([vr["mesh.line_load"]], nValues=PAIRS * 10)
    assert any(f"number {PAIRS * slices}" in m for m in messages)
    state = f.getFMUState()
    f.setFloat64([vr["gear2.phi"]], [2 * te / rb2])
    f.doStep(1e-3, 1e-3)
    moved = f.getFloat64([vr["mesh.line_load"]], nValues=PAIRS * slices)
    assert not np.array_equal(moved, line_load.ravel())
    f.setFMUState(state)
    assert f.getFloat64([vr["mesh.line_load"]], nValues=PAIRS * slices) == list(line_load.ravel())
    f.freeFMUState(state)
    f.terminate()
    f.freeInstance()


def test_fmi2_elements_of_the_generic_fmu(fmu_path, md):
    """The generic FMI 2.0 FMU lists no element but reads every one by its value reference
    (what a scene FMU lists): the largest line load is mesh.max_line_load; an element past
    model.slices' columns and a directional derivative of an element are refused naming them."""
    vr = {v.name: v.valueReference for v in md.modelVariables}
    assert not any(v.valueReference >= ELEMENT_BASE for v in md.modelVariables)
    log = LogCapture()
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path)), modelIdentifier="GearMesh", instanceName="two")
    f.instantiate(callbacks=log.callbacks)
    f.setupExperiment(startTime=0.0)
    f.setReal([vr["gear2.phi"]], [1e-4])
    f.enterInitializationMode()
    f.exitInitializationMode()
    f.doStep(0.0, 1e-3)
    slices = f.getInteger([vr["model.slices"]])[0]
    line_load = f.getReal([element_vr("mesh.line_load", i) for i in range(PAIRS * slices)])
    assert max(line_load) == f.getReal([vr["mesh.max_line_load"]])[0] > 0
    with pytest.raises(FMICallException):
        f.getReal([element_vr("mesh.line_load", PAIRS * slices)])
    assert f"element {PAIRS * slices} of mesh.line_load, which has {PAIRS * slices} elements" in log.text()
    with pytest.raises(FMICallException):
        f.getDirectionalDerivative([element_vr("mesh.line_load", 0)], [vr["gear2.phi"]], [1.0])
    assert "the arrays have no directional derivative" in log.text()
    f.doStep(1e-3, 1e-3)  # still usable
    f.terminate()
    f.freeInstance()


def test_generic_fmi2_annotation_describes_the_arrays(fmu_path):
    """<Tool name="GearMesh arrays"> names each array once with its element base, dimensions and
    units, in the order and at the value references the binary reads."""
    from gearmesh.scene_fmu import array_variables

    with zipfile.ZipFile(fmu_path) as z:
        arrays = array_variables(z.read("modelDescription.xml").decode())
    assert list(arrays) == ARRAYS
    assert [a.element_base for a in arrays.values()] == [element_vr(n, 0) for n in ARRAYS]
    assert arrays["mesh.line_load"].dimensions == (str(PAIRS), "model.slices")
    assert arrays["mesh.line_load"].unit == "N/m" and arrays["mesh.slice_position"].causality == "calculatedParameter"
    assert arrays["mesh.te_orders"].dimensions == ("dynamics.mesh_orders",) and arrays["mesh.te_orders"].unit == "m"


def test_intermediate_update_offers_the_line_loads(fmu3_path):
    """In the large-step mode at a 5 ms step, the intermediate-update callback reads the line loads
    at each internal step (intermediateUpdate="true"): they change from step to step, each adds up
    to the mesh's normal force read with it, and the last is the step's outputs. The mesh orders,
    which a whole step makes, are not offered there (refused naming the rule); after the step the
    array mesh.te_orders has dynamics.mesh_orders (set in Configuration Mode) elements, the first
    three the scalars mesh.te_order<k>."""
    md = read_model_description(str(fmu3_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slices = 10
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(fmu3_path)), modelIdentifier="GearMesh",
                  instanceName="intermediate")
    samples = []

    def update(env, t, set_requested, get_allowed, finished, can_return_early, early, early_time):
        loads = f.getFloat64([vr["mesh.line_load"], vr["mesh.pair_force"], vr["mesh.normal_force"]],
                             nValues=PAIRS * slices + PAIRS + 1)
        samples.append((t, np.array(loads)))
        if len(samples) == 1:
            try:
                f.getFloat64([vr["mesh.te_orders"]], nValues=orders)
                refused.append(False)
            except FMICallException:
                refused.append(True)

    messages, refused, orders = [], [], 5
    f.instantiate(intermediateUpdate=update,
                  logMessage=lambda env, status, category, message: messages.append(message.decode()))
    f.enterConfigurationMode()
    f.setUInt64([vr["dynamics.mesh_orders"]], [orders])
    f.exitConfigurationMode()
    w = 1000 * 2 * np.pi / 60
    f.setInt32([vr["model.dynamics"]], [1])
    f.setFloat64([vr["gear1.omega"], vr["gear2.omega"], vr["gear1.shaft_stiffness"], vr["gear1.shaft_omega"],
                  vr["gear2.torque"]], [w, -w, 2e4, w, 200.0])
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.doStep(0.0, 5e-3)
    end = np.array(f.getFloat64([vr["mesh.line_load"], vr["mesh.pair_force"], vr["mesh.normal_force"]],
                                nValues=PAIRS * slices + PAIRS + 1))
    te_orders = f.getFloat64([vr["mesh.te_orders"]], nValues=orders)
    scalars = f.getFloat64([vr[f"mesh.te_order{k}"] for k in (1, 2, 3)])
    f.terminate()
    f.freeInstance()
    assert refused == [True] and any("read during an intermediate update" in m for m in messages), messages
    assert te_orders[:3] == scalars and len(te_orders) == orders
    assert len(samples) >= 10
    assert np.array_equal(samples[-1][1], end)
    values = np.array([s[1] for s in samples])
    assert len({v.tobytes() for v in values}) > len(samples) // 2  # the samples are the internal steps'
    pair_force, normal_force = values[:, PAIRS * slices:-1], values[:, -1]
    assert np.allclose(pair_force.sum(axis=1), normal_force, rtol=1e-12) and normal_force.max() > 0
