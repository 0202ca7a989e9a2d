"""The Python packages' layout and surface: one version for the project (CMakeLists.txt), the user
package apart from the maintainer tools and the FE reference, no module that finds the repository
from its own location or edits sys.path, no import cycle, `import gearmesh` exporting what a
script needs, and docs/tooling.md's example printing what the page says. The installed wheel's
run outside the repository: test_package.py."""
from __future__ import annotations

import ast
import os
import pathlib
import re
import subprocess
import sys
import tomllib

import gearmesh
from conftest import REPO

PACKAGE = REPO / "python" / "gearmesh"
DEV = REPO / "tools" / "gearmesh_dev"


def documented_example() -> tuple[str, list[str]]:
    """docs/tooling.md's "From Python" block and the lines it promises to print."""
    text = (REPO / "docs" / "tooling.md").read_text(encoding="utf-8")
    section = text[text.index("## From Python"):]
    section = section[:section.index("\n## ", 3)]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    promised = re.search(r"^prints (`[^`]+`(?: and `[^`]+`)*)", section, re.M).group(1)
    return code, re.findall(r"`([^`]+)`", promised)


def test_one_version_for_the_project():
    cmake = re.search(r"project\(GearMesh VERSION ([0-9.]+)", (REPO / "CMakeLists.txt").read_text()).group(1)
    assert gearmesh.__version__ == cmake
    for pyproject in (REPO / "tools" / "pyproject.toml", REPO / "reference_fe" / "pyproject.toml"):
        assert tomllib.loads(pyproject.read_text())["project"]["version"] == cmake, pyproject
    root = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert root["project"]["dynamic"] == ["version"]
    assert root["tool"]["scikit-build"]["metadata"]["version"]["input"] == "CMakeLists.txt"


def test_the_packages_come_from_the_checkout_installs():
    import gearmesh_dev
    import reference_fe

    for module, folder in ((gearmesh, PACKAGE), (gearmesh_dev, DEV), (reference_fe, REPO / "reference_fe")):
        assert pathlib.Path(module.__file__).resolve().parent == folder.resolve(), module


def _python_files(*folders: pathlib.Path) -> list[pathlib.Path]:
    return [p for f in folders for p in sorted(f.rglob("*.py"))]


def test_no_module_finds_the_repository_by_its_own_location():
    tests = REPO / "tests"
    offenders = []
    for path in _python_files(PACKAGE, DEV, REPO / "reference_fe", tests):
        text = path.read_text(encoding="utf-8")
        if (re.search(r"__file__\)?(\.resolve\(\))?\.parents\[", text)
                or re.search(r"^\s*sys\.path\.insert", text, re.M)):
            offenders.append(path.relative_to(REPO).as_posix())
    # test_fmu_conformance writes a child script that imports the test module itself
    assert offenders == ["tests/python/test_fmu_conformance.py", "tests/python/test_masters.py"], offenders


def _imports(path: pathlib.Path, package: str) -> set[str]:
    """The modules of `package` that `path` imports at its top level (not inside functions)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == package:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == package)
    return found


def _module_name(path: pathlib.Path, root: pathlib.Path, package: str) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join([package, *parts])


def test_the_user_package_has_no_import_cycle_and_needs_no_developer_tool():
    modules = {_module_name(p, PACKAGE, "gearmesh"): p for p in _python_files(PACKAGE)}
    for name, path in modules.items():
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"^\s*(from|import) (gearmesh_dev|reference_fe)\b", text, re.M), name
    graph = {name: {m for m in _imports(path, "gearmesh") if m in modules and m != name}
             for name, path in modules.items()}
    # the package's __init__ is imported with any submodule: leave it out of the cycle search
    graph = {n: e - {"gearmesh"} for n, e in graph.items() if n != "gearmesh"}
    state: dict[str, int] = {}
    cycles = []

    def visit(node, stack):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack + [nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, cycles


def test_the_reference_shares_no_code_with_the_product():
    for path in _python_files(REPO / "reference_fe"):
        assert not re.search(r"^\s*(from|import) gearmesh", path.read_text(encoding="utf-8"), re.M), path


def test_import_gearmesh_gives_what_a_script_needs():
    for name in ("load_scene", "write_scene_fmu", "loaded_te", "run_main", "open_fmu", "resolve_paths",
                 "generic_fmu", "Paths", "Scene", "SceneError", "GearMeshFMU", "FMUError"):
        assert name in gearmesh.__all__ and hasattr(gearmesh, name), name
    # the CLI is a layer over the same calls: its main job and scene FMU go through them
    cli = (PACKAGE / "cli.py").read_text()
    assert "Paths.resolve" in cli


def test_documented_example_prints_what_the_page_says(tmp_path):
    code, promised = documented_example()
    assert len(promised) == 2 and len(code.strip().splitlines()) <= 12
    import shutil

    shutil.copy(REPO / "scenarios" / "paper_setA_3U4U.toml", tmp_path)
    (tmp_path / "example.py").write_text(code)
    done = subprocess.run([sys.executable, "example.py"], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines() == promised
    assert (tmp_path / "setA.fmu").is_file()


def test_paths_follow_options_then_environment_then_checkout(tmp_path):
    from gearmesh.paths import Paths

    env = {"GEARMESH_CHECKOUT": str(REPO)}
    p = Paths.resolve(env=env, cwd=tmp_path)
    assert p.checkout == REPO and p.scenes == REPO / "scenarios" and p.output == REPO / "output"
    assert p.fmu == REPO / "build" / "GearMesh.fmu"  # the editable install carries no FMU
    p = Paths.resolve(env={**env, "GEARMESH_FMU": "/x/a.fmu", "GEARMESH_OUTPUT": "/x/out"}, cwd=tmp_path)
    assert p.fmu == pathlib.Path("/x/a.fmu") and p.output == pathlib.Path("/x/out")
    p = Paths.resolve(fmu="b.fmu", output="o", env={**env, "GEARMESH_FMU": "/x/a.fmu"}, cwd=tmp_path)
    assert p.fmu == pathlib.Path("b.fmu") and p.output == pathlib.Path("o")
    # outside a checkout, with nothing set: no scenes, output/ in the working directory, the user's cache
    p = Paths.resolve(env={}, cwd=tmp_path)
    assert p.checkout is None and p.scenes is None and p.output == tmp_path / "output"
    assert not p.cache.is_relative_to(tmp_path) and p.compliance_cache == p.cache / "compliance"
    try:
        p.require("scenes")
    except FileNotFoundError as exc:
        assert "GEARMESH_SCENES" in str(exc)
    else:
        raise AssertionError("require('scenes') outside a checkout must fail")
    # inside a checkout's subfolder, found from the working directory
    assert Paths.resolve(env={}, cwd=REPO / "docs" / "guide").checkout == REPO


def test_paths_find_the_packages_compliance_tool_and_say_how_to_get_it(tmp_path, monkeypatch):
    """The package's data folder as pip install leaves it with compliance_tool (built when gmsh and
    CHOLMOD were found) and without it (a published wheel): Paths takes the package's tool before a
    checkout's, and without any names the install route (the slow test_package.py installs both)."""
    from gearmesh import paths

    data = tmp_path / "data"
    data.mkdir()
    (data / "GearMesh.fmu").write_bytes(b"")
    monkeypatch.setattr(paths, "package_data", lambda: data)
    monkeypatch.setattr(paths.shutil, "which", lambda name: None)  # none on PATH
    work = tmp_path / "work"
    work.mkdir()
    p = paths.Paths.resolve(env={}, cwd=work)
    assert p.fmu == data / "GearMesh.fmu"
    assert p.compliance_tool is None or not p.compliance_tool.exists()  # no checkout, none on PATH here
    try:
        p.require("compliance_tool")
    except paths.NotFound as exc:
        message = str(exc)
    else:
        raise AssertionError("require('compliance_tool') must fail without a tool")
    for route in ("pip install gmsh", "libsuitesparse-dev", "pip install --force-reinstall --no-deps",
                  "GEARMESH_COMPLIANCE_TOOL", "GPL"):
        assert route in message, (route, message)
    (data / "compliance_tool").write_bytes(b"")
    assert paths.Paths.resolve(env={}, cwd=work).require("compliance_tool") == data / "compliance_tool"
    # before the checkout's build, as the package's FMU
    in_checkout = paths.Paths.resolve(env={"GEARMESH_CHECKOUT": str(REPO)}, cwd=work)
    assert in_checkout.compliance_tool == data / "compliance_tool"
    env = {"GEARMESH_COMPLIANCE_TOOL": "/x/compliance_tool"}
    assert paths.Paths.resolve(env=env, cwd=work).compliance_tool == pathlib.Path("/x/compliance_tool")
