"""Every reference to the project's docs from code, tests, tooling and READMEs points at a file in
the repository and, where it names one, at a section that exists there: `docs/physics.md §5`
needs a heading "## 5." in docs/physics.md, `docs/design.md, "Derivatives"` a heading
"## Derivatives". The plan documents the project started from are not in the repository, so
naming them is a dangling reference too."""
from __future__ import annotations

import pathlib
import re
import subprocess
from conftest import REPO

TEXT = (".c", ".h", ".cpp", ".hpp", ".py", ".md", ".txt", ".toml", ".html", ".sh", ".cmake")
REFERENCE = re.compile(r'docs/([A-Za-z_]+\.md)(?:,?\s*(?:§(\d+)|"([^"\n]+)"))?')
# a README and a quoted section: `README, "Choosing a level"`, `reference_fe/README.md, "Outputs"`
README_REFERENCE = re.compile(r'\b((?:[a-z_]+/)?README)(?:\.md)?(?:,\s*|\s+\(?)"([^"\n]+)"')
OUTSIDE = re.compile(r"\b(PHYSICS|DESIGN|FMI|STYLE)\.md\b")


def tracked_text_files() -> list[pathlib.Path]:
    names = subprocess.check_output(["git", "ls-files"], cwd=REPO, text=True).split()
    this = pathlib.Path(__file__).resolve()  # its examples below are dangling on purpose
    return [REPO / n for n in names
            if (n.endswith(TEXT) or n.endswith("CMakeLists.txt")) and REPO / n != this]


def headings(doc: pathlib.Path, levels: tuple[str, ...] = ("## ",)) -> set[str]:
    return {line[len(p):].strip() for line in doc.read_text(encoding="utf-8").splitlines()
            for p in levels if line.startswith(p)}


def dangling(files: list[pathlib.Path]) -> list[str]:
    found = []
    for path in files:
        text = path.read_text(encoding="utf-8", errors="replace")
        for lineno, line in enumerate(text.splitlines(), start=1):
            where = f"{path.relative_to(REPO) if path.is_relative_to(REPO) else path}:{lineno}"
            if OUTSIDE.search(line):
                found.append(f"{where}: names {OUTSIDE.search(line).group(0)}, not in the repository")
            for m in REFERENCE.finditer(line):
                doc = REPO / "docs" / m.group(1)
                if not doc.is_file():
                    found.append(f"{where}: docs/{m.group(1)} does not exist")
                    continue
                heads = headings(doc)
                if m.group(2) and not any(h.startswith(f"{m.group(2)}.") for h in heads):
                    found.append(f"{where}: docs/{m.group(1)} has no section §{m.group(2)}")
                if m.group(3) and m.group(3) not in heads:
                    found.append(f'{where}: docs/{m.group(1)} has no section "{m.group(3)}"')
            for m in README_REFERENCE.finditer(line):
                readme = REPO / f"{m.group(1)}.md"
                if not readme.is_file():
                    found.append(f"{where}: {m.group(1)}.md does not exist")
                elif not any(h == m.group(2) or h.startswith(m.group(2) + " (")
                             for h in headings(readme, ("## ", "### "))):
                    found.append(f'{where}: {m.group(1)}.md has no section "{m.group(2)}"')
    return found


def test_every_doc_reference_resolves():
    problems = dangling(tracked_text_files())
    assert not problems, "\n".join(problems)


def test_a_dangling_reference_is_found(tmp_path):
    bad = tmp_path / "x.cpp"
    bad.write_text('// see docs/physics.md §42, docs/design.md, "Nowhere", docs/none.md and '
                   "PHYSICS.md\n// fine: docs/physics.md §5, docs/design.md \"core\"\n"
                   '// README, "No such section"; nowhere/README.md, "Outputs"\n'
                   '// fine: README, "Choosing a level", reference_fe/README.md, "Outputs"\n')
    problems = dangling([bad])
    assert len(problems) == 6, problems
