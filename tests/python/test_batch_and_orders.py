"""Batch runs and the order analysis (issue 5)."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from gearmesh.batch import run as batch
from gearmesh.prescribed_motion import mesh_order_amplitudes
from gearmesh.scene import load_scene
from conftest import REPO

SCENES = REPO / "scenarios"


def test_order_analysis_recovers_the_harmonics_of_a_synthetic_te():
    pitches, per_pitch = 3, 40
    n = np.arange(pitches * per_pitch)
    x = 2 * math.pi * n / per_pitch  # one period per pitch = the first mesh order
    te = 5e-6 + 0.7e-6 * np.sin(x + 0.3) + 0.2e-6 * np.cos(2 * x) + 0.05e-6 * np.sin(3 * x)
    amp = mesh_order_amplitudes(te, pitches, orders=(1, 2, 3))
    assert amp[1] == pytest.approx(0.7e-6, rel=1e-9)
    assert amp[2] == pytest.approx(0.2e-6, rel=1e-9)
    assert amp[3] == pytest.approx(0.05e-6, rel=1e-9)


def test_batch_runs_scenes_times_torques_times_variations(fmu_path, tmp_path):
    scene = load_scene(SCENES / "paper_setB_P1P2.toml")
    cases = batch.expand([scene], [100.0, 300.0], {"model.friction_coefficient": [0.3, 0.4]})
    assert len(cases) == 4
    result = batch.run_batch(cases, fmu_path, tmp_path, jobs=2)  # a local Dask cluster
    tidy, summary = result.tidy, result.summary
    with summary.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 4
    by = {(float(r["torque_Nm"]), float(r["model.friction_coefficient"])): r for r in rows}
    # more torque, more TE; friction changes the loaded TE (the paper's Figure 8 effect)
    assert float(by[(300.0, 0.3)]["mean_te_m"]) > float(by[(100.0, 0.3)]["mean_te_m"])
    assert by[(300.0, 0.3)]["order1_m"] != by[(300.0, 0.4)]["order1_m"]
    with tidy.open() as fh:
        assert sum(1 for _ in fh) - 1 == 4 * 3 * 40  # one row per roll angle
    report = (tmp_path / "batch_report.md").read_text()
    assert "model.friction_coefficient 0.4: order 1" not in report  # labels live in the plot
    assert "paper_setB_P1P2_orders.png" in report
    assert (tmp_path / "paper_setB_P1P2_orders.png").stat().st_size > 0
    # bit for bit the same as the cases run one after the other in this process, without Dask
    serial = tmp_path / "serial"
    serial.mkdir()
    batch.write_outputs(batch.run_in_process(cases, fmu_path), cases, serial)
    for name in ("batch_te.csv", "batch_summary.csv"):
        assert (serial / name).read_bytes() == (tmp_path / name).read_bytes(), name


def test_bad_variation_is_named():
    with pytest.raises(ValueError, match="model.damping"):
        batch.parse_variation("model.damping=a,b")


def test_report_plots_variations_that_lost_a_case(tmp_path):
    """A case that failed leaves its variation's curve one torque short: the report plots each
    curve over its own torques (the clean-clone CI of 9f5728f crashed there: x and y of
    different lengths)."""
    from gearmesh.batch import run as batch

    def row(mu, torque):
        return {"scene": "s", "torque_Nm": torque, "model.friction_coefficient": mu,
                "mean_te_m": 1e-5, "ptp_te_m": 1e-6, "order1_m": 1e-7 * torque, "order2_m": 1e-8}

    summary = [row(0.0, t) for t in (50.0, 200.0, 350.0)] + [row(0.4, t) for t in (50.0, 350.0)]
    report = batch.write_report(tmp_path, summary)
    assert report.is_file() and (tmp_path / "s_orders.png").stat().st_size > 0
    assert "model.friction_coefficient" in report.read_text()
