"""A sampled study of one scene (docs/batch.md, "Studies"): `--sample NAME=DIST(A,B)` draws
FMU parameters or inputs (e.g. gear2.rx, a misalignment) and single pitch deviations per tooth
(gear<i>.pitch_A / pitch_B, written into a generated deviation file per case) with numpy's
random Generator from `--seed`; the cases then run as a batch (gearmesh.batch).

DIST is normal(MEAN,SD) or uniform(LO,HI); the numbers take a unit of the variable's quantity as
the FMU's modelDescription.xml defines it (its unit or one of that unit's display units: m, mm,
um; rad, mrad, deg; ...), a number without unit that of the other number, or SI if neither has
one. Pitch deviations are drawn per tooth and then centred (their sum around the gear must be
zero, docs/model.md), which scales their spread by sqrt((z-1)/z).
"""
from __future__ import annotations

import dataclasses
import difflib
import json
import math
import pathlib
import re
from dataclasses import dataclass

import numpy as np

from gearmesh.batch.cases import Case
from gearmesh.main_job import RUN_DEFAULTS
from gearmesh.param_ranges import fmu_ranges
from gearmesh.scene import Scene

MAX_CASES = 100_000
# set by the quasi-static sweep itself: sampling them would be overwritten
SWEEP_VARIABLES = {"gear1.phi", "gear2.phi", "gear1.omega", "gear2.omega", "mesh.load_torque",
                   "model.quasi_static"}
MAX_PITCH_M = 10000e-6   # the deviation file's limit (|deviation| <= 10000 um)
_SPEC = re.compile(r"^\s*([A-Za-z0-9_.]+)\s*=\s*([a-z]+)\s*\((.*)\)\s*$")
_NUMBER = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*([^\s\d.+-][^\s]*)?\s*$")
_PITCH = re.compile(r"^gear([12])\.pitch_([AB])$")
DISTRIBUTIONS = ("normal", "uniform")


@dataclass(frozen=True)
class Sample:
    text: str          # the spec as given
    name: str          # FMU variable, or gear<i>.pitch_<flank>
    dist: str          # normal | uniform
    a: float           # mean or low bound, SI
    b: float           # standard deviation or high bound, SI
    unit: str          # the unit the spec used (for the report)
    factor: float      # SI -> that unit


@dataclass
class Plan:
    scene: Scene
    samples: list[Sample]
    seed: int
    cases: int
    values: dict[str, np.ndarray]     # name -> (cases,) or pitch: (cases, teeth), SI
    out: pathlib.Path


def _units(md) -> dict[str, dict[str, float]]:
    """Unit name -> {accepted spelling: factor from SI}, from the FMU's UnitDefinitions."""
    out = {}
    for unit in md.unitDefinitions:
        out[unit.name] = {unit.name: 1.0, **{d.name: d.factor for d in unit.displayUnits}}
    return out


def variable_unit(name: str, md, where: str) -> str:
    """The unit of `name`, a Real parameter or input of the FMU that the sweep does not set
    (ValueError naming `where` and what is allowed; close names suggested)."""
    variables = {v.name: v for v in md.modelVariables}
    var = variables.get(name)
    if var is None or var.causality not in ("parameter", "input") or var.type != "Real":
        close = difflib.get_close_matches(name, [n for n, v in variables.items()
                                                 if v.type == "Real"], 3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise ValueError(f"{where}: unknown parameter {name!r}{hint}; allowed: a Real parameter "
                         "or input of the FMU (docs/fmi.md), or for --sample gear1.pitch_A, "
                         "gear1.pitch_B, gear2.pitch_A, gear2.pitch_B")
    if name in SWEEP_VARIABLES:
        raise ValueError(f"{where}: {name} is set by the sweep itself; allowed: any other Real "
                         f"parameter or input (not {', '.join(sorted(SWEEP_VARIABLES))})")
    return var.unit or (var.declaredType.unit if var.declaredType else None) or ""


def parse_sample(text: str, md) -> Sample:
    """One --sample spec, checked against the FMU's variables and units (ValueError naming the
    spec and what is allowed)."""
    m = _SPEC.match(text)
    if not m:
        raise ValueError(f"--sample {text!r}: expected NAME=normal(MEAN,SD) or "
                         "NAME=uniform(LO,HI), e.g. gear2.rx=normal(0,0.3mrad)")
    name, dist, args = m.groups()
    if dist not in DISTRIBUTIONS:
        raise ValueError(f"--sample {text!r}: unknown distribution {dist!r}; allowed: "
                         f"{', '.join(DISTRIBUTIONS)}")
    unit = "m" if _PITCH.match(name) else variable_unit(name, md, f"--sample {text!r}")
    parts = args.split(",")
    parsed = [_NUMBER.match(p) for p in parts]
    if len(parts) != 2 or not all(parsed):
        raise ValueError(f"--sample {text!r}: {dist} takes two numbers with an optional unit, "
                         f"e.g. {dist}(0,0.3mrad)")
    given = {p.group(2) for p in parsed if p.group(2)}
    spellings = _units(md).get(unit, {unit: 1.0} if unit else {})
    if len(given) > 1:
        raise ValueError(f"--sample {text!r}: two units {sorted(given)}; give both numbers in one")
    used = given.pop() if given else unit
    if used and used not in spellings:
        allowed = ", ".join(spellings) if spellings else "none (a dimensionless number)"
        raise ValueError(f"--sample {text!r}: unit {used!r} is not one of {name}'s; allowed: "
                         f"{allowed}")
    factor = spellings.get(used, 1.0) if used else 1.0
    a, b = (float(p.group(1)) / factor for p in parsed)
    if not all(map(math.isfinite, (a, b))):
        raise ValueError(f"--sample {text!r}: the numbers must be finite")
    if dist == "normal" and b < 0:
        raise ValueError(f"--sample {text!r}: standard deviation {b * factor:g} {used}; allowed "
                         "range [0, inf)")
    if dist == "uniform" and b < a:
        raise ValueError(f"--sample {text!r}: low bound above high bound; allowed: LO <= HI")
    return Sample(text, name, dist, a, b, used, factor)


def plan(scene: Scene, specs: list[str], cases: int, seed: int, fmu: pathlib.Path,
         out: pathlib.Path) -> Plan:
    """Parse the specs, draw every case's values, write the deviation files and study.json (the
    seed and specs, so that the study reproduces). ValueError on bad input."""
    from fmpy import read_model_description

    if not 1 <= cases <= MAX_CASES:
        raise ValueError(f"--cases {cases}: allowed range [1, {MAX_CASES}]")
    if not 0 <= seed < 2**63:
        raise ValueError(f"--seed {seed}: allowed range [0, 2^63)")
    md = read_model_description(str(fmu))
    samples = [parse_sample(s, md) for s in specs]
    names = [s.name for s in samples]
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"--sample {twice[0]}: given twice; allowed: one spec per parameter")
    rng = np.random.default_rng(seed)
    ranges = fmu_ranges(fmu)
    values = {}
    for s in samples:
        pitch = _PITCH.match(s.name)
        size = (cases, _teeth(scene, md, int(pitch.group(1)))) if pitch else cases
        drawn = rng.normal(s.a, s.b, size) if s.dist == "normal" else rng.uniform(s.a, s.b, size)
        if pitch:
            if f"gear{pitch.group(1)}.deviations" in scene.parameters:
                raise ValueError(f"--sample {s.text!r}: the scene already has "
                                 f"gear{pitch.group(1)}.deviations_file; allowed: pitch "
                                 "sampling on a gear without a deviation file")
            drawn = drawn - drawn.mean(axis=1, keepdims=True)
            rng_text, bad = f"[{-MAX_PITCH_M * 1e6:g}, {MAX_PITCH_M * 1e6:g}] um", \
                np.abs(drawn) > MAX_PITCH_M
        else:
            r = ranges.get(s.name)
            bad = np.array([not r.contains(float(v)) for v in drawn]) if r else drawn != drawn
            rng_text = f"{r.text(1 / s.factor)} {s.unit}".rstrip() if r else "finite"
        if bad.any():
            raise ValueError(f"--sample {s.text!r}: {int(bad.sum())} of {bad.size} draws outside "
                             f"the allowed range {rng_text}; narrow the distribution")
        values[s.name] = drawn
    result = Plan(scene, samples, seed, cases, values, out)
    _write_plan(result)
    return result


def _teeth(scene: Scene, md, gear: int) -> int:
    name = f"gear{gear}.teeth"
    if name in scene.parameters:
        return int(scene.parameters[name])
    return int(next(v.start for v in md.modelVariables if v.name == name))


def _write_plan(p: Plan) -> None:
    p.out.mkdir(parents=True, exist_ok=True)
    (p.out / "study.json").write_text(json.dumps({
        "scene": str(p.scene.path), "seed": p.seed, "cases": p.cases,
        "samples": [s.text for s in p.samples],
        "values_SI": {n: v.tolist() for n, v in p.values.items() if v.ndim == 1}}, indent=1))
    folder = p.out / "deviations"
    for k in range(p.cases):
        for gear in (1, 2):
            lines = [f"pitch {t} {flank} {float(f) * 1e6!r}"
                     for flank in "AB" if f"gear{gear}.pitch_{flank}" in p.values
                     for t, f in enumerate(p.values[f"gear{gear}.pitch_{flank}"][k])]
            if lines:
                folder.mkdir(exist_ok=True)
                teeth = p.values.get(f"gear{gear}.pitch_A", p.values.get(f"gear{gear}.pitch_B")).shape[1]
                deviation_file(p, k, gear).write_text("\n".join([
                    "gearmesh-deviations 1",
                    f"# gearmesh study, seed {p.seed}, case {k}: single pitch deviations in um",
                    f"teeth {teeth}", *lines, ""]))


def deviation_file(p: Plan, case: int, gear: int) -> pathlib.Path:
    return p.out / "deviations" / f"case{case:06d}.gear{gear}.txt"


def expand(p: Plan, torques: list[float] | None) -> list[Case]:
    """Every case x torque (default: the scene's run.torques_Nm); column `case` numbers them."""
    run = {**RUN_DEFAULTS, **p.scene.run}
    scalar = sorted(n for n in p.values if not _PITCH.match(n))
    gears = sorted({int(_PITCH.match(n).group(1)) for n in p.values if _PITCH.match(n)})
    out = []
    for k in range(p.cases):
        scene = p.scene
        if gears:
            resources, parameters = dict(scene.resources), dict(scene.parameters)
            for gear in gears:
                resources[f"gear{gear}_study.txt"] = deviation_file(p, k, gear)
                parameters[f"gear{gear}.deviations"] = f"gear{gear}_study.txt"
            scene = dataclasses.replace(scene, resources=resources, parameters=parameters)
        overrides = tuple((n, float(p.values[n][k])) for n in scalar)
        for torque in torques or run["torques_Nm"]:
            out.append(Case(scene, float(torque), overrides, (("case", k),)))
    return out
