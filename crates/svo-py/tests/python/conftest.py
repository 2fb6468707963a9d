"""Shared fixtures: the repository's paths, the command-line programs the results are held
to (``SVO_BAKE`` and ``SVO_VIEW``, which the Rust test that runs this suite sets), and
small meshes."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import svo

REPO = Path(__file__).resolve().parents[4]
TORUS = REPO / "fixtures" / "torus.obj"
CONFORMANCE = REPO / "fixtures" / "format" / "conformance"


def program(name: str) -> Path:
    """The path of ``svo-bake`` or ``svo-view`` from ``SVO_BAKE``/``SVO_VIEW``, else on
    PATH; a test without it is skipped, or fails under CI."""
    env = os.environ.get(name.upper().replace("-", "_"))
    path = env or shutil.which(name)
    if path and Path(path).is_file():
        return Path(path)
    why = f"{name} not found: set {name.upper().replace('-', '_')} or put it on PATH"
    if os.environ.get("CI"):
        pytest.fail(why)
    pytest.skip(why)


@pytest.fixture
def tetra() -> svo.Mesh:
    """A closed tetrahedron, unit legs along the axes."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    return svo.Mesh(v, f)


@pytest.fixture
def torus() -> svo.Mesh:
    """The repository's torus (9216 triangles)."""
    return svo.Mesh.load(TORUS)
