"""Where GearMesh finds and puts its files: one `Paths` object, filled from the options a command
or script passes, the environment and the working directory (never from where this package
lies on disk).

| field | option, then environment, then ... |
|---|---|
| fmu | `$GEARMESH_FMU`; the installed package's GearMesh.fmu; the checkout's build/GearMesh.fmu |
| fmu3 | `$GEARMESH_FMU3`; the package's GearMesh-fmi3.fmu; the checkout's build/GearMesh-fmi3.fmu |
| train_binary | `$GEARMESH_TRAIN_BINARY`; the package's GearTrain.so; the checkout's build/fmu_src/GearTrain.so |
| train_binary3 | `$GEARMESH_TRAIN_BINARY3`; the package's GearTrain3.so; the checkout's build/fmu_src/GearTrain3.so |
| train_header | the package's train_variables.h; the checkout's fmu_src/train_variables.h |
| compliance_tool | `$GEARMESH_COMPLIANCE_TOOL`; the package's compliance_tool (built by pip install when gmsh and
  CHOLMOD were found); the checkout's build/compliance_tool/compliance_tool; `compliance_tool` on PATH |
| scenes | `$GEARMESH_SCENES`; the checkout's scenarios/ |
| output | `$GEARMESH_OUTPUT`; the checkout's output/; output/ in the working directory |
| cache | `$GM_CACHE`; the checkout's .cache/; the user's cache folder (platformdirs) |
| compliance_cache | `$GEARMESH_COMPLIANCE_CACHE`; the checkout's output/compliance_cache; cache/compliance |

The checkout is a GearMesh source tree: the `checkout` option, else `$GEARMESH_CHECKOUT`, else the
working directory or the nearest folder above it holding GearMesh's CMakeLists.txt and
modelDescription/variables.h; None outside one. An installed package (`pip install`) carries
the FMUs and the train binary itself, and compliance_tool when its libraries were found at
install; a developer's editable install in a checkout finds them in the checkout's build/
(tools/bootstrap.sh sets `GEARMESH_CHECKOUT`).
"""
from __future__ import annotations

import dataclasses
import importlib.resources
import os
import pathlib
import shutil
from collections.abc import Mapping

ENV_FMU = "GEARMESH_FMU"
ENV_FMU3 = "GEARMESH_FMU3"
ENV_TRAIN_BINARY = "GEARMESH_TRAIN_BINARY"
ENV_TRAIN_BINARY3 = "GEARMESH_TRAIN_BINARY3"
ENV_COMPLIANCE_TOOL = "GEARMESH_COMPLIANCE_TOOL"
ENV_COMPLIANCE_CACHE = "GEARMESH_COMPLIANCE_CACHE"
ENV_CHECKOUT = "GEARMESH_CHECKOUT"
ENV_SCENES = "GEARMESH_SCENES"
ENV_OUTPUT = "GEARMESH_OUTPUT"
ENV_CACHE = "GM_CACHE"


# How to get compliance_tool (docs/tooling.md, "Install"): a wheel to redistribute carries none.
COMPLIANCE_TOOL_ROUTE = (
    "the FE level's compliance_tool links gmsh and SuiteSparse CHOLMOD, and a published wheel carries none (gmsh "
    "is GPL); pip install of a checkout builds it into the package when both are found: install "
    "libsuitesparse-dev (Debian) and pip install gmsh into this environment, then install the checkout again "
    "(pip install --force-reinstall --no-deps CHECKOUT; with -v its CMake output names what is missing); or "
    f"build it in a checkout (cmake --build build --target compliance_tool) and set ${ENV_COMPLIANCE_TOOL} to "
    "the binary, or put compliance_tool on PATH")


class NotFound(FileNotFoundError):
    """A file GearMesh needs is in none of the places it looks; the message says how to get it."""


def package_data() -> pathlib.Path | None:
    """The installed package's data folder (GearMesh.fmu, GearMesh-fmi3.fmu, GearTrain.so,
    train_variables.h, maybe compliance_tool), None when the package carries none (a developer's editable install)."""
    try:
        data = importlib.resources.files("gearmesh") / "data"
    except ModuleNotFoundError:  # pragma: no cover - gearmesh is this package
        return None
    path = pathlib.Path(str(data))
    return path if (path / "GearMesh.fmu").is_file() else None


def is_checkout(folder: pathlib.Path) -> bool:
    """A GearMesh source tree: its CMakeLists.txt names the project and it has the variable table."""
    cmake = folder / "CMakeLists.txt"
    if not (cmake.is_file() and (folder / "modelDescription" / "variables.h").is_file()):
        return False
    return "project(GearMesh" in cmake.read_text(errors="replace")


def find_checkout(start: pathlib.Path) -> pathlib.Path | None:
    """`start` or the nearest folder above it that is a GearMesh checkout."""
    start = start.resolve()
    for folder in (start, *start.parents):
        if is_checkout(folder):
            return folder
    return None


def _first(*candidates: pathlib.Path | None) -> pathlib.Path | None:
    """The first candidate that exists, else the last one given (where it would be)."""
    given = [c for c in candidates if c is not None]
    for c in given:
        if c.exists():
            return c
    return given[-1] if given else None


def _env_path(env: Mapping[str, str], name: str) -> pathlib.Path | None:
    value = env.get(name)
    return pathlib.Path(value).expanduser() if value else None


@dataclasses.dataclass(frozen=True)
class Paths:
    """The files and folders of one run; `Paths.resolve()` fills them (module docstring)."""
    fmu: pathlib.Path | None
    fmu3: pathlib.Path | None
    train_binary: pathlib.Path | None
    train_binary3: pathlib.Path | None
    train_header: pathlib.Path | None
    compliance_tool: pathlib.Path | None
    scenes: pathlib.Path | None
    output: pathlib.Path
    cache: pathlib.Path
    compliance_cache: pathlib.Path
    checkout: pathlib.Path | None

    @classmethod
    def resolve(cls, *, fmu: os.PathLike | str | None = None, output: os.PathLike | str | None = None,
                checkout: os.PathLike | str | None = None, cwd: os.PathLike | str | None = None,
                env: Mapping[str, str] | None = None) -> Paths:
        """The paths from the options given (None: not given), then `env` (default os.environ),
        then the installed package's data and the checkout (module docstring)."""
        env = os.environ if env is None else env
        cwd = pathlib.Path(cwd) if cwd is not None else pathlib.Path.cwd()
        if checkout is not None:
            root = pathlib.Path(checkout).resolve()
        elif env.get(ENV_CHECKOUT):
            root = pathlib.Path(env[ENV_CHECKOUT]).expanduser().resolve()
        else:
            root = find_checkout(cwd)
        data = package_data()
        build = root / "build" if root else None

        def pick(option, env_name, data_name, build_rel):
            if option is not None:
                return pathlib.Path(option)
            from_env = _env_path(env, env_name) if env_name else None
            if from_env is not None:
                return from_env
            return _first(data / data_name if data else None, build / build_rel if build else None)

        which = shutil.which("compliance_tool")
        tool = _env_path(env, ENV_COMPLIANCE_TOOL) or _first(
            data / "compliance_tool" if data else None,
            build / "compliance_tool" / "compliance_tool" if build else None,
            pathlib.Path(which) if which else None)
        if env.get(ENV_OUTPUT):
            out = pathlib.Path(env[ENV_OUTPUT]).expanduser()
        else:
            out = (root or cwd) / "output"
        if output is not None:
            out = pathlib.Path(output)
        if env.get(ENV_CACHE):
            cache = pathlib.Path(env[ENV_CACHE]).expanduser()
        elif root:
            cache = root / ".cache"
        else:
            import platformdirs

            cache = pathlib.Path(platformdirs.user_cache_dir("gearmesh"))
        compliance_cache = (_env_path(env, ENV_COMPLIANCE_CACHE)
                            or (root / "output" / "compliance_cache" if root else cache / "compliance"))
        return cls(fmu=pick(fmu, ENV_FMU, "GearMesh.fmu", "GearMesh.fmu"),
                   fmu3=pick(None, ENV_FMU3, "GearMesh-fmi3.fmu", "GearMesh-fmi3.fmu"),
                   train_binary=pick(None, ENV_TRAIN_BINARY, "GearTrain.so",
                                     pathlib.Path("fmu_src") / "GearTrain.so"),
                   train_binary3=pick(None, ENV_TRAIN_BINARY3, "GearTrain3.so",
                                      pathlib.Path("fmu_src") / "GearTrain3.so"),
                   train_header=_first(data / "train_variables.h" if data else None,
                                       root / "fmu_src" / "train_variables.h" if root else None),
                   compliance_tool=tool,
                   scenes=_env_path(env, ENV_SCENES) or (root / "scenarios" if root else None),
                   output=out, cache=cache, compliance_cache=compliance_cache, checkout=root)

    def require(self, field: str) -> pathlib.Path:
        """The path of `field` when it exists; else NotFound saying where GearMesh looked and how
        to get the file."""
        path = getattr(self, field)
        if path is not None and path.exists():
            return path
        how = {
            "fmu": f"install the package (pip install gearmesh, or pip install a checkout), build "
                   f"a checkout (cmake --build build --target fmu), or set ${ENV_FMU}",
            "fmu3": f"install the package, build a checkout (target fmu3), or set ${ENV_FMU3}",
            "train_binary": f"install the package, build a checkout (target GearTrain), or set "
                            f"${ENV_TRAIN_BINARY}",
            "train_binary3": f"install the package, build a checkout (target GearTrain3), or set "
                             f"${ENV_TRAIN_BINARY3}",
            "train_header": "install the package, or work in a GearMesh checkout",
            "compliance_tool": COMPLIANCE_TOOL_ROUTE,
            "scenes": f"name the scene files, work in a GearMesh checkout, or set ${ENV_SCENES}",
        }.get(field, "")
        where = path if path is not None else "nowhere (not installed, no checkout)"
        raise NotFound(f"{field.replace('_', ' ')} not found (looked for {where}): {how}")


def resolve(**options) -> Paths:
    """Paths.resolve(**options)."""
    return Paths.resolve(**options)
