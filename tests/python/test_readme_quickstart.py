"""The README's fmpy quick start runs as printed and prints what the README says it prints; the
printed TE is the approach it sets (5 um along the line of action, gear 1 at rest) and the force
lies in the range of the pair's mesh stiffness (ISO 6336-1's single-pair c' of set A, 15.6
N/(mm um) over 23 mm, to 0.5x-1.5x: level 4 of this pair at the pitch point is about 0.8 c')."""
from __future__ import annotations

import pathlib
import re
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parents[2]


def quick_start() -> tuple[str, str]:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Quick start"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    promised = re.search(r"prints `([^`]+)`", section).group(1)
    return code, promised


def test_readme_quick_start_runs(fmu_path, tmp_path):
    code, promised = quick_start()
    assert '"build/GearMesh.fmu"' in code
    script = tmp_path / "quick_start.py"
    script.write_text(code.replace('"build/GearMesh.fmu"', repr(str(fmu_path))))
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == promised
    te, force = map(float, re.match(r"TE (\S+) um, normal force (\S+) N", promised).groups())
    assert te == 5.0
    assert 0.5 * 15.6e9 * 0.023 * 5e-6 < force < 1.5 * 15.6e9 * 0.023 * 5e-6


def test_readme_states_the_fmus_default_level_and_force(fmu_path):
    """The level the quick start names is the generic FMU's default (modelDescription's start
    value of model.stiffness), and at level 0 its force is the user constant x face width x TE
    of the FMU's start values."""
    from fmpy import read_model_description

    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Quick start"):]
    level = int(re.search(r"the generic FMU's defaults: the paper's gear set A at\s+level (\d)", section).group(1))
    start = {v.name: v.start for v in read_model_description(str(fmu_path)).modelVariables}
    assert level == int(start["model.stiffness"])
    _, promised = quick_start()
    force = float(re.search(r"normal force (\S+) N", promised).group(1))
    if level == 0:
        expected = float(start["model.user_stiffness"]) * float(start["gear1.face_width"]) * 5e-6
        assert force == round(expected)
