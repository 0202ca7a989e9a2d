"""GearMesh under five FMI co-simulation masters, unmodified (issue 29; docs/guide/masters.md).

The generic FMU (build/GearMesh.fmu) and set A's scene FMU (`gearmesh fmu
scenarios/paper_setA_3U4U.toml`: the torsional interface; a copy of the scene with `[fmu] mode =
"large_step"` for the large-step mode) run in the plain, quasi-static and large-step modes at
communication steps of 1e-3 and 1e-2 s for 0.1 s, wired to a second FMU, Ramps
(tests/masters/ramps.c, built here with the host's cc): a motor held at 1 rad/s (an angle ramp
and its speed) and a constant load torque or a prescribed approach. Every master must give the
TE (mesh.te) of FMPy's run within 0.01 um at every communication point:

* FMPy (the venv's): the reference, tests/masters/run_fmpy.py;
* fmi-sim (crates.io; built into the cache by tools/bootstrap-platforms.sh, or here if missing):
  one FMU, the ramps as its input file (linear interpolation gives them exactly);
* libcosim (PyPI libcosimpy, its manylinux wheel pip-installed into the cache):
  tests/masters/run_libcosim.py in a subprocess;
* INTO-CPS Maestro and FMI4j (Maven Central, copied into the cache by mvn from
  tests/masters/pom.xml): Maestro's sg1 import of a multi-model with every case of a step as
  instances of one run, and tests/masters/Fmi4jDriver.java.

The installs go into the platform cache (platforms.cache_dir(): $GM_CACHE, else .cache/), once;
an install or run that fails here fails the test with the master's own message. The discard
tests run a step the large-step mode cannot make under FMPy (the FMU's behaviour), Maestro (with
and without rollback) and libcosim."""
from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time
import zipfile

import pytest

from gearmesh_dev import platforms
from conftest import REPO

MASTERS = REPO / "tests" / "masters"
SCENE = REPO / "scenarios" / "paper_setA_3U4U.toml"
sys.path.insert(0, str(MASTERS))
from run_fmpy import run_case  # noqa: E402  (the reference master)

LIBCOSIMPY_VERSION = "0.0.6"
FMI_SIM_VERSION = re.search(r"GM_FMI_SIM_VERSION=(\S+)",
                            (REPO / "tools" / "bootstrap-platforms.sh").read_text()).group(1)
STEPS = (1e-3, 1e-2)
STOP = 0.1
TE_TOLERANCE = 0.01e-6  # m: 0.01 um
W = 1.0  # rad/s: the motor's speed
LOAD = 100.0  # N.m: the load torque (quasi-static: mesh.load_torque; large-step: -load.torque)
APPROACH = 10e-6  # m: the plain mode's prescribed TE
R_B2 = 0.5 * 2.6e-3 * 57 * math.cos(math.radians(20))  # set A's base radius (gear 2)
# The undamped case (docs/stability.md): free gears from rest with the teeth touching, no mesh or
# contact damping, gear 1 driven by 151 N m against 150 N m on gear 2 (both about +z: a brake on
# the external gear 2), 2 s: a run-up through tooth changes to about 480 rpm.
UNDAMPED_TORQUES = (151.0, 150.0)
UNDAMPED_STOP = 2.0
LARGE_STEP = {"gear1.shaft_stiffness": ("Real", 2e4), "gear1.shaft_damping": ("Real", 10.0),
              "model.damping": ("Real", 4e5)}
TIMES: dict[str, float] = {}  # master -> seconds of its runs (printed by test_summary)
TABLE: dict[tuple[str, str], float] = {}  # (master, case) -> max |TE - FMPy's| in m
OTHER: dict[tuple[str, str], tuple[str, float]] = {}  # the other output, its max difference / max |value|
TE: dict[tuple[str, str], list[float]] = {}  # (master, case) -> its TE at every point
UNDAMPED: dict[tuple[str, str], tuple[float, float, float]] = {}  # -> TE difference, energy made, largest


def fail_with(what: str, done: subprocess.CompletedProcess) -> None:
    pytest.fail(f"{what} failed (exit {done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")


# ---------------------------------------------------------------------------------------------
# The FMUs: GearMesh (generic, scene, scene large-step) and Ramps
# ---------------------------------------------------------------------------------------------

def build_ramps(folder: pathlib.Path, state: bool) -> pathlib.Path:
    """Ramps.fmu (tests/masters/ramps.c) built by the host's cc; state: canGetAndSetFMUstate."""
    unpacked = folder / ("ramps" if state else "ramps-no-state")
    (unpacked / "binaries" / "linux64").mkdir(parents=True)
    done = subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-I", str(REPO / "third_party" / "fmi2"),
                           str(MASTERS / "ramps.c"), "-o", str(unpacked / "binaries" / "linux64" / "Ramps.so")],
                          capture_output=True, text=True)
    if done.returncode:
        fail_with("cc (the Ramps FMU)", done)
    md = (MASTERS / "modelDescription.xml").read_text()
    if not state:
        md = md.replace(' canGetAndSetFMUstate="true"', "")
    fmu = folder / ("Ramps.fmu" if state else "RampsNoState.fmu")
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", md)
        z.write(unpacked / "binaries" / "linux64" / "Ramps.so", "binaries/linux64/Ramps.so")
    return fmu


def scene_fmu(scene: pathlib.Path, out: pathlib.Path) -> pathlib.Path:
    """gearmesh fmu SCENE --out OUT, as a user runs it."""
    done = subprocess.run([sys.executable, "-m", "gearmesh", "fmu", str(scene), "--out", str(out)],
                          capture_output=True, text=True, cwd=REPO)
    if done.returncode:
        fail_with("gearmesh fmu", done)
    return out


@pytest.fixture(scope="module")
def fmus(fmu_path, tmp_path_factory) -> dict[str, pathlib.Path]:
    folder = tmp_path_factory.mktemp("masters-fmus")
    large_step = folder / "setA_large_step.toml"
    large_step.write_text(SCENE.read_text() + '\n[fmu]\nmode = "large_step"\n')
    return {"generic": fmu_path, "scene": scene_fmu(SCENE, folder / "setA.fmu"),
            "scene_large_step": scene_fmu(large_step, folder / "setA_large_step.fmu"),
            "ramps": build_ramps(folder, state=True), "ramps_no_state": build_ramps(folder, state=False)}


def make_case(kind: str, mode: str, step: float, fmus: dict) -> dict:
    """One run: GearMesh `kind` (generic or scene) in `mode` at `step`, wired to Ramps."""
    if mode == "plain":  # both spins prescribed: the TE is APPROACH, the forces are the test
        parameters = {}
        ramps = {"a1": 0.0, "b1": W, "a2": W, "a3": APPROACH / R_B2, "b3": -W, "a4": -W}
        wiring = ["gear1.phi", "gear1.omega", "gear2.phi", "gear2.omega"]
        outputs = ["mesh.te", "gear1.mz"]
    elif mode == "quasi_static":  # gear 1 turned, a constant load: the loaded TE over a pitch
        parameters = {"model.quasi_static": ("Boolean", True)}
        ramps = {"a1": 0.0, "b1": W, "a2": W, "a3": LOAD}
        wiring = ["gear1.phi", "gear1.omega", "mesh.load_torque"]
        outputs = ["mesh.te", "gear1.mz"]
    elif mode == "undamped":  # free gears from rest, no damping at all, 151 N m against 150 N m
        parameters = {"model.dynamics": ("Integer", 1), "model.damping": ("Real", 0.0),
                      "dynamics.mesh_damping_ratio": ("Real", 0.0)}
        ramps = {"a1": UNDAMPED_TORQUES[0], "a2": UNDAMPED_TORQUES[1]}
        wiring = ["gear1.torque", "gear2.torque"]
        outputs = ["mesh.te", "energy.residual", "energy.kinetic", "energy.elastic", "energy.work_in"]
    else:  # a motor at W through gear 1's shaft (a power bond), a brake of LOAD on gear 2
        parameters = dict(LARGE_STEP)
        if kind == "generic":
            parameters["model.dynamics"] = ("Integer", 1)
        ramps = {"a1": 0.0, "b1": W, "a2": W, "a3": -LOAD}
        wiring = ["drive.shaft_phi", "drive.shaft_omega", "load.torque"]
        outputs = ["mesh.te", "drive.speed"]
    fmu = fmus["scene_large_step"] if kind == "scene" and mode == "large_step" else fmus[kind]
    return {"name": f"{kind}-{mode}-{step:g}", "fmu": str(fmu), "ramps": str(fmus["ramps_no_state"]),
            "parameters": parameters, "ramp_parameters": ramps,
            "connections": [[f"y{i + 1}", target] for i, target in enumerate(wiring)],
            "step": step, "stop": UNDAMPED_STOP if mode == "undamped" else STOP, "outputs": outputs}


@pytest.fixture(scope="module")
def cases(fmus) -> list[dict]:
    return [make_case(kind, mode, step, fmus) for kind in ("generic", "scene")
            for mode in ("plain", "quasi_static", "large_step") for step in STEPS] \
        + [make_case("generic", "undamped", step, fmus) for step in STEPS]


@pytest.fixture(scope="module")
def reference(cases) -> dict[str, dict]:
    start = time.perf_counter()
    out = {case["name"]: run_case(case) for case in cases}
    TIMES["FMPy"] = time.perf_counter() - start
    return out


def test_the_reference_runs_load_the_mesh(reference, cases):
    """FMPy runs every case; the TE is what each mode should give: the prescribed approach
    (plain), a loaded TE of a few um changing over the pitch (quasi-static), a loaded mesh
    turning at the motor's speed at the end (large-step), and for the undamped run-up the energy
    rule of gearmesh stability's undamped cases: the energy made (-energy.residual) at most 1e-3
    of the run's largest kinetic + elastic energy (docs/stability.md; the envelope rule is for a
    steady speed, and a run-up to 480 rpm changes the mesh's excitation). The other masters give
    FMPy's TE within 0.01 um, so the undamped case holds under each of them."""
    stops = {c["name"]: c["stop"] for c in cases}
    for name, r in reference.items():
        assert "error" not in r, (name, r.get("error"))
        te = r["mesh.te"]
        step = float(name.rsplit("-", 1)[1])
        assert len(te) == round(stops[name] / step), name
        if "undamped" in name:
            made, largest = undamped_energy_made(r)
            assert made <= 1e-3 * largest, (name, made, largest)
            assert r["energy.work_in"][-1] > 10.0, name  # the run-up happened
            print(f"{name}: energy made {made:.3g} J of the largest {largest:.4g} J, TE {min(te) * 1e6:.2f} "
                  f"... {max(te) * 1e6:.2f} um")
        elif "plain" in name:
            assert max(abs(x - APPROACH) for x in te) < 1e-12, name
        elif "quasi_static" in name:
            assert all(2e-6 < x < 6e-6 for x in te) and max(te) - min(te) > 0.2e-6, (name, te)
        else:
            assert 2e-6 < te[-1] < 6e-6 and abs(r["drive.speed"][-1] - W) < 0.05, (name, te[-1])


def undamped_energy_made(r: dict) -> tuple[float, float]:
    """The energy an undamped run made (-energy.residual, J) and its largest kinetic + elastic."""
    largest = max(k + e for k, e in zip(r["energy.kinetic"], r["energy.elastic"]))
    return max(-x for x in r["energy.residual"]), largest


def compare(master: str, results: dict, reference: dict) -> None:
    """Every case ran and gave FMPy's TE within TE_TOLERANCE at every communication point; the
    undamped run-up, which rattles through the backlash at speed so that a step an ulp off (libcosim's
    nanoseconds) parts the TE by micrometres within the 2 s, by the energy rule on the master's own
    run instead."""
    problems = []
    for name, ref in reference.items():
        got = results.get(name, {"error": "no result"})
        if "error" in got:
            problems.append(f"{name}: {got['error']}")
            continue
        if len(got["mesh.te"]) != len(ref["mesh.te"]) or \
                max(abs(a - b) for a, b in zip(got["time"], ref["time"])) > 1e-9:
            problems.append(f"{name}: {len(got['time'])} points at {got['time'][:3]}..., FMPy {len(ref['time'])}")
            continue
        diff = max(abs(a - b) for a, b in zip(got["mesh.te"], ref["mesh.te"]))
        if "undamped" in name:
            made, largest = undamped_energy_made(got)
            UNDAMPED[(master, name)] = (diff, made, largest)
            if not made <= 1e-3 * largest:
                problems.append(f"{name}: the undamped run made {made:.3g} J, allowed 1e-3 of {largest:.4g} J")
            continue
        other = [n for n in ref if n not in ("time", "mesh.te")][0]  # gear1.mz or drive.speed
        scale = max(abs(b) for b in ref[other])
        relative = max(abs(a - b) for a, b in zip(got[other], ref[other])) / scale
        TABLE[(master, name)] = diff
        OTHER[(master, name)] = (other, relative)
        TE[(master, name)] = got["mesh.te"]
        if not diff <= TE_TOLERANCE:
            problems.append(f"{name}: TE differs from FMPy's by up to {diff * 1e6:.4g} um")
        if other == "gear1.mz" and not relative <= 1e-9:  # prescribed or quasi-static: the same inputs
            problems.append(f"{name}: gear1.mz differs from FMPy's by up to {relative:.3g} of its largest")
    assert not problems, f"{master}:\n" + "\n".join(problems)


# ---------------------------------------------------------------------------------------------
# fmi-sim (crates.io)
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def fmi_sim() -> pathlib.Path:
    """fmi-sim in the cache (tools/bootstrap-platforms.sh builds it; built here if missing)."""
    cache = platforms.cache_dir()
    binary = cache / "cargo" / "bin" / "fmi-sim"
    version = ""
    if binary.exists():  # fmi-sim prints its version as an error
        done = subprocess.run([binary, "--version"], capture_output=True, text=True,
                              env=dict(os.environ, RUST_BACKTRACE="0"))
        version = done.stdout + done.stderr
    if f"fmi-sim {FMI_SIM_VERSION}" not in version:
        if shutil.which("cargo") is None:
            pytest.fail(f"fmi-sim {FMI_SIM_VERSION} is not in {binary.parent} and cargo is not on the PATH "
                        "(Rust >= 1.85, rustup): tools/bootstrap-platforms.sh builds it")
        env = dict(os.environ, CARGO_HOME=str(cache / "cargo-home"), CARGO_TARGET_DIR=str(cache / "cargo-target"))
        done = subprocess.run(["cargo", "install", "--quiet", "--locked", "--debug", "fmi-sim", "--version",
                               FMI_SIM_VERSION, "--root", str(cache / "cargo")], capture_output=True, text=True,
                              env=env)
        if done.returncode:
            fail_with(f"cargo install fmi-sim {FMI_SIM_VERSION}", done)
    return binary


def run_fmi_sim(binary: pathlib.Path, case: dict, folder: pathlib.Path) -> dict:
    """One case: the ramps as fmi-sim's input file, the parameters as its initial values."""
    folder.mkdir(parents=True, exist_ok=True)
    ramps = case["ramp_parameters"]
    columns = [(target, ramps.get(f"a{source[1:]}", 0.0), ramps.get(f"b{source[1:]}", 0.0))
               for source, target in case["connections"]]
    with open(folder / "in.csv", "w") as f:
        f.write(",".join(["time"] + [c[0] for c in columns]) + "\n")
        for t in (0.0, case["stop"]):
            f.write(",".join([repr(t)] + [repr(float(a + b * t)) for _, a, b in columns]) + "\n")
    values = [f"{name}={str(value).lower() if kind == 'Boolean' else value}"
              for name, (kind, value) in case["parameters"].items()]
    command = [str(binary), "--model", case["fmu"], "--input-file", str(folder / "in.csv"),
               "--output-file", str(folder / "out.csv"), "co-simulation", "-s", "0", "-f", repr(case["stop"]),
               "--output-interval", repr(case["step"])]
    for value in values:
        command += ["--init-values", value]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, RUST_BACKTRACE="0"))
    if done.returncode:
        return {"error": f"exit {done.returncode}: {done.stderr[-2000:]}"}
    with open(folder / "out.csv") as f:
        rows = list(csv.DictReader(f))
    rows = [r for r in rows if float(r["time"]) > 0.5 * case["step"]]
    return {"time": [float(r["time"]) for r in rows],
            **{name: [float(r[name]) for r in rows] for name in case["outputs"]}}


def test_fmi_sim(fmi_sim, cases, reference, tmp_path):
    start = time.perf_counter()
    results = {case["name"]: run_fmi_sim(fmi_sim, case, tmp_path / case["name"]) for case in cases}
    TIMES["fmi-sim"] = time.perf_counter() - start
    compare("fmi-sim", results, reference)


# ---------------------------------------------------------------------------------------------
# libcosim (PyPI libcosimpy)
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def libcosimpy() -> pathlib.Path:
    """libcosimpy's wheel (manylinux, libcosimc inside) pip-installed into the cache."""
    target = platforms.cache_dir() / f"libcosimpy-{LIBCOSIMPY_VERSION}"
    if not (target / "libcosimpy" / "libcosimc").is_dir():
        partial = target.with_name(target.name + ".partial")
        shutil.rmtree(partial, ignore_errors=True)
        done = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--only-binary", ":all:",
                               "--target", str(partial), f"libcosimpy=={LIBCOSIMPY_VERSION}"],
                              capture_output=True, text=True)
        if done.returncode:
            fail_with(f"pip install libcosimpy=={LIBCOSIMPY_VERSION}", done)
        shutil.rmtree(target, ignore_errors=True)
        partial.rename(target)
    return target


def run_libcosim(path: pathlib.Path, cases: list[dict], folder: pathlib.Path,
                 log_level: str = "WARNING") -> tuple[dict, subprocess.CompletedProcess]:
    (folder / "cases.json").write_text(json.dumps({"cases": cases, "log_level": log_level}))
    done = subprocess.run([sys.executable, str(MASTERS / "run_libcosim.py"), str(folder / "cases.json"),
                           str(folder / "out.json")], capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, PYTHONPATH=str(path)))
    if done.returncode:
        fail_with("libcosim (tests/masters/run_libcosim.py)", done)
    return json.loads((folder / "out.json").read_text()), done


def test_libcosim(libcosimpy, cases, reference, tmp_path):
    start = time.perf_counter()
    results, _ = run_libcosim(libcosimpy, cases, tmp_path)
    TIMES["libcosim"] = time.perf_counter() - start
    compare("libcosim", results, reference)


# ---------------------------------------------------------------------------------------------
# Maestro and FMI4j (Maven Central)
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def jars() -> pathlib.Path:
    """The jars of tests/masters/pom.xml in the cache (mvn dependency:copy-dependencies)."""
    pom = MASTERS / "pom.xml"
    folder = platforms.cache_dir() / "masters" / "jars"
    stamp = hashlib.sha256(pom.read_bytes()).hexdigest()
    if not (folder / "pom.sha256").is_file() or (folder / "pom.sha256").read_text() != stamp:
        for tool in ("mvn", "java"):
            if shutil.which(tool) is None:
                pytest.fail(f"{tool} not found: tools/bootstrap-platforms.sh installs maven and openjdk-17")
        shutil.rmtree(folder, ignore_errors=True)
        done = subprocess.run(["mvn", "-q", "-B", "-f", str(pom), f"-Dmaven.repo.local={platforms.cache_dir() / 'm2'}",
                               "dependency:copy-dependencies", f"-DoutputDirectory={folder}",
                               "-Dmdep.stripVersion=true"], capture_output=True, text=True)
        if done.returncode:
            fail_with("mvn dependency:copy-dependencies (tests/masters/pom.xml)", done)
        (folder / "pom.sha256").write_text(stamp)
    return folder


def maestro_command(jars: pathlib.Path, folder: pathlib.Path) -> list[str]:
    """Maestro, its log at INFO, its unpacked FMUs in `folder`."""
    return ["java", f"-Djava.io.tmpdir={folder}", f"-Dlog4j2.configurationFile={MASTERS / 'maestro-log4j2.xml'}",
            "-jar", str(jars / "maestro-jar-with-dependencies.jar")]


def maestro_config(cases: list[dict]) -> tuple[dict, dict]:
    """Maestro's multi-model and simulation configuration (its sg1 import) of cases at one step:
    each case a GearMesh instance, connected to a Ramps instance per mode (Maestro's import time
    grows faster than the number of instances: 6 s for one pair, 23 s for six)."""
    fmus, connections, parameters, logged = {}, {}, {}, {}
    for case in cases:
        key = "{" + pathlib.Path(case["fmu"]).stem.lower().replace("_", "") + "}"
        fmus[key] = pathlib.Path(case["fmu"]).as_uri()
        fmus["{ramps}"] = pathlib.Path(case["ramps"]).as_uri()
        instance = case["name"].rsplit("-", 1)[0].replace("-", "_")
        gm, ramps = f"{key}.{instance}", f"{{ramps}}.r_{case['name'].split('-')[-2]}"
        for source, target in case["connections"]:
            connections.setdefault(f"{ramps}.{source}", []).append(f"{gm}.{target}")
        for name, (kind, value) in case["parameters"].items():
            parameters[f"{gm}.{name}"] = value
        for name, value in case["ramp_parameters"].items():
            parameters[f"{ramps}.{name}"] = value
        logged[gm] = case["outputs"]
    step = cases[0]["step"]
    return ({"fmus": fmus, "connections": connections, "parameters": parameters, "logVariables": logged},
            # Maestro steps while t + h <= endTime, t a running sum: end half a step late, or the
            # sum's rounding (0.1 at 1e-3 s) drops the last step
            {"startTime": 0.0, "endTime": cases[0]["stop"] + 0.5 * step,
             "algorithm": {"type": "fixed-step", "size": step}})


def run_maestro(jars: pathlib.Path, cases: list[dict], folder: pathlib.Path,
                timeout: float = 600) -> tuple[dict, subprocess.CompletedProcess]:
    folder.mkdir(parents=True, exist_ok=True)
    multi_model, simulation = maestro_config(cases)
    (folder / "mm.json").write_text(json.dumps(multi_model, indent=1))
    (folder / "sim.json").write_text(json.dumps(simulation, indent=1))
    done = subprocess.run(maestro_command(jars, folder)
                          + ["import", "sg1", "mm.json", "sim.json", "-output", "out", "-i", "-nop"],
                          capture_output=True, text=True, timeout=timeout, cwd=folder)
    results = {}
    if done.returncode == 0:
        with open(folder / "out" / "outputs.csv") as f:
            rows = [r for r in csv.DictReader(f) if float(r["time"]) > 0.5 * cases[0]["step"]]
        for case in cases:
            key = "{" + pathlib.Path(case["fmu"]).stem.lower().replace("_", "") + "}"
            gm = f"{key}.{case['name'].rsplit('-', 1)[0].replace('-', '_')}"
            results[case["name"]] = {"time": [float(r["time"]) for r in rows],
                                     **{n: [float(r[f"{gm}.{n}"]) for r in rows] for n in case["outputs"]}}
    return results, done


def test_maestro(jars, cases, reference, tmp_path):
    """One Maestro run per communication step and stop time, every case of it an instance pair in it."""
    start = time.perf_counter()
    results = {}
    for step, stop in sorted({(c["step"], c["stop"]) for c in cases}):
        got, done = run_maestro(jars, [c for c in cases if c["step"] == step and c["stop"] == stop],
                                tmp_path / f"step{step:g}-stop{stop:g}")
        if done.returncode:
            fail_with(f"Maestro at {step:g} s to {stop:g} s", done)
        results.update(got)
    TIMES["Maestro"] = time.perf_counter() - start
    compare("Maestro", results, reference)


def run_fmi4j(jars: pathlib.Path, cases: list[dict], folder: pathlib.Path) -> dict:
    lines = []
    for c in cases:
        lines += [f"case {c['name']}", f"fmu {c['fmu']}", f"ramps {c['ramps']}", f"step {c['step']!r}",
                  f"stop {c['stop']!r}"]
        lines += [f"param {kind} {name} {str(value).lower() if kind == 'Boolean' else value!r}"
                  for name, (kind, value) in c["parameters"].items()]
        lines += [f"ramp {name} {float(value)!r}" for name, value in c["ramp_parameters"].items()]
        lines += [f"connect {s} {t}" for s, t in c["connections"]] + [f"output {o}" for o in c["outputs"]] + ["end"]
    (folder / "cases.txt").write_text("\n".join(lines) + "\n")
    classpath = ":".join(str(j) for j in sorted(jars.glob("*.jar")) if not j.name.startswith("maestro"))
    done = subprocess.run(["java", f"-Djava.io.tmpdir={folder}", "-cp", classpath, str(MASTERS / "Fmi4jDriver.java"),
                           str(folder / "cases.txt"),
                           str(folder / "out.txt")], capture_output=True, text=True, timeout=600)
    if done.returncode:
        fail_with("FMI4j (tests/masters/Fmi4jDriver.java)", done)
    # FMI4j's native bridge prints the FMUs' log messages to stdout, one line each; the ones that
    # are not OK go with a case's error (the driver's own message says only which call failed)
    log = [line for line in done.stdout.splitlines() if line.startswith("[FMI native bridge]")
           and any(word in line for word in ("Warning", "Discard", "Error", "Fatal"))]
    results, outputs, current = {}, {c["name"]: c["outputs"] for c in cases}, None
    for line in (folder / "out.txt").read_text().splitlines():
        word, _, rest = line.partition(" ")
        if word == "case":
            name = rest
            current = results[name] = {"time": [], **{n: [] for n in outputs[name]}}
        elif word == "row":
            values = [float(x) for x in rest.split()]
            current["time"].append(values[0])
            for n, v in zip(outputs[name], values[1:]):
                current[n].append(v)
        elif word == "error":
            current["error"] = rest + (f"; the FMUs' last log messages: {' | '.join(log[-5:])}" if log else "")
    return results


def test_fmi4j(jars, cases, reference, tmp_path):
    start = time.perf_counter()
    results = run_fmi4j(jars, cases, tmp_path)
    TIMES["FMI4j"] = time.perf_counter() - start
    compare("FMI4j", results, reference)


def test_fmi4j_error_carries_the_fmus_message(jars, fmus, tmp_path):
    """A case the FMU refuses (level 5 without its databases: an Error at
    fmi2ExitInitializationMode) reports the FMU's own message, which names the parameter, not only
    the call that failed."""
    case = make_case("generic", "plain", STEPS[0], fmus)
    case["name"] = "refused"
    case["parameters"] = {"model.stiffness": ("Integer", 5)}
    result = run_fmi4j(jars, [case], tmp_path)["refused"]
    assert "exitInitializationMode" in result.get("error", ""), result.keys()
    assert "gear1.compliance" in result["error"], result["error"]


# ---------------------------------------------------------------------------------------------
# A step the FMU discards
# ---------------------------------------------------------------------------------------------

def discard_case(fmus: dict, ramps: str = "ramps") -> dict:
    """Large-step mode with the internal step fixed at 1 ms (dynamics.min_step = max_step) and
    500 N.m on a mesh at rest: the first internal step fails, the 10 ms step is discarded."""
    return {"name": "discard-0.01", "fmu": str(fmus["generic"]), "ramps": str(fmus[ramps]),
            "parameters": {"model.dynamics": ("Integer", 1), "dynamics.min_step": ("Real", 1e-3),
                           "dynamics.max_step": ("Real", 1e-3)},
            "ramp_parameters": {"a1": 500.0, "a2": -500.0},
            "connections": [["y1", "drive.torque"], ["y2", "load.torque"]],
            "step": 1e-2, "stop": 0.03, "outputs": ["mesh.te", "drive.speed"]}


REASON = "discarded: large-step dynamics: the internal step fell below dynamics.min_step"


def test_a_discarded_step_says_why_and_refuses_an_unchanged_retry(new, fmus):
    """FMI level (FMPy): with logging off, the discard's reason still reaches the logger (status
    fmi2Warning, category logStatusWarning); nothing changes (fmi2LastSuccessfulTime is the
    step's start). The same step again with nothing changed (inputs set to the values they have)
    is refused with fmi2Error naming the discard, as is a step of 0 s (FMI 2.0: > 0); after a
    rollback the step may be tried again, and the instance stays usable: other inputs step on."""
    from ctypes import byref, c_double

    from fmpy.fmi2 import fmi2Discard, fmi2Error, fmi2LastSuccessfulTime, fmi2Warning
    from test_fmu_conformance import assert_error

    inst = new(logging_on=False)
    s = inst.slave
    s.setupExperiment(startTime=0.0)
    inst.set({name: value for name, (_, value) in discard_case(fmus)["parameters"].items()})
    s.enterInitializationMode()  # the gears at rest at phi = 0
    s.exitInitializationMode()
    inputs = {"drive.torque": 500.0, "load.torque": -500.0}
    inst.set(inputs)
    state = s.getFMUstate()
    before = inst.outputs()
    assert_error(s.doStep, 0.0, 1e-2, status=fmi2Discard)
    name, status, category, message = inst.log.records[-1]
    assert (status, category) == (fmi2Warning, "logStatusWarning") and REASON in message, inst.log.records[-1]
    t = c_double()
    s.fmi2GetRealStatus(s.component, fmi2LastSuccessfulTime, byref(t))
    assert t.value == 0.0 and inst.outputs() == before
    inst.outputs()
    inst.set(inputs)  # the same values: nothing changes
    assert_error(s.doStep, 0.0, 1e-2, status=fmi2Error)
    status, message = inst.log.records[-1][1:4:2]
    assert status == fmi2Error and "nothing has changed since" in message and REASON[11:] in message, message
    assert_error(s.doStep, 0.0, 0.0, status=fmi2Error)
    message = inst.log.messages("logStatusError")[-1]
    assert "communicationStepSize = 0 s" in message and "fmi2LastSuccessfulTime = 0 s" in message, message
    s.setFMUstate(state)  # rolled back: the master may try again (and is discarded again)
    assert_error(s.doStep, 0.0, 1e-2, status=fmi2Discard)
    inst.set({"drive.torque": 0.0, "load.torque": 0.0})  # other inputs (no torque): the step is taken
    s.doStep(0.0, 1e-2)
    s.fmi2GetRealStatus(s.component, fmi2LastSuccessfulTime, byref(t))
    assert t.value == 1e-2
    s.freeFMUstate(state)


@pytest.mark.parametrize("ramps", ["ramps_no_state", "ramps"])
def test_maestro_stops_at_a_discard_with_the_reason(jars, fmus, ramps, tmp_path):
    """Maestro's fixed-step algorithm (3.1.1) retries a discarded step: without rollback (an FMU
    that cannot get and set its state) the same step for ever, with rollback (every FMU can) a
    step cut to fmi2LastSuccessfulTime, here 0 s. Either way the run now stops at the retry with
    the FMU's messages: the discard's reason and why the retry cannot succeed."""
    _, done = run_maestro(jars, [discard_case(fmus, ramps)], tmp_path, timeout=120)
    assert done.returncode != 0, done.stdout[-2000:]
    log = done.stdout + done.stderr
    assert "logStatusWarning Warning" in log and REASON in log, log[-3000:]
    expected = "nothing has changed since" if ramps == "ramps_no_state" else "communicationStepSize = 0 s"
    assert expected in log and "Failed to 'doStep'" in log, log[-3000:]


def test_libcosim_shows_the_reason_of_a_discard(libcosimpy, fmus, tmp_path):
    """libcosim (fixed step) ends the run at a discarded step ("Step not complete"); the FMU's
    reason is in its log at the warning level (a message of status fmi2Discard it logs at its
    debug level only)."""
    results, done = run_libcosim(libcosimpy, [discard_case(fmus)], tmp_path, log_level="WARNING")
    assert "Step not complete" in results["discard-0.01"]["error"], results
    log = done.stdout + done.stderr
    assert re.search(r"\[warning\].*\[FMI status=warning, category=logStatusWarning\].*" + REASON, log), log[-3000:]


def test_the_masters_agree_with_each_other():
    """Every pair of masters that ran a case gives its TE within TE_TOLERANCE of each other."""
    masters = sorted({m for m, _ in TE})
    assert len(masters) == 4, f"masters that ran: {masters}"
    worst = max(max(abs(a - b) for a, b in zip(TE[(m, name)], TE[(n, name)]))
                for m in masters for n in masters if m < n for (k, name) in TE if k == m and (n, name) in TE)
    assert worst <= TE_TOLERANCE, f"two masters differ by {worst * 1e6:.3g} um"


def test_summary():
    """The measured times and the TE agreement (pytest -s shows them)."""
    print("\nmaster      seconds  max |TE - FMPy's| over the 12 cases (um)")
    for master, seconds in TIMES.items():
        diffs = [d for (m, _), d in TABLE.items() if m == master]
        print(f"{master:10s} {seconds:7.2f}  {max(diffs) * 1e6 if diffs else float('nan'):.2g}")
    for (master, name), diff in sorted(TABLE.items()):
        other, relative = OTHER[(master, name)]
        print(f"  {master:9s} {name:28s} TE {diff * 1e6:.2g} um, {other} {relative:.2g} of its largest")
    for (master, name), (diff, made, largest) in sorted(UNDAMPED.items()):
        print(f"  {master:9s} {name:28s} energy made {made:.3g} J of {largest:.4g} J, TE {diff * 1e6:.2g} um "
              "from FMPy's")


def test_the_guide_names_the_versions_tested():
    """docs/guide/masters.md quotes the versions this module installs."""
    guide = (REPO / "docs" / "guide" / "masters.md").read_text(encoding="utf-8")
    pom = (MASTERS / "pom.xml").read_text()
    versions = dict(re.findall(r"<artifactId>([\w-]+)</artifactId>\s*<version>([\d.]+)</version>", pom))
    from importlib.metadata import version
    for name, quoted in [("fmpy", version("fmpy")), ("fmi-sim", FMI_SIM_VERSION),
                         ("libcosimpy", LIBCOSIMPY_VERSION), ("maestro", versions["maestro"]),
                         ("fmi-import", versions["fmi-import"])]:
        assert quoted in guide, f"docs/guide/masters.md does not quote {name} {quoted}"


@pytest.mark.parametrize("train", ["two_stage_reducer", "planetary_3_planets"])
def test_fmi_sim_runs_a_train_fmu_as_built(fmi_sim, fmu_path, tmp_path, train):
    """fmi-sim accepts the train FMUs too (`gearmesh train-fmu`, unmodified): 10 ms of the scene's
    train with its inputs at their start values, every recorded output finite."""
    from gearmesh.train_fmu import build_train_fmu

    fmu = build_train_fmu(REPO / "scenarios" / "trains" / f"{train}.toml", tmp_path / f"{train}.fmu", fmu_path)
    out = tmp_path / "out.csv"
    done = subprocess.run([fmi_sim, "--model", fmu, "--output-file", out, "co-simulation", "-f", "1e-3"],
                          capture_output=True, text=True, timeout=300)
    if done.returncode:
        fail_with(f"fmi-sim on {fmu.name}", done)
    rows = out.read_text().splitlines()
    assert len(rows) >= 2 and "energy.residual" in rows[0].split(","), rows[:2]
    assert all(math.isfinite(float(x)) for x in rows[-1].split(","))


@pytest.mark.parametrize("mode", ["plain", "quasi_static", "large_step"])
def test_fmi_sim_runs_the_fmi3_fmu_as_the_fmi2_one(fmi_sim, fmus, tmp_path, mode):
    """fmi-sim (its FMI 3 import) runs GearMesh-fmi3.fmu, built beside the 2.0 FMU, in each mode of
    the generic cases at 1e-3 s: the TE at every communication point is the 2.0 FMU's under
    fmi-sim within 1e-15 m (measured: plain and quasi-static equal, large-step 3.6e-17 m apart:
    fmi-sim's two imports hand over step sizes an ulp apart, which the large-step integrator
    follows; under FMPy the two FMUs agree bit for bit, tests/python/test_fmi3.py). fmi-sim 0.7
    reads every output with one value and stops at the first array (docs/guide/masters.md), so it
    runs the FMU with its scalar variables only, as `gearmesh fmu SCENE --fmi3` writes it for a
    scene that asks for no array: the same binary."""
    from gearmesh.scene_fmu import array_variables, build_scene_fmu, model_variables

    case = make_case("generic", mode, 1e-3, fmus)
    generic3 = pathlib.Path(case["fmu"]).with_name("GearMesh-fmi3.fmu")
    if not generic3.is_file():
        pytest.fail(f"{generic3} not found: build the 'fmu3' target first (tools/run-tests does)")
    with zipfile.ZipFile(generic3) as z:
        xml = z.read("modelDescription.xml").decode()
    fmu3 = build_scene_fmu(generic3, {}, {}, tmp_path / "scalars3.fmu", set(model_variables(xml))
                           - set(array_variables(xml)))
    runs = [run_fmi_sim(fmi_sim, case, tmp_path / "fmi2"), run_fmi_sim(fmi_sim, {**case, "fmu": str(fmu3)},
                                                                      tmp_path / "fmi3")]
    for r in runs:
        assert "error" not in r, r.get("error")
    assert len(runs[0]["mesh.te"]) == len(runs[1]["mesh.te"]) == round(STOP / 1e-3)
    assert max(abs(a - b) for a, b in zip(runs[0]["mesh.te"], runs[1]["mesh.te"])) <= 1e-15
    assert max(abs(x) for x in runs[1]["mesh.te"]) > 1e-6  # a loaded mesh
