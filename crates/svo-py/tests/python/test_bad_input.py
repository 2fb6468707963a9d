"""Bad input raises an exception with the library's one-line message; none crashes the
interpreter (a crash would end this whole test run)."""

import random

import numpy as np
import pytest

import svo
from conftest import CONFORMANCE, TORUS

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


@pytest.mark.parametrize(
    "vertices, faces, error, message",
    [
        (V[:, :2], F, ValueError, "shape (N, 3)"),
        (V.ravel(), F, ValueError, "shape (N, 3)"),
        (V, F[:, :2], ValueError, "shape (N, 3)"),
        (V.astype(complex), F, TypeError, "float32 or float64"),
        (V.astype(bool), F, TypeError, "float32 or float64"),
        (V.astype(str), F, TypeError, "float32 or float64"),
        (V, F.astype(np.float64), TypeError, "integers"),
        (V, F - 1, ValueError, "is not a vertex index"),
        (V, F + 2**32, ValueError, "is not a vertex index"),
        (V, F + 10, svo.MeshError, "vertex"),
        (np.where(V == 1, np.nan, V), F, svo.MeshError, "non-finite"),
        (np.where(V == 1, np.inf, V), F, svo.MeshError, "non-finite"),
        (V, np.zeros((0, 3), dtype=np.int64), svo.MeshError, "no triangles"),
        (np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), svo.MeshError, "no triangles"),
        ([[0, 0], [1]], F, ValueError, "inhomogeneous|sequence"),
        (object(), None, TypeError, "vertices and faces"),
    ],
)
def test_bad_arrays(vertices, faces, error, message):
    with pytest.raises(error, match=message.replace("(", r"\(").replace(")", r"\)")):
        svo.Mesh(vertices, faces)


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.obj"):
        svo.Mesh.load(tmp_path / "missing.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(svo.MeshError):
        svo.Mesh.load(bad)
    odd = tmp_path / "mesh.xyz"
    odd.write_text("0 0 0\n")
    with pytest.raises(svo.MeshError, match="xyz"):
        svo.Mesh.load(odd)
    with pytest.raises(FileNotFoundError):
        svo.Octree.load(tmp_path / "missing.svo")
    with pytest.raises(IsADirectoryError):
        svo.Octree.load(tmp_path)


@pytest.mark.parametrize("depth", [0, 31, 255, 256, -1, 10**20])
def test_absurd_depths(depth):
    with pytest.raises((svo.BakeError, OverflowError), match="depth|int"):
        svo.bake(svo.Mesh(V, F), depth=depth)


def test_bad_bake_options():
    m = svo.Mesh(V, F)
    with pytest.raises(svo.BakeError, match="GiB allowed"):
        svo.bake(svo.Mesh.load(TORUS), depth=20, max_memory=1 << 20)
    # by default, the memory available now
    with pytest.raises(svo.BakeError, match="GiB allowed"):
        svo.bake(svo.Mesh.load(TORUS), depth=24)
    with pytest.raises(ValueError, match="threads"):
        svo.bake(m, depth=3, threads=0)
    with pytest.raises(ValueError, match="strategy"):
        svo.bake(m, depth=3, strategy="fast")
    with pytest.raises(ValueError, match="channel"):
        svo.bake(m, depth=3, channels="normal,shininess")
    with pytest.raises(svo.BakeError, match="contour"):
        svo.bake(m, depth=3, channels=["contour"])
    with pytest.raises(ValueError, match="closed|vote"):
        svo.bake(m, depth=3, solid="hollow")
    open_mesh = svo.Mesh(V, F[:3])
    with pytest.raises(svo.BakeError, match="open edges|closed"):
        svo.bake(open_mesh, depth=3, solid=True)


def test_every_invalid_file_of_the_conformance_corpus_raises():
    invalid = sorted(CONFORMANCE.glob("check-*.svo"))
    assert len(invalid) > 50
    for path in invalid:
        with pytest.raises(svo.FormatError, match="check"):
            svo.Octree.load(path)
        with pytest.raises(svo.FormatError):
            svo.Octree.from_bytes(path.read_bytes())
    newer = CONFORMANCE / "check-03-version-newer.svo"
    with pytest.raises(svo.FormatError, match="newer"):
        svo.Octree.load(newer)


def test_damaged_bytes_raise_or_load():
    good = svo.bake(svo.Mesh.load(TORUS), depth=4).to_bytes()
    rng = random.Random(59)
    outcomes = {"loaded": 0, "refused": 0}
    for _ in range(400):
        b = bytearray(good)
        cut = rng.random() < 0.3
        if cut:
            b = b[: rng.randrange(len(b))]
        else:
            for _ in range(rng.randint(1, 8)):
                b[rng.randrange(len(b))] = rng.randrange(256)
        try:
            svo.Octree.from_bytes(bytes(b))
            outcomes["loaded"] += 1
        except svo.FormatError:
            outcomes["refused"] += 1
    assert outcomes["refused"] > 300


def test_bad_queries_and_casts():
    t = svo.bake(svo.Mesh(V, F), depth=4)
    with pytest.raises(ValueError, match="shape"):
        t.contains(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="origins and"):
        t.cast(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="mode"):
        t.cast([0, 0, 0], [1, 0, 0], mode="sphere")
    with pytest.raises(ValueError, match="NaN"):
        t.cast([0, 0, 0], [1, 0, 0], t_max=float("nan"))
    with pytest.raises(ValueError, match="max_cells"):
        t.dense(max_cells=100)
    with pytest.raises(ValueError, match="image size"):
        t.render(0, 10)
    with pytest.raises(ValueError, match="pixel count"):
        t.render(-5, 10)
    with pytest.raises(ValueError, match="image size"):
        t.render(100000, 100000)
    with pytest.raises(ValueError, match="field of view"):
        t.render(8, 8, fov=180)
    with pytest.raises(ValueError, match="finite"):
        t.render(8, 8, eye=(float("nan"), 0, 0))
    with pytest.raises(ValueError, match="shadow"):
        t.render(8, 8, shadows="soft")
    with pytest.raises(ValueError, match="lod"):
        t.render(8, 8, lod=-1)
    with pytest.raises(ValueError, match="view"):
        t.render(8, 8, view="nowhere")
    # NaN and zero directions are misses, not errors
    h = t.cast([[0, 0, 0], [np.nan, 0, 0]], [[0, 0, 0], [1, 0, 0]])
    assert not h.hit.any() and (h.leaf == -1).all() and np.isnan(h.t).all()
    # NaN points are outside every cell
    assert not t.contains([np.nan, 0.1, 0.1]).any()
    assert t.leaf_at([np.inf, 0.1, 0.1])[0] == -1


def test_exports_that_do_not_fit(tmp_path):
    t = svo.bake(svo.Mesh(V, F), depth=9, channels="none")
    with pytest.raises(svo.ExportError, match="vox"):
        t.save_vox(tmp_path / "t.vox")
    assert not (tmp_path / "t.vox").exists()
    with pytest.raises(FileNotFoundError):
        t.save(tmp_path / "no" / "such" / "folder" / "t.svo")
