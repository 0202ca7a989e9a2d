"""User tables through the FMU (core/src/user_tables.hpp): stiffness level 1 with
model.stiffness_table and the TE excitation model.te_table, files inside a scene FMU's resources/
(gearmesh.scene_fmu), also from the scene keys [model] stiffness_table_file / te_table_file; bad
or missing files give fmi2Error naming the parameter, and the instance goes on once fixed.

Forces are checked with prescribed spin angles in single contact, where the one loaded slice
carries k(theta) b TE with theta = gear 1's roll angle at the contact point (roll distance / r_b1),
and the quasi-static TE at zero load against the TE table.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import extract, read_model_description

from gearmesh.scene import SceneError, parse_scene
from gearmesh.scene_fmu import build_scene_fmu

import test_fmu_conformance as conformance
from test_fmu_conformance import assert_error
from test_fmu_microgeometry import Pair, Stepper
from conftest import REPO

FACE = 0.023  # m, the default face width
TE = 4e-6     # m, approach on flank A
# k(theta) = (theta/deg - 5) N/(mm um): linear in gear 1's roll angle
LINEAR_TABLE = "gearmesh-stiffness-table 1\n# k = theta - 5\n10 5\n40 35\n"
BAD_STIFFNESS = "gearmesh-stiffness-table 1\n17 15\n29 -15\n"
BAD_TE = "gearmesh-te-table 1\n0 1\n7 1\n"  # 7 deg is beyond the pitch of 57 teeth
ROWS = 24
SINE_TE = "gearmesh-te-table 1\n" + "".join(
    f"{360 / 57 * k / ROWS!r} {math.sin(2 * math.pi * k / ROWS)!r}\n" for k in range(ROWS))


def k_table(theta: float) -> float:
    """The linear table's stiffness at roll angle theta (rad), N/m^2."""
    return (math.degrees(theta) - 5) * 1e9


def sine_at(phi1: float) -> float:
    """The sine TE table interpolated at phi1, m (periodic, linear between rows)."""
    pitch = 2 * math.pi / 57
    u = (phi1 % pitch) / pitch * ROWS
    k = int(u)
    rows = [math.sin(2 * math.pi * j / ROWS) for j in range(ROWS + 1)]
    return 1e-6 * float(np.interp(u, [k, k + 1], rows[k:k + 2]))





@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    d = tmp_path_factory.mktemp("tables")
    files = {"linear.txt": LINEAR_TABLE, "bad k.txt": BAD_STIFFNESS, "sine.txt": SINE_TE,
             "tables/bad_te.txt": BAD_TE}
    out = {}
    for name, text in files.items():
        path = d / name.replace("/", "_")
        path.write_text(text)
        out[name] = path
    out["example_k.txt"] = REPO / "scenarios" / "user_stiffness_example.txt"
    out["example_te.txt"] = REPO / "scenarios" / "user_te_example.txt"
    return out


def scene_fmu(fmu_path, tmp_path, parameters, resources, name="scene"):
    out = build_scene_fmu(fmu_path, parameters, resources, tmp_path / f"{name}.fmu")
    directory = tmp_path / f"{name} dir"
    extract(str(out), str(directory))
    return directory, read_model_description(str(out))


def started(new, directory, md, params=None):
    inst = new(directory=directory, model_description=md)
    inst.initialize(params or {})
    return inst, Stepper(inst)


def test_level_1_follows_the_stiffness_table(new, fmu_path, tmp_path, tables):
    directory, md = scene_fmu(fmu_path, tmp_path, {"model.stiffness": 1, "model.stiffness_table": "linear.txt"},
                              {"linear.txt": tables["linear.txt"]})
    inst, step = started(new, directory, md)
    assert inst.get("model.stiffness") == 1 and inst.get("model.stiffness_table") == "linear.txt"
    pair = Pair(inst)
    names = ("mesh.normal_force", "mesh.stiffness", "mesh.pairs_in_contact")
    forces = []
    for frac in (0.47, 0.5, 0.53):  # single contact
        s = frac * pair.length
        force, stiffness, pairs = step(pair.pose(pair.phi1(s), TE), names)
        assert pairs == 1
        # the contact point lies midway between the overlapping flanks, TE/2 back from gear 1's
        theta = (pair.rho_sap1 + s - TE / 2) / pair.rb1
        assert stiffness == pytest.approx(k_table(theta) * FACE, rel=1e-9), frac
        assert force == pytest.approx(k_table(theta) * FACE * TE, rel=1e-9), frac
        forces.append(force)
    assert forces[0] < forces[1] < forces[2]  # the stiffness rises along the path


def test_level_1_and_te_table_from_scene_keys(new, fmu_path, tmp_path, tables):
    """A scene with both table keys: the files become resources, the FMU starts at level 1 with
    them, and quasi-static at zero load its TE is the TE table."""
    (tmp_path / "k.txt").write_text(LINEAR_TABLE)
    (tmp_path / "te.txt").write_text(SINE_TE)
    sc = parse_scene('[model]\nstiffness_level = 1\nstiffness_table_file = "k.txt"\n'
                     'te_table_file = "te.txt"\n', tmp_path / "scene.toml")
    assert sc.parameters["model.stiffness_table"] == "model_k.txt"
    assert sc.parameters["model.te_table"] == "model_te.txt"
    assert sc.resources == {"model_k.txt": (tmp_path / "k.txt").resolve(),
                            "model_te.txt": (tmp_path / "te.txt").resolve()}
    directory, md = scene_fmu(fmu_path, tmp_path, {**sc.parameters, "model.quasi_static": True},
                              sc.resources)
    inst, step = started(new, directory, md)
    pitch = 2 * math.pi / 57
    for k in range(12):
        phi1 = pitch * (k + 0.3) / 6 - 3 * pitch
        te, force = step({"gear1.phi": phi1, "mesh.load_torque": 0.0}, ("mesh.te", "mesh.normal_force"))
        assert force == 0.0
        assert te == pytest.approx(sine_at(phi1), abs=1e-13), k
    # under load the TE adds the excitation to what the table's stiffness gives
    te_loaded = step({"gear1.phi": pitch / 4, "mesh.load_torque": 100.0}, ("mesh.te",))
    assert te_loaded > sine_at(pitch / 4) + 1e-6


def test_example_tables_work_in_a_scene_fmu(new, fmu_path, tmp_path, tables):
    directory, md = scene_fmu(fmu_path, tmp_path, {"model.stiffness": 1, "model.stiffness_table": "example_k.txt",
                                                   "model.te_table": "example_te.txt"},
                              {n: tables[n] for n in ("example_k.txt", "example_te.txt")})
    _, step = started(new, directory, md)
    out = conformance.run(step.inst, 5)
    assert all(math.isfinite(x) for row in out for x in row)
    # mid-path (23 deg, single contact), phi1 = a quarter pitch: TE_exc = 0.5 um
    inst = step.inst
    pair = Pair(inst)
    s = 23 * math.pi / 180 * pair.rb1 - pair.rho_sap1
    phi1 = pair.phi1(s)
    exc = 0.5e-6 * math.sin(2 * math.pi * ((phi1 % (2 * math.pi / 57)) / (2 * math.pi / 57)))
    step.t = 5 * conformance.H
    force = step(pair.pose(phi1, TE + TE / 2))
    # within the table's row spacing the sine and the stiffness are close to their samples
    assert force == pytest.approx(15.499e9 * FACE * (TE + TE / 2 - exc), rel=2e-2)


@pytest.mark.parametrize("params, says", [
    ({"model.stiffness": 1, "model.stiffness_table": "missing.txt"}, ["model.stiffness_table", "cannot open"]),
    ({"model.stiffness": 1, "model.stiffness_table": "bad k.txt"},
     ["model.stiffness_table", "bad k.txt:3: stiffness -15", "allowed"]),
    ({"model.stiffness": 1, "model.stiffness_table": "../linear.txt"}, ["model.stiffness_table", '".." component']),
    ({"model.stiffness": 1, "model.stiffness_table": "tables\\bad_te.txt"}, ["model.stiffness_table", "backslash"]),
    ({"model.stiffness": 1}, ['model.stiffness_table = ""', "allowed"]),
    ({"model.stiffness": 4, "model.stiffness_table": "linear.txt"},
     ["model.stiffness_table", "model.stiffness = 1 (user tables) only", 'allowed: ""']),
    ({"model.te_table": "missing.txt"}, ["model.te_table", "cannot open"]),
    ({"model.te_table": "tables/bad_te.txt"}, ["model.te_table", "bad_te.txt:3: angle 7 deg", "360/57"]),
    ({"model.te_table": "/etc/hostname"}, ["model.te_table", "absolute path"]),
])
def test_bad_table_is_named_and_can_be_fixed(new, fmu_path, tmp_path, tables, params, says):
    directory, md = scene_fmu(fmu_path, tmp_path, {}, tables)
    inst = new(directory=directory, model_description=md)
    inst.slave.setupExperiment(startTime=0.0)
    inst.set(params)
    inst.slave.enterInitializationMode()
    assert_error(inst.slave.exitInitializationMode)
    message = inst.log.messages("logStatusError")[-1]
    for word in says:
        assert word in message, message
    assert_error(inst.slave.getReal, [inst.vr("geometry.contact_ratio")])  # same on a get
    # fix it and go on: the good tables
    fixed = {"model.stiffness_table": "linear.txt" if params.get("model.stiffness") == 1 else "",
             "model.te_table": "sine.txt"}
    inst.set(fixed)
    inst.set(conformance.drive(0.0))
    inst.slave.exitInitializationMode()
    out = conformance.run(inst, 2)
    assert all(math.isfinite(x) for row in out for x in row)


def test_table_without_resource_location(new, md):
    from ctypes import byref

    from fmpy.fmi2 import fmi2CoSimulation

    inst = new(instantiate=False)
    c = inst.slave.fmi2Instantiate(b"r", fmi2CoSimulation, md.guid.encode(), None, byref(inst.log.callbacks), 0, 0)
    assert c is not None
    inst.slave.component = c
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({"model.te_table": "sine.txt"})
    inst.slave.enterInitializationMode()
    assert_error(inst.slave.exitInitializationMode)
    message = inst.log.messages("logStatusError")[-1]
    assert "model.te_table" in message and "resource location" in message, message
    inst.set({"model.te_table": ""})
    inst.slave.exitInitializationMode()


def test_state_round_trip_keeps_the_tables(new, fmu_path, tmp_path, tables):
    directory, md = scene_fmu(fmu_path, tmp_path, {}, tables)
    params = {"model.stiffness": 1, "model.stiffness_table": "linear.txt", "model.te_table": "sine.txt"}
    a = new(directory=directory, model_description=md)
    a.initialize(params)
    conformance.run(a, 3)
    blob = a.slave.serializeFMUstate(a.slave.getFMUstate())
    after = conformance.run(a, 4, t0=3 * conformance.H)
    b = new(directory=directory, model_description=md, name="b")
    b.slave.setFMUstate(b.slave.deSerializeFMUstate(blob))
    assert b.get("model.stiffness_table") == "linear.txt" and b.get("model.te_table") == "sine.txt"
    assert conformance.run(b, 4, t0=3 * conformance.H) == after


@pytest.mark.parametrize("parameters, says", [
    ({"model.stiffness_table": "absent.txt"}, "no such file"),
    ({"model.te_table": "../sine.txt"}, "inside resources/"),
])
def test_scene_fmu_checks_table_names(fmu_path, tmp_path, tables, parameters, says):
    with pytest.raises(ValueError, match=says):
        build_scene_fmu(fmu_path, parameters, {"sine.txt": tables["sine.txt"]}, tmp_path / "bad.fmu")


@pytest.mark.parametrize("text, words", [
    # the level's rules are the core's: its messages, in the FMU's names
    ('[model]\nstiffness_level = 1\n', ['model.stiffness_table = "": model.stiffness = 1']),
    ('[model]\nstiffness_level = 4\nstiffness_table_file = "k.txt"\n',
     ['model.stiffness_table = "model_k.txt"', "model.stiffness = 1 (user tables) only", "has model.stiffness = 4"]),
    ('[model]\nstiffness_table_file = "k.txt"\n', ["model.stiffness_table", "has model.stiffness = 4"]),
    ('[model]\nte_table_file = "absent.txt"\n', ["model.te_table_file", "no such file"]),
    ('[model]\nte_table_file = ""\n', ["model.te_table_file", "non-empty file name"]),
])
def test_scene_table_keys_are_checked(tmp_path, text, words):
    (tmp_path / "k.txt").write_text(LINEAR_TABLE)
    with pytest.raises(SceneError) as err:
        parse_scene(text, tmp_path / "scene.toml")
    for w in words:
        assert w in str(err.value), str(err.value)
