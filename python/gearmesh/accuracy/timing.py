"""Time per evaluation through fmpy, as tests/benchmarks/bench_tooling.py measures it: the wall time
of each fmi2DoStep call (fmpy's wrapper included), and the bare fmpy round trip of a call that
does no contact work (level 0, the pair held open inside the backlash), measured in the same
process, to subtract. Medians over the calls, robust against a machine shared with other jobs."""
from __future__ import annotations

import statistics
import time

from gearmesh.fmu_driver import GearMeshFMU


class StepTimer:
    """Wraps an instance's doStep and records the wall time of every call."""

    def __init__(self, fmu: GearMeshFMU):
        self.seconds: list[float] = []
        inner = fmu.fmu.doStep

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds.append(time.perf_counter() - t0)

        fmu.fmu.doStep = timed

    def median(self) -> float:
        if not self.seconds:
            raise ValueError("no fmi2DoStep call was timed")
        return statistics.median(self.seconds)


def round_trip(fmu_path, steps: int = 2000) -> float:
    """Median seconds of one fmi2DoStep through fmpy that does no contact work."""
    if steps < 1:
        raise ValueError(f"round trip steps = {steps}; allowed: >= 1")
    with GearMeshFMU(fmu_path, {"model.stiffness": 0}, instance_name="round_trip") as fmu:
        timer = StepTimer(fmu)
        g = fmu.get(["geometry.backlash", "gear2.base_diameter"])
        open_phi2 = -0.5 * g["geometry.backlash"] / (g["gear2.base_diameter"] / 2)
        for _ in range(steps):
            fmu.step({"gear2.phi": open_phi2})
        return timer.median()
