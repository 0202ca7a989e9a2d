"""The FMU's documentation/index.html (issue 13 item 8): generated from README.md and docs/fmi.md
(`gearmesh-dev fmu-docs`, tools/gearmesh_dev/fmu_docs.py), packed into the built FMU as
committed, and naming only variables the FMU has."""
from __future__ import annotations

import html
import re
import zipfile

from gearmesh_dev import fmu_docs

_PREFIXES = ("gear<i>", "gear1", "gear2", "mesh", "model", "solver", "pair", "geometry",
             "dynamics", "energy")


def test_committed_page_is_generated():
    committed = fmu_docs.OUTPUT.read_text(encoding="utf-8")
    assert committed == fmu_docs.generate(), (
        "fmu_src/documentation/index.html is stale: run `gearmesh-dev fmu-docs`")


def test_fmu_carries_the_page(fmu_path):
    with zipfile.ZipFile(fmu_path) as z:
        packed = z.read("documentation/index.html").decode("utf-8")
    assert packed == fmu_docs.OUTPUT.read_text(encoding="utf-8")


def named_variables(page: str) -> set[str]:
    """The variable names in the page's code spans: gear<i> expanded to gear1 and gear2, a
    leading-dot suffix (`.uy`) completed with the prefix of the last full name before it;
    wildcards (`energy.*`) and values (`model.dynamics = 1`) are not names."""
    names, prefix = set(), None
    for span in re.findall(r"<code>(.*?)</code>", page):
        text = html.unescape(span).strip()
        if not re.fullmatch(r"[a-z0-9_<>]*\.[a-z0-9_]+", text):
            continue
        if text.startswith("."):
            if prefix is None:
                continue
            text = prefix + text
        head = text.split(".", 1)[0]
        if head not in _PREFIXES:
            prefix = None
            continue
        prefix = head
        names.update({text.replace("<i>", "1"), text.replace("<i>", "2")})
    return names


def test_page_names_only_real_variables(md, fmu_path):
    """Every variable the page names is one of the FMU's, or an array it describes."""
    import zipfile

    from gearmesh.scene_fmu import array_variables

    with zipfile.ZipFile(fmu_path) as z:
        arrays = set(array_variables(z.read("modelDescription.xml").decode()))
    real = {v.name for v in md.modelVariables} | arrays
    named = named_variables(fmu_docs.OUTPUT.read_text(encoding="utf-8"))
    assert len(named) > 40, sorted(named)
    unknown = sorted(named - real)
    assert not unknown, f"index.html names variables the FMU does not have: {unknown}"


def test_name_reader():
    page = ("<code>gear&lt;i&gt;.ux</code>, <code>.uy</code> <code>mesh.te</code> "
            "<code>energy.*</code> <code>model.dynamics = 1</code> <code>docs/fmi.md</code>")
    assert named_variables(page) == {"gear1.ux", "gear2.ux", "gear1.uy", "gear2.uy", "mesh.te"}
