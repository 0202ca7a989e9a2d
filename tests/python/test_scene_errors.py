"""Every malformed scene is a SceneError naming the file and the key or line, never a traceback
(docs/reliability.md): the corpus in fixtures/bad_scenes/ through load_scene and through
`gearmesh check`, and the resource rule (files stay inside the scene's folder, or
[scene] resource_root, and are regular files)."""
from __future__ import annotations

import os
import pathlib
import re
import subprocess
import sys

import pytest

from gearmesh import cli
from gearmesh.scene import SceneError, load_scene, parse_scene
from conftest import REPO

HERE = pathlib.Path(__file__).resolve().parent
BAD = HERE / "fixtures" / "bad_scenes"
# files that cannot carry their "# ... -- expect: ..." comment line
EXPECT = {"empty.toml": "empty scene", "utf16.toml": "UTF-16 byte-order mark"}


def expected(path: pathlib.Path) -> str:
    if path.name in EXPECT:
        return EXPECT[path.name]
    first = path.read_bytes().split(b"\n", 1)[0].decode("ascii")
    m = re.fullmatch(r"# .+ -- expect: (.+)", first)
    assert m, f"{path.name}: first line must be '# <what is wrong> -- expect: <words of the message>'"
    return m.group(1)


CORPUS = sorted(BAD.glob("*.toml"))


def test_the_corpus_is_large_enough():
    assert len(CORPUS) >= 30


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.stem)
def test_bad_scene_is_a_scene_error_naming_file_and_key_or_line(path):
    with pytest.raises(SceneError) as err:  # any other exception fails the test
        load_scene(path)
    message = str(err.value)
    assert message.startswith(f"{path}: "), message
    assert expected(path) in message, message
    assert "Traceback" not in message


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.stem)
def test_check_command_reports_without_traceback(path, capsys):
    assert cli.main(["check", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith(f"gearmesh: {path}: ") and expected(path) in captured.err


def test_check_command_in_a_process(tmp_path):
    """`gearmesh check FILE` for a few of the worst files: exit 2, the message on
    stderr, no traceback."""
    for name in ("nested_arrays.toml", "invalid_utf8.toml", "scene_is_number.toml", "binary_junk.toml",
                 "escaping_path.toml"):
        path = BAD / name
        proc = subprocess.run([sys.executable, "-m", "gearmesh", "check", str(path)], capture_output=True,
                              text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr
        assert f"gearmesh: {path}: " in proc.stderr and expected(path) in proc.stderr
        assert "Traceback" not in proc.stderr


def test_committed_scenes_load():
    scenes = sorted((REPO / "scenarios").glob("*.toml")) + sorted((REPO / "scenarios" / "fe").glob("*.toml"))
    assert len(scenes) >= 6
    assert cli.main(["check", *map(str, scenes)]) == 0


def test_utf8_byte_order_mark_is_accepted(tmp_path):
    plain = load_scene(REPO / "scenarios" / "paper_setA_3U4U.toml")
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + (REPO / "scenarios" / "paper_setA_3U4U.toml").read_bytes())
    assert load_scene(bom).parameters == plain.parameters
    bad = tmp_path / "bom_bad.toml"
    bad.write_bytes(b"\xef\xbb\xbf[pair]\nnormal_module_mm = 2.0\n[pair\n")
    with pytest.raises(SceneError, match=r"bom_bad.toml: not valid TOML: .*line 3"):
        load_scene(bad)


def test_fifo_as_scene_file_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match="scene.toml: not a regular file"):
        load_scene(fifo)


# ---- the resource rule --------------------------------------------------------------------------

def test_files_outside_the_scene_folder_are_refused(tmp_path):
    outside = tmp_path / "secret.txt"
    outside.write_text("x")
    folder = tmp_path / "scenes"
    folder.mkdir()
    scene = folder / "s.toml"
    for key, section in (("deviations_file", "gear1"), ("te_table_file", "model")):
        text = f'[{section}]\n{key} = "../secret.txt"\n'
        with pytest.raises(SceneError) as err:
            parse_scene(text, scene)
        message = str(err.value)
        assert f"{section}.{key} = '../secret.txt': resolves to {outside}, outside {folder}" in message
        assert "inside the scene's folder" in message
    with pytest.raises(SceneError, match=r"gear1.body.mesh_file = .*outside"):
        parse_scene('[model]\nstiffness_level = 5\n[gear1.body]\nmesh_file = "../secret.txt"\n', scene)
    with pytest.raises(SceneError, match=r"gear2.body.compliance_file = .*outside"):
        parse_scene('[model]\nstiffness_level = 5\n[gear2.body]\ncompliance_file = "/etc/passwd"\n', scene)


def test_symlinks_are_resolved_before_the_rule(tmp_path):
    outside = tmp_path / "secret.txt"
    outside.write_text("x")
    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "link.txt").symlink_to(outside)
    (folder / "data").mkdir()
    (folder / "data" / "te.txt").write_text("x")
    (folder / "inner.txt").symlink_to(folder / "data" / "te.txt")
    with pytest.raises(SceneError, match=r"model.te_table_file = 'link.txt': resolves to .*secret.txt, outside"):
        parse_scene('[model]\nte_table_file = "link.txt"\n', folder / "s.toml")
    # a link (or subfolder) that stays inside is fine
    s = parse_scene('[model]\nte_table_file = "inner.txt"\n', folder / "s.toml")
    assert s.resources["model_te.txt"] == folder / "data" / "te.txt"


def test_non_regular_files_are_refused(tmp_path):
    os.mkfifo(tmp_path / "pipe.txt")
    (tmp_path / "dir.txt").mkdir()
    for name in ("pipe.txt", "dir.txt"):
        with pytest.raises(SceneError, match=rf"model.te_table_file = '{name}': .* is not a regular file"):
            parse_scene(f'[model]\nte_table_file = "{name}"\n', tmp_path / "s.toml")


def test_symlink_loop_is_a_scene_error(tmp_path):
    (tmp_path / "a.txt").symlink_to(tmp_path / "b.txt")
    (tmp_path / "b.txt").symlink_to(tmp_path / "a.txt")
    with pytest.raises(SceneError, match=r"model.te_table_file = 'a.txt': "):
        parse_scene('[model]\nte_table_file = "a.txt"\n', tmp_path / "s.toml")


def test_resource_root_widens_the_folder(tmp_path):
    shared = tmp_path / "shared.txt"
    shared.write_text("x")
    folder = tmp_path / "scenes"
    folder.mkdir()
    text = '[model]\nte_table_file = "../shared.txt"\n'
    with pytest.raises(SceneError, match="outside"):
        parse_scene(text, folder / "s.toml")
    s = parse_scene('[scene]\nresource_root = ".."\n' + text, folder / "s.toml")
    assert s.resources["model_shared.txt"] == shared
    # still nothing outside the root
    with pytest.raises(SceneError, match=rf"resolves to /etc/passwd, outside {tmp_path}"):
        parse_scene('[scene]\nresource_root = ".."\n[model]\nte_table_file = "/etc/passwd"\n', folder / "s.toml")


# Scenes the core refuses (its rules between parameters, the level's, the geometry, the tilt bound),
# with the FMU parameters and inputs they set.
CORE_REFUSED = [
    ("[model]\nstiffness_level = 1\n", {"model.stiffness": 1}),
    ("[model]\nstiffness_level = 4\ncoupled_teeth = 5\n", {"model.stiffness": 4, "model.coupled_teeth": 5}),
    ("[pair]\ncenter_distance_mm = 140\n", {"pair.center_distance": 0.140}),
    ("[pair]\nrack_dedendum = 0.9\n", {"pair.rack_dedendum": 0.9}),
    ("[gear1.mounting]\ntilt_y_mrad = -25\n", {"gear1.ry": -0.025}),
]


@pytest.mark.parametrize("text, values", CORE_REFUSED, ids=[t.split("\n")[-2] for t, _ in CORE_REFUSED])
def test_a_scene_the_core_refuses_fails_with_the_cores_message(fmu_path, text, values):
    """The scene's error is the message the FMU gives at initialization for the same values (the
    core's gm_model_check through the binary's gearmesh_check, gm_model_create's message)."""
    from gearmesh.fmu_driver import FMUError, GearMeshFMU

    with pytest.raises(SceneError) as err:
        parse_scene(text, fmu=fmu_path)
    with pytest.raises(FMUError) as init:
        GearMeshFMU(fmu_path, values)
    assert str(init.value).endswith(f"fmi2ExitInitializationMode: {err.value}"), (str(err.value), str(init.value))
    with GearMeshFMU(fmu_path, values, initialize=False) as instance:
        assert instance.check() == str(err.value)
