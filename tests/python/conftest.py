"""Shared pytest fixtures: the built FMU and its extracted copy."""
from __future__ import annotations

import os
import pathlib
import shutil

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def fmu_path() -> pathlib.Path:
    """The packed GearMesh.fmu of the build tree (GEARMESH_FMU overrides)."""
    path = pathlib.Path(os.environ.get("GEARMESH_FMU", REPO / "build" / "GearMesh.fmu"))
    if not path.is_file():
        pytest.fail(f"{path} not found: build the 'fmu' target first (tools/run-tests does)")
    return path


@pytest.fixture(scope="session")
def fmu_dir(fmu_path, tmp_path_factory) -> pathlib.Path:
    """The FMU extracted once per session."""
    from fmpy import extract

    target = tmp_path_factory.mktemp("fmu")
    extract(str(fmu_path), str(target))
    return target
