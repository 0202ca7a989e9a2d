"""GearMesh's maintainer tools (docs/developer/README.md): the multi-platform FMU, the generated
documentation (FMU page, references, figures), the tooth-coupling fit and the accuracy ledgers.
They work on a checkout of the repository and are not part of the user package `gearmesh`;
`gearmesh-dev COMMAND` runs them."""
from __future__ import annotations

import pathlib

from gearmesh.paths import Paths


def checkout() -> pathlib.Path:
    """The GearMesh checkout these tools work on: $GEARMESH_CHECKOUT, else the working directory or
    the nearest folder above it that is one (gearmesh.paths)."""
    root = Paths.resolve().checkout
    if root is None:
        raise RuntimeError("gearmesh-dev works on a GearMesh checkout: run it inside one or set "
                           "GEARMESH_CHECKOUT")
    return root
