"""Benchmark of the FE level's preprocessing and evaluation (prints figures, never gates).

1. compliance_tool on set A's 57-tooth gear at the default mesh (scenarios/fe/paper_setA_3U4U_fe.toml,
   targets <= 60 s and <= 4 GiB on this machine), against a baseline build of a small gear
   (z 20, m 2 mm, b 10 mm, coarse mesh) in the same process; wall time from this process, the
   tool's own summary line (total_s, peak_rss_MiB) and getrusage(RUSAGE_CHILDREN).maxrss.
   Each build is forced (no cache hit) into a temporary cache that 2. then reuses.
2. One fmi2DoStep of the quasi-static loaded TE at level 5 (set A, the database of 1.) against
   level 4 of the same FMU, in the same process: median and spread over repeats.

    PYTHONPATH=tools python tests/benchmarks/bench_fe_preprocessing.py [--repeats N] [--small-only]

The set A build is one run by default (it takes minutes and GiB); a failed build is printed.
"""
from __future__ import annotations

import argparse
import math
import pathlib
import resource
import statistics
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tools"))

from gearmesh import compliance  # noqa: E402
from gearmesh.fmu_driver import GearMeshFMU  # noqa: E402
from gearmesh.scene import load_scene, parse_scene  # noqa: E402
from gearmesh.scene_fmu import build_scene_fmu  # noqa: E402

SMALL = """
[pair]
center_distance_mm = 40.0
normal_module_mm = 2.0
[gear1]
teeth = 20
profile_shift = 0.0
face_width_mm = 10.0
thickness_allowance_um = -20
[gear2]
teeth = 20
profile_shift = 0.0
face_width_mm = 10.0
thickness_allowance_um = -20
[model]
stiffness_level = 5
slices = 5
[fe]
profile_elements = 3
width_elements = 2
fillet_elements = 2
body_size_mm = 6.0
"""


def spread(values):
    med = statistics.median(values)
    return f"median {med:.3g}, min {min(values):.3g}, max {max(values):.3g} (n = {len(values)})"


def timed_build(scene, cache, gear=1):
    """One forced build (no cache hit) into `cache`, which part 2 then reuses."""
    start = time.perf_counter()
    b = compliance.build_gear(scene, gear, cache=cache, progress=False, force=True)
    wall = time.perf_counter() - start
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # MiB (Linux: KiB)
    return wall, b.summary, rss


def step_times(fmu_file, overrides, repeats, points=40, torque=200.0):
    """Per-step wall times (s) of the quasi-static loaded TE over one pitch, `repeats` times."""
    per_step = []
    with GearMeshFMU(fmu_file, {"model.quasi_static": True, **overrides}) as fmu:
        z1 = fmu.get(["gear1.teeth"])["gear1.teeth"]
        angles = [i * 2 * math.pi / z1 / points for i in range(points)]
        for _ in range(repeats):
            start = time.perf_counter()
            for phi in angles:
                fmu.step({"gear1.phi": phi, "mesh.load_torque": torque, "gear1.omega": 0.0,
                          "gear2.omega": 0.0})
            per_step.append((time.perf_counter() - start) / points)
    return per_step


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=1, help="builds of the 57-tooth gear")
    ap.add_argument("--small-repeats", type=int, default=3)
    ap.add_argument("--small-only", action="store_true")
    ap.add_argument("--fmu", type=pathlib.Path, default=REPO / "build" / "GearMesh.fmu")
    args = ap.parse_args()

    tmp = tempfile.TemporaryDirectory()
    cache = pathlib.Path(tmp.name) / "cache"
    small = parse_scene(SMALL, REPO / "small.toml")
    small_runs = [timed_build(small, cache) for _ in range(args.small_repeats)]
    print(f"small gear (z 20, {small_runs[0][1].get('nodes')} nodes): wall s "
          f"{spread([r[0] for r in small_runs])}; tool total_s "
          f"{spread([r[1]['total_s'] for r in small_runs])}; peak RSS "
          f"{small_runs[0][1].get('peak_rss_MiB')} MiB")
    timings = [("small pair z 20/20, 5 slices", small)]
    if not args.small_only:
        set_a = load_scene(REPO / "scenarios" / "fe" / "paper_setA_3U4U_fe.toml")
        try:
            big_runs = [timed_build(set_a, cache) for _ in range(args.repeats)]
        except compliance.ComplianceError as exc:
            rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
            print(f"set A gear (z 57, default mesh): FAILED ({exc}); peak RSS {rss:.0f} MiB "
                  "(getrusage, children)")
        else:
            s = big_runs[0][1]
            print(f"set A gear (z 57, default mesh: {s.get('nodes')} nodes, {s.get('dofs')} dofs, "
                  f"grid {s.get('grid')}): wall s {spread([r[0] for r in big_runs])}; tool total_s "
                  f"{spread([r[1]['total_s'] for r in big_runs])} (mesh {s.get('mesh_s')}, assembly "
                  f"{s.get('assembly_s')}, factorization {s.get('factor_s')}, solves "
                  f"{s.get('solve_s')}); peak RSS {s.get('peak_rss_MiB')} MiB (tool), "
                  f"{big_runs[-1][2]:.0f} MiB (getrusage, children); targets 60 s, 4096 MiB")
            ratio = (statistics.median(r[0] for r in big_runs)
                     / statistics.median(r[0] for r in small_runs))
            print(f"ratio set A / small gear build (wall): {ratio:.1f}")
            timings.append(("set A 57/57, 10 slices", set_a))

    for label, scene in timings:
        with tempfile.TemporaryDirectory() as run_dir:
            full = compliance.with_databases(scene, cache=cache, progress=False)  # cache hits
            fmu_file = build_scene_fmu(args.fmu, full.parameters, full.resources,
                                       pathlib.Path(run_dir) / "fe.fmu")
            no_db = {"gear1.compliance": "", "gear2.compliance": ""}
            torque = 50.0 if scene is small else 200.0
            l5 = step_times(fmu_file, {}, 7, torque=torque)
            l4 = step_times(fmu_file, {"model.stiffness": 4, **no_db}, 7, torque=torque)
        print(f"fmi2DoStep (quasi-static loaded TE, {label}, {torque:g} N m, through fmpy): "
              f"level 5 {spread([t * 1e6 for t in l5])} us, level 4 "
              f"{spread([t * 1e6 for t in l4])} us; ratio "
              f"{statistics.median(l5) / statistics.median(l4):.2f}")
    tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
