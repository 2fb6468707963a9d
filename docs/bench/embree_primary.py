#!/usr/bin/env python3
"""Embree's primary-ray throughput on a mesh, for the same camera as an svo-view render.

Usage:
    svo-view bunny.svo --json --size 1920x1080 --bounces 0 --shadows none --bench 1 > cam.json
    python3 docs/bench/embree_primary.py ../shared/models/stanford/stanford-bunny.obj cam.json [runs]

Needs `pip install embreex trimesh numpy` (Embree 4 through the embreex binding, the one
trimesh uses). The rays (pixel centres at half-integers, vertical field of view) are made
in numpy beforehand and not timed; the timed part is `EmbreeScene.run` for closest hits,
which traces them one after another on one thread. Prints the median ms and Mrays/s.
"""
import json
import statistics
import sys
import time

import numpy as np
import trimesh
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh


def camera_rays(cam, width, height):
    eye = np.array(cam["eye"], dtype=np.float64)
    target = np.array(cam["target"], dtype=np.float64)
    up = np.array(cam["up"], dtype=np.float64)
    fwd = target - eye
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    upv = np.cross(right, fwd)
    tan_half = np.tan(np.radians(cam["fov_deg"]) * 0.5)
    aspect = width / height
    xs = (2.0 * (np.arange(width) + 0.5) / width - 1.0) * tan_half * aspect
    ys = (1.0 - 2.0 * (np.arange(height) + 0.5) / height) * tan_half
    sx, sy = np.meshgrid(xs, ys)
    d = fwd[None, None, :] + sx[..., None] * right + sy[..., None] * upv
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    d = d.reshape(-1, 3).astype(np.float32)
    o = np.broadcast_to(eye.astype(np.float32), d.shape).copy()
    return o, d


def main():
    mesh_path, cam_path = sys.argv[1], sys.argv[2]
    runs = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    report = json.load(open(cam_path))
    width, height = report["width"], report["height"]
    mesh = trimesh.load(mesh_path, force="mesh", process=False)
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, mesh.triangles.astype(np.float32))
    o, d = camera_rays(report["camera"], width, height)
    scene.run(o, d)  # warm-up (builds the BVH)
    times = []
    hits = 0
    for _ in range(runs):
        t0 = time.perf_counter()
        ids = scene.run(o, d)
        times.append(time.perf_counter() - t0)
        hits = int((ids >= 0).sum())
    med = statistics.median(times)
    n = width * height
    print(f"embree: {len(mesh.faces)} triangles, {width}x{height}, {hits / n * 100:.1f}% hit, "
          f"median {med * 1e3:.1f} ms over {runs} runs, {n / med / 1e6:.1f} Mrays/s")


if __name__ == "__main__":
    main()
