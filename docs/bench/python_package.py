"""Side-by-side figures of the Python package for docs/benchmarks.md: ``svo.bake`` and
``Octree.cast`` from Python against open3d's and trimesh's voxelizers and Embree (embreex),
each with its error against the exact voxel set, and (driven by ``svo-bench``, which times
the Rust calls between this script's runs) against the same calls from Rust.

    pip install ./crates/svo-py open3d trimesh embreex
    python3 docs/bench/python_package.py MESH RAYS.bin   # then commands on stdin

Each command line is answered with one JSON line:

    bake DEPTH        one svo.bake (default options, all cores): ms, leaves
    open3d DEPTH [C]  VoxelGrid.create_from_triangle_mesh_within_bounds on svo's grid: ms,
                      and unless C is 0, its voxels and the cells missed and extra against
                      svo's exact set at DEPTH
    trimesh DEPTH     trimesh.voxel.creation.voxelize_subdivide on svo's grid: the same
    rays N            N rays (seeded) written to RAYS.bin as little-endian float64 rows
                      (origin, direction) for the Rust side
    cast DEPTH        one Octree.cast of those rays through the depth-DEPTH tree: ms, hits;
                      the leaf each ray hit (-1 for none) written to RAYS.bin.leaf
    embree            one embreex closest-hit run of those rays (one thread): ms, hits, and
                      its agreement with the last cast (hit or miss, and the distance)

The first line names the versions. Loading and baking the trees the commands compare with are
not timed.
"""
import json
import statistics
import sys
import time

import numpy as np

import svo


def timed(f):
    t0 = time.perf_counter()
    out = f()
    return (time.perf_counter() - t0) * 1e3, out


def keys(cells, n):
    cells = np.asarray(cells, dtype=np.int64)
    return set((cells[:, 0] * n + cells[:, 1]) * n + cells[:, 2])


class Bench:
    def __init__(self, path, rays_path):
        self.mesh = svo.Mesh.load(path)
        self.v, self.f = self.mesh.vertices, self.mesh.faces.astype(np.int64)
        self.rays_path = rays_path
        self.trees = {}
        self.exact = {}
        self.rays = None
        self.last_cast = None

    def tree(self, depth):
        if depth not in self.trees:
            self.trees[depth] = svo.bake(self.mesh, depth=depth)
        return self.trees[depth]

    def exact_set(self, depth):
        if depth not in self.exact:
            self.exact[depth] = keys(self.tree(depth).cells(), 2**depth)
        return self.exact[depth]

    def compare(self, depth, cells):
        exact = self.exact_set(depth)
        got = keys(cells, 2**depth)
        return {"voxels": len(got), "missed": len(exact - got), "extra": len(got - exact)}

    def bake(self, depth):
        ms, tree = timed(lambda: svo.bake(self.mesh, depth=depth))
        self.trees.setdefault(depth, tree)
        return {"ms": ms, "leaves": tree.leaf_count}

    def open3d(self, depth, compare=1):
        import open3d as o3d

        tree = self.tree(depth)
        origin, side = tree.root
        lo = np.asarray(origin)
        mesh = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(self.v), o3d.utility.Vector3iVector(self.f))
        ms, grid = timed(lambda: o3d.geometry.VoxelGrid.create_from_triangle_mesh_within_bounds(
            mesh, tree.cell_size, lo, lo + side))
        if not compare:
            return {"ms": ms}
        cells = np.array([v.grid_index for v in grid.get_voxels()]).reshape(-1, 3)
        return {"ms": ms, **self.compare(depth, cells)}

    def trimesh(self, depth):
        import trimesh
        from trimesh.voxel.creation import voxelize_subdivide

        tree = self.tree(depth)
        lo = np.asarray(tree.root[0])
        pitch = tree.cell_size
        # trimesh's cell k is centred on k * pitch: shifted so that it is svo's cell k - 1
        mesh = trimesh.Trimesh(self.v - lo + 0.5 * pitch, self.f, process=False)
        ms, grid = timed(lambda: voxelize_subdivide(mesh, pitch))
        cells = np.round(grid.points / pitch).astype(np.int64) - 1
        return {"ms": ms, **self.compare(depth, cells)}

    def make_rays(self, n):
        rng = np.random.default_rng(60)
        lo, hi = (np.asarray(b) for b in self.mesh.bounds)
        centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
        u = rng.normal(size=(n, 3))
        o = centre + 2 * radius * u / np.linalg.norm(u, axis=1)[:, None]
        d = rng.uniform(lo, hi, size=(n, 3)) - o
        d /= np.linalg.norm(d, axis=1)[:, None]
        self.rays = (np.ascontiguousarray(o), np.ascontiguousarray(d))
        np.concatenate([o, d], axis=1).astype("<f8").tofile(self.rays_path)
        return {"rays": n}

    def cast(self, depth):
        tree = self.tree(depth)
        ms, hits = timed(lambda: tree.cast(*self.rays))
        self.last_cast = (depth, hits)
        hits.leaf.astype("<i8").tofile(self.rays_path + ".leaf")
        return {"ms": ms, "hits": int(hits.hit.sum())}

    def embree(self):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene, self.v[self.f].astype(np.float32))
        o, d = (a.astype(np.float32) for a in self.rays)
        scene.run(o, d)  # builds the BVH
        ms, out = timed(lambda: scene.run(o, d, output=1))
        hit = out["geomID"] >= 0
        result = {"ms": ms, "hits": int(hit.sum())}
        if self.last_cast is not None:
            depth, h = self.last_cast
            cell = self.tree(depth).cell_size
            both = hit & h.hit
            result["agree"] = float((hit == h.hit).mean())
            result["depth"] = depth
            result["median_t_cells"] = float(np.median(np.abs(h.t[both] - out["tfar"][both]))) / cell
        return result


def main():
    bench = Bench(sys.argv[1], sys.argv[2])
    versions = {"svo": svo.__version__, "numpy": np.__version__, "python": sys.version.split()[0]}
    for name in ["open3d", "trimesh", "embreex"]:
        try:
            versions[name] = __import__(name).__version__
        except Exception as e:  # noqa: BLE001 - a missing baseline is reported, not fatal
            versions[name] = f"missing: {e}"
    print(json.dumps({"versions": versions, "triangles": len(bench.mesh)}), flush=True)
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        cmd, args = words[0], [int(w) for w in words[1:]]
        try:
            out = {
                "bake": lambda: bench.bake(*args),
                "open3d": lambda: bench.open3d(*args),
                "trimesh": lambda: bench.trimesh(*args),
                "rays": lambda: bench.make_rays(*args),
                "cast": lambda: bench.cast(*args),
                "embree": lambda: bench.embree(),
            }[cmd]()
        except Exception as e:  # noqa: BLE001 - the caller reports it
            out = {"error": f"{type(e).__name__}: {e}"}
        print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
