"""The first TE curve of docs/guide/first-steps.md (the README points there) runs as printed,
prints what the page says it prints and draws its picture; the printed mean TE lies in the range
the pair's ISO 6336-1 stiffness gives (F / (c' b) at 0.5x-1.5x: set A's c' is 15.8 N/(mm um),
23 mm of face); and the defaults the page states are the generic FMU's start values."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from conftest import REPO



def first_curve() -> tuple[str, str, str]:
    """The section's text, its Python block and the line it promises to print."""
    text = (REPO / "docs" / "guide" / "first-steps.md").read_text(encoding="utf-8")
    section = text[text.index("## A first TE curve"):]
    end = section.find("\n## ", 3)
    section = section if end < 0 else section[:end]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    promised = re.search(r"prints `([^`]+)`", section).group(1)
    return section, code, promised


def test_readme_first_te_curve_runs_as_printed(fmu_path, tmp_path):
    _, code, promised = first_curve()
    assert len(code.strip().splitlines()) <= 20
    (tmp_path / "build").mkdir()
    os.symlink(fmu_path, tmp_path / "build" / "GearMesh.fmu")  # the repository's layout
    (tmp_path / "first_curve.py").write_text(code)
    env = {**os.environ, "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "first_curve.py"], capture_output=True, text=True,
                         timeout=120, cwd=tmp_path, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == promised
    assert (tmp_path / "te.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    mean, pp = map(float, re.match(r"mean TE (\S+) um, peak-to-peak (\S+) um", promised).groups())
    rb2 = 0.5 * 2.6e-3 * 57 * 0.9396926  # m, base radius of set A's gear 2 (cos 20 deg)
    iso = 350.0 / rb2 / (15.8e9 * 0.023) * 1e6  # um: the load over c' b
    assert 0.5 * iso < mean < 1.5 * iso
    assert 0 < pp < mean


def test_readme_states_the_fmus_defaults(md):
    """The pair and the level the section names are the modelDescription's start values."""
    section, _, _ = first_curve()
    start = {v.name: v.start for v in md.modelVariables}
    pair = re.search(r"the paper's gear set A \((\d+)/(\d+) teeth, module ([\d.]+) mm, (\d+) mm face\)\s+"
                     r"at level (\d) with (\d+) slices", section)
    assert pair, "docs/guide/first-steps.md's first curve no longer states the defaults"
    z1, z2, module, face, level, slices = pair.groups()
    assert (int(z1), int(z2)) == (int(start["gear1.teeth"]), int(start["gear2.teeth"]))
    assert abs(float(module) * 1e-3 - float(start["pair.normal_module"])) < 1e-12
    for i in (1, 2):
        assert abs(float(face) * 1e-3 - float(start[f"gear{i}.face_width"])) < 1e-12
    assert int(level) == int(start["model.stiffness"])
    assert int(slices) == int(start["model.slices"])
