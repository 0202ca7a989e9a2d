"""A parameter's name is written once in C/C++: its row in core/include/gearmesh/parameters.h.
Messages take it from there (GM_PARAM_NAME and its siblings in core/src/params.hpp, GM_FMU_NAME in
modelDescription/variables.h), so a renamed parameter cannot leave a message naming the old one.
The scan reads every string literal outside comments in the core, the FMU sources and
compliance_tool; the tables themselves, the variables' descriptions and compliance_tool's usage
text (which shows example --param names) are where names belong."""

import re

from conftest import REPO

TABLE = REPO / "core/include/gearmesh/parameters.h"
# where a parameter's name may stand as a literal: the table, the FMU variable tables (their rows'
# descriptions cross-reference parameters), the train FMU's own table, compliance_tool's usage
ALLOWED = {
    "core/include/gearmesh/parameters.h",
    "core/include/gearmesh/outputs.h",
    "modelDescription/variables.h",
    "fmu_src/train_variables.h",
}
USAGE = re.compile(r"usage|--param NAME|--ring-outer|--coupled N")
LITERAL = re.compile(r'"((?:[^"\\\n]|\\.)*)"')


def parameter_names():
    text = TABLE.read_text()
    names = set(re.findall(r'X\(A, "([a-z0-9_.]+)",', text))
    suffixes = re.findall(r'X\(A, "gear" #i "(\.[a-z0-9_]+)"', text)
    suffixes += ["." + f for f in re.findall(r"GM_PARAMETERS_FLANK\(X, A, i, n, ([a-z0-9_]+),", text)]
    for suffix in suffixes:
        names |= {"gear1" + suffix, "gear2" + suffix}
    return names


def literals(path):
    """(line, text) of each string literal outside // and /* */ comments."""
    source = path.read_text()
    code = re.sub(r"/\*.*?\*/", lambda m: re.sub(r"[^\n]", " ", m.group()), source, flags=re.S)
    code = re.sub(r"//[^\n]*", "", code)
    for m in LITERAL.finditer(code):
        yield code.count("\n", 0, m.start()) + 1, m.group(1)


def offenders(names, files, root=REPO):
    pattern = re.compile(r"(?<![\w.])(" + "|".join(re.escape(n) for n in sorted(names, key=len, reverse=True))
                         + r")(?![\w])")
    found = []
    for path in files:
        rel = path.relative_to(root).as_posix()
        if rel in ALLOWED:
            continue
        lines = path.read_text().splitlines()
        for line, text in literals(path):
            if rel.startswith("compliance_tool/") and USAGE.search(lines[line - 1] + text):
                continue
            for m in pattern.finditer(text):
                found.append(f"{rel}:{line}: {m.group(1)}")
    return found


def sources():
    for folder, patterns in (("core", ("*.cpp", "*.hpp", "*.h")), ("fmu_src", ("*.c", "*.h")),
                             ("compliance_tool", ("*.cpp", "*.hpp")), ("modelDescription", ("*.h",))):
        for pattern in patterns:
            yield from sorted((REPO / folder).rglob(pattern))


def test_the_table_has_the_names():
    names = parameter_names()
    assert {"model.stiffness", "gear1.teeth", "gear2.compliance", "dynamics.tolerance", "gear2.tip_relief"} <= names
    assert len(names) > 80


def test_no_message_spells_a_parameter_name():
    found = offenders(parameter_names(), list(sources()))
    assert not found, "parameter names written as literals (use GM_PARAM_NAME and its siblings):\n" + "\n".join(found)


def test_the_scan_sees_a_planted_name(tmp_path):
    """The scan finds a literal that names a parameter, and not one inside a comment or a longer
    name."""
    probe = tmp_path / "core" / "probe.cpp"
    probe.parent.mkdir()
    probe.write_text('// "model.stiffness" in a comment\n/* "gear1.teeth" */\n'
                     'const char* a = "pair.center_distance = 1 m";\nconst char* b = "mesh.stiffness";\n')
    assert offenders(parameter_names(), [probe], tmp_path) == ["core/probe.cpp:3: pair.center_distance"]
