"""`gearmesh-dev figures` (tools/gearmesh_dev/figures.py): the cheap pictures are made into a temporary
folder and are PNGs of a plausible size; the schematic's geometry is the FMU's (its drawn teeth
have the FMU's backlash, its lines of action touch the base circles, its path of contact has the
FMU's contact ratio); and every picture in docs/img/ is one the script makes (none drawn by
hand). The expensive pictures (te_set_a: a level-5 database; stability_map: the quick stability
suite; study_histogram: a study on a Dask cluster; compliance_mesh: a compliance_tool run) are
made by `gearmesh-dev figures`, not here."""
from __future__ import annotations

import math
import pathlib
import struct

import numpy as np
import pytest

from gearmesh_dev import cli, figures
from gearmesh.scene import load_scene
from gearmesh.scene_fmu import build_scene_fmu
from conftest import REPO

DOCS_IMG = REPO / "docs" / "img"
PNG = b"\x89PNG\r\n\x1a\n"
MAX_BYTES = 200 * 1024


def png_size(path: pathlib.Path) -> tuple[int, int]:
    """(width, height) from the PNG's IHDR; fails if the file is not a PNG."""
    head = path.read_bytes()[:24]
    assert head[:8] == PNG, f"{path}: not a PNG"
    assert head[12:16] == b"IHDR", f"{path}: no IHDR chunk"
    return struct.unpack(">II", head[16:24])


def check_picture(path: pathlib.Path) -> None:
    assert path.is_file(), f"{path} not written"
    width, height = png_size(path)
    assert 400 <= width <= 2000 and 300 <= height <= 1200, f"{path}: {width} x {height} px"
    assert 10 * 1024 < path.stat().st_size < MAX_BYTES, f"{path}: {path.stat().st_size} bytes"


def test_cheap_pictures(fmu_path, tmp_path):
    out = tmp_path / "img"
    made = figures.make(out, ["schematic", "pareto", "aliasing"],
                        figures.Options(fmu=fmu_path, work=tmp_path / "work"))
    assert set(made) == {"schematic", "pareto", "aliasing"}
    assert sorted(p.name for p in out.iterdir()) == ["aliasing.png", "pareto.png", "schematic.png"]
    # the aliasing picture's point: at 1 kHz the 2.85 kHz mesh line lands at 150 Hz
    assert "largest line at 150 Hz" in made["aliasing"][2], made["aliasing"][2]
    for name, (path, seconds, _) in made.items():
        assert path == out / figures.FILES[name]
        check_picture(path)


@pytest.fixture(scope="module")
def geometry(fmu_path, tmp_path_factory):
    scene = load_scene(figures.SCENE_A, fmu_path)
    fmu = build_scene_fmu(fmu_path, scene.parameters, scene.resources,
                          tmp_path_factory.mktemp("figures") / "setA.fmu")
    return figures.pair_geometry(fmu, {})


def test_schematic_is_the_fmus_geometry(geometry):
    g1, g2 = geometry.gears
    # the teeth drawn from docs/physics.md §1 have the FMU's backlash along flank B's line
    assert geometry.drawn_backlash() == pytest.approx(geometry.backlash, rel=1e-9)
    for flank, (force, t1, t2) in geometry.lines.items():
        # the lines of action from the FMU's contact force and moment touch both base circles
        assert np.linalg.norm(t1 - g1.centre) == pytest.approx(g1.r_b, rel=1e-9)
        assert np.linalg.norm(t2 - g2.centre) == pytest.approx(g2.r_b, rel=1e-9)
        # and lie at the operating pressure angle (docs/physics.md §0: flank A pushes gear 1
        # back, -x and -y, when gear 1 drives in +phi_1)
        a = geometry.alpha_wt
        expected = np.array([-math.sin(a), -math.cos(a) if flank == 1 else math.cos(a)])
        assert force == pytest.approx(expected, abs=1e-9)
    start, end = geometry.path
    assert (end - start) / geometry.base_pitch == pytest.approx(geometry.contact_ratio, rel=1e-9)
    outline = figures.gear_outline(g1)
    radii = np.linalg.norm(outline - g1.centre, axis=1)
    assert radii.max() == pytest.approx(g1.r_a) and radii.min() == pytest.approx(g1.r_f)


def test_docs_img_holds_only_the_scripts_pictures():
    """No hand-made orphans: every docs/img/*.png is a file `gearmesh-dev figures` writes (and each
    file it writes is there), each within the size limit."""
    found = {p.name for p in DOCS_IMG.glob("*.png")}
    assert found, "docs/img/ holds no pictures: run `gearmesh-dev figures`"
    orphans = found - set(figures.FILES.values())
    assert not orphans, f"docs/img/ pictures no script makes: {sorted(orphans)}"
    missing = set(figures.FILES.values()) - found
    assert not missing, f"pictures the script makes, not in docs/img/: {sorted(missing)}"
    for name in found:
        png_size(DOCS_IMG / name)
        assert (DOCS_IMG / name).stat().st_size < MAX_BYTES, name


def test_unknown_picture_is_refused(tmp_path, capsys):
    assert cli.main(["figures", "--only", "schematic", "nope", "--out", str(tmp_path)]) == 2
    assert "nope" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
