"""Batch runs: scenes x load cases x parameter variations as tasks on a Dask cluster (a local
one with one worker per core unless a scheduler is given: gearmesh.batch.cluster, gearmesh.batch.tasks),
with a progress bar; results as tidy tables (one row per observation) and a summary per case.
docs/batch.md."""
from __future__ import annotations

import csv
import pathlib
from dataclasses import dataclass

import numpy as np

from gearmesh.batch.cases import OBSERVATIONS, Case, expand, parse_variation, run_case
from gearmesh.compliance import with_databases
from gearmesh.main_job import RUN_DEFAULTS
from gearmesh.prescribed_motion import mesh_order_amplitudes
from gearmesh.scene import Scene

def summarize(rows: list[dict], pitches_of: dict[str, int]) -> list[dict]:
    """Per case: mean and peak-to-peak TE and the first two mesh-order amplitudes."""
    keys = [k for k in rows[0] if k not in OBSERVATIONS]
    groups: dict[tuple, list[float]] = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in keys), []).append(r["te_m"])
    summary = []
    for key, te in groups.items():
        case = dict(zip(keys, key))
        orders = mesh_order_amplitudes(te, pitches_of[case["scene"]])
        summary.append({**case, "mean_te_m": float(np.mean(te)), "ptp_te_m": float(np.ptp(te)),
                        "order1_m": orders[1], "order2_m": orders[2]})
    return summary


def write_rows(path: pathlib.Path, rows: list[dict]) -> None:
    """A CSV of the rows; its columns are the rows' keys in order of appearance."""
    names = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=names)
        writer.writeheader()
        writer.writerows(rows)


def run_in_process(cases: list[Case], generic_fmu: pathlib.Path) -> list[dict]:
    """The cases one after the other in this process, without Dask (the reference the cluster's
    results are checked against, and the benchmark's baseline)."""
    scenes: dict[int, Scene] = {}
    rows = []
    for case in cases:
        if id(case.scene) not in scenes:
            scenes[id(case.scene)] = with_databases(case.scene, progress=False)
        scene = scenes[id(case.scene)]
        rows += run_case(Case(scene, case.torque, case.overrides, case.tags), str(generic_fmu))
    return rows


@dataclass
class BatchResult:
    tidy: pathlib.Path
    summary: pathlib.Path
    summary_rows: list[dict]
    ran: int                     # cases run now
    skipped: int                 # cases finished by an earlier (interrupted) run
    errors: dict[str, str]       # case label -> error, after its retry


def run_batch(cases: list[Case], generic_fmu: pathlib.Path, out: pathlib.Path,
              jobs: int | None = None, scheduler: str | None = None,
              shared: pathlib.Path | None = None, report: bool = True) -> BatchResult:
    """Run the cases on a Dask cluster (`scheduler`, else a local one of `jobs` workers, default
    one per core); each finished case is kept in out/cases/ as it arrives, and cases found there
    are skipped (resume). Writes out/batch_te.csv (tidy), out/batch_summary.csv, and with
    `report` out/batch_report.md, from the finished cases; failed cases (after one retry) are in
    BatchResult.errors and out/batch_errors.csv."""
    from gearmesh.batch import cluster, tasks as batch_tasks

    out.mkdir(parents=True, exist_ok=True)
    with cluster.connect(scheduler, jobs) as client:
        rows, ran, skipped, errors = batch_tasks.run(client, cases, pathlib.Path(generic_fmu),
                                                     out, shared)
    tidy, summary = out / "batch_te.csv", out / "batch_summary.csv"
    errors_csv = out / "batch_errors.csv"
    errors_csv.unlink(missing_ok=True)
    if errors:
        write_rows(errors_csv, [{"case": k, "error": v} for k, v in errors.items()])
    summary_rows = write_outputs(rows, cases, out)
    if report and summary_rows:
        write_report(out, summary_rows)
    return BatchResult(tidy, summary, summary_rows, ran, skipped, errors)


def write_outputs(rows: list[dict], cases: list[Case], out: pathlib.Path) -> list[dict]:
    """out/batch_te.csv and out/batch_summary.csv from the cases' rows (in any order); returns
    the summary rows."""
    rows = sorted(rows, key=lambda r: (r["scene"], r["torque_Nm"],
                                       tuple(str(r.get(k)) for k in sorted(r)), r["gear1_phi_rad"]))
    pitches = {c.scene.name: {**RUN_DEFAULTS, **c.scene.run}["te_pitches"] for c in cases}
    write_rows(out / "batch_te.csv", rows)
    summary_rows = summarize(rows, pitches) if rows else []
    write_rows(out / "batch_summary.csv", summary_rows)
    return summary_rows


def write_report(out: pathlib.Path, summary: list[dict]) -> pathlib.Path:
    """batch_report.md with one plot per scene: mesh orders over torque per variation."""
    from gearmesh.main_job import plot

    fixed = {"scene", "torque_Nm", "mean_te_m", "ptp_te_m", "order1_m", "order2_m"}
    lines = ["# GearMesh batch", "", "| " + " | ".join(summary[0]) + " |",
             "|" + "---|" * len(summary[0])]
    lines += ["| " + " | ".join(f"{v:.6g}" if isinstance(v, float) else str(v)
                                for v in r.values()) + " |" for r in summary]
    lines.append("")
    for scene in sorted({r["scene"] for r in summary}):
        rows = [r for r in summary if r["scene"] == scene]
        variations = sorted({tuple((k, r[k]) for k in r if k not in fixed) for r in rows})
        curves = {}
        for var in variations:
            sel = sorted((r for r in rows if all(r[k] == v for k, v in var)),
                         key=lambda r: r["torque_Nm"])
            torques = [r["torque_Nm"] for r in sel]  # each curve its own: a failed case is missing
            label = ", ".join(f"{k} {v:g}" for k, v in var) or "base"
            curves[f"{label}: order 1"] = (torques, [r["order1_m"] * 1e6 for r in sel])
            curves[f"{label}: order 2"] = (torques, [r["order2_m"] * 1e6 for r in sel])
        plot(out / f"{scene}_orders.png", None, curves, "load on gear 2 (N m)",
             "mesh order amplitude (um)", f"{scene}: batch")
        lines += [f"![{scene}]({scene}_orders.png)", ""]
    report = out / "batch_report.md"
    report.write_text("\n".join(lines), encoding="utf-8")
    return report


__all__ = ["OBSERVATIONS", "BatchResult", "Case", "expand", "parse_variation", "run_batch", "run_case",
           "run_in_process", "summarize", "write_outputs", "write_report", "write_rows"]
