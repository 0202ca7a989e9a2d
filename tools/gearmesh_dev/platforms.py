"""The multi-platform GearMesh.fmu (docs/platforms.md): binaries for linux64 (glibc >= 2.17),
win64 and darwin64 (x86_64 + aarch64 in one universal dylib), all built on this Linux machine by
one cross toolchain, Zig's clang (the `ziglang` package from PyPI), beside the FMU's sources/.

* linux64: the repository's own CMake build with the FMU alone (GM_BUILD_COMPLIANCE_TOOL=OFF,
  no tests, Python disabled) and Zig as the C/C++ compiler for x86_64-linux-gnu.2.17; it also
  writes modelDescription.xml, the documentation and sources/.
* win64, darwin64: the <SourceFiles> of that FMU compiled from its sources/ alone (what an
  importer of the source FMU does), one Zig target each; the two macOS slices are joined into
  one universal (fat) Mach-O by llvm-lipo, since FMI 2.0 has one darwin64 folder.
* The gear-train FMU's binary, GearTrain (fmu_src/model_train.c in place of model_gearmesh.c,
  the same core and FMI layer): linux64 from the same CMake build (its GearTrain target), win64
  and darwin64 from the objects of the sources/ build above plus fmu_src/model_train.c, read
  from the repository (the pair FMU's sources/ is its own source FMU: every unit there is one of
  its <SourceFiles>, and an importer that compiles them all must not meet a second model).
  `gearmesh train-fmu --binaries` packs them into a train scene's FMU.

`gearmesh-dev platforms` writes build-platforms/GearMesh.fmu and the train binaries,
build-platforms/GearTrain/binaries/<platform>/GearTrain.<suffix>; tools/bootstrap-platforms.sh
runs it in the test command, and tests/python/test_platforms.py checks the result.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile

from gearmesh.train_fmu import SUFFIX, TRAIN_IDENTIFIER
from gearmesh_dev import checkout

REPO = checkout()
FMI2_HEADERS = REPO / "third_party" / "fmi2"
EXPORT_MAP = REPO / "fmu_src" / "GearMesh.map"  # the fmi2 functions the binary exports
MODEL_IDENTIFIER = "GearMesh"
PAIR_MODEL = "model_gearmesh.c"  # the pair's unit of <SourceFiles>; the train binary has instead:
TRAIN_MODEL = REPO / "fmu_src" / "model_train.c"

LINUX_TARGET = "x86_64-linux-gnu.2.17"  # glibc 2.17 (2012): CentOS 7 and every later distribution
WINDOWS_TARGET = "x86_64-windows-gnu"
# macOS 12 (2021) and later; without a version Zig 0.17 takes its newest, 15.0
DARWIN_TARGETS = ("x86_64-macos.12.0", "aarch64-macos.12.0")

# Flags of the compile units, for every compiler: the CMake Release build's language levels (C11
# and C++17 with the GNU/POSIX extensions, CMake's default) and optimisation, and no symbol visible
# but the fmi2 functions (fmi2Functions.h marks them for export).
C_FLAGS = ["-std=gnu11", "-O3", "-DNDEBUG", "-fvisibility=hidden"]
CXX_FLAGS = ["-std=gnu++17", "-O3", "-DNDEBUG", "-fvisibility=hidden", "-fvisibility-inlines-hidden"]


class BuildError(RuntimeError):
    """A compiler, linker or tool failed; the message names the step and carries its output."""


def cache_dir() -> pathlib.Path:
    """Where downloaded tools and Zig's compiled C/C++ runtimes are kept: $GM_CACHE, else the
    git-ignored .cache/ of the repository."""
    return pathlib.Path(os.environ.get("GM_CACHE") or REPO / ".cache")


def zig() -> pathlib.Path:
    """The Zig binary of the ziglang package installed in this Python (tools/requirements.txt),
    from a copy of the package in the cache (ziglang-<version>/). Zig's cache keys hold the path
    of its lib/ folder, so runtimes built with the venv's own copy (a new path in every clean
    clone) would be built again in every clone; the copy's path stays the same."""
    try:
        import ziglang
        from importlib.metadata import version
    except ImportError as exc:
        raise BuildError("the ziglang package is not installed in this Python: tools/bootstrap.sh "
                         "installs tools/requirements.txt into .venv") from exc
    stable = cache_dir() / f"ziglang-{version('ziglang')}"
    if not (stable / "zig").is_file():
        stable.parent.mkdir(parents=True, exist_ok=True)
        tmp = pathlib.Path(tempfile.mkdtemp(prefix=stable.name + ".", dir=stable.parent))
        shutil.copytree(pathlib.Path(ziglang.__file__).parent, tmp / "ziglang", symlinks=True)
        try:
            os.replace(tmp / "ziglang", stable)
        except OSError:  # another build put it there first
            if not (stable / "zig").is_file():
                raise
        shutil.rmtree(tmp, ignore_errors=True)
    return stable / "zig"


def zig_env() -> dict[str, str]:
    env = dict(os.environ)
    env["ZIG_GLOBAL_CACHE_DIR"] = str(cache_dir() / "zig")
    return env


def eigen_include() -> str:
    """Eigen's include directory (header-only, so the host's headers serve every target)."""
    try:
        flags = subprocess.run(["pkg-config", "--cflags-only-I", "eigen3"], check=True,
                               capture_output=True, text=True).stdout.split()
    except (OSError, subprocess.CalledProcessError) as exc:
        raise BuildError("Eigen 3 not found by pkg-config (Debian: libeigen3-dev)") from exc
    return flags[0][2:]


def exported_functions() -> list[str]:
    """The function names fmu_src/GearMesh.map exports: the fmi2 functions and gearmesh_check."""
    return re.findall(r"^\s*((?:fmi2|gearmesh_)\w+);", EXPORT_MAP.read_text(), re.M)


def _run(cmd: list[str], what: str, env: dict | None = None, cwd: pathlib.Path | None = None) -> None:
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env, cwd=cwd)
    if done.returncode != 0:
        raise BuildError(f"{what} failed (exit {done.returncode}):\n{' '.join(map(str, cmd))}\n"
                         f"{done.stdout}{done.stderr}")


def _write_wrapper(path: pathlib.Path, tool: str, target: str) -> pathlib.Path:
    """A compiler CMake can be given: Zig's `cc`/`c++` for one target."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'#!/bin/sh\nexec "{zig()}" {tool} -target {target} "$@"\n')
    path.chmod(0o755)
    return path


def build_linux64(out: pathlib.Path, jobs: int) -> tuple[pathlib.Path, pathlib.Path]:
    """The FMU-only CMake build with Zig for glibc 2.17; returns its GearMesh.fmu (linux64 only)
    and its train binary, GearTrain.so."""
    build = out / "linux64"
    cc = _write_wrapper(out / "zig" / "cc", "cc", LINUX_TARGET)
    cxx = _write_wrapper(out / "zig" / "c++", "c++", LINUX_TARGET)
    if not (build / "CMakeCache.txt").is_file():
        _run(["cmake", "-S", REPO, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
              f"-DCMAKE_C_COMPILER={cc}", f"-DCMAKE_CXX_COMPILER={cxx}",
              "-DGM_BUILD_COMPLIANCE_TOOL=OFF", "-DGM_BUILD_TESTS=OFF", "-DGM_BUILD_BENCHMARKS=OFF",
              # the FMU alone must not need them: configure fails if anything still looks for them
              "-DCMAKE_DISABLE_FIND_PACKAGE_Python3=ON", "-DCMAKE_DISABLE_FIND_PACKAGE_GTest=ON"],
             "configuring the linux64 build", env=zig_env())
    _run(["cmake", "--build", build, "--target", "fmu", TRAIN_IDENTIFIER, "--parallel", str(jobs)],
         "building the linux64 FMU and train binary", env=zig_env())
    return build / "GearMesh.fmu", build / "fmu_src" / f"{TRAIN_IDENTIFIER}.so"


def source_files(model_description: str) -> list[str]:
    """The <SourceFiles> of the CoSimulation element."""
    root = ET.fromstring(model_description)
    files = [f.get("name") for f in root.iterfind("./CoSimulation/SourceFiles/File")]
    if not files:
        raise BuildError("modelDescription.xml lists no <SourceFiles> in <CoSimulation>")
    return files


def compile_sources(sources: pathlib.Path, files: list[str], cc: list[str], cxx: list[str],
                    link: list[str], out: pathlib.Path, objects: pathlib.Path, jobs: int,
                    env: dict | None = None) -> pathlib.Path:
    """Compile `files` (names inside `sources`, or paths of files elsewhere: an object is named
    by the file's name) with `cc`/`cxx` and link them with `cxx` into the shared library `out`:
    sources/, the FMI 2.0 headers and Eigen are the only include directories. An object newer
    than its source and every header in `sources` is kept."""
    includes = [f"-I{sources}", f"-I{FMI2_HEADERS}", f"-I{eigen_include()}"]
    headers = max(p.stat().st_mtime for p in sources.rglob("*") if p.is_file() and p.suffix in (".h", ".hpp"))
    objects.mkdir(parents=True, exist_ok=True)

    def one(name: str | pathlib.Path) -> pathlib.Path:
        source = sources / name  # an absolute path stays itself
        obj = objects / (source.name + ".o")
        if obj.is_file() and obj.stat().st_mtime > max(headers, source.stat().st_mtime):
            return obj
        compiler, flags = (cxx, CXX_FLAGS) if source.suffix in (".cpp", ".cc", ".cxx") else (cc, C_FLAGS)
        _run([*compiler, *flags, *includes, "-c", source, "-o", obj], f"compiling {source.name}", env=env)
        return obj

    with concurrent.futures.ThreadPoolExecutor(max(1, jobs)) as pool:
        objs = list(pool.map(one, files))
    out.parent.mkdir(parents=True, exist_ok=True)
    _run([*cxx, *objs, *link, "-o", out], f"linking {out.name}", env=env)
    return out


def _sync(z: zipfile.ZipFile, prefix: str, target: pathlib.Path) -> None:
    """Make `target` hold the entries under `prefix` of `z`, rewriting only the files whose
    contents changed (so that the objects of unchanged sources are kept)."""
    wanted = {}
    for info in z.infolist():
        if info.filename.startswith(prefix) and not info.is_dir():
            wanted[target / info.filename[len(prefix):]] = z.read(info)
    for path in [p for p in target.rglob("*") if p.is_file()] if target.is_dir() else []:
        if path not in wanted:
            path.unlink()
    for path, data in wanted.items():
        if not path.is_file() or path.read_bytes() != data:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)


def build_from_sources(fmu: pathlib.Path, out: pathlib.Path, jobs: int) -> dict[str, dict[str, pathlib.Path]]:
    """win64 and darwin64 binaries from the sources/ of `fmu`: model identifier (GearMesh,
    GearTrain) -> platform -> library. The train binary links the same objects with
    fmu_src/model_train.c's in place of model_gearmesh.c's (compiled with the same include
    directories, against the headers of sources/): only that one unit is compiled for it."""
    work = out / "sources-build"
    sources = work / "sources"
    with zipfile.ZipFile(fmu) as z:
        md = z.read("modelDescription.xml").decode("utf-8")
        _sync(z, "sources/", sources)
    files = source_files(md)
    if PAIR_MODEL not in files:
        raise BuildError(f"modelDescription.xml's <SourceFiles> lists no {PAIR_MODEL}")
    units = {MODEL_IDENTIFIER: files, TRAIN_IDENTIFIER: [f for f in files if f != PAIR_MODEL] + [TRAIN_MODEL]}
    env = zig_env()

    def target(t: str) -> tuple[list[str], list[str]]:
        return [str(zig()), "cc", "-target", t], [str(zig()), "c++", "-target", t]

    built: dict[str, dict[str, pathlib.Path]] = {name: {} for name in units}
    for name, unit_files in units.items():
        cc, cxx = target(WINDOWS_TARGET)
        # the DLL exports what fmi2Functions.h marks __declspec(dllexport): the fmi2 functions
        built[name]["win64"] = compile_sources(sources, unit_files, cc, cxx, ["-shared"],
                                               work / WINDOWS_TARGET / f"{name}.dll",
                                               work / WINDOWS_TARGET / "obj", jobs, env)
        # Zig's Mach-O linker ignores -exported_symbols_list: hidden visibility leaves the fmi2
        # functions and libc++'s replaceable operator new/delete exported (docs/platforms.md).
        slices = []
        for t in DARWIN_TARGETS:
            cc, cxx = target(t)
            slices.append(compile_sources(sources, unit_files, cc, cxx,
                                          ["-shared", f"-Wl,-install_name,@rpath/{name}.dylib"],
                                          work / t / f"{name}.dylib", work / t / "obj", jobs, env))
        built[name]["darwin64"] = lipo(slices, work / f"{name}.dylib")
    return built


def llvm_lipo() -> str:
    """llvm-lipo of LLVM's binutils (Debian 12: package llvm-14, llvm-lipo-14)."""
    for name in ["llvm-lipo", *(f"llvm-lipo-{v}" for v in range(21, 13, -1))]:
        if shutil.which(name):
            return name
    raise BuildError("llvm-lipo not found: tools/bootstrap-platforms.sh installs llvm-14 (Debian)")


def lipo(slices: list[pathlib.Path], out: pathlib.Path) -> pathlib.Path:
    """One universal (fat) Mach-O of single-architecture slices."""
    _run([llvm_lipo(), "-create", *slices, "-output", out], "joining the macOS slices (llvm-lipo)")
    return out


def pack(linux_fmu: pathlib.Path, binaries: dict[str, pathlib.Path], out: pathlib.Path) -> pathlib.Path:
    """`linux_fmu` with binaries/<platform>/GearMesh<suffix> added for each of `binaries`."""
    tmp = pathlib.Path(tempfile.mkstemp(prefix=out.name + ".", dir=out.parent)[1])
    try:
        with zipfile.ZipFile(linux_fmu) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
            for info in src.infolist():
                dst.writestr(info, src.read(info), zipfile.ZIP_DEFLATED)
            for platform, lib in sorted(binaries.items()):
                info = zipfile.ZipInfo(f"binaries/{platform}/{MODEL_IDENTIFIER}{SUFFIX[platform]}",
                                       (1980, 1, 1, 0, 0, 0))
                info.external_attr = 0o755 << 16
                dst.writestr(info, lib.read_bytes(), zipfile.ZIP_DEFLATED)
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out


def train_binaries(out: pathlib.Path) -> pathlib.Path:
    """The folder of the train binaries, <platform>/GearTrain<suffix> (the layout of an FMU's
    binaries/, which `gearmesh train-fmu --binaries` takes)."""
    return out / TRAIN_IDENTIFIER / "binaries"


def build(out: pathlib.Path, jobs: int) -> pathlib.Path:
    """The multi-platform FMU, out/GearMesh.fmu, and the train binaries, train_binaries(out)
    (both removed first: a failed build leaves neither)."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "GearMesh.fmu").unlink(missing_ok=True)
    shutil.rmtree(out / TRAIN_IDENTIFIER, ignore_errors=True)
    linux_fmu, linux_train = build_linux64(out, jobs)
    built = build_from_sources(linux_fmu, out, jobs)
    fmu = pack(linux_fmu, built[MODEL_IDENTIFIER], out / "GearMesh.fmu")
    staging = out / f"{TRAIN_IDENTIFIER}.tmp"
    shutil.rmtree(staging, ignore_errors=True)
    for platform, lib in {"linux64": linux_train, **built[TRAIN_IDENTIFIER]}.items():
        (staging / "binaries" / platform).mkdir(parents=True)
        shutil.copy2(lib, staging / "binaries" / platform / f"{TRAIN_IDENTIFIER}{SUFFIX[platform]}")
    os.replace(staging, out / TRAIN_IDENTIFIER)
    return fmu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="gearmesh-dev platforms", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=pathlib.Path, default=REPO / "build-platforms")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="parallel compiles (1..256)")
    args = parser.parse_args(argv)
    if not 1 <= args.jobs <= 256:
        parser.error(f"--jobs {args.jobs}: allowed range 1..256")
    try:
        fmu = build(args.out.resolve(), args.jobs)
    except BuildError as exc:
        print(f"gearmesh-dev platforms: {exc}", file=sys.stderr)
        return 1
    print(fmu)
    print(train_binaries(args.out.resolve()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
