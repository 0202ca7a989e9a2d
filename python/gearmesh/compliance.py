"""Compliance databases of a scene at the FE level (model.stiffness = 5): each gear's .gcdb
from compliance_tool, cached, and shipped in the scene FMU as gear<i>.compliance.

The tool (compliance_tool/README.md) takes the gear as --param pairs with the FMU's names in SI
and the body ([gear<i>.body]) and discretization ([fe]) as flags in mm; this module passes a
scene's keys that way. Builds are cached in output/compliance_cache (git-ignored) under a SHA-256
of the tool binary's bytes and of every input that can change the database: the gear's own
parameters, the pair's, the gear's role (its helix hand: gear 2 of an external pair turns the
other way; the ring of an internal pair), the mating gear's parameters (conservative: the tool
validates the whole pair), the body and [fe] options, model.coupled_teeth and the bytes of a
user mesh. The gear's number is not an input, so two equal gears of a pair (set A) build once:
the database records the gear, not its number (core/src/compliance_db.cpp, record_gear). Not in
the key: the shared libraries the tool loads (gmsh, CHOLMOD); clear the cache after changing them.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time
from collections import deque
from dataclasses import dataclass

from gearmesh.levels import Level
from gearmesh.param_ranges import parameter_use
from gearmesh.paths import COMPLIANCE_TOOL_ROUTE, Paths
from gearmesh.scene import BODY_SCHEMA, FE_SCHEMA, SCHEMA, Scene

TOOL_ENV = "GEARMESH_COMPLIANCE_TOOL"
CACHE_ENV = "GEARMESH_COMPLIANCE_CACHE"
_SUMMARY = re.compile(r"^compliance_tool:\s+(nodes=.*)$")


class ComplianceError(RuntimeError):
    """A database could not be built; the message names the gear and the scene keys involved."""


@dataclass
class Build:
    gear: int
    path: pathlib.Path        # the database in the cache
    cached: bool              # True: found in the cache, the tool did not run
    key: str                  # the cache key (SHA-256 hex)
    seconds: float = 0.0      # wall time of the tool run (0 on a cache hit)
    summary: dict = dataclasses.field(default_factory=dict)  # the tool's summary line, parsed


def default_tool() -> pathlib.Path:
    """$GEARMESH_COMPLIANCE_TOOL, else the installed package's, else the checkout's build, else
    compliance_tool on PATH (gearmesh.paths)."""
    tool = Paths.resolve().compliance_tool
    return tool if tool is not None else pathlib.Path("compliance_tool")


def default_cache() -> pathlib.Path:
    """$GEARMESH_COMPLIANCE_CACHE, else the checkout's output/compliance_cache, else the user's cache
    folder (gearmesh.paths)."""
    return Paths.resolve().compliance_cache


def sha256_file(path: pathlib.Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


_tool_hashes: dict[tuple, str] = {}


def tool_hash(tool: pathlib.Path) -> str:
    """SHA-256 of a file (the tool binary; a batch's input files), remembered per (path, size,
    mtime) within the process."""
    st = tool.stat()
    key = (str(tool.resolve()), st.st_size, st.st_mtime_ns)
    if key not in _tool_hashes:
        _tool_hashes[key] = sha256_file(tool)
    return _tool_hashes[key]


def needs_build(scene: Scene) -> list[int]:
    """The gears whose database the tool has to make (level 5, no prebuilt compliance_file)."""
    if scene.level != Level.FE:
        return []
    return [i for i in (1, 2) if f"gear{i}.compliance" not in scene.parameters]


def _body_parameters(scene: Scene) -> dict:
    """The scene's FMU parameters that the tool reads (the parameter table's body flag: the pair,
    the gears' body and material, coupled teeth); the rest does not change the body."""
    use = parameter_use()
    return {name: value for name, value in scene.parameters.items() if name in use and use[name].body}


def tool_arguments(scene: Scene, gear: int, threads: int = 1) -> list[str]:
    """compliance_tool's arguments for one gear, without --out and --note."""
    args = ["--gear", str(gear)]
    for name, value in sorted(_body_parameters(scene).items()):
        text = ("1" if value else "0") if isinstance(value, bool) else repr(value)
        args += ["--param", f"{name}={text}"]
    for key, value in scene.bodies.get(gear, {}).items():
        flag = BODY_SCHEMA[key].variable
        args += [flag, str(value) if isinstance(value, pathlib.Path) else repr(value)]
    for key, value in scene.fe.items():
        args += [FE_SCHEMA[key].variable, repr(value)]
    coupled = scene.parameters.get("model.coupled_teeth")
    if coupled is not None:
        args += ["--coupled", str(coupled)]
    if threads != 1:
        args += ["--threads", str(threads)]
    return args


def cache_key(scene: Scene, gear: int, tool: pathlib.Path, threads: int = 1) -> str:
    """SHA-256 of the tool and of everything that can change gear `gear`'s database (module doc)."""
    params = _body_parameters(scene)
    other = 3 - gear

    def gear_params(i):
        return {n.split(".", 1)[1]: v for n, v in params.items() if n.startswith(f"gear{i}.")}

    pair = {n: v for n, v in params.items() if n.startswith("pair.")}
    beta = pair.get("pair.helix_angle", 0.0)
    internal = bool(pair.get("pair.internal", False))
    role = {"hand_helix_angle": (beta if gear == 1 or internal else -beta) + 0.0,
            "ring": gear == 2 and internal}
    pair.pop("pair.helix_angle", None)
    body = {}
    for key, value in scene.bodies.get(gear, {}).items():
        body[key] = sha256_file(value) if isinstance(value, pathlib.Path) else value
    inputs = {"tool": tool_hash(tool), "gear": gear_params(gear), "mate": gear_params(other),
              "pair": pair, "role": role, "body": body, "fe": scene.fe,
              "coupled": params.get("model.coupled_teeth"), "threads": threads}
    text = json.dumps(inputs, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _scene_keys_for(scene: Scene, gear: int) -> dict[str, str]:
    """Text that can appear in the tool's messages -> the scene key (with its value)."""
    out = {}
    for key, value in scene.bodies.get(gear, {}).items():
        flag = BODY_SCHEMA[key].variable
        label = f"gear{gear}.body.{key} = {value}"
        stem = key.removesuffix("_mm").removesuffix("_file")
        for token in (flag, stem, stem.replace("_", " "), stem.replace("_", "-")):
            if token:
                out[token] = label
    for key, value in scene.fe.items():
        flag = FE_SCHEMA[key].variable
        stem = key.removesuffix("_mm")
        for token in (flag, stem, stem.replace("_", " ")):
            out[token] = f"fe.{key} = {value}"
    for section, keys in SCHEMA.items():
        for key, spec in keys.items():
            if spec.variable in scene.parameters:
                out[spec.variable] = f"{section}.{key}"
    return out


def _explain(scene: Scene, gear: int, message: str) -> str:
    """The tool's message with the scene keys it concerns named (longest match first)."""
    tokens = _scene_keys_for(scene, gear)
    named = []
    for token in sorted(tokens, key=len, reverse=True):
        if re.search(r"(?<![\w.-])" + re.escape(token) + r"(?![\w-])", message):
            if tokens[token] not in named:
                named.append(tokens[token])
    if named:
        return f"{message} [scene key: {', '.join(named)}]"
    given = [f"gear{gear}.body.{k}" for k in scene.bodies.get(gear, {})] + [f"fe.{k}" for k in scene.fe]
    return message + (f" [scene keys given for this build: {', '.join(given)}]" if given else "")


def check_bodies(scene: Scene, tool: pathlib.Path | None = None) -> None:
    """The body of each gear the tool is to build against that gear (compliance_tool --check: the
    web, the holes, the bore and the ring against each other and the root circle, the tool's rules
    in one place); ComplianceError with the tool's message and the scene keys it names. Without a
    compliance_tool nothing is checked here: building the databases then says how to get it."""
    gears = [i for i in needs_build(scene) if scene.bodies.get(i)]
    if not gears:
        return
    tool = pathlib.Path(tool) if tool is not None else Paths.resolve().compliance_tool
    if tool is None or not tool.is_file():
        return
    for gear in gears:
        proc = subprocess.run([str(tool), "--check", *tool_arguments(scene, gear)], capture_output=True, text=True)
        if proc.returncode != 0:
            lines = [t.removeprefix("compliance_tool: ") for t in proc.stderr.splitlines()
                     if t.strip() and not t.startswith(("usage:", "  "))]
            raise ComplianceError(_in_scene_terms(_explain(scene, gear, (lines or ["no message"])[-1]), gear))


def _in_scene_terms(message: str, gear: int) -> str:
    """The tool's message with its flags named as the scene's keys (--hub-diameter-mm ->
    gear<gear>.body.hub_diameter_mm, --depth-mm -> fe.depth_mm)."""
    names = {spec.variable: f"gear{gear}.body.{key}" for key, spec in BODY_SCHEMA.items() if spec.variable}
    names |= {spec.variable: f"fe.{key}" for key, spec in FE_SCHEMA.items()}
    for flag in sorted(names, key=len, reverse=True):
        message = re.sub(r"(?<![\w-])" + re.escape(flag) + r"(?![\w-])", names[flag], message)
    return message


def parse_summary(text: str) -> dict:
    """`compliance_tool: nodes=... total_s=... peak_rss_MiB=...` -> {name: number}."""
    out = {}
    for line in text.splitlines():
        m = _SUMMARY.match(line.strip())
        if m:
            for item in m.group(1).split():
                name, _, value = item.partition("=")
                try:
                    out[name] = float(value) if any(c in value for c in ".eE") else int(value)
                except ValueError:
                    out[name] = value
    return out


def build_gear(scene: Scene, gear: int, tool: pathlib.Path | None = None,
               cache: pathlib.Path | None = None, progress: bool = True, threads: int = 1,
               force: bool = False) -> Build:
    """Gear `gear`'s database: from the cache, or made by the tool and stored there.
    progress: pass the tool's stderr through (prefixed with the scene and gear)."""
    tool = pathlib.Path(tool or default_tool())
    cache = pathlib.Path(cache or default_cache())
    if not tool.is_file():
        try:
            Paths.resolve().require("compliance_tool")
        except FileNotFoundError as exc:  # the message names the tool's path when it looked there
            raise ComplianceError(str(exc) if str(tool) in str(exc) else f"{tool}: {exc}") from None
        raise ComplianceError(f"{tool}: compliance_tool not found: {COMPLIANCE_TOOL_ROUTE}")
    key = cache_key(scene, gear, tool, threads)
    target = cache / f"{key}.gcdb"
    if target.is_file() and not force:
        meta = target.with_suffix(".json")
        summary = json.loads(meta.read_text())["summary"] if meta.is_file() else {}
        return Build(gear, target, True, key, 0.0, summary)
    cache.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f"{key}.", suffix=".part", dir=cache)
    os.close(fd)
    args = tool_arguments(scene, gear, threads)
    command = [str(tool), "--scene", str(scene.path), "--out", tmp, *args]
    label = f"{scene.name} gear{gear}"
    tail: deque[str] = deque(maxlen=20)
    start = time.perf_counter()
    try:
        with tempfile.TemporaryFile("w+") as out:
            proc = subprocess.Popen(command, stdout=out, stderr=subprocess.PIPE, text=True)
            for line in proc.stderr:
                tail.append(line.rstrip())
                if progress:
                    print(f"[{label}] {line.rstrip()}", file=sys.stderr, flush=True)
            rc = proc.wait()
            out.seek(0)
            stdout = out.read()
        seconds = time.perf_counter() - start
        if rc != 0:
            lines = [t for t in tail if t.strip()]
            errors = [t for t in lines if not t.startswith("usage:") and not t.startswith("  ")]
            message = (errors or lines or ["no message"])[0 if rc == 2 else -1]
            if rc < 0:
                cause = " (SIGKILL: often the out-of-memory killer; coarsen [fe])" if rc == -9 else ""
                message = f"killed by signal {-rc}{cause} after: {message}"
            raise ComplianceError(f"{label}: compliance_tool failed (exit {rc}): "
                                  f"{_explain(scene, gear, message)}")
        summary = parse_summary(stdout)
        os.replace(tmp, target)
        target.with_suffix(".json").write_text(json.dumps(
            {"scene": str(scene.path), "gear": gear, "arguments": args, "seconds": seconds,
             "summary": summary}, indent=1, default=str))
        return Build(gear, target, False, key, seconds, summary)
    finally:
        pathlib.Path(tmp).unlink(missing_ok=True)


def build_databases(scene: Scene, tool: pathlib.Path | None = None,
                    cache: pathlib.Path | None = None, progress: bool = True,
                    gears: list[int] | None = None, threads: int = 1,
                    force: bool = False) -> dict[int, Build]:
    """The databases the scene needs (or of `gears`), gear by gear (equal gears build once)."""
    gears = needs_build(scene) if gears is None else gears
    return {i: build_gear(scene, i, tool, cache, progress, threads, force) for i in gears}


def with_databases(scene: Scene, tool: pathlib.Path | None = None,
                   cache: pathlib.Path | None = None, progress: bool = True) -> Scene:
    """The scene with its databases as FMU resources gear<i>.gcdb named by gear<i>.compliance
    (level 5; any other level: the scene itself)."""
    builds = build_databases(scene, tool, cache, progress)
    if not builds:
        return scene
    parameters, resources = dict(scene.parameters), dict(scene.resources)
    for i, b in builds.items():
        resources[f"gear{i}.gcdb"] = b.path
        parameters[f"gear{i}.compliance"] = f"gear{i}.gcdb"
    return dataclasses.replace(scene, parameters=parameters, resources=resources)
