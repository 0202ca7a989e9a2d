"""The system-simulation guide's two-inertia example runs as printed and prints what the guide
says; its steady state is the closed form (motor torque = load, speeds T_m / c_load, gear 2's
in its own sense equal to the motor's: set A's gears have equal teeth) and its TE is the quasi-static TE at the
load torque, measured here independently through the FMU's quasi-static mode."""
from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
from conftest import REPO



def example() -> tuple[str, str]:
    text = (REPO / "docs" / "guide" / "system-simulation.md").read_text(encoding="utf-8")
    section = text[text.index("## A two-inertia example"):]
    section = section[:section.index("\n## ", 3)]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    promised = re.search(r"prints `([^`]+)`", section).group(1)
    return code, promised


def quasi_static_mean_te(fmu_path, torque: float) -> float:
    """Mean loaded TE over one mesh pitch at `torque` on gear 2 (quasi-static mode)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path)), modelIdentifier="GearMesh")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setBoolean([vr["model.quasi_static"]], [True])
    fmu.exitInitializationMode()
    fmu.setReal([vr["mesh.load_torque"]], [torque])
    te = []
    for i, phi in enumerate(np.linspace(0.0, 2 * np.pi / 57, 40, endpoint=False)):
        fmu.setReal([vr["gear1.phi"]], [phi])
        fmu.doStep(i * 1e-3, 1e-3)
        te.append(fmu.getReal([vr["mesh.te"]])[0])
    fmu.terminate()
    fmu.freeInstance()
    return float(np.mean(te))


def test_two_inertia_example_runs_as_printed(fmu_path, tmp_path):
    code, promised = example()
    (tmp_path / "build").mkdir()
    os.symlink(fmu_path, tmp_path / "build" / "GearMesh.fmu")
    (tmp_path / "two_inertia.py").write_text(code)
    out = subprocess.run([sys.executable, "two_inertia.py"], capture_output=True, text=True,
                         timeout=300, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == promised
    motor, gear2, load, te = map(float, re.match(
        r"motor (\S+) rad/s, gear 2 (\S+) rad/s, brake (\S+) N m, TE (\S+) um", promised).groups())
    T_m, c_load = 200.0, 10.0
    assert abs(motor - T_m / c_load) < 0.01 * T_m / c_load
    assert abs(gear2 - motor) < 0.01 * motor          # equal teeth; gear 2's speed in its own sense
    assert abs(load - T_m) < 0.01 * T_m
    assert abs(te * 1e-6 - quasi_static_mean_te(fmu_path, T_m)) < 0.3e-6
