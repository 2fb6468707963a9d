"""svo.Mesh: from arrays of every accepted dtype and layout, from files and from trimesh."""

import numpy as np
import pytest
import trimesh

import svo
from conftest import TORUS

V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]


@pytest.mark.parametrize("vdtype", [np.float64, np.float32, np.int32, np.int64, np.float16])
@pytest.mark.parametrize("fdtype", [np.int64, np.int32, np.uint32, np.uint64, np.int16, np.uint8])
def test_dtypes_give_the_same_mesh(vdtype, fdtype):
    m = svo.Mesh(np.array(V, dtype=vdtype), np.array(F, dtype=fdtype))
    assert m.vertices.dtype == np.float64 and m.faces.dtype == np.uint32
    np.testing.assert_array_equal(m.vertices, np.array(V, dtype=np.float64))
    np.testing.assert_array_equal(m.faces, np.array(F))
    assert len(m) == 4


def test_lists_strided_fortran_and_read_only_arrays():
    wide = np.zeros((4, 6))
    wide[:, ::2] = V  # every other column: a strided view
    faces = np.asfortranarray(np.array(F, dtype=np.int32))
    ro = np.array(V, dtype=np.float32)
    ro.flags.writeable = False
    faces_ro = np.array(F)
    faces_ro.flags.writeable = False
    for vertices, f in [(V, F), (wide[:, ::2], faces), (ro, faces_ro)]:
        m = svo.Mesh(vertices, f)
        np.testing.assert_array_equal(m.vertices, np.array(V, dtype=np.float64))
        np.testing.assert_array_equal(m.faces, np.array(F))
    assert not ro.flags.writeable  # left as it was


def test_an_object_with_vertices_and_faces():
    sphere = trimesh.creation.icosphere(subdivisions=2)
    m = svo.Mesh(sphere)
    np.testing.assert_array_equal(m.vertices, sphere.vertices)
    np.testing.assert_array_equal(m.faces, sphere.faces)
    # bake takes it as it is, too
    assert svo.bake(sphere, depth=4).leaf_count == svo.bake(m, depth=4).leaf_count


def test_load_a_file():
    m = svo.Mesh.load(TORUS)
    assert len(m) == 9216
    lo, hi = m.bounds
    assert all(a < b for a, b in zip(lo, hi))
    assert "9216 triangles" in repr(m)
    m2 = svo.Mesh.load(str(TORUS))
    np.testing.assert_array_equal(m.vertices, m2.vertices)
