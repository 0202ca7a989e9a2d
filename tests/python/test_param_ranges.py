"""One source of parameter ranges (core/src/param_ranges.cpp, docs/fmi.md "Ranges"): the min and
max that modelDescription.xml declares are what the binary enforces at initialization, every
static range check of the binary is declared, and the scene checks give the same ranges in the
scene's units."""
from __future__ import annotations

import math

import pytest
from fmpy.fmi1 import FMICallException

from gearmesh.param_ranges import Range, fmu_ranges
from gearmesh.scene import SCHEMA, SceneError, parse_scene

from test_fmu_conformance import LEVEL0

NUMERIC = ("Real", "Integer")


def ranged(md, fmu_path) -> list[tuple]:
    """(variable, Range) of every parameter with a declared min or max: the bounds as fmpy reads
    them, the open flags from the GearMesh annotation."""
    flags = fmu_ranges(fmu_path)
    out = []
    for v in md.modelVariables:
        if v.causality == "parameter" and (v.min is not None or v.max is not None):
            f = flags[v.name]
            lo = float(v.min) if v.min is not None else -math.inf
            hi = float(v.max) if v.max is not None else math.inf
            out.append((v, Range(lo, hi, f.lo_open, f.hi_open)))
    return out


def range_message(v, value: float, r: Range) -> str:
    """The binary's message for a value outside the static range (param_ranges.cpp)."""
    unit = f" {v.unit}" if v.unit else ""
    bounds = f"{'(' if r.lo_open or math.isinf(r.lo) else '['}{r.lo:.9g}, {r.hi:.9g}" \
             f"{')' if r.hi_open or math.isinf(r.hi) else ']'}"
    return f"{v.name} = {value:.9g}{unit}: allowed range {bounds}{unit}"


def refused_by_static_range(log: str | None, v, value: float, r: Range) -> bool:
    """The log says v = value is outside the static range with r's bounds, either bracket (a
    bound the binary treats as open but modelDescription.xml as closed is found too)."""
    if log is None:
        return False
    closed = range_message(v, value, Range(r.lo, r.hi))
    return any(closed.replace("[", a, 1).replace("]", b, 1) in log for a in "[(" for b in "])")


def just_outside(v, bound: float, is_open: bool, direction: float) -> float:
    """The nearest value beyond the bound (the bound itself when it is open)."""
    if is_open:
        return bound
    return bound + direction if v.type == "Integer" else math.nextafter(bound, direction * math.inf)


def refusal(new, v, value, base: dict | None = None) -> str | None:
    """The FMU's log when initialization with v = value (and the parameters base) fails, else
    None."""
    inst = new()
    try:
        inst.initialize({**(base or {}), v.name: int(value) if v.type == "Integer" else value})
    except FMICallException:
        return inst.log.text()
    return None


def bounds(md, fmu_path):
    """(variable, Range, bound, is_open, direction) of every finite declared bound."""
    for v, r in ranged(md, fmu_path):
        for bound, is_open, direction in ((r.lo, r.lo_open, -1.0), (r.hi, r.hi_open, 1.0)):
            if math.isfinite(bound):
                yield v, r, bound, is_open, direction


def test_declared_ranges_of_the_issue(md, fmu_path):
    """The ranges issue 13 found undeclared or wrong."""
    declared = {v.name: r for v, r in ranged(md, fmu_path)}
    for i in (1, 2):
        assert declared[f"gear{i}.teeth"] == Range(5, 2000)
        assert declared[f"gear{i}.thickness_allowance"].hi == 0
        assert declared[f"gear{i}.profile_crowning"] == Range(0, 1e-3)
        assert declared[f"gear{i}.poisson_ratio"] == Range(0, 0.5, hi_open=True)
    assert declared["model.slices"] == Range(1, 200)
    assert declared["pair.center_distance"] == Range(0, 20, lo_open=True)
    variables = {v.name: v for v in md.modelVariables}
    assert variables["pair.center_distance"].description.endswith("(min exclusive)")


def test_every_declared_bound_is_enforced_at_initialization(new, md, fmu_path):
    """Just outside a declared bound: refused, the message naming the variable and the declared
    range. At a closed bound: not refused by the static range (a bound that depends on other
    parameters, or the geometry, may still refuse it, with its own message)."""
    checked = 0
    for v, r, bound, is_open, direction in bounds(md, fmu_path):
        bad = just_outside(v, bound, is_open, direction)
        log = refusal(new, v, bad)
        assert log is not None, f"{v.name} = {bad!r} accepted; declared {r}"
        assert range_message(v, bad, r) in log, log
        if not is_open:
            log = refusal(new, v, bound)
            assert not refused_by_static_range(log, v, bound, r), log
        checked += 1
    assert checked >= 120


def test_parameters_accepted_at_their_closed_bounds(new, md, fmu_path):
    """Parameters that no other parameter or the geometry constrains initialize at each closed
    bound: at level 0 on one slice (LEVEL0), where none of them does. At the default level 4
    model.coupled_teeth's maximum is 3 and one solver iteration does not converge the coupled
    contact (test_coupled_teeth_bound_at_level_4, test_iteration_cap_at_level_4_names_its_parameter)."""
    free = ("model.slices", "model.friction_coefficient", "model.damping", "model.rated_line_load",
            "solver.max_iterations", "gear1.youngs_modulus", "gear2.profile_crowning",
            "gear1.inertia", "gear2.shaft_damping", "dynamics.tolerance", "model.coupled_teeth")
    for v, r, bound, is_open, _ in bounds(md, fmu_path):
        if v.name in free and not is_open:
            assert refusal(new, v, bound, LEVEL0) is None, f"{v.name} = {bound!r}"


def test_coupled_teeth_bound_at_level_4(new, md):
    """model.coupled_teeth is declared [0, 10] (level 5's databases); level 4 (the default)
    couples at most 3 neighbouring teeth (its fitted table): 3 is accepted, 4 refused with a
    message naming the variable, the level and its range."""
    v = next(v for v in md.modelVariables if v.name == "model.coupled_teeth")
    level4 = {"model.stiffness": 4}
    assert refusal(new, v, 3, level4) is None
    log = refusal(new, v, 4, level4)
    assert log is not None and "model.coupled_teeth = 4: level 4 (analytical) couples at most 3" in log, log
    assert "allowed range [0, 3]" in log, log


def test_iteration_cap_at_level_4_names_its_parameter(new, md):
    """solver.max_iterations = 1, its declared minimum, at level 4 (the default): one iteration
    does not converge the contact of the wound-up start pose, and the refusal must name
    solver.max_iterations, as uncoupled level 4 (model.coupled_teeth = 0) does ("a slice's force
    did not converge within solver.max_iterations"), with tooth coupling too (the default)."""
    v = next(v for v in md.modelVariables if v.name == "solver.max_iterations")
    for coupled in (0, 2):
        log = refusal(new, v, 1, {"model.stiffness": 4, "model.coupled_teeth": coupled})
        assert log is None or "solver.max_iterations" in log, f"model.coupled_teeth = {coupled}: {log}"


def test_every_range_check_is_declared(new, md):
    """A numeric parameter without a declared bound is not refused by a range check on that side
    (relief lengths: only their dependent bound, while the relief is on)."""
    for v in md.modelVariables:
        if v.causality != "parameter" or v.type not in NUMERIC:
            continue
        huge = 2**31 - 1 if v.type == "Integer" else 1e30
        for declared, value in ((v.max, huge), (v.min, -huge)):
            if declared is None:
                log = refusal(new, v, value)
                assert log is None or f"{v.name} = " not in log, log


@pytest.mark.parametrize("text, message", [
    ("[gear1]\nteeth = 3\n", "gear1.teeth = 3: allowed range [5, 2000]"),
    ("[gear2]\nface_width_mm = 3000\n", "gear2.face_width_mm = 3000 mm: allowed range (0, 2000] mm"),
    ("[gear2]\nface_width_mm = 0\n", "gear2.face_width_mm = 0 mm: allowed range (0, 2000] mm"),
    ("[gear1]\nthickness_allowance_um = 1\n",
     "gear1.thickness_allowance_um = 1 um: allowed range [-50000, 0] um"),
])
def test_scene_check_names_the_fmu_range_in_scene_units(text, message):
    with pytest.raises(SceneError) as err:
        parse_scene(text)
    assert str(err.value) == message


def test_every_scene_key_of_a_parameter_has_the_fmu_range(md, fmu_path):
    """Each numeric scene key of an FMU parameter: refused just beyond the FMU's declared bound
    (fmpy's reading), the range in the key's unit."""
    declared = {v.name: r for v, r in ranged(md, fmu_path)}
    keys = [(section, name, key) for section, table in SCHEMA.items() for name, key in table.items()
            if key.kind in (int, float)]
    assert len(keys) >= 40
    for section, name, key in keys:
        r = declared[key.variable]
        for bound, direction in ((r.lo, -1), (r.hi, 1)):
            if math.isinf(bound):
                continue
            value = bound / key.factor + direction * (1 if key.kind is int else 1e-6 * max(1, abs(bound / key.factor)))
            value = int(round(value)) if key.kind is int else value
            with pytest.raises(SceneError) as err:
                parse_scene(f"[{section}]\n{name} = {value!r}\n")
            unit = f" {key.unit}" if key.unit else ""
            assert str(err.value).endswith(f": allowed range {r.text(key.factor)}{unit}"), str(err.value)
