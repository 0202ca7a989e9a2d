"""Scene FMUs that list only what their scene uses: `gearmesh fmu SCENE --interface
torsional|planar|full` (python/gearmesh/scene_interface.py; docs/fmi.md, "Scene interfaces").

The interfaces are checked against the generic FMU: fmpy validates each, the listed sets are the
ones the docs state, a hidden scene value still acts (a tilt kept in resources/ moves the
torques), and on the scene's runs every output an interface lists equals the full FMU's bit for
bit (same binary, same value references)."""
from __future__ import annotations

import math
import pathlib
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from gearmesh.cli import main as cli_main
from gearmesh.fmu_command import write_scene_fmu
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.scene import SceneError, load_scene, parse_scene
from gearmesh.scene_interface import InterfaceError, TORSIONAL_OUTPUTS
from conftest import REPO

SET_A = REPO / "scenarios" / "paper_setA_3U4U.toml"
W1 = 10 * 2 * math.pi / 60


def scene_with(tmp_path, extra: str, name: str = "s.toml"):
    """Set A with `extra` TOML appended, as a scene file in tmp_path."""
    path = tmp_path / name
    path.write_text(SET_A.read_text() + "\n" + extra)
    return load_scene(path)


def listed(fmu: pathlib.Path) -> dict[str, str]:
    """name -> causality of the variables the FMU's modelDescription lists."""
    return {v.name: v.causality for v in read_model_description(str(fmu)).modelVariables}


def names(fmu, causality):
    return {n for n, c in listed(fmu).items() if c == causality}


@pytest.fixture(scope="module")
def set_a_fmus(fmu_path, tmp_path_factory):
    """Set A's scene FMU with each interface."""
    out = tmp_path_factory.mktemp("interfaces")
    scene = load_scene(SET_A)
    return {i: out / f"setA.{i}.fmu" for i in ("torsional", "planar", "full")
            if write_scene_fmu(scene, fmu_path, out / f"setA.{i}.fmu", i)}


@pytest.mark.parametrize("interface", ["torsional", "planar", "full"])
def test_fmpy_validates_every_interface(set_a_fmus, interface):
    assert validate_fmu(str(set_a_fmus[interface])) == []


def test_torsional_lists_the_spins_and_the_mesh_outputs(set_a_fmus):
    fmu = set_a_fmus["torsional"]
    # set A fixes no mode: the inputs and outputs of all three modes
    # (the large-step mode's torques and shaft ends as the drive and load ports, each in its
    # gear's own sense of rotation; the housing-frame ones are the full interface's)
    assert names(fmu, "input") == {"gear1.phi", "gear2.phi", "gear1.omega", "gear2.omega",
                                   "mesh.load_torque", "drive.torque", "load.torque",
                                   "drive.shaft_phi", "load.shaft_phi", "drive.shaft_omega",
                                   "load.shaft_omega"}
    # the large-step mode's energy account is there for a master to check the integration by
    energy = {f"energy.{x}" for x in ("kinetic", "elastic", "initial", "work_in", "work_out", "friction",
                                      "damping", "parametric", "residual")}
    # and the mesh orders over whole mesh cycles, for NVH at long steps
    orders = {f"mesh.{s}_order{k}{x}" for s in ("te", "normal_force") for k in (1, 2, 3) for x in ("", "_phase")}
    assert names(fmu, "output") == set(TORSIONAL_OUTPUTS) | energy | orders | {"mesh.order_cycles"} | {
        f"{p}.{x}" for p in ("drive", "load") for x in ("angle", "speed", "shaft_torque", "shaft_torque_mean")}
    parameters = names(fmu, "parameter")
    fixed = load_scene(SET_A).parameters
    assert not parameters & set(fixed), "a parameter the scene sets is listed"
    # not read at level 4: the other levels' inputs and level 5's databases
    assert not parameters & {"model.user_stiffness", "model.stiffness_table", "model.rated_line_load",
                             "gear1.compliance", "gear2.compliance"}
    # left at the FMU's defaults, read at level 4 (its tooth coupling too): still tunable
    assert {"gear1.lead_crowning", "model.damping", "solver.tolerance", "model.quasi_static",
            "model.coupled_teeth"} <= parameters
    assert names(fmu, "calculatedParameter") == names(set_a_fmus["full"], "calculatedParameter")


def test_planar_adds_the_in_plane_motion_and_forces(set_a_fmus):
    t, p = set_a_fmus["torsional"], set_a_fmus["planar"]
    in_plane = {f"gear{i}.{x}" for i in (1, 2) for x in ("ux", "uy", "vx", "vy")}
    assert names(p, "input") == names(t, "input") | in_plane
    assert names(p, "output") == names(t, "output") | {f"gear{i}.{x}" for i in (1, 2)
                                                       for x in ("fx", "fy", "fx_mean", "fy_mean")}
    assert names(p, "parameter") == names(t, "parameter")


def test_full_lists_everything_the_generic_fmu_does(set_a_fmus, fmu_path):
    assert listed(set_a_fmus["full"]) == listed(fmu_path)


def test_a_fixed_mode_narrows_the_interface(tmp_path, fmu_path):
    scene = scene_with(tmp_path, '[fmu]\nmode = "quasi_static"\n')
    out = tmp_path / "qs.fmu"
    interface, _ = write_scene_fmu(scene, fmu_path, out)
    assert interface == "torsional"
    assert validate_fmu(str(out)) == []
    assert names(out, "input") == {"gear1.phi", "gear1.omega", "gear2.omega", "mesh.load_torque"}
    assert names(out, "output") == set(TORSIONAL_OUTPUTS)
    parameters = names(out, "parameter")
    assert "model.quasi_static" not in parameters and "gear1.inertia" not in parameters
    with GearMeshFMU(out) as f:  # the fixed mode acts: gear 2's spin is solved for the load
        f.step({"gear1.omega": W1, "gear2.omega": -W1, "mesh.load_torque": 200.0})
        # the contact on gear 2 balances its load
        assert f.get(["gear2.mz"])["gear2.mz"] == pytest.approx(-200.0, rel=1e-6)


def test_a_large_step_scene_lists_its_energy_account(tmp_path, fmu_path):
    """The torsional FMU of a large-step scene lists the energy account, and it closes: a drive
    torque against a brake through the mesh, energy in = energy out + stored + lost."""
    scene = scene_with(tmp_path, '[fmu]\nmode = "large_step"\n')
    out = tmp_path / "ls.fmu"
    interface, _ = write_scene_fmu(scene, fmu_path, out)
    assert interface == "torsional"
    assert validate_fmu(str(out)) == []
    account = ["energy.kinetic", "energy.elastic", "energy.initial", "energy.work_in", "energy.work_out",
               "energy.friction", "energy.damping", "energy.parametric", "energy.residual"]
    assert set(account) <= names(out, "output")
    with GearMeshFMU(out) as f:
        for _ in range(20):
            f.step({"drive.torque": 100.0, "load.torque": -100.0}, 1e-3)
        e = f.get(account)
    assert e["energy.work_in"] > 0
    balance = (e["energy.work_in"] - e["energy.work_out"]
               - (e["energy.kinetic"] + e["energy.elastic"] - e["energy.initial"])
               - e["energy.friction"] - e["energy.damping"] - e["energy.parametric"])
    assert balance == pytest.approx(e["energy.residual"], abs=1e-12 + 1e-9 * e["energy.work_in"])
    assert abs(e["energy.residual"]) <= 1e-2 * e["energy.work_in"]


def test_tunable_keeps_a_scene_parameter_listed(tmp_path, fmu_path):
    scene = scene_with(tmp_path, '[fmu]\ntunable = ["model.friction_coefficient"]\n')
    out = tmp_path / "t.fmu"
    write_scene_fmu(scene, fmu_path, out, "torsional", ["model.slices"])
    start = {v.name: v.start for v in read_model_description(str(out)).modelVariables}
    assert start["model.friction_coefficient"] == "0.4" and start["model.slices"] == "10"
    with pytest.raises(InterfaceError, match="tunable 'mesh.te': not a parameter"):
        write_scene_fmu(scene, fmu_path, tmp_path / "u.fmu", "torsional", ["mesh.te"])


def test_default_interface_follows_the_mounting(tmp_path, fmu_path):
    cases = {"": "torsional", "[gear2.mounting]\nbearing_motion = true\n": "planar",
             "[gear2.mounting]\ntilt_x_mrad = 0.3\n": "full",
             "[gear2.mounting]\ncenter_x_um = 20.0\n": "torsional"}
    for n, (extra, expected) in enumerate(cases.items()):
        scene = scene_with(tmp_path, extra, f"s{n}.toml")
        assert write_scene_fmu(scene, fmu_path, tmp_path / f"d{n}.fmu")[0] == expected, extra


def test_a_hidden_tilt_still_acts(tmp_path, fmu_path):
    """The torsional FMU of a misaligned scene keeps the tilt in its start values: its torque
    equals the full FMU's (the tilt listed there) and differs from the aligned pair's."""
    tilted = scene_with(tmp_path, "[gear2.mounting]\ntilt_y_mrad = 0.5\n")
    fmus = {}
    for interface in ("torsional", "full"):
        fmus[interface] = tmp_path / f"{interface}.fmu"
        write_scene_fmu(tilted, fmu_path, fmus[interface], interface)
    assert "gear2.ry" not in listed(fmus["torsional"])
    aligned = tmp_path / "aligned.fmu"
    write_scene_fmu(load_scene(SET_A), fmu_path, aligned, "torsional")
    torque = {}
    for key, fmu in (*fmus.items(), ("aligned", aligned)):
        with GearMeshFMU(fmu, {"model.quasi_static": True}) as f:
            f.step({"gear1.omega": W1, "gear2.omega": -W1, "mesh.load_torque": 300.0, "gear1.phi": 0.01})
            torque[key] = f.get(["gear1.mz", "mesh.te"])
    assert torque["torsional"] == torque["full"]
    assert torque["torsional"]["mesh.te"] != torque["aligned"]["mesh.te"]


def run(fmu: pathlib.Path, mode: dict, inputs, outputs) -> list[dict]:
    """The outputs after each step of `inputs` (a list of dicts)."""
    with GearMeshFMU(fmu, mode) as f:
        rows = []
        for values in inputs:
            f.step(values, 1e-3)
            rows.append(f.get(sorted(outputs)))
    return rows


def spin_inputs(steps: int, quasi_static: bool, planar: bool = False) -> list[dict]:
    """Gear 1 turned over one base pitch of set A (57 teeth, equal gears), loaded by a rising
    torque (quasi-static) or held at a 10 um approach (plain, r_b 69.6 mm)."""
    rows = []
    for k in range(steps):
        phi = 2 * math.pi / 57 * k / steps
        row = {"gear1.phi": phi, "gear1.omega": W1, "gear2.omega": -W1}
        row.update({"mesh.load_torque": 50.0 + 10 * k} if quasi_static else {"gear2.phi": 10e-6 / 0.0696 - phi})
        if planar:
            row.update({"gear2.ux": 2e-6 * math.sin(k), "gear2.vy": 1e-4})
        rows.append(row)
    return rows


@pytest.mark.parametrize("interface", ["torsional", "planar"])
@pytest.mark.parametrize("quasi_static", [True, False])
def test_outputs_equal_the_full_fmus_bit_for_bit(set_a_fmus, interface, quasi_static):
    fmu = set_a_fmus[interface]
    outputs = names(fmu, "output")
    inputs = spin_inputs(12, quasi_static, planar=interface == "planar")
    mode = {"model.quasi_static": quasi_static}
    mine, full = run(fmu, mode, inputs, outputs), run(set_a_fmus["full"], mode, inputs, outputs)
    assert mine == full
    assert any(row["mesh.normal_force"] > 0 for row in mine)  # the runs load the mesh


def test_large_step_outputs_equal_the_full_fmus_bit_for_bit(tmp_path, fmu_path):
    scene = scene_with(tmp_path, '[fmu]\nmode = "large_step"\n')
    fmus = {i: tmp_path / f"{i}.fmu" for i in ("torsional", "full")}
    for i, path in fmus.items():
        write_scene_fmu(scene, fmu_path, path, i)
    torsional_inputs = names(fmus["torsional"], "input")
    assert {"drive.torque", "load.torque", "drive.shaft_phi"} <= torsional_inputs
    assert not {"mesh.load_torque", "gear1.torque", "gear2.torque"} & torsional_inputs
    outputs = names(fmus["torsional"], "output")
    start = {"gear1.omega": W1, "gear2.omega": -W1}
    inputs = [{"drive.torque": 20.0 + k, "load.torque": 18.0} for k in range(8)]
    mine, full = run(fmus["torsional"], start, inputs, outputs), run(fmus["full"], start, inputs, outputs)
    assert mine == full
    assert mine[-1]["drive.speed"] != W1  # the torques moved the spins


def test_the_usual_wiring_loads_the_mesh(tmp_path, fmu_path):
    """A drive +T and a brake -T on the torsional FMU's ports (each in its gear's own sense)
    load the mesh: set A's equal gears at rest, 150 N m, 0.2 s at 1 ms; the mean normal force is
    T / r_b1 (the static balance) within 2 %, the gears stay near rest, the load port's speed is
    gear 2's speed negated (an external gear 2 turns against +z), and no warning is logged. The
    same torques as +T, -T about the housing's +z (the full interface's gear<i>.torque) drive
    both gears the same way: the mesh carries nothing, the gears run up, and the FMU warns once,
    naming the signs."""
    scene = scene_with(tmp_path, '[fmu]\nmode = "large_step"\n')
    fmus = {i: tmp_path / f"{i}.fmu" for i in ("torsional", "full")}
    for i, path in fmus.items():
        write_scene_fmu(scene, fmu_path, path, i)
    T, h = 150.0, 1e-3
    with GearMeshFMU(fmus["torsional"], {"model.damping": 4e5}) as f:
        rb1 = 0.5 * f.get(["gear1.base_diameter"])["gear1.base_diameter"]
        forces = []
        for _ in range(200):
            f.step({"drive.torque": T, "load.torque": -T}, h)
            forces.append(f.get(["mesh.normal_force"])["mesh.normal_force"])
        ports = f.get(["drive.speed", "load.speed", "drive.angle", "load.angle"])
        assert abs(np.mean(forces[100:]) / (T / rb1) - 1) < 0.02
        assert abs(ports["drive.speed"]) < 1.0 and abs(ports["load.speed"]) < 1.0
        assert not f.warnings, f.warnings
    with GearMeshFMU(fmus["full"], {"model.damping": 4e5}) as f:
        for _ in range(200):
            f.step({"gear1.torque": T, "gear2.torque": -T}, h)
        got = f.get(["mesh.normal_force", "gear1.speed", "gear2.speed", "load.speed", "drive.speed"])
        assert got["mesh.normal_force"] == 0 and got["gear1.speed"] > 100 and got["gear2.speed"] < -100
        assert got["load.speed"] == -got["gear2.speed"] and got["drive.speed"] == got["gear1.speed"]
        warned = [w for w in f.warnings if "check the signs" in w]
        assert len(warned) == 1, f.warnings


def test_level_5_resources_only_at_level_5(tmp_path, fmu_path, set_a_fmus):
    with zipfile.ZipFile(set_a_fmus["torsional"]) as z:
        assert not [n for n in z.namelist() if n.endswith(".gcdb")]
    for g in (1, 2):
        (tmp_path / f"g{g}.gcdb").write_bytes(b"x")  # shipped as is: the build does not read it
    text = SET_A.read_text().replace("stiffness_level = 4", "stiffness_level = 5")
    text += '\n[gear1.body]\ncompliance_file = "g1.gcdb"\n[gear2.body]\ncompliance_file = "g2.gcdb"\n'
    scene = parse_scene(text.replace("levels = [5, 4]", "levels = [5]"), tmp_path / "fe.toml")
    out = tmp_path / "fe.fmu"
    write_scene_fmu(scene, fmu_path, out, "torsional")
    with zipfile.ZipFile(out) as z:
        assert sorted(n for n in z.namelist() if n.endswith(".gcdb")) == [
            "resources/gear1_g1.gcdb", "resources/gear2_g2.gcdb"]
    assert "gear1.compliance" not in listed(out)  # fixed by the scene: in the start values file


def test_the_command_line_writes_and_refuses(tmp_path, fmu_path, capsys):
    out = tmp_path / "cli.fmu"
    assert cli_main(["fmu", str(SET_A), "--interface", "planar", "--fmu", str(fmu_path),
                     "--out", str(out)]) == 0
    assert "planar interface, 19 inputs" in capsys.readouterr().out
    assert validate_fmu(str(out)) == []
    assert cli_main(["fmu", str(SET_A), "--tunable", "no.such", "--fmu", str(fmu_path),
                     "--out", str(tmp_path / "x.fmu")]) == 2
    assert "tunable 'no.such': not a parameter" in capsys.readouterr().err
    assert not (tmp_path / "x.fmu").exists()


@pytest.mark.parametrize("extra, words", [
    ('[fmu]\ninterface = "radial"\n', "fmu.interface = 'radial': allowed: torsional, planar, full"),
    ('[fmu]\nmode = "implicit"\n', "fmu.mode = 'implicit': allowed: prescribed, quasi_static, large_step"),
    ('[fmu]\ntunable = "model.slices"\n', "fmu.tunable"),
    ("[fmu]\nlevel = 3\n", "fmu.level: unknown key"),
    ("[gear2.mounting]\ntilt_z_mrad = 1\n", "gear2.mounting.tilt_z_mrad: unknown key"),
    ("[gear2.mounting]\ntilt_x_mrad = 50\n", "gear2.rx = 0.05 rad: outside the small-tilt range"),  # the core's
    ("[gear1.mounting]\ncenter_y_um = -2e4\n", "gear1.mounting.center_y_um"),
    ("[gear1.mounting]\nbearing_motion = 1\n", "gear1.mounting.bearing_motion"),
])
def test_bad_fmu_and_mounting_keys_are_named(tmp_path, extra, words):
    with pytest.raises(SceneError, match=words.replace("(", r"\(").replace(".", r"\.")):
        scene_with(tmp_path, extra)
