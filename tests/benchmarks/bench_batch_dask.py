"""Benchmark of batches on Dask (issue 17): cases per second on a local cluster of 1 and of 2
single-threaded worker processes (cluster start-up excluded: one warm-up batch per cluster,
then `repeats` timed batches, each into a fresh folder so that nothing is skipped), median and
spread, the scaling ratio 2 workers / 1 worker, and the ratio to a baseline measured in the same
process: the same cases run one after the other without Dask (batch.run_in_process). Prints;
never asserts on time.

    .venv/bin/python tests/benchmarks/bench_batch_dask.py [build/GearMesh.fmu] [cases] [repeats]
"""
from __future__ import annotations

import os
import pathlib
import statistics
import sys
import tempfile
import time

from gearmesh.batch import run as batch, tasks as batch_tasks, cluster
from gearmesh.paths import find_checkout
from gearmesh.scene import load_scene

REPO = find_checkout(pathlib.Path(__file__).parent)


def the_cases(n: int) -> list[batch.Case]:
    """n cases of set B (3 pitches x 40 points each, level 4, 10 slices), torques 50..350 N m."""
    scene = load_scene(REPO / "scenarios" / "paper_setB_P1P2.toml")
    torques = [50.0 + 300.0 * i / max(1, n - 1) for i in range(n)]
    return batch.expand([scene], torques, {})


def figures(rates: list[float]) -> str:
    return f"{statistics.median(rates):6.2f} cases/s ({min(rates):.2f}..{max(rates):.2f})"


def main(fmu: pathlib.Path, n: int, repeats: int) -> None:
    cases = the_cases(n)
    print(f"{n} cases, {repeats} repeats, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.2f} at the start")
    serial = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        batch.run_in_process(cases, fmu)
        serial.append(n / (time.perf_counter() - t0))
    print(f"baseline, serial in this process (no Dask): {figures(serial)}")
    medians = {}
    for workers in (1, 2):
        rates = []
        with cluster.connect(None, workers) as client, tempfile.TemporaryDirectory() as tmp:
            for i in range(repeats + 1):
                out = pathlib.Path(tmp) / str(i)
                t0 = time.perf_counter()
                rows, ran, _, errors = batch_tasks.run(client, cases, fmu, out)
                seconds = time.perf_counter() - t0
                assert ran == n and not errors, errors  # a broken run is no figure
                if i:  # the first batch warms the workers up (imports, first FMU)
                    rates.append(n / seconds)
        medians[workers] = statistics.median(rates)
        print(f"Dask, local cluster of {workers} worker(s): {figures(rates)} = "
              f"{medians[workers] / statistics.median(serial):.2f} x baseline")
    print(f"scaling 2 workers / 1 worker: {medians[2] / medians[1]:.2f}; load average "
          f"{os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else REPO / "build" / "GearMesh.fmu"),
         int(sys.argv[2]) if len(sys.argv) > 2 else 16, int(sys.argv[3]) if len(sys.argv) > 3 else 3)
