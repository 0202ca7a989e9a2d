"""A planetary stage whose ring is at the FE level (scenarios/trains/planetary_ring_fe.toml: a thin
ring clamped at its outer diameter, level 5; compliance_tool builds the planet's and the ring's
databases once, cached): its train FMU carries each mesh's databases in resources/mesh<k>/,
passes fmpy's validation and keeps the Willis ratio, the torque balance and equal planet shares
at 1e-2 s, as the level-2 stage does (test_train_fmu.py)."""
from __future__ import annotations

import math
import pathlib
import zipfile

import numpy as np

from gearmesh import train_fmu

REPO = pathlib.Path(__file__).resolve().parents[2]


def test_planetary_stage_with_an_fe_ring(fmu_path, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.validation import validate_fmu

    fmu = train_fmu.build_train_fmu(REPO / "scenarios" / "trains" / "planetary_ring_fe.toml",
                                    tmp_path / "planetary_ring_fe.fmu", fmu_path)
    with zipfile.ZipFile(fmu) as z:
        ring_meshes = {n.split("/")[1] for n in z.namelist() if n.endswith(".gcdb")}
    assert ring_meshes == {"mesh2", "mesh4", "mesh6"}  # the planet-ring meshes, at level 5
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier="GearTrain", instanceName="p")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    zs, zr, ws, load = 21, 63, 100.0, 100.0
    wc, twist = ws * zs / (zs + zr), load * zs / (zs + zr) / 1e4
    names, values = ["sun.omega", "carrier.omega", "motor.far_omega", "carrier.torque", "motor.far_phi"], \
        [ws, wc, ws, -load, twist]
    for p in (1, 2, 3):
        names += [f"planet{p}.omega", f"planet{p}.phi"]
        values += [wc - (ws - wc), 2 * (2 * math.pi * (p - 1) / 3)]
    f.setReal([vr[n] for n in names], values)
    f.exitInitializationMode()
    read = ["sun.speed", "carrier.speed", "motor.torque", "ring.holding_torque", "sun_planet1.normal_force",
            "sun_planet2.normal_force", "sun_planet3.normal_force", "energy.residual", "energy.work_in"]
    rows = []
    for i in range(150):
        t = i * 1e-2
        f.setReal([vr["motor.far_phi"], vr["motor.far_omega"], vr["carrier.torque"]], [twist + ws * t, ws, -load])
        f.doStep(t, 1e-2)
        rows.append(f.getReal([vr[n] for n in read]))
    f.terminate()
    f.freeInstance()
    x = np.array(rows)
    assert np.all(np.isfinite(x))
    last = x[100:]
    assert abs(last[:, 1].mean() / last[:, 0].mean() - zs / (zs + zr)) < 1e-5
    assert abs(last[:, 2].mean() - load * zs / (zs + zr)) < 0.02 * load
    assert abs(last[:, 3].mean() - load * zr / (zs + zr)) < 0.02 * load
    shares = last[:, 4:7].mean(axis=0) / last[:, 4:7].mean(axis=0).sum()
    assert np.allclose(shares, 1 / 3, atol=1e-6)
    assert abs(x[-1, 7]) <= 1e-3 * x[-1, 8] and x[-1, 7] >= -1e-5 * x[-1, 8]
