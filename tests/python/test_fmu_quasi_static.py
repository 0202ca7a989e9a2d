"""Quasi-static mode through fmpy (issue 4): gear 2's spin is solved for mesh.load_torque, so
one fmi2DoStep per roll angle gives the loaded TE; friction power and state round trips."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearmesh.fmu_driver import GearMeshFMU

from test_fmu_conformance import LEVEL0

K_PRIME, FACE = 1.5e10, 0.023
RELIEF = {f"gear{i}.{k}": v for i in (1, 2)
          for k, v in (("tip_relief", 40e-6), ("tip_relief_length", 0.05e-3))}


def loaded_te(fmu, phi1, torque, omega1=0.0):
    rb = fmu.get(["gear1.base_diameter", "gear2.base_diameter"])
    fmu.step({"gear1.phi": phi1, "mesh.load_torque": torque, "gear1.omega": omega1,
              "gear2.omega": -omega1 * rb["gear1.base_diameter"] / rb["gear2.base_diameter"],
              "gear2.phi": 123.0})  # ignored in the quasi-static mode
    return fmu.get(["mesh.te", "mesh.normal_force", "mesh.pairs_in_contact", "gear2.mz",
                    "mesh.friction_power", "gear1.mz"])


def test_one_step_per_roll_angle_gives_the_loaded_te(fmu_path):
    """Level 0 on one slice (LEVEL0; the defaults are level 4): the loaded TE is the closed form
    F / (n k' b) with n pairs in contact."""
    with GearMeshFMU(fmu_path, {"model.quasi_static": True, **LEVEL0, **RELIEF}) as fmu:
        rb2 = fmu.get(["gear2.base_diameter"])["gear2.base_diameter"] / 2
        torque = 250.0
        F = torque / rb2
        levels = set()
        for phi1 in np.linspace(0.0, 2 * math.pi / 57, 97, endpoint=False):
            out = loaded_te(fmu, phi1, torque)
            assert out["gear2.mz"] == pytest.approx(-torque, rel=1e-9)  # the load is balanced
            expected = F / (out["mesh.pairs_in_contact"] * K_PRIME * FACE)
            if out["mesh.te"] == pytest.approx(expected, rel=1e-9):
                levels.add(out["mesh.pairs_in_contact"])
        assert levels == {1, 2}


def test_friction_power_and_its_sign(fmu_path):
    params = {"model.quasi_static": True, "model.friction_coefficient": 0.1,
              "model.friction_velocity": 1e-5, **RELIEF}
    with GearMeshFMU(fmu_path, params) as fmu:
        powers = [loaded_te(fmu, phi1, 200.0, omega1=1.0)["mesh.friction_power"]
                  for phi1 in np.linspace(0.0, 0.1, 40)]
    assert min(powers) >= 0
    assert max(powers) > 0


def test_state_round_trip_keeps_the_warm_start(fmu_path):
    with GearMeshFMU(fmu_path, {"model.quasi_static": True}) as fmu:
        loaded_te(fmu, 0.01, 180.0)
        state = fmu.fmu.getFMUstate()
        first = loaded_te(fmu, 0.02, 180.0)
        fmu.fmu.setFMUstate(state)
        fmu.time -= 1e-3
        again = loaded_te(fmu, 0.02, 180.0)
        fmu.fmu.freeFMUstate(state)
    assert again == first
