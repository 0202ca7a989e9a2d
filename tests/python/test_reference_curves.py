"""CI regression of every scene's loaded TE against its reference curves in scenarios/:
fails beyond reference_curves.TOLERANCE; the references are regenerated only on purpose."""
from __future__ import annotations

import pytest

from gearmesh import reference_curves as rc
from gearmesh.scene import load_scene
from conftest import REPO

SCENES = sorted((REPO / "scenarios").glob("*.toml"))


@pytest.mark.parametrize("scene_path", SCENES, ids=[p.stem for p in SCENES])
def test_scene_matches_its_reference_te(scene_path, fmu_path):
    scene = load_scene(scene_path)
    if not scene.run.get("torques_Nm"):
        pytest.fail(f"{scene_path}: a scene needs run.torques_Nm and a reference curve")
    assert rc.reference_path(scene).is_file(), "no reference curve: write it on purpose"
    worst = rc.compare(scene, rc.compute(scene, fmu_path))
    assert worst <= rc.TOLERANCE, f"loaded TE moved by {worst:.3g} m"


def test_the_comparison_can_fail(fmu_path, tmp_path):
    """A reference that differs by 2 nm somewhere is caught."""
    scene = load_scene(SCENES[0])
    curves = rc.compute(scene, fmu_path)
    shifted = dict(curves, **{"mesh.te": curves["mesh.te"].copy()})
    shifted["mesh.te"][5] += 2e-9
    copy = scene.__class__(**{**scene.__dict__, "path": tmp_path / scene.path.name})
    rc.write(copy, shifted)
    assert rc.compare(copy, curves) == pytest.approx(2e-9, rel=1e-3)
