"""The settings `gearmesh accuracy` compares (python/gearmesh/accuracy/settings.py): level 5's FE
variants (mesh coarse/fine, flank grid loaded at 70/50 %) on top of the scene's [fe] keys, their
own cached databases, and what those cost to build (docs/validation.md, "FE variants")."""
from __future__ import annotations

import json
import math

import pytest

from gearmesh import compliance
from gearmesh.accuracy import report as accuracy_report, settings as accuracy_settings
from gearmesh.accuracy.settings import FE_VARIANTS, Setting
from gearmesh.scene import load_scene
from conftest import REPO

SET_A = REPO / "scenarios" / "paper_setA_3U4U.toml"
HELICAL = REPO / "scenarios" / "fe" / "helical_fe.toml"


def test_full_preset_has_each_variant_with_databases_only():
    full = accuracy_settings.settings("full", (0, 2), ("mesh-fine", "grid-50%"), 2)
    variants = [s for s in full if s.fe]
    assert variants == [Setting(5, 10, 2, fe="mesh-fine"), Setting(5, 10, 2, fe="grid-50%")]
    assert variants[0].label == "L5 s10 c2 mesh-fine"
    assert Setting(5, 10, 2).label == "L5 s10 c2"
    assert not [s for s in accuracy_settings.settings("quick", (0, 2), ("mesh-fine",)) if s.fe]


def test_level5_preset_is_the_scenes_own_level5_at_every_torque():
    """The FE level's ledger: level 5 at 10 slices and the coupled teeth that have databases (the
    scene's own, accuracy.level5_databases), no variants, every reference torque."""
    assert accuracy_settings.settings("level5", (2,), ("mesh-fine",)) == [Setting(5, 10, 2)]
    assert accuracy_settings.settings("level5") == []  # no databases: nothing at level 5
    assert accuracy_settings.torques("level5", [150.0, 50.0, 350.0]) == [50.0, 150.0, 350.0]
    assert accuracy_settings.torques("quick", [150.0, 50.0, 350.0]) == [50.0, 350.0]
    with pytest.raises(ValueError, match="allowed: quick, level5, full"):
        accuracy_settings.settings("fast")


def test_variant_keys_go_over_the_scenes_fe():
    helical = load_scene(HELICAL)
    assert helical.fe.get("profile_elements") == 6  # the scene's own [fe]
    grid = accuracy_settings.level5_scene(helical, 2, "grid-70%")
    assert grid.fe == {**helical.fe, "load_fraction": 0.7}
    fine = accuracy_settings.level5_scene(helical, 2, "mesh-fine")
    assert fine.fe["profile_elements"] == 12 and fine.fe["width_elements"] == 6
    assert accuracy_settings.level5_scene(helical, 2).fe == helical.fe
    with pytest.raises(ValueError, match="mesh-huge.*allowed: mesh-coarse"):
        accuracy_settings.level5_scene(helical, 2, "mesh-huge")


def test_each_variant_has_its_own_databases(fmu_path, tmp_path):
    scene = load_scene(SET_A)
    tool = tmp_path / "compliance_tool"
    tool.write_bytes(b"a stand-in: the cache key hashes the tool's bytes")
    cache = tmp_path / "cache"
    cache.mkdir()
    keys = {fe: compliance.cache_key(accuracy_settings.level5_scene(scene, 2, fe), 1, tool)
            for fe in (None, *FE_VARIANTS)}
    assert len(set(keys.values())) == len(keys), "a variant shares another's database"
    for gear in (1, 2):
        at = accuracy_settings.level5_scene(scene, 2, "grid-50%")
        (cache / f"{compliance.cache_key(at, gear, tool)}.gcdb").write_bytes(b"")
    found = accuracy_settings.cached_databases(scene, 2, fmu_path, tool, cache, fe="grid-50%")
    assert found and all(p.parent == cache for p in found.values())
    assert accuracy_settings.cached_databases(scene, 2, fmu_path, tool, cache, fe="mesh-fine") is None
    assert accuracy_settings.cached_databases(scene, 2, fmu_path, tool, cache) is None


def test_database_cost_from_the_cache_records(tmp_path):
    def record(name, seconds, mib):
        path = tmp_path / f"{name}.gcdb"
        path.write_bytes(b"")
        path.with_suffix(".json").write_text(json.dumps(
            {"summary": {"total_s": seconds, "peak_rss_MiB": mib}}))
        return path

    a, b = record("a", 40.0, 3000.0), record("b", 25.0, 3100.0)
    cost = accuracy_settings.database_cost({1: a, 2: b})
    assert (cost.build_s, cost.peak_MiB) == (65.0, 3100.0)
    same = accuracy_settings.database_cost({1: a, 2: a})  # equal gears: one database, one build
    assert (same.build_s, same.peak_MiB) == (40.0, 3000.0)
    b.with_suffix(".json").unlink()
    assert accuracy_settings.database_cost({1: a, 2: b}) is None
    entry = {"db_build_s": 65.0, "db_peak_MiB": 3100.0}
    assert accuracy_report.database(entry) == "65 s, 3.0 GiB"
    assert accuracy_report.database({"db_build_s": math.nan, "db_peak_MiB": math.nan}) == ""
