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
