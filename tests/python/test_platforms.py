"""The multi-platform FMU, the source FMU and the FMI checkers (docs/platforms.md).

build-platforms/GearMesh.fmu and the train binaries, build-platforms/GearTrain/binaries, are
built by tools/bootstrap-platforms.sh (`gearmesh-dev platforms`), which also installs
fmi-sim and VDMCheck2 into the cache; a missing piece fails these tests, it does not skip them.
What runs for real here: linux64 (this machine: Debian 12, glibc 2.36, so newer than the 2.17
the binary needs), win64 under wine, the sources built by the host compiler; the darwin64
binary is only built and inspected. The binaries' checks run on the pair's (GearMesh) and on
the train's (GearTrain, packed into the two-stage reducer's train FMU)."""
from __future__ import annotations

import hashlib
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import textwrap
import zipfile

import lief
import pytest

from gearmesh import train_fmu
from gearmesh_dev import platforms
from gearmesh.fmu_command import write_scene_fmu
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.scene import load_scene
from gearmesh.scene_fmu import build_scene_fmu
from conftest import REPO

PLATFORMS = REPO / "build-platforms"
SCENE = REPO / "scenarios" / "paper_setA_3U4U.toml"
TRAIN_SCENE = REPO / "scenarios" / "trains" / "two_stage_reducer.toml"
MODELS = [platforms.MODEL_IDENTIFIER, platforms.TRAIN_IDENTIFIER]  # GearMesh, GearTrain
FMI2 = platforms.exported_functions()
OUTPUTS = ["mesh.te", "mesh.normal_force", "mesh.pairs_in_contact", "mesh.friction_power",
           "gear1.fx", "gear1.fy", "gear1.mz", "gear2.fx", "gear2.fy", "gear2.mz"]


def need(path: pathlib.Path, what: str) -> pathlib.Path:
    if not path.exists():
        pytest.fail(f"{path} not found ({what}): tools/bootstrap-platforms.sh builds and installs it")
    return path


@pytest.fixture(scope="module")
def multi_fmu() -> pathlib.Path:
    return need(PLATFORMS / "GearMesh.fmu", "the multi-platform FMU")


@pytest.fixture(scope="module")
def train_binaries() -> pathlib.Path:
    return need(platforms.train_binaries(PLATFORMS), "the multi-platform train binaries")


@pytest.fixture(scope="module")
def multi_train_fmu(multi_fmu, train_binaries, tmp_path_factory) -> pathlib.Path:
    """The two-stage reducer's train FMU with every train binary of the platform build
    (gearmesh train-fmu --binaries build-platforms/GearTrain/binaries)."""
    return train_fmu.build_train_fmu(TRAIN_SCENE, tmp_path_factory.mktemp("train") / "reducer.fmu", multi_fmu,
                                     binaries_folder=train_binaries)


def fmu_binaries(fmu: pathlib.Path, model: str) -> dict[str, bytes]:
    """platform -> the bytes of binaries/<platform>/<model>.<suffix> of `fmu`."""
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        out = {}
        for platform, suffix in platforms.SUFFIX.items():
            name = f"binaries/{platform}/{model}{suffix}"
            assert name in names, f"{fmu} has no {name}"
            out[platform] = z.read(name)
    return out


@pytest.fixture(scope="module", params=MODELS)
def binary(request):
    """platform -> the bytes of each platform's binary: the multi-platform FMU's (GearMesh) and
    the reducer's train FMU's (GearTrain)."""
    fmu = "multi_fmu" if request.param == platforms.MODEL_IDENTIFIER else "multi_train_fmu"
    return fmu_binaries(request.getfixturevalue(fmu), request.param)


# ---------------------------------------------------------------------------------------------
# Build hygiene: pinned FMI headers, the FMU alone with a compiler and Eigen
# ---------------------------------------------------------------------------------------------

def cmake_cache(build: pathlib.Path) -> dict[str, str]:
    text = need(build / "CMakeCache.txt", "a configured build").read_text()
    return dict(m.groups() for m in re.finditer(r"^([A-Za-z0-9_]+):[A-Z_]+=(.*)$", text, re.M))


def test_fmi_headers_are_pinned_in_the_repository():
    readme = (REPO / "third_party" / "fmi2" / "README.md").read_text()
    for name, md5 in re.findall(r"^\| (fmi2\w+\.h) \| ([0-9a-f]{32}) \|$", readme, re.M):
        assert hashlib.md5((REPO / "third_party" / "fmi2" / name).read_bytes()).hexdigest() == md5, name
    assert len(re.findall(r"^\| fmi2\w+\.h \|", readme, re.M)) == 3
    assert "2-Clause BSD License" in (REPO / "third_party" / "fmi2" / "LICENSE.txt").read_text()
    for build in (REPO / "build", PLATFORMS / "linux64"):
        assert pathlib.Path(cmake_cache(build)["FMI2_INCLUDE_DIR"]) == REPO / "third_party" / "fmi2"


def test_the_fmu_alone_needs_a_compiler_and_eigen_only():
    """build-platforms/linux64 is the FMU-only CMake build (Zig as the compiler, Python and
    GoogleTest disabled for find_package): nothing of gmsh, SuiteSparse, GoogleTest or Python was
    looked up, and it made a whole FMU."""
    cache = cmake_cache(PLATFORMS / "linux64")
    assert cache["GM_BUILD_COMPLIANCE_TOOL"] == "OFF" and cache["GM_BUILD_TESTS"] == "OFF"
    assert cache["CMAKE_DISABLE_FIND_PACKAGE_Python3"] == "ON"
    assert pathlib.Path(cache["CMAKE_CXX_COMPILER"]).name == "c++"
    assert "zig" in pathlib.Path(cache["CMAKE_CXX_COMPILER"]).read_text()
    looked_up = [k for k in cache if re.match(r"(CHOLMOD|SUITESPARSE|GMSH|GTest|Python3)_", k)]
    assert not looked_up, looked_up
    assert "Eigen3_DIR" in cache
    with zipfile.ZipFile(need(PLATFORMS / "linux64" / "GearMesh.fmu", "the FMU-only build")) as z:
        assert {"modelDescription.xml", "binaries/linux64/GearMesh.so"} <= set(z.namelist())


def test_the_full_build_keeps_the_compliance_tool():
    cache = cmake_cache(REPO / "build")
    assert cache["GM_BUILD_COMPLIANCE_TOOL"] == "ON"
    assert (REPO / "build" / "compliance_tool" / "compliance_tool").is_file()


# ---------------------------------------------------------------------------------------------
# linux64: glibc 2.17
# ---------------------------------------------------------------------------------------------

def glibc_versions(elf: bytes) -> set[tuple[int, ...]]:
    """The GLIBC_x.y versions an ELF shared object needs."""
    binary = lief.ELF.parse(list(elf))
    return {tuple(int(n) for n in aux.name[len("GLIBC_"):].split("."))
            for req in binary.symbols_version_requirement for aux in req.get_auxiliary_symbols()
            if aux.name.startswith("GLIBC_")}


def test_linux64_needs_glibc_2_17_at_most(binary):
    versions = glibc_versions(binary["linux64"])
    assert versions and max(versions) <= (2, 17), sorted(versions)
    elf = lief.ELF.parse(list(binary["linux64"]))
    assert set(elf.libraries) <= {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2",
                                  "ld-linux-x86-64.so.2"}, elf.libraries
    assert {s.name for s in elf.exported_symbols} == set(FMI2)


def test_the_glibc_check_sees_a_newer_glibc():
    """The check above can fail: the host build (Debian 12's gcc and glibc 2.36) needs newer
    versions than 2.17."""
    native = need(REPO / "build" / "fmu_src" / "GearMesh.so", "the host build").read_bytes()
    assert max(glibc_versions(native)) > (2, 17)


def scene_fmu(generic: pathlib.Path, out: pathlib.Path, quasi_static: bool = True) -> pathlib.Path:
    """The paper's set A as a scene FMU (resources: its start values), by default in the
    quasi-static mode."""
    scene = load_scene(SCENE, generic)
    return build_scene_fmu(generic, {**scene.parameters, "model.quasi_static": quasi_static}, scene.resources, out)


def poses(fmu: GearMeshFMU, quasi_static: bool, steps: int = 30):
    """The inputs of each step: quasi-static, gear 1 turned over one base pitch at two load
    torques (the loaded TE is solved); plain, the same angles at two approaches (TE held)."""
    g = fmu.get(["gear1.base_diameter", "gear2.base_diameter", "gear1.teeth"])
    r1, r2 = g["gear1.base_diameter"] / 2, g["gear2.base_diameter"] / 2
    for level in ((100.0, 300.0) if quasi_static else (5e-6, 15e-6)):
        for k in range(steps // 2):
            phi1 = k * 2 * math.pi / (g["gear1.teeth"] * steps / 2)
            common = {"gear1.phi": phi1, "gear1.omega": 1.0, "gear2.omega": -r1 / r2}
            yield {**common, "mesh.load_torque": level} if quasi_static else \
                {**common, "gear2.phi": (level - r1 * phi1) / r2}


def sweep(fmu_path: pathlib.Path, quasi_static: bool = True) -> list[list[float]]:
    """The steps of poses() through fmpy: rows of OUTPUTS."""
    with GearMeshFMU(fmu_path) as fmu:
        rows = []
        for inputs in list(poses(fmu, quasi_static)):
            fmu.step(inputs)
            rows.append(list(fmu.get(OUTPUTS).values()))
    return rows


def assert_close(a, b, rel: float = 1e-12) -> None:
    assert len(a) == len(b) and a, (len(a), len(b))
    worst = 0.0
    for ra, rb in zip(a, b):
        for x, y in zip(ra, rb):
            scale = max(abs(x), abs(y))
            worst = max(worst, abs(x - y) / scale if scale else 0.0)
    assert worst <= rel, f"largest relative difference {worst:.3g} > {rel:g}"


def test_linux64_zig_binary_runs_like_the_host_build(multi_fmu, fmu_path, tmp_path):
    """The glibc-2.17 binary, loaded by fmpy on this machine, against the host build."""
    assert_close(sweep(scene_fmu(multi_fmu, tmp_path / "multi.fmu")),
                 sweep(scene_fmu(fmu_path, tmp_path / "host.fmu")))


# ---------------------------------------------------------------------------------------------
# win64: run under wine
# ---------------------------------------------------------------------------------------------

def wine() -> str:
    if not shutil.which("wine"):
        pytest.fail("wine not found: tools/bootstrap-platforms.sh installs wine and wine64")
    return shutil.which("wine")


def call_script(fmu: pathlib.Path, uri: str, quasi_static: bool) -> str:
    """The steps of poses() as a run_calls script (tests/platforms/run_calls.c)."""
    import fmpy

    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    get = {v.name: ("i" if v.type == "Integer" else "r") + str(v.valueReference) for v in md.modelVariables}
    lines = [f"instantiate {md.guid} {uri}", "setup 0", "init"]
    with GearMeshFMU(fmu) as f:
        for inputs in list(poses(f, quasi_static)):
            lines += [f"real {vr[name]} {value!r}" for name, value in inputs.items()]
            lines += ["step 0.001", "get " + " ".join(get[n] for n in OUTPUTS)]
    lines.append("terminate")
    return "\n".join(lines) + "\n"


def run_calls_output(cmd: list[str], env=None) -> list[list[float]]:
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return [[float(x) for x in line.split()[1:]] for line in done.stdout.splitlines() if line.startswith("get")]


@pytest.fixture(scope="module")
def run_calls(tmp_path_factory) -> dict[str, pathlib.Path]:
    """tests/platforms/run_calls.c built for Windows by Zig (win64) and for this machine by cc
    (linux64): platform -> executable."""
    out = tmp_path_factory.mktemp("run_calls")
    driver = REPO / "tests" / "platforms" / "run_calls.c"
    flags = ["-O2", f"-I{platforms.FMI2_HEADERS}"]
    subprocess.run([platforms.zig(), "cc", "-target", platforms.WINDOWS_TARGET, *flags, driver, "-o",
                    out / "run_calls.exe"], check=True, env=platforms.zig_env())
    subprocess.run(["cc", *flags, driver, "-o", out / "run_calls", "-ldl"], check=True)
    return {"win64": out / "run_calls.exe", "linux64": out / "run_calls"}


def under_wine(run_calls: dict[str, pathlib.Path], library: pathlib.Path, script: pathlib.Path) -> list[list[float]]:
    """run_calls.exe under wine on a DLL and a script, both named by their Z: (/) paths."""
    env = {**os.environ, "WINEPREFIX": str(platforms.cache_dir() / "wineprefix"), "WINEDEBUG": "-all"}
    return run_calls_output([wine(), run_calls["win64"], "Z:" + library.as_posix(), "Z:" + script.as_posix()],
                            env=env)


@pytest.mark.parametrize("quasi_static, rel", [(False, 1e-12), (True, 1e-10)], ids=["plain", "quasi_static"])
def test_win64_runs_under_wine_like_linux64(multi_fmu, run_calls, tmp_path, quasi_static, rel):
    """run_calls.c, cross-compiled for Windows, LoadLibrary's the DLL under wine and runs the
    scene's calls; the same driver built for Linux runs them on the linux64 binary. The
    resource location is a file URI with a drive letter (file:///Z:/..., wine's Z: is /).
    Plain mode (poses in, forces out): within 1e-12 relative (measured 2.9e-13, a small friction
    force component). Quasi-static: the TE is solved from the load by iteration, and the two C
    runtimes' libm differ in the last bits: measured 1.0e-11 relative on the TE (6e-17 m), so
    1e-10 (docs/platforms.md)."""
    fmu = scene_fmu(multi_fmu, tmp_path / "scene.fmu", quasi_static)
    unzipped = tmp_path / "unzipped"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzipped)
    resources = (unzipped / "resources").as_posix() + "/"
    (tmp_path / "linux.txt").write_text(call_script(fmu, "file://" + resources, quasi_static))
    (tmp_path / "win.txt").write_text(call_script(fmu, "file:///Z:" + resources, quasi_static))
    linux = run_calls_output([run_calls["linux64"], unzipped / "binaries/linux64/GearMesh.so", tmp_path / "linux.txt"])
    win = under_wine(run_calls, unzipped / "binaries/win64/GearMesh.dll", tmp_path / "win.txt")
    assert len(linux) == 30
    assert all(row[1] > 0 for row in linux)  # loaded: a normal force at every step
    assert_close(win, linux, rel)


# The train binary (GearTrain) under wine: the two-stage reducer turning at the motor's speed with
# the load on its output (tests/python/test_train_fmu.py's run), a few communication steps.
W_IN, LOAD = 100.0, 200.0                     # rad/s at the motor, N m against the output's turning
RATIO = (57 / 19) * (61 / 23)                 # input over output speed
TRAIN_OUTPUTS = ["stage1.te", "stage1.normal_force", "stage2.te", "stage2.normal_force", "input.speed",
                 "output.speed", "motor.torque", "dynamics.steps"]


def train_call_script(fmu: pathlib.Path, uri: str, steps: int = 10, h: float = 1e-3) -> str:
    """The reducer's run as a run_calls script: the bodies start at the motor's speed (through
    the ratios), then `steps` steps of h with the motor's far end turning at W_IN and the load
    on the output."""
    import fmpy

    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    get = {v.name: ("i" if v.type == "Integer" else "r") + str(v.valueReference) for v in md.modelVariables}
    start = {"input.omega": W_IN, "intermediate.omega": -W_IN * 19 / 57, "output.omega": W_IN / RATIO,
             "motor.far_omega": W_IN, "output.torque": -LOAD}
    lines = [f"instantiate {md.guid} {uri}", "setup 0", *[f"real {vr[n]} {x!r}" for n, x in start.items()], "init"]
    for k in range(steps):
        inputs = {"motor.far_phi": W_IN * k * h, "motor.far_omega": W_IN, "output.torque": -LOAD}
        lines += [f"real {vr[n]} {x!r}" for n, x in inputs.items()]
        lines += [f"step {h!r}", "get " + " ".join(get[n] for n in TRAIN_OUTPUTS)]
    lines.append("terminate")
    return "\n".join(lines) + "\n"


def test_win64_train_runs_under_wine_like_linux64(multi_train_fmu, run_calls, tmp_path):
    """The reducer's train FMU, built with the platform build's train binaries: its GearTrain.dll
    under wine (resources through a file:///Z:/... location) against its linux64 GearTrain.so,
    10 steps of 1 ms; the linux64 one also against the host build's (GCC) GearTrain.so.
    The load closes the backlash in the first step and the meshes' contacts ring down: the two C
    runtimes' libm round some results differently (UCRT, glibc), and the contacts carry that up
    to 1.1e-8 relative here (measured: stage1.normal_force, step 8; over 40 steps it peaks at
    4.7e-7 in step 11, then the damped train lets it decay to 1e-11), with the same internal
    steps in every step. So 1e-6, far below the integrator's own accuracy (1e-8 m of local error
    per internal step against TEs of 3e-6 to 5e-5 m) and far below a wrong parameter or resource
    (docs/platforms.md). Zig's linux64 binary and the host build's agree bit for bit (held to
    1e-12, as the pair's)."""
    unzipped = tmp_path / "unzipped"
    with zipfile.ZipFile(multi_train_fmu) as z:
        z.extractall(unzipped)
    resources = (unzipped / "resources").as_posix() + "/"
    (tmp_path / "linux.txt").write_text(train_call_script(multi_train_fmu, "file://" + resources))
    (tmp_path / "win.txt").write_text(train_call_script(multi_train_fmu, "file:///Z:" + resources))
    linux = run_calls_output([run_calls["linux64"], unzipped / "binaries/linux64/GearTrain.so", tmp_path / "linux.txt"])
    host = run_calls_output([run_calls["linux64"], need(REPO / "build" / "fmu_src" / "GearTrain.so", "the host build"),
                             tmp_path / "linux.txt"])
    win = under_wine(run_calls, unzipped / "binaries/win64/GearTrain.dll", tmp_path / "win.txt")
    assert len(linux) == 10
    assert all(row[1] > 0 and row[3] > 0 for row in linux[-3:])  # both stages loaded at the end
    assert_close(host, linux, rel=1e-12)
    assert_close(win, linux, rel=1e-6)


def test_win64_exports_the_fmi2_functions(binary):
    pe = lief.PE.parse(list(binary["win64"]))
    assert pe.header.machine == lief.PE.Header.MACHINE_TYPES.AMD64
    assert {e.name for e in pe.get_export().entries} == set(FMI2)
    imports = {i.name.lower() for i in pe.imports}
    assert all(d == "kernel32.dll" or d.startswith("api-ms-win-crt-") for d in imports), imports


# ---------------------------------------------------------------------------------------------
# darwin64: built, not run
# ---------------------------------------------------------------------------------------------

def test_darwin64_is_a_universal_dylib_exporting_the_fmi2_functions(binary):
    fat = lief.MachO.parse(list(binary["darwin64"]))
    assert fat is not None and fat.size == 2
    cpus = set()
    for macho in fat:
        cpus.add(macho.header.cpu_type)
        assert macho.header.file_type == lief.MachO.Header.FILE_TYPE.DYLIB
        assert list(macho.build_version.minos) == [12, 0, 0]  # loads on macOS 12 and later
        exported = {s.name for s in macho.exported_symbols}
        # besides the fmi2 functions and gearmesh_check: libc++'s replaceable operator new/delete (__Znwm, __ZdlPv,
        # ...) and the linker's own image symbols (docs/platforms.md, "Targets and toolchain")
        others = exported - {"_" + f for f in FMI2}
        assert exported - others == {"_" + f for f in FMI2}
        assert all(re.match(r"__Z(nw|na|dl|da)", e) for e in others - {"__mh_dylib_header", "___dso_handle"}), others
        assert [lib.name for lib in macho.libraries
                if not lib.name.endswith(("GearMesh.dylib", "GearTrain.dylib"))] == ["/usr/lib/libSystem.B.dylib"]
    assert cpus == {lief.MachO.Header.CPU_TYPE.X86_64, lief.MachO.Header.CPU_TYPE.ARM64}


def test_the_multi_platform_fmu_carries_every_platform_and_the_sources(multi_fmu, fmu_path):
    with zipfile.ZipFile(multi_fmu) as multi, zipfile.ZipFile(fmu_path) as host:
        names = set(multi.namelist())
        assert {"binaries/linux64/GearMesh.so", "binaries/win64/GearMesh.dll",
                "binaries/darwin64/GearMesh.dylib"} <= names
        assert {n for n in names if n.startswith("sources/")} == \
            {n for n in host.namelist() if n.startswith("sources/")}
        assert multi.read("modelDescription.xml") == host.read("modelDescription.xml")


def test_the_train_fmu_carries_every_platform(multi_train_fmu, train_binaries, fmu_path, tmp_path, monkeypatch):
    """gearmesh train-fmu --binaries (or $GEARMESH_TRAIN_BINARIES) packs the platform build's
    GearTrain for linux64, win64 and darwin64; without either, the host build's linux64 binary
    alone, as before. The rest of the FMU is the same."""
    expected = {f"binaries/{p}/GearTrain{s}": (train_binaries / p / f"GearTrain{s}").read_bytes()
                for p, s in platforms.SUFFIX.items()}
    monkeypatch.delenv("GEARMESH_TRAIN_BINARY", raising=False)
    monkeypatch.delenv("GEARMESH_TRAIN_BINARIES", raising=False)
    default = train_fmu.build_train_fmu(TRAIN_SCENE, tmp_path / "default.fmu", fmu_path)
    monkeypatch.setenv("GEARMESH_TRAIN_BINARIES", str(train_binaries))
    from_env = train_fmu.build_train_fmu(TRAIN_SCENE, tmp_path / "env.fmu", fmu_path)

    def contents(fmu: pathlib.Path) -> tuple[dict[str, bytes], dict[str, bytes]]:
        with zipfile.ZipFile(fmu) as z:
            files = {n: z.read(n) for n in z.namelist()}
        return ({n: d for n, d in files.items() if n.startswith("binaries/")},
                {n: d for n, d in files.items() if not n.startswith("binaries/")})

    multi, env, host = contents(multi_train_fmu), contents(from_env), contents(default)
    assert multi[0] == expected and env[0] == expected
    assert host[0] == {"binaries/linux64/GearTrain.so": (REPO / "build" / "fmu_src" / "GearTrain.so").read_bytes()}
    assert multi[1] == env[1] == host[1]


# ---------------------------------------------------------------------------------------------
# Source FMU: sources/ built alone
# ---------------------------------------------------------------------------------------------

def test_source_files_name_every_compile_unit(fmu_path):
    with zipfile.ZipFile(fmu_path) as z:
        listed = platforms.source_files(z.read("modelDescription.xml").decode())
        units = {n[len("sources/"):] for n in z.namelist()
                 if n.startswith("sources/") and n.endswith((".c", ".cpp"))}
    assert sorted(listed) == sorted(units)
    assert "fmi2_functions.c" in units and "capi.cpp" in units


def test_the_sources_alone_build_an_fmu_equal_to_the_binary(fmu_path, tmp_path):
    """An importer's build: the host's cc and c++ compile the <SourceFiles> with sources/, the
    pinned FMI 2.0 headers and Eigen as the only include directories and no definitions; the
    library, put in place of the binary, gives the binary FMU's outputs."""
    unzipped = tmp_path / "fmu"
    with zipfile.ZipFile(fmu_path) as z:
        z.extractall(unzipped)
        files = platforms.source_files(z.read("modelDescription.xml").decode())
    (unzipped / "binaries" / "linux64" / "GearMesh.so").unlink()
    platforms.compile_sources(unzipped / "sources", files, ["cc", "-fPIC"], ["c++", "-fPIC"], ["-shared"],
                              unzipped / "binaries" / "linux64" / "GearMesh.so", tmp_path / "obj", jobs=2)
    rebuilt = tmp_path / "rebuilt.fmu"
    with zipfile.ZipFile(rebuilt, "w") as z:
        for path in sorted(unzipped.rglob("*")):
            if path.is_file():
                z.write(path, path.relative_to(unzipped).as_posix())
    assert_close(sweep(scene_fmu(rebuilt, tmp_path / "rebuilt-scene.fmu")),
                 sweep(scene_fmu(fmu_path, tmp_path / "binary-scene.fmu")), rel=0.0)


# ---------------------------------------------------------------------------------------------
# Checkers: fmpy, fmi-sim, VDMCheck2
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module", params=["generic", "torsional", "planar", "full"])
def checked_fmu(request, multi_fmu, tmp_path_factory) -> pathlib.Path:
    """The multi-platform FMU, and set A's scene FMU with each interface built from it
    (gearmesh fmu --interface; python/gearmesh/scene_interface.py)."""
    if request.param == "generic":
        return multi_fmu
    out = tmp_path_factory.mktemp("interface") / f"setA.{request.param}.fmu"
    write_scene_fmu(load_scene(SCENE, multi_fmu), multi_fmu, out, request.param)
    return out


def test_fmpy_validates_and_simulates(checked_fmu):
    from fmpy import simulate_fmu
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(checked_fmu)) == []
    result = simulate_fmu(str(checked_fmu), stop_time=1e-3, output_interval=1e-4)
    assert len(result) == 11 and all(math.isfinite(x) for x in result[-1])


def fmi_sim(fmu: pathlib.Path, out: pathlib.Path) -> subprocess.CompletedProcess:
    binary = need(platforms.cache_dir() / "cargo" / "bin" / "fmi-sim", "fmi-sim from crates.io")
    return subprocess.run([binary, "--model", fmu, "--output-file", out, "co-simulation", "-f", "1e-3"],
                          capture_output=True, text=True, timeout=300)


def test_fmi_sim_simulates(checked_fmu, tmp_path):
    """fmi-sim (crates.io) simulates every FMU as built: GearMesh's open range bounds are model-level
    vendor annotations, which it reads past (it refuses a ScalarVariable's own <Annotations>)."""
    assert b"<Annotations>" not in zipfile.ZipFile(checked_fmu).read("modelDescription.xml")
    done = fmi_sim(checked_fmu, tmp_path / "out.csv")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    rows = (tmp_path / "out.csv").read_text().splitlines()
    assert len(rows) >= 11, rows[:3]
    assert all(math.isfinite(float(x)) for x in rows[-1].split(","))


def vdmcheck(target: pathlib.Path) -> subprocess.CompletedProcess:
    jar = need(platforms.cache_dir() / "vdmcheck2" / "vdmcheck2.jar", "VDMCheck2 from Maven Central")
    return subprocess.run(["java", "-jar", jar, target], capture_output=True, text=True, timeout=300)


def test_vdmcheck2_finds_no_errors(checked_fmu):
    done = vdmcheck(checked_fmu)
    assert done.returncode == 0 and "No errors found." in done.stdout, done.stdout + done.stderr


def test_vdmcheck2_finds_a_broken_model_description(multi_fmu, tmp_path):
    """The checker can fail: an output with a start value and initial="calculated" is illegal."""
    xml = zipfile.ZipFile(multi_fmu).read("modelDescription.xml").decode()
    broken, n = re.subn(r'(name="mesh\.te"[^>]*initial="calculated">\s*<Real[^/]*?)/>', r'\1 start="1"/>', xml)
    assert n == 1
    (tmp_path / "modelDescription.xml").write_text(broken)
    done = vdmcheck(tmp_path / "modelDescription.xml")
    assert done.returncode != 0 and "No errors found." not in done.stdout, done.stdout


# An importer may unload the FMU's library (dlclose) long before its process ends, as FMPy's
# freeLibrary does; nothing the library leaves behind may then run at exit. The Zig-built binaries
# link libc++, which registers a static object's destructor for the process's exit: a function-local
# static std::string in the core (a message built on first use) crashed the process there, after all
# its work, with SIGSEGV. The case: level 4's coupled solve capped at one iteration
# (solver.max_iterations = 1), which builds the message naming the parameter, then the instance
# freed and the library unloaded, in a child process whose exit status is checked. (The CMake
# build's FMU links libstdc++, which runs such destructors at dlclose: it cannot show this.)
CHILD = textwrap.dedent("""
    import sys
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    fmu = sys.argv[1]
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="unload")
    slave.instantiate(loggingOn=True)  # FMPy's default logger prints the FMU's messages
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setInteger([vr["solver.max_iterations"]], [1])
    slave.setReal([vr["gear2.phi"]], [0.004])  # wound up: one iteration cannot converge the contact
    try:
        slave.exitInitializationMode()
        print("initialized")
    except Exception:
        print("refused")
    slave.freeInstance()
    slave.freeLibrary()
    sys.stdout.flush()
""")


def check_unload(fmu) -> None:
    """The case on `fmu`: the child exits with status 0 after producing the message."""
    done = subprocess.run([sys.executable, "-c", CHILD, str(fmu)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, f"exit status {done.returncode}\n{done.stdout}\n{done.stderr}"
    # the message that builds the static text was produced: the case exercises it
    assert "solver.max_iterations" in done.stdout, done.stdout


def test_the_linux_binary_leaves_nothing_to_run_at_exit(multi_fmu):
    """The multi-platform FMU's linux64 binary unloaded, then the process exits cleanly (exit
    status -11 on the binary with the static std::string)."""
    check_unload(multi_fmu)
