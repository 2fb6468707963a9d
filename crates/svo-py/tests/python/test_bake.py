"""svo.bake: the same tree as svo-bake, byte for byte; no cell that the surface touches
missed (held to points on the surface that trimesh samples and subdivides)."""

import subprocess

import numpy as np
import pytest
import trimesh

import svo
from conftest import TORUS, program


@pytest.mark.parametrize(
    "depth, flags, kwargs",
    [
        (6, [], {}),
        (5, ["--channels", "normal,colour"], {"channels": "normal,colour"}),
        (5, ["--channels", "none", "--strategy", "aabb-plane"], {"channels": [], "strategy": "aabb-plane"}),
        (5, ["--solid"], {"solid": True}),
        (5, ["--lod", "filtered"], {"lod": True}),
        (4, ["--pad", "2"], {"pad": 2}),
    ],
)
def test_the_same_bytes_as_svo_bake(tmp_path, depth, flags, kwargs):
    out = tmp_path / "torus.svo"
    subprocess.run(
        [program("svo-bake"), TORUS, "--depth", str(depth), "-o", out, "--quiet", *flags],
        check=True,
    )
    tree = svo.bake(svo.Mesh.load(TORUS), depth=depth, **kwargs)
    assert tree.to_bytes() == out.read_bytes()
    assert svo.Octree.load(out).to_bytes() == out.read_bytes()


def test_threads_do_not_change_the_tree(torus):
    one = svo.bake(torus, depth=7, threads=1).to_bytes()
    assert svo.bake(torus, depth=7, threads=2).to_bytes() == one
    assert svo.bake(torus, depth=7).to_bytes() == one


@pytest.mark.parametrize("depth", [3, 6, 8])
def test_no_surface_point_outside_the_leaves(depth):
    mesh = trimesh.creation.icosphere(subdivisions=3)
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(np.random.default_rng(7).random(3)))
    tree = svo.bake(mesh, depth=depth, channels="none")
    points, _ = trimesh.sample.sample_surface(mesh, 20000, seed=depth)
    assert tree.contains(points).all()
    assert tree.contains(mesh.vertices).all()
    # trimesh's voxelizer marks the cells of its subdivided vertices: all of them are ours.
    v, _ = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=tree.cell_size / 2)
    assert tree.contains(v).all()


def test_the_inexact_strategies_hold_a_superset(torus):
    exact = {tuple(c) for c in svo.bake(torus, depth=6, channels="none").cells()}
    for s in ["aabb-plane", "sat-leaf"]:
        loose = {tuple(c) for c in svo.bake(torus, depth=6, channels="none", strategy=s).cells()}
        assert exact <= loose and len(loose) > len(exact)
    for s in ["aabb-plane-sat", "plane-sat-leaf"]:
        same = {tuple(c) for c in svo.bake(torus, depth=6, channels="none", strategy=s).cells()}
        assert same == exact


def test_solid_fills_the_inside(torus):
    surface = svo.bake(torus, depth=6)
    solid = svo.bake(torus, depth=6, solid="closed")
    leaves = solid.leaves()
    assert leaves["interior"].sum() == solid.leaf_count - surface.leaf_count > 0
    assert np.isnan(leaves["normal"][leaves["interior"]]).all()
    assert solid.contains(np.array([[0.0, 0.0, 0.0]])).sum() in (0, 1)


def test_huge_and_tiny_coordinates():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float64)
    f = [[0, 1, 2]]
    base = svo.bake(svo.Mesh(v, f), depth=6, channels="none").cells()
    for scale in [1e-30, 1e30]:
        cells = svo.bake(svo.Mesh(v * scale, f), depth=6, channels="none").cells()
        np.testing.assert_array_equal(cells, base)
