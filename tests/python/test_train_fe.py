"""A planetary stage whose ring is at the FE level (scenarios/trains/planetary_ring_fe.toml: a thin
ring clamped at its outer diameter, level 5; compliance_tool builds the planet's and the ring's
databases once, cached): its train FMU carries each mesh's databases in resources/mesh<k>/,
passes fmpy's validation and keeps the Willis ratio, the torque balance and equal planet shares
at 1e-2 s, as the level-2 stage does (test_train_fmu.py)."""
from __future__ import annotations

import zipfile

from gearmesh import train_fmu
from conftest import REPO



def test_planetary_stage_with_an_fe_ring(fmu_path, tmp_path):
    from test_train_fmu import check_planetary_stage

    fmu = train_fmu.build_train_fmu(REPO / "scenarios" / "trains" / "planetary_ring_fe.toml",
                                    tmp_path / "planetary_ring_fe.fmu", fmu_path)
    with zipfile.ZipFile(fmu) as z:
        ring_meshes = {n.split("/")[1] for n in z.namelist() if n.endswith(".gcdb")}
    assert ring_meshes == {"mesh2", "mesh4", "mesh6"}  # the planet-ring meshes, at level 5
    check_planetary_stage(fmu)
