"""A train FMU's own-sense ports (fmu_src/train_variables.h: <body>.load_torque, .forward_speed;
<shaft>.forward_phi, .forward_omega, .forward_torque): each body's own sense of rotation is the
sign of its speed when the input turns forwards (gearmesh.train_fmu.own_senses), checked here
against the closed forms of the scenes' kinematics; a load given in a body's own sense is the
same run as its housing-frame torque negated where the body turns backwards; the usual wiring
(+T drive, -T brake, each in its own sense) loads the train."""
from __future__ import annotations

import numpy as np
import pytest

from gearmesh import train_fmu
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.scene import load_scene
from conftest import REPO

TRAINS = REPO / "scenarios" / "trains"


@pytest.mark.parametrize("name, expected", [
    # 19 -> 57 | 23 -> 61: the intermediate turns backwards, the output forwards
    ("two_stage_reducer", {"input": 1, "intermediate": -1, "output": 1}),
    # through an idler the output turns the input's way
    ("idler", {"input": 1, "idler": -1, "output": 1}),
    # sun forwards, ring held: the carrier forwards (z_s / (z_s + z_r) > 0), the planets backwards
    # (w_p = w_c - (z_s / z_p)(w_s - w_c) = -0.5 w_s for 21/21/63)
    ("planetary_3_planets", {"sun": 1, "planet1": -1, "planet2": -1, "planet3": -1, "ring": 1, "carrier": 1}),
    # two pairs closed by shafts: pinions forwards, wheels backwards
    ("back_to_back_set_a", {"a1": 1, "b1": -1, "a2": 1, "b2": -1}),
])
def test_own_senses_are_the_kinematics(fmu_path, name, expected):
    train = train_fmu.load_train(TRAINS / f"{name}.toml")
    scenes = [load_scene(m["_scene"], fmu_path) for m in train.meshes]
    senses = train_fmu.own_senses(train, scenes)
    assert {b["name"]: s for b, s in zip(train.bodies, senses)} == expected


def run(fmu, inputs: dict, steps: int = 60, h: float = 1e-2) -> dict[str, np.ndarray]:
    read = ["input.speed", "intermediate.speed", "intermediate.forward_speed", "output.speed",
            "output.forward_speed", "stage1.normal_force", "stage2.normal_force", "motor.torque",
            "motor.forward_torque"]
    rows = []
    with GearMeshFMU(fmu, {"input.omega": 10.0, "intermediate.omega": -10.0 * 19 / 57,
                           "output.omega": 10.0 * 19 / 57 * 23 / 61}) as f:
        for k in range(steps):
            values = {n: v(k * h) if callable(v) else v for n, v in inputs.items()}
            f.step(values, h)
            rows.append(f.get(read))
    return {n: np.array([r[n] for r in rows]) for n in read}


def test_a_load_in_its_own_sense_is_the_housing_torque_signed_by_the_sense(fmu_path, tmp_path):
    """The reducer: the motor's far end at 10 rad/s forwards given as forward_phi/forward_omega
    (the input body turns forwards: the same numbers as far_phi/far_omega); 100 N m on the
    intermediate (which turns backwards) as load_torque = +100 and as torque = -100 are the same
    run bit for bit; the brake -200 N m on the output in its own sense loads both stages, and the
    forward outputs are the housing ones times the sense."""
    fmu = train_fmu.build_train_fmu(TRAINS / "two_stage_reducer.toml", tmp_path / "r.fmu", fmu_path)
    drive = {"motor.forward_phi": lambda t: 10.0 * t, "motor.forward_omega": 10.0}
    own = run(fmu, {**drive, "intermediate.load_torque": 100.0, "output.load_torque": -200.0})
    housing = run(fmu, {"motor.far_phi": lambda t: 10.0 * t, "motor.far_omega": 10.0,
                        "intermediate.torque": -100.0, "output.torque": -200.0})
    for n in own:
        assert np.array_equal(own[n], housing[n]), n
    assert np.array_equal(own["intermediate.forward_speed"], -own["intermediate.speed"])
    assert np.array_equal(own["output.forward_speed"], own["output.speed"])
    assert np.array_equal(own["motor.forward_torque"], own["motor.torque"])  # the input turns forwards
    settled = slice(30, None)
    assert np.all(own["intermediate.forward_speed"][settled] > 0)
    assert np.all(own["stage1.normal_force"][settled] > 0) and np.all(own["stage2.normal_force"][settled] > 0)
