"""The two-stage reducer's train FMU against an independent integration of the same system: two
plain pair elements (the generic FMU in its plain mode, moments read at the current inputs) joined
by the intermediate body, with the motor shaft and the load, integrated by scipy's Radau (an
implicit Runge-Kutta method with its own error control; none of the train's or the large-step
mode's code). Both start in the loaded equilibrium (each mesh at its quasi-static TE) and run 30
ms; the TE of both stages at the communication points agrees within 0.1 um. Measured: 0.034 and
0.059 um, the same at train tolerances 1e-10 and 1e-11 m and Radau tolerances 1e-10 and 1e-12:
a difference of the two paths at the tooth changes, not of either integration's accuracy."""
from __future__ import annotations

import math
import shutil

import numpy as np

from gearmesh import train_fmu
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.scene import load_scene
from conftest import REPO

TRAINS = REPO / "scenarios" / "trains"


def test_two_stage_train_matches_an_independent_implicit_integration(fmu_path, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from scipy.integrate import solve_ivp

    for name in ("stage1_19_57.toml", "stage2_23_61.toml"):
        shutil.copy(TRAINS / name, tmp_path / name)
    (tmp_path / "two_stage_reducer.toml").write_text((TRAINS / "two_stage_reducer.toml").read_text().replace(
        "[run]", "[dynamics]\ntolerance_m = 1e-10\n\n[run]"))
    fmu = train_fmu.build_train_fmu(tmp_path / "two_stage_reducer.toml", tmp_path / "train.fmu", fmu_path)
    J, k, c, w_in, load, psi = np.array([0.002, 0.03, 0.05]), 2e4, 5.0, 100.0, 200.0, math.pi / 2
    r1, r2 = 57 / 19, 61 / 23
    w0 = np.array([w_in, -w_in / r1, w_in / (r1 * r2)])
    far0 = load / (r1 * r2) / k
    meshes = [(load_scene(tmp_path / "stage1_19_57.toml", fmu_path), (0, 1), 0.0),
              (load_scene(tmp_path / "stage2_23_61.toml", fmu_path), (1, 2), psi)]

    def quasi_static_te(scene, phi1, gear2_load, w1, w2):
        with GearMeshFMU(fmu_path, {**scene.parameters, "model.quasi_static": True}) as q:
            q.step({"gear1.phi": phi1, "gear1.omega": w1, "gear2.omega": w2, "mesh.load_torque": gear2_load})
            out = q.get(["mesh.te", "gear1.base_diameter", "gear2.base_diameter"])
            return out["mesh.te"], 0.5 * out["gear1.base_diameter"], 0.5 * out["gear2.base_diameter"]

    te1, _, rb2 = quasi_static_te(meshes[0][0], 0.0, load / r2, w0[0], w0[1])
    phi_int = te1 / rb2
    te2, rb1b, rb2b = quasi_static_te(meshes[1][0], phi_int - psi, load, w0[1], w0[2])
    phi_out = (te2 - rb1b * (phi_int - psi)) / rb2b + psi

    plain = [GearMeshFMU(fmu_path, s.parameters) for s, _, _ in meshes]

    def element(x, i):
        _, (a, b), angle = meshes[i]
        plain[i].set({"gear1.phi": x[a] - angle, "gear2.phi": x[b] - angle, "gear1.omega": x[3 + a],
                      "gear2.omega": x[3 + b]})

    def rhs(t, x):
        torque = np.array([k * (far0 + w_in * t - x[0]) + c * (w_in - x[3]), 0.0, -load])
        for i, (_, (a, b), _) in enumerate(meshes):
            element(x, i)
            m = plain[i].get(["gear1.mz", "gear2.mz"])
            torque[a] += m["gear1.mz"]
            torque[b] += m["gear2.mz"]
        return np.concatenate([x[3:], torque / J])

    H, N = 1e-3, 30
    x0 = np.array([0.0, phi_int, phi_out, *w0])
    sol = solve_ivp(rhs, (0, N * H), x0, method="Radau", t_eval=[H * (i + 1) for i in range(N)], rtol=1e-10,
                    atol=1e-13)
    assert sol.status == 0, sol.message
    reference = []
    for j in range(N):
        row = []
        for i in range(2):
            element(sol.y[:, j], i)
            row.append(plain[i].get(["mesh.te"])["mesh.te"])
        reference.append(row)
    for p in plain:
        p.close()

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier="GearTrain", instanceName="t")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.setReal([vr[n] for n in ("input.omega", "intermediate.omega", "output.omega", "intermediate.phi", "output.phi",
                                "motor.far_omega", "motor.far_phi", "output.torque")],
              [*w0, phi_int, phi_out, w_in, far0, -load])
    f.exitInitializationMode()
    train = []
    for i in range(N):
        f.setReal([vr["motor.far_phi"], vr["motor.far_omega"], vr["output.torque"]], [far0 + w_in * i * H, w_in, -load])
        f.doStep(i * H, H)
        train.append(f.getReal([vr["stage1.te"], vr["stage2.te"]]))
    f.terminate()
    f.freeInstance()
    difference = np.abs(np.array(train) - np.array(reference)).max(axis=0)
    ripple = np.ptp(np.array(reference), axis=0)
    assert np.all(difference < 0.1e-6), difference
    assert np.all(ripple > 1e-6)  # the comparison sees the stages' tooth-change ripple
