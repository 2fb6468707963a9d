"""Octree.cast held to a brute-force reference: every leaf cell's box against every ray,
for random rays, axis-parallel rays (with -0.0), rays along cell faces and through corners."""

import numpy as np
import pytest
import trimesh

import svo

EPS = 1e-4  # in cells: rays closer than this to a tie (a grazed edge) may go either way


def boxes(tree):
    origin, _ = tree.root
    lo = np.asarray(origin) + tree.cells() * tree.cell_size
    return lo, lo + tree.cell_size


def brute(tree, o, d):
    """Per ray: the first parameter at which it touches a leaf's closed box, the first at
    which it enters one's interior (a segment of positive length inside the open box: a ray
    running along a face only touches), and that leaf."""
    lo, hi = boxes(tree)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d[:, None, :]
        t0 = (lo[None] - o[:, None]) * inv
        t1 = (hi[None] - o[:, None]) * inv
    # a zero component: inside the closed slab (touch) or the open one (enter), the whole
    # line; outside, nothing
    zero = d[:, None, :] == 0
    o3 = o[:, None]
    closed = (o3 >= lo[None]) & (o3 <= hi[None])
    open_ = (o3 > lo[None]) & (o3 < hi[None])

    def span(inside):
        near = np.where(zero, np.where(inside, -np.inf, np.inf), np.minimum(t0, t1))
        far = np.where(zero, np.where(inside, np.inf, -np.inf), np.maximum(t0, t1))
        return np.maximum(near.max(axis=2), 0.0), far.min(axis=2)

    scale = tree.cell_size / np.linalg.norm(d, axis=1)[:, None]  # parameter per cell
    t_in, t_out = span(closed)
    touch = np.where(t_out >= t_in, t_in, np.inf)
    t_in, t_out = span(open_)
    enter = np.where(t_out - t_in > EPS * scale, t_in, np.inf)
    return touch.min(axis=1), enter.min(axis=1), enter.argmin(axis=1), scale[:, 0]


def check(tree, o, d, mode="cube"):
    h = tree.cast(o, d, mode=mode)
    touch, enter, leaf, scale = brute(tree, o, d)
    t = np.where(h.hit, h.t, np.inf)
    tol = EPS * scale
    # never later than a leaf the ray enters, never earlier than the first it touches
    assert (t <= enter + tol).all(), np.flatnonzero(t > enter + tol)[:10]
    assert (t >= touch - tol).all()
    # where the first touch is a clean entry, the same leaf at the same distance
    finite = np.isfinite(enter)
    clean = finite & (np.subtract(enter, touch, where=finite, out=np.full_like(enter, np.inf)) <= tol)
    np.testing.assert_allclose(h.t[clean], enter[clean], atol=1e-3 * tree.cell_size)
    assert (h.hit == np.isfinite(touch))[np.isfinite(enter) | ~np.isfinite(touch)].all()
    np.testing.assert_allclose(
        h.point[h.hit], o[h.hit] + h.t[h.hit, None] * d[h.hit], atol=1e-9 * tree.root[1]
    )
    # a unit normal, zero only for a ray that starts inside a leaf
    started_inside = h.t[h.hit] == 0
    assert ((np.abs(h.normal[h.hit]).sum(axis=1) > 0.99) | started_inside).all()
    return h, clean, leaf


@pytest.fixture(scope="module")
def bunnyish():
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.vertices *= [1.0, 0.7, 0.5]
    return svo.bake(mesh, depth=4, channels="none")


def test_random_rays(bunnyish):
    rng = np.random.default_rng(60)
    lo, hi = bunnyish.bounds
    lo, hi = np.asarray(lo), np.asarray(hi)
    o = rng.uniform(lo - 1, hi + 1, size=(400, 3))
    target = rng.uniform(lo, hi, size=(400, 3))
    d = target - o
    h, clean, leaf = check(bunnyish, o, d)
    assert h.hit.sum() > 100 and clean.sum() > 350


def test_axis_parallel_rays_with_negative_zero(bunnyish):
    dense = bunnyish.dense()
    n = dense.shape[0]
    origin, side = bunnyish.root
    c = bunnyish.cell_size
    idx = np.arange(n)
    ys, zs = np.meshgrid(idx, idx, indexing="ij")
    ys, zs = ys.ravel(), zs.ravel()
    for axis in range(3):
        for sign in (1.0, -1.0):
            o = np.empty((n * n, 3))
            others = [a for a in range(3) if a != axis]
            o[:, others[0]] = origin[others[0]] + (ys + 0.5) * c
            o[:, others[1]] = origin[others[1]] + (zs + 0.5) * c
            o[:, axis] = origin[axis] - 1.0 if sign > 0 else origin[axis] + side + 1.0
            for zero in (0.0, -0.0):
                d = np.full((n * n, 3), zero)
                d[:, axis] = sign
                h, clean, _ = check(bunnyish, o, d)
                rows = np.moveaxis(dense, axis, 2).reshape(n * n, n)
                if sign < 0:
                    rows = rows[:, ::-1]
                has = rows.any(axis=1)
                np.testing.assert_array_equal(h.hit, has)
                first = rows.argmax(axis=1)
                np.testing.assert_allclose(h.t[has], 1.0 + first[has] * c, rtol=1e-6)


def test_rays_along_faces_and_through_corners(bunnyish):
    origin, side = bunnyish.root
    c = bunnyish.cell_size
    n = round(side / c)
    k = np.arange(n + 1)
    # along x, in the planes between cells (on faces and edges)
    o = np.stack([np.full(n + 1, origin[0] - 1.0), origin[1] + k * c, origin[2] + k[::-1] * c], axis=1)
    check(bunnyish, o, np.tile([1.0, 0.0, 0.0], (n + 1, 1)))
    # diagonals through grid corners
    o = np.asarray(origin) - 1.0 + np.stack([np.zeros(n + 1), k * c, np.zeros(n + 1)], axis=1)
    check(bunnyish, o, np.tile([1.0, 1.0, 1.0], (n + 1, 1)))
    check(bunnyish, o + [side + 2, 0, side + 2], np.tile([-1.0, 1.0, -1.0], (n + 1, 1)))


def test_contours_and_t_max(torus):
    tree = svo.bake(torus, depth=6)
    lo, hi = (np.asarray(b) for b in tree.bounds)
    rng = np.random.default_rng(61)
    o = rng.uniform(lo - 2, hi + 2, size=(2000, 3))
    d = rng.uniform(lo, hi, size=(2000, 3)) - o
    d /= np.linalg.norm(d, axis=1)[:, None]
    contour = tree.cast(o, d)
    cube = tree.cast(o, d, mode="cube")
    both = contour.hit & cube.hit
    # the contour slab lies inside the cube: never hit before it
    assert (contour.t[both] >= cube.t[both] - 1e-9).all()
    assert contour.hit.sum() <= cube.hit.sum()
    # t_max keeps the hits up to it
    cut = np.nanmedian(contour.t)
    near = tree.cast(o, d, t_max=cut)
    np.testing.assert_array_equal(near.hit, contour.hit & (contour.t <= cut))
    np.testing.assert_array_equal(near.leaf[near.hit], contour.leaf[near.hit])
    # one origin for every ray, and threads do not change a hit
    one = tree.cast(o[0], d, threads=1)
    np.testing.assert_array_equal(one.leaf, tree.cast(np.tile(o[0], (2000, 1)), d).leaf)
    assert len(one) == 2000 and "hits" in repr(one)
    # hits land in their leaves' cells
    centre_cells = tree.leaves()["cell"][contour.leaf[contour.hit]]
    p = (contour.point[contour.hit] - np.asarray(tree.root[0])) / tree.cell_size
    assert (np.abs(p - (centre_cells + 0.5)) <= 0.5 + 1e-4).all()  # float32 in the grid
