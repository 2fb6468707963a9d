"""Exact sparse voxel octrees from triangle meshes.

Bake a mesh (a file, NumPy arrays or a ``trimesh.Trimesh``) into an octree that holds
exactly the cells its triangles touch, with per-leaf normals, colours, materials and
contours; save and load it as a validated ``.svo`` file; cast rays through it and ray trace
it on the CPU. NumPy arrays go in and come out; long calls release the GIL.

>>> import numpy as np, svo
>>> mesh = svo.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), [[0, 1, 2]])
>>> tree = svo.bake(mesh, depth=4)
>>> hits = tree.cast([0.2, 0.2, -1.0], [0.0, 0.0, 1.0])
>>> bool(hits.hit[0])
True
"""

from ._svo import (
    MAX_DEPTH,
    BakeError,
    ExportError,
    FormatError,
    Hits,
    Mesh,
    MeshError,
    Octree,
    __version__,
    bake,
)

__all__ = [
    "MAX_DEPTH",
    "BakeError",
    "ExportError",
    "FormatError",
    "Hits",
    "Mesh",
    "MeshError",
    "Octree",
    "__version__",
    "bake",
]
