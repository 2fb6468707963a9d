"""svo.Octree: files and bytes, exports, cells, the dense grid, leaves and point queries."""

import numpy as np
import pytest

import svo
from conftest import CONFORMANCE


def test_files_and_bytes_round_trip(tmp_path, torus):
    tree = svo.bake(torus, depth=5)
    path = tmp_path / "t.svo"
    n = tree.save(path)
    assert n == path.stat().st_size
    assert path.read_bytes() == tree.to_bytes()
    again = svo.Octree.load(path)
    assert again.to_bytes() == tree.to_bytes()
    assert svo.Octree.from_bytes(tree.to_bytes()).leaf_count == tree.leaf_count
    assert (again.depth, again.leaf_count, again.node_count) == (tree.depth, tree.leaf_count, tree.node_count)
    assert again.build["source_triangles"] == 9216 and again.build["strategy"] == "exact"
    assert list(again.channels) == ["normal", "contour", "colour", "reflectivity", "refractivity", "ior"]
    assert again.channels["normal"] == "per-leaf" and again.channels["colour"] == "constant"
    assert [p.name for p in tmp_path.iterdir()] == ["t.svo"]  # nothing left beside it


def test_every_valid_file_of_the_conformance_corpus_loads():
    valid = sorted(CONFORMANCE.glob("valid-*.svo"))
    assert len(valid) >= 30
    for path in valid:
        tree = svo.Octree.load(path)
        assert tree.cells().shape == (tree.leaf_count, 3)
        assert svo.Octree.from_bytes(path.read_bytes()).leaf_count == tree.leaf_count


def test_cells_dense_and_leaves_agree(tetra):
    tree = svo.bake(tetra, depth=5)
    cells = tree.cells()
    assert cells.dtype == np.uint32 and cells.shape == (tree.leaf_count, 3) == (len(tree), 3)
    assert len({tuple(c) for c in cells}) == tree.leaf_count
    dense = tree.dense()
    assert dense.shape == (32, 32, 32) and dense.sum() == tree.leaf_count
    assert dense[cells[:, 0], cells[:, 1], cells[:, 2]].all()
    leaves = tree.leaves()
    np.testing.assert_array_equal(leaves["cell"], cells)
    assert leaves["normal"].shape == (tree.leaf_count, 3)
    np.testing.assert_allclose(np.linalg.norm(leaves["normal"], axis=1), 1, atol=1e-4)
    assert leaves["colour"].dtype == np.uint8 and leaves["colour"].shape == (tree.leaf_count, 4)
    assert leaves["contour"].shape == (tree.leaf_count, 2)
    assert (leaves["contour"][:, 0] <= leaves["contour"][:, 1]).all()
    assert not leaves["interior"].any()
    assert set(svo.bake(tetra, depth=3, channels="none").leaves()) == {"cell", "interior"}


def test_point_queries(tetra):
    tree = svo.bake(tetra, depth=5)
    origin, side = tree.root
    size = tree.cell_size
    assert size == side / 32
    cells = tree.cells()
    centres = np.asarray(origin) + (cells + 0.5) * size
    assert tree.contains(centres).all()
    np.testing.assert_array_equal(tree.leaf_at(centres), np.arange(tree.leaf_count))
    lo, hi = tree.bounds
    outside = np.array([np.asarray(lo) - 1, np.asarray(hi) + 1])
    assert not tree.contains(outside).any()
    dense = tree.dense()
    empty = np.argwhere(~dense)[:50]
    assert not tree.contains(np.asarray(origin) + (empty + 0.5) * size).any()
    assert tree.contains(centres[0]).shape == (1,)


def test_exports(tmp_path, torus):
    tree = svo.bake(torus, depth=5)
    assert tree.save_binvox(tmp_path / "t.binvox") > 0
    data = (tmp_path / "t.binvox").read_bytes()
    assert data.startswith(b"#binvox 1\ndim 32 32 32")
    assert tree.save_vox(tmp_path / "t.vox") > 0
    assert (tmp_path / "t.vox").read_bytes()[:4] == b"VOX "
