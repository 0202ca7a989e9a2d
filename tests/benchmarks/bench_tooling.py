"""Benchmark of the fmpy tooling (issue 5): wall time of a one-revolution quasi-static TE sweep
at 7 torques and of a 1 s dynamic drivetrain run, each split into the FMU's share (time inside
fmi2DoStep) and the Python share, median and spread over repeats, with the ratio to a baseline
measured in the same run (one fmpy doStep round trip of an FMU call that does no contact work:
the pair held open inside the backlash). Prints; never asserts on time.

    .venv/bin/python tests/benchmarks/bench_tooling.py [build/GearMesh.fmu]
"""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from gearmesh.accuracy.timing import StepTimer
from gearmesh.drivetrain import Drivetrain, simulate
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.prescribed_motion import loaded_te_sweep

PARAMS = {"model.stiffness": 4, "model.slices": 10, "model.friction_coefficient": 0.4,
          "model.friction_velocity": 1e-5}


def measure(run, repeats=5):
    total, inside, calls = [], [], 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        timer = run()
        total.append(time.perf_counter() - t0)
        inside.append(sum(timer.seconds))
        calls = len(timer.seconds)
    return total, inside, calls


def report(name, total, inside, calls, base):
    med = statistics.median(total)
    fmu = statistics.median(inside)
    print(f"{name:58s} {med:7.3f} s ({min(total):.3f}..{max(total):.3f})  FMU {fmu / med:5.1%}"
          f"  Python {1 - fmu / med:5.1%}  {calls} steps, {med / calls * 1e6:6.1f} us/step"
          f" = {med / calls / base:5.1f} x baseline")


def main(fmu_path: str) -> None:
    def baseline():
        with GearMeshFMU(fmu_path, {"model.stiffness": 0}) as fmu:
            timer = StepTimer(fmu)
            j = fmu.get(["geometry.backlash"])["geometry.backlash"]
            rb2 = fmu.get(["gear2.base_diameter"])["gear2.base_diameter"] / 2
            for _ in range(2000):
                fmu.step({"gear2.phi": -0.5 * j / rb2})
        return timer

    total, inside, calls = measure(baseline)
    base = statistics.median(total) / calls
    print(f"baseline: one fmpy step round trip (set inputs, doStep, no contact) "
          f"{base * 1e6:.1f} us")

    def sweep():
        with GearMeshFMU(fmu_path, {**PARAMS, "model.quasi_static": True}) as fmu:
            timer = StepTimer(fmu)
            loaded_te_sweep(fmu, [50, 100, 150, 200, 250, 300, 350], 10 * 2 * np.pi / 60,
                            pitches=57, points_per_pitch=10)
        return timer

    report("quasi-static sweep: 1 revolution x 7 torques, 10 pts/pitch", *measure(sweep), base)

    def dynamic():
        with GearMeshFMU(fmu_path, PARAMS) as fmu:
            timer = StepTimer(fmu)
            simulate(fmu, Drivetrain(spin_up=0.1), 1.0, 1e-3)
        return timer

    report("drivetrain: 1 s at h = 1 ms, implicit (Newton + repeats)", *measure(dynamic, 3), base)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "build/GearMesh.fmu")
