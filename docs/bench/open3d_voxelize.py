"""Side-by-side baseline for docs/benchmarks.md: open3d's voxelizer on the same mesh, grid and
root cube as `svo-bake` (root = AABB minimum, side = largest extent, 2^depth cells per axis).

    pip install open3d
    python3 docs/bench/open3d_voxelize.py ../shared/models/stanford/stanford-bunny.obj 8 10

Prints the median of 5 runs of VoxelGrid.create_from_triangle_mesh_within_bounds (the voxel
set only, no octree, attributes or file), loading excluded, and the voxel count.
"""
import statistics
import sys
import time

import numpy as np
import open3d as o3d


def main():
    path = sys.argv[1]
    depths = [int(d) for d in sys.argv[2:]] or [8]
    mesh = o3d.io.read_triangle_mesh(path)
    v = np.asarray(mesh.vertices)
    lo, hi = v.min(axis=0), v.max(axis=0)
    side = float((hi - lo).max())
    print(f"{path}: {len(mesh.triangles)} triangles, open3d {o3d.__version__}, "
          f"{o3d.utility.get_num_threads() if hasattr(o3d.utility, 'get_num_threads') else '?'} threads")
    for depth in depths:
        n = 2 ** depth
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            grid = o3d.geometry.VoxelGrid.create_from_triangle_mesh_within_bounds(
                mesh, side / n, lo, lo + side)
            times.append(time.perf_counter() - t0)
        print(f"depth {depth} ({n}^3): median {statistics.median(times) * 1e3:.1f} ms, "
              f"{len(grid.get_voxels())} voxels")


if __name__ == "__main__":
    main()
