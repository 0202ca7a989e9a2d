"""The scene parser fuzzed with Hypothesis: whatever the file holds, load_scene returns a Scene or
raises SceneError, never another exception (docs/reliability.md, "Scene files"). Inputs: the
committed scenes with lines changed, deleted, repeated or added (values of every TOML type, keys
of the schema, files outside the folder), arbitrary text, and arbitrary bytes.

Bounded for the test suite (300 examples each, a fixed seed: the same inputs every run);
HYPOTHESIS_PROFILE=explore draws new ones, e.g.
  HYPOTHESIS_PROFILE=explore .venv/bin/python -m pytest tests/python/test_scene_fuzz.py
"""
from __future__ import annotations

import os
import pathlib
import shutil

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from gearmesh.scene import BODY_SCHEMA, FE_SCHEMA, RUN_SCHEMA, SCHEMA, SceneError, load_scene
from conftest import REPO

SCENES = sorted((REPO / "scenarios").rglob("*.toml"))

settings.register_profile("ci", max_examples=300, deadline=None, derandomize=True, database=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("explore", max_examples=5000, deadline=None, database=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="module")
def scenarios(tmp_path_factory) -> pathlib.Path:
    """A copy of scenarios/, so that the mutated scenes find (or miss) their files as the real ones
    would, and nothing is written into the repository."""
    root = tmp_path_factory.mktemp("fuzz") / "scenarios"
    shutil.copytree(REPO / "scenarios", root)
    return root


def load_or_refuse(path: pathlib.Path) -> None:
    """load_scene's contract: a Scene, or a SceneError starting with the file's path."""
    try:
        load_scene(path)
    except SceneError as exc:
        assert str(exc).startswith(f"{path}: "), str(exc)


KEYS = sorted({f"{section}.{key}" for section, keys in SCHEMA.items() for key in keys}
              | {f"fe.{key}" for key in FE_SCHEMA} | {f"run.{key}" for key in RUN_SCHEMA}
              | {f"gear1.body.{key}" for key in BODY_SCHEMA})
SECTIONS = sorted(SCHEMA) + ["scene", "fe", "run", "gear1.body", "gear2.body", "gear3", "[run]", "pair.x"]

toml_value = st.one_of(
    st.integers(-(2**70), 2**70).map(str),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.booleans().map(lambda b: str(b).lower()),
    st.text(max_size=20).map(lambda s: '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'),
    st.sampled_from([
        "nan", "inf", "-inf", "1e400", "-0.0", "0x1F", "1_000", "1979-05-27", "07:32:00", "[]", "[1, 2]",
        "[1, 'a']", "[[1], [2]]", "{}", "{a = 1}", "'literal'", '"""multi\nline"""', '"../../../../etc/passwd"',
        '"/etc/passwd"', '"."', '""', '"fe"', '"paper_setA_3U4U.toml"', "[" * 200, "9" * 5000,
    ]),
)


@st.composite
def mutated_scene(draw) -> tuple[pathlib.Path, str]:
    source = draw(st.sampled_from(SCENES))
    lines = source.read_text(encoding="utf-8").splitlines()
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, max(len(lines) - 1, 0)))
        kind = draw(st.sampled_from(["value", "value", "delete", "repeat", "key", "section", "cut"]))
        if kind == "value" and lines and "=" in lines[i]:
            lines[i] = lines[i].split("=", 1)[0] + "= " + draw(toml_value)
        elif kind == "delete" and lines:
            del lines[i]
        elif kind == "repeat" and lines:
            lines.insert(i, lines[i])
        elif kind == "key":
            key = draw(st.sampled_from(KEYS))
            lines.insert(i, f"{key.split('.', 1)[1] if draw(st.booleans()) else key} = {draw(toml_value)}")
        elif kind == "section":
            lines.insert(i, f"[{draw(st.sampled_from(SECTIONS))}]")
        elif kind == "cut" and lines:
            lines[i] = lines[i][: draw(st.integers(0, len(lines[i])))]
    return source, "\n".join(lines) + "\n"


@given(mutated_scene())
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
def test_mutated_committed_scene_loads_or_is_a_scene_error(scenarios, case):
    source, text = case
    path = scenarios / source.relative_to(REPO / "scenarios").parent / "fuzzed.toml"
    path.write_text(text, encoding="utf-8")
    load_or_refuse(path)


@given(st.text(max_size=400))
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
def test_any_text_loads_or_is_a_scene_error(scenarios, text):
    path = scenarios / "fuzzed_text.toml"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    load_or_refuse(path)


@given(st.binary(max_size=400))
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
def test_any_bytes_load_or_are_a_scene_error(scenarios, data):
    path = scenarios / "fuzzed_bytes.toml"
    path.write_bytes(data)
    load_or_refuse(path)
