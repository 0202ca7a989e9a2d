"""Shared pytest fixtures: the built FMU and its extracted copy."""
from __future__ import annotations

import os
import pathlib
import shutil

import pytest

from gearmesh.paths import ENV_CHECKOUT, find_checkout

# The checkout the tests belong to (they read its scenes, docs and build); the package under test
# resolves its files through the same checkout (gearmesh.paths), as tools/bootstrap.sh sets it.
REPO = find_checkout(pathlib.Path(__file__).parent)
os.environ.setdefault(ENV_CHECKOUT, str(REPO))

# Modules that take seconds to minutes (CalculiX runs, the stability suite's subset, the main
# job, FE databases, Dask clusters, the platform stage): marked `slow`, left out by
# `tools/run-tests --quick` (pytest -m "not slow"). The rest runs in about half a minute.
SLOW_MODULES = {"test_stability", "test_main_job", "test_package", "test_train_fe", "test_reference_fe_smoke",
                "test_reference_fe3d_smoke", "test_reference_fe3d_lineload_smoke", "test_fe_scenes", "test_compliance_db_fe",
                "test_batch_tasks", "test_platforms", "test_stability_trains", "test_masters"}


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: seconds to minutes; left out by tools/run-tests --quick")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.module.__name__.rsplit(".", 1)[-1] in SLOW_MODULES:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def fmu_path() -> pathlib.Path:
    """The packed GearMesh.fmu of the build tree (GEARMESH_FMU overrides)."""
    path = pathlib.Path(os.environ.get("GEARMESH_FMU", REPO / "build" / "GearMesh.fmu"))
    if not path.is_file():
        pytest.fail(f"{path} not found: build the 'fmu' target first (tools/run-tests does)")
    return path


@pytest.fixture(scope="session")
def fmu3_path(fmu_path) -> pathlib.Path:
    """GearMesh-fmi3.fmu beside the 2.0 FMU (GEARMESH_FMU3 overrides)."""
    path = pathlib.Path(os.environ.get("GEARMESH_FMU3", pathlib.Path(fmu_path).with_name("GearMesh-fmi3.fmu")))
    if not path.is_file():
        pytest.fail(f"{path} not found: build the 'fmu3' target first (tools/run-tests does)")
    return path


@pytest.fixture(scope="session")
def fmu_dir(fmu_path, tmp_path_factory) -> pathlib.Path:
    """The FMU extracted once per session."""
    from fmpy import extract

    target = tmp_path_factory.mktemp("fmu")
    extract(str(fmu_path), str(target))
    return target


@pytest.fixture(scope="session")
def md(fmu_path):
    """The FMU's model description."""
    from fmpy import read_model_description

    return read_model_description(str(fmu_path))


@pytest.fixture
def new(fmu_dir, md):
    """Factory of FMI-level Instances (test_fmu_conformance.Instance) of the generic FMU, or of
    another extracted FMU, freed after the test."""
    from test_fmu_conformance import Instance

    made = []

    def make(directory=None, model_description=None, **kwargs):
        inst = Instance(directory or fmu_dir, model_description or md, **kwargs)
        made.append(inst)
        return inst

    yield make
    for inst in made:
        inst.free()


@pytest.fixture
def ccx_installed():
    """CalculiX on the path; a failure, not a skip, when it is missing (tools/bootstrap.sh
    installs calculix-ccx)."""
    if shutil.which("ccx") is None:
        pytest.fail("CalculiX (ccx) not installed: tools/bootstrap.sh installs calculix-ccx")
