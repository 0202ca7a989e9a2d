"""The FMU parameters' ranges as the FMU declares them: min and max in its modelDescription.xml,
written from the core's parameter table (core/include/gearmesh/parameters.h), whose ranges the
binary enforces; and what reads each parameter (parameter_use: the levels and modes, the gear
body, a file), from the same table through the model's <Tool name="GearMesh.parameters">.
Open bounds, which FMI 2.0 cannot state, are marked in the model's vendor annotation
<Tool name="GearMesh"><Ranges><Range variable="..." minExclusive="true" .../>
(modelDescription/generate_model_description.c).
"""
from __future__ import annotations

import functools
import math
import pathlib
import types
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass

from gearmesh.paths import Paths



@dataclass(frozen=True)
class Range:
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    start: float | None = None  # the FMU's default (its start value), if it declares one

    def contains(self, x: float | int) -> bool:
        """x finite and inside (an int of any size is compared exactly)."""
        if not isinstance(x, int) and not math.isfinite(x):
            return False
        above = x > self.lo if self.lo_open else x >= self.lo
        return above and (x < self.hi if self.hi_open else x <= self.hi)

    def text(self, scale: float = 1.0) -> str:
        """'[lo, hi]' of the values v with v * scale in the range; round brackets at open or
        missing bounds."""
        lo, hi = self.lo / scale, self.hi / scale
        left = "(" if self.lo_open or math.isinf(lo) else "["
        right = ")" if self.hi_open or math.isinf(hi) else "]"
        return f"{left}{lo:g}, {hi:g}{right}"


def default_fmu() -> pathlib.Path:
    """$GEARMESH_FMU, else the installed package's GearMesh.fmu, else the checkout's build
    (gearmesh.paths)."""
    return Paths.resolve().require("fmu")


def fmu_ranges(fmu: pathlib.Path | str | None = None) -> Mapping[str, Range]:
    """FMU parameter name -> its Range (SI), for every parameter with a declared min or max.
    FileNotFoundError names a missing FMU; OSError an FMU without a readable
    modelDescription.xml."""
    path = pathlib.Path(fmu) if fmu is not None else default_fmu()
    try:
        stat = path.stat()
    except OSError:
        raise FileNotFoundError(f"{path}: no FMU; the ranges of the FMU parameters come from its "
                                "modelDescription.xml (build the 'fmu' target, or name the FMU "
                                "with --fmu or GEARMESH_FMU)") from None
    return _read(str(path.resolve()), stat.st_mtime_ns, stat.st_size)


def open_bounds(root: ET.Element) -> dict[str, dict[str, str]]:
    """variable name -> its exclusive-bound flags (minExclusive, maxExclusive), from the model's
    <VendorAnnotations><Tool name="GearMesh"><Ranges><Range variable=...> (generate_model_description.c)."""
    return {r.get("variable"): dict(r.attrib)
            for r in root.findall("VendorAnnotations/Tool[@name='GearMesh']/Ranges/Range")}


@dataclass(frozen=True)
class Use:
    """What reads a parameter (gearmesh/parameters.h): the stiffness levels and the modes
    (prescribed, quasi_static, large_step; None: all), whether compliance_tool reads it for the
    gear body, whether it names a file."""
    levels: frozenset[int] | None = None
    modes: frozenset[str] | None = None
    body: bool = False
    file: bool = False

    def read(self, level: int | None, modes) -> bool:
        """Whether a scene at `level` (None: not fixed) running in `modes` reads it."""
        if self.levels is not None and level is not None and level not in self.levels:
            return False
        return self.modes is None or any(m in self.modes for m in modes)


def parameter_use(fmu: pathlib.Path | str | None = None) -> Mapping[str, Use]:
    """FMU parameter name -> its Use, for every parameter the table marks (the others: Use()).
    An FMI 3.0 FMU carries no vendor annotations (docs/fmi.md): its use is that of the FMI 2.0
    default_fmu() built from the same table."""
    path = pathlib.Path(fmu) if fmu is not None else default_fmu()
    stat = path.stat()
    out = _read_use(str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    if out is None:
        return parameter_use(default_fmu())
    return out


def fmi_version(fmu: pathlib.Path | str) -> str:
    """The FMU's fmiVersion ("2.0", "3.0"), from its modelDescription.xml."""
    path = pathlib.Path(fmu)
    stat = path.stat()
    return _read_version(str(path.resolve()), stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=8)
def _read_version(path: str, mtime_ns: int, size: int) -> str:
    with zipfile.ZipFile(path) as z:
        return ET.fromstring(z.read("modelDescription.xml")).get("fmiVersion", "")


@functools.lru_cache(maxsize=8)
def _read_use(path: str, mtime_ns: int, size: int) -> Mapping[str, Use] | None:
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    if root.get("fmiVersion", "").startswith("3"):
        return None
    out = {}
    for p in root.findall("VendorAnnotations/Tool[@name='GearMesh.parameters']/Parameters/Parameter"):
        levels, modes = p.get("levels"), p.get("modes")
        out[p.get("variable")] = Use(frozenset(int(x) for x in levels.split()) if levels else None,
                                     frozenset(modes.split()) if modes else None,
                                     p.get("body") == "true", p.get("file") == "true")
    return types.MappingProxyType(out)


@functools.lru_cache(maxsize=8)
def _read(path: str, mtime_ns: int, size: int) -> Mapping[str, Range]:
    """The ranges of the FMU at path (mtime and size: a rebuilt FMU is read again)."""
    try:
        with zipfile.ZipFile(path) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError) as exc:
        raise OSError(f"{path}: not an FMU with a readable modelDescription.xml ({exc})") from None
    out = {}
    exclusive = open_bounds(root)
    for sv in root.iter("ScalarVariable"):
        typ = sv[0]
        if sv.get("causality") != "parameter" or ("min" not in typ.attrib and "max" not in typ.attrib):
            continue
        flags = exclusive.get(sv.get("name"), {})
        start = typ.get("start")
        out[sv.get("name")] = Range(float(typ.get("min", "-inf")), float(typ.get("max", "inf")),
                                    flags.get("minExclusive") == "true",
                                    flags.get("maxExclusive") == "true",
                                    float(start) if start is not None and typ.tag != "Boolean" else None)
    return types.MappingProxyType(out)
