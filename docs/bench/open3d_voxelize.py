"""Side-by-side baseline for docs/benchmarks.md: open3d's voxelizer on the same mesh, grid and
root cube as `svo-bake` (root = AABB minimum, side = largest extent, 2^depth cells per axis).

    pip install open3d
    python3 docs/bench/open3d_voxelize.py ../shared/models/stanford/stanford-bunny.obj 8 10

Prints the median of 5 runs of VoxelGrid.create_from_triangle_mesh_within_bounds (the voxel
set only, no octree, attributes or file), loading excluded, and the voxel count.

With --serve instead of depths, the mesh stays loaded and each line "DEPTH RUNS" read from
stdin is answered with one result line (the median of RUNS runs), so that a caller can time
its own work between open3d's runs, side by side in one sitting.
"""
import statistics
import sys
import time

import numpy as np
import open3d as o3d


def measure(mesh, lo, side, depth, runs):
    n = 2 ** depth
    times = []
    voxels = 0
    for i in range(runs):
        t0 = time.perf_counter()
        grid = o3d.geometry.VoxelGrid.create_from_triangle_mesh_within_bounds(
            mesh, side / n, lo, lo + side)
        times.append(time.perf_counter() - t0)
        if i == runs - 1:
            voxels = len(grid.get_voxels())
        # Freed off the clock (at the next assignment it would be inside the next run's time).
        del grid
    return f"depth {depth} ({n}^3): median {statistics.median(times) * 1e3:.1f} ms, {voxels} voxels"


def main():
    path = sys.argv[1]
    serve = sys.argv[2:] == ["--serve"]
    depths = [] if serve else [int(d) for d in sys.argv[2:]] or [8]
    mesh = o3d.io.read_triangle_mesh(path)
    v = np.asarray(mesh.vertices)
    lo, hi = v.min(axis=0), v.max(axis=0)
    side = float((hi - lo).max())
    print(f"{path}: {len(mesh.triangles)} triangles, open3d {o3d.__version__}, "
          f"{o3d.utility.get_num_threads() if hasattr(o3d.utility, 'get_num_threads') else '?'} threads",
          flush=True)
    for depth in depths:
        print(measure(mesh, lo, side, depth, 5), flush=True)
    if serve:
        for line in sys.stdin:
            if not line.strip():
                continue
            depth, runs = (int(x) for x in line.split())
            print(measure(mesh, lo, side, depth, runs), flush=True)


if __name__ == "__main__":
    main()
