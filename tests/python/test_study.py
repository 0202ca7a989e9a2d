"""Sampled studies (issue 17): seeded draws in SI from the units the FMU defines, generated pitch
deviation files the FMU reads, and bad input named without a traceback."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gearmesh import cli
from gearmesh.batch import run as batch, study
from gearmesh.scene import load_scene
from conftest import REPO

SCENES = REPO / "scenarios"


def test_study_draws_are_seeded_in_si_and_pitch_files_close(fmu_path, tmp_path):
    scene = load_scene(SCENES / "paper_setB_P1P2.toml")
    specs = ["gear2.rx=normal(0,0.3mrad)", "gear1.pitch_A=uniform(-2um,2)"]
    plan = study.plan(scene, specs, 5, 42, fmu_path, tmp_path)
    rng = np.random.default_rng(42)
    assert np.array_equal(plan.values["gear2.rx"], rng.normal(0.0, 0.3e-3, 5))
    raw = rng.uniform(-2e-6, 2e-6, (5, 57))
    assert np.allclose(plan.values["gear1.pitch_A"], raw - raw.mean(axis=1, keepdims=True),
                       rtol=0, atol=1e-18)
    record = json.loads((tmp_path / "study.json").read_text())
    assert (record["seed"], record["samples"]) == (42, specs)
    text = study.deviation_file(plan, 3, 1).read_text().splitlines()
    f = [float(line.split()[3]) for line in text if line.startswith("pitch ")]
    assert len(f) == 57 and abs(sum(f)) < 1e-9 and max(map(abs, f)) > 0.1
    cases = study.expand(plan, [200.0])
    assert [dict(c.tags)["case"] for c in cases] == [0, 1, 2, 3, 4]
    # the FMU reads the generated file, and the drawn pitch errors change the loaded TE
    rows = batch.run_in_process(cases[3:4], fmu_path)
    plain = batch.run_in_process([batch.Case(scene, 200.0, cases[3].overrides)], fmu_path)
    assert max(abs(a["te_m"] - b["te_m"]) for a, b in zip(rows, plain)) > 1e-8


@pytest.mark.parametrize("argv, needle", [
    (["--sample", "gear2.rx=normal(0,0.3parsec)"], "unit 'parsec' is not one of gear2.rx's; "
     "allowed: rad, deg, mrad"),
    (["--sample", "gear2.rxx=normal(0,1)"], "unknown parameter 'gear2.rxx' (did you mean gear2.rx"),
    (["--sample", "gear2.rx=0.3"], "expected NAME=normal(MEAN,SD) or NAME=uniform(LO,HI)"),
    (["--sample", "gear2.rx=gauss(0,1mrad)"], "unknown distribution 'gauss'; allowed: normal"),
    (["--sample", "gear2.rx=normal(0,-1mrad)"], "standard deviation -1 mrad; allowed range [0"),
    (["--sample", "gear1.phi=normal(0,1mrad)"], "gear1.phi is set by the sweep itself"),
    (["--sample", "model.friction_coefficient=normal(0.3,1)"], "draws outside the allowed range"),
    (["--sample", "gear2.rx=normal(0,1mrad)", "--cases", "0"], "--cases 0: allowed range [1, 100000]"),
    (["--sample", "gear2.rx=normal(0,1mrad)", "--cases", "10000000"], "allowed range [1, 100000]"),
    (["--sample", "gear2.rx=normal(0,1mrad)", "--seed", "-1"], "--seed -1: allowed range"),
])
def test_bad_study_input_is_named_without_traceback(argv, needle, fmu_path, tmp_path, capsys):
    args = ["study", str(SCENES / "paper_setB_P1P2.toml"), "--fmu", str(fmu_path),
            "--out", str(tmp_path), *argv]
    if "--cases" not in argv:
        args += ["--cases", "20"]
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err


def test_study_report_lists_the_worst_cases_and_plots_the_distribution(fmu_path, tmp_path):
    from gearmesh.batch import study_report

    scene = load_scene(SCENES / "paper_setB_P1P2.toml")
    plan = study.plan(scene, ["gear2.rx=uniform(-0.5,0.5mrad)"], 3, 7, fmu_path, tmp_path)
    cases = study.expand(plan, [150.0])
    rows = batch.run_in_process(cases, fmu_path)
    summary = batch.write_outputs(rows, cases, tmp_path)
    result = batch.BatchResult(tmp_path / "batch_te.csv", tmp_path / "batch_summary.csv",
                               summary, len(cases), 0, {})
    text = study_report.write(plan, result, worst=2).read_text()
    # the worst case by peak-to-peak TE, from the tidy rows directly
    te = {k: np.array([r["te_m"] for r in rows if r["case"] == k]) for k in range(3)}
    worst = max(te, key=lambda k: np.ptp(te[k]))
    table = text[text.index("## The 2 worst"):].splitlines()
    first = table[4].split("|")
    assert first[1].strip() == str(worst)
    assert float(first[3]) == pytest.approx(np.ptp(te[worst]) * 1e6, rel=1e-3)
    assert float(first[6]) == pytest.approx(plan.values["gear2.rx"][worst] * 1e3, rel=1e-3)
    assert len([line for line in table if line.startswith("| ")]) == 3  # header + 2 cases
    assert "seed 7" in text and (tmp_path / "study_distribution.png").stat().st_size > 0
