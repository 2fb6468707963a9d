"""Type stubs of the compiled module ``svo._svo``, which ``svo`` re-exports."""

from collections.abc import Sequence
from os import PathLike
from typing import Any, Literal, Optional, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_Points = npt.ArrayLike  # (N, 3) float32/float64, or one (3,) point where noted
_Vec3 = Union[Sequence[float], npt.NDArray[np.floating[Any]]]

MAX_DEPTH: int
__version__: str

class MeshError(ValueError):
    """A mesh that cannot be baked: no triangles, a non-finite coordinate, an index past the
    vertices, or a file that does not parse."""

class BakeError(ValueError):
    """A bake refused before it starts: a depth outside 1..=30, a tree larger than the
    memory available, an open mesh for a closed solid fill, contours without normals."""

class FormatError(ValueError):
    """An .svo file or byte string that is not a valid tree: bad magic bytes, truncated,
    corrupt (the numbered check of docs/format.md that failed is named), or from a newer
    format version."""

class ExportError(ValueError):
    """A tree that an export format cannot hold (binvox up to depth 10, MagicaVoxel up to 8)."""

class Mesh:
    """A triangle mesh: vertex positions (float64) and triangles (indices into them), with
    the materials, textures, lights and camera views a file brings.

    ``Mesh(vertices, faces)`` takes an ``(N, 3)`` float array and an ``(M, 3)`` integer
    array; ``Mesh(obj)`` takes any object with ``vertices`` and ``faces`` (a
    ``trimesh.Trimesh``). The arrays are copied once. A mesh without triangles, with a
    non-finite coordinate or with an index past the vertices raises ``svo.MeshError``."""

    def __init__(self, vertices: Any, faces: Optional[npt.ArrayLike] = None) -> None: ...
    @staticmethod
    def load(path: _Path) -> Mesh:
        """Loads a mesh file: ``.obj`` (with its MTL materials), ``.obj.gz``, ``.ply``,
        ``.gltf`` or ``.glb``."""
    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """The vertex positions, an ``(N, 3)`` float64 array (a copy)."""
    @property
    def faces(self) -> npt.NDArray[np.uint32]:
        """The triangles, an ``(M, 3)`` uint32 array of vertex indices (a copy)."""
    @property
    def bounds(self) -> tuple[list[float], list[float]]:
        """The bounds of the vertices the triangles use: ``(min, max)``."""
    def __len__(self) -> int: ...

class Hits:
    """Where rays hit, as arrays (row ``i``: ray ``i``)."""

    t: npt.NDArray[np.float64]
    """``(N,)``: the hit is ``origin + t * direction``; NaN on a miss."""
    point: npt.NDArray[np.float64]
    """``(N, 3)``: the hit point; NaN on a miss."""
    normal: npt.NDArray[np.float64]
    """``(N, 3)``: the unit normal facing the ray (zero for a ray starting inside a leaf);
    NaN on a miss."""
    leaf: npt.NDArray[np.int64]
    """``(N,)``: the leaf's index (a row of ``Octree.cells()``); -1 on a miss."""
    hit: npt.NDArray[np.bool_]
    """``(N,)``: whether the ray hit."""
    def __len__(self) -> int: ...

class Octree:
    """A sparse voxel octree: ``2**depth`` cells a side over its root cube, the leaves'
    cells and their attribute channels, with what made it and the scene's lights and views.
    Leaf ``i`` is row ``i`` of ``cells()`` and of every array of ``leaves()``."""

    @staticmethod
    def load(path: _Path) -> Octree:
        """Reads an ``.svo`` file (any format version), checking it."""
    @staticmethod
    def from_bytes(data: bytes) -> Octree:
        """Reads an ``.svo`` file held in memory, checked as ``load`` checks files."""
    def save(self, path: _Path) -> int:
        """Writes the tree as an ``.svo`` file, atomically; returns the bytes written."""
    def to_bytes(self) -> bytes:
        """The ``.svo`` file's bytes."""
    def save_binvox(self, path: _Path) -> int:
        """Writes the leaves as a ``.binvox`` grid (depth 10 at most), atomically."""
    def save_vox(self, path: _Path) -> int:
        """Writes the leaves as a MagicaVoxel ``.vox`` model (depth 8 at most), atomically."""
    @property
    def depth(self) -> int: ...
    @property
    def leaf_count(self) -> int: ...
    @property
    def node_count(self) -> int: ...
    @property
    def root(self) -> tuple[list[float], float]:
        """``(origin, side)`` of the root cube, scene units."""
    @property
    def cell_size(self) -> float: ...
    @property
    def bounds(self) -> tuple[list[float], list[float]]:
        """The bounds of the leaves' cells, ``(min, max)``, scene units."""
    @property
    def channels(self) -> dict[str, Literal["constant", "per-leaf"]]: ...
    @property
    def build(self) -> dict[str, Any]:
        """``{"generator", "strategy", "source_triangles"}``."""
    def cells(self) -> npt.NDArray[np.uint32]:
        """The leaves' integer cells, ``(N, 3)``."""
    def dense(self, max_cells: int = 2**30) -> npt.NDArray[np.bool_]:
        """The leaves as a boolean grid indexed ``[x, y, z]``; refused past ``max_cells``."""
    def leaves(self) -> dict[str, npt.NDArray[Any]]:
        """``cell``, ``interior`` and each stored channel (``normal``, ``contour``,
        ``colour``, ``reflectivity``, ``refractivity``, ``ior``) as arrays."""
    def contains(self, points: _Points) -> npt.NDArray[np.bool_]:
        """Whether each point lies in a leaf's cell."""
    def leaf_at(self, points: _Points) -> npt.NDArray[np.int64]:
        """The leaf whose cell holds each point, -1 where none does."""
    def cast(
        self,
        origins: _Points,
        directions: _Points,
        t_max: float = ...,
        mode: Literal["contour", "cube"] = "contour",
        threads: Optional[int] = None,
    ) -> Hits:
        """Casts rays through the tree, in parallel with the GIL released."""
    def render(
        self,
        width: int = 640,
        height: int = 480,
        eye: Optional[_Vec3] = None,
        target: Optional[_Vec3] = None,
        up: Optional[_Vec3] = None,
        fov: float = 40.0,
        view: Optional[str] = None,
        lights: Optional[Sequence[_Vec3]] = None,
        mode: Literal["contour", "cube"] = "contour",
        shadows: Literal["product", "max", "opaque", "none"] = "product",
        reflections: int = 3,
        refractions: int = 3,
        lod: float = 0.0,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.uint8]:
        """Ray traces the tree on the CPU: a ``(height, width, 3)`` sRGB image."""
    def render_aovs(
        self,
        width: int = 640,
        height: int = 480,
        eye: Optional[_Vec3] = None,
        target: Optional[_Vec3] = None,
        up: Optional[_Vec3] = None,
        fov: float = 40.0,
        view: Optional[str] = None,
        lights: Optional[Sequence[_Vec3]] = None,
        mode: Literal["contour", "cube"] = "contour",
        shadows: Literal["product", "max", "opaque", "none"] = "product",
        reflections: int = 3,
        refractions: int = 3,
        lod: float = 0.0,
        threads: Optional[int] = None,
    ) -> dict[str, npt.NDArray[Any]]:
        """``colour``, ``depth``, ``normal``, ``leaf`` and ``cost`` per pixel."""
    def __len__(self) -> int: ...

def bake(
    mesh: Any,
    depth: int = 8,
    strategy: Literal["exact", "aabb-plane", "aabb-plane-sat", "sat-leaf", "plane-sat-leaf"] = "exact",
    solid: Union[None, bool, Literal["closed", "vote"]] = None,
    channels: Union[None, str, Sequence[str]] = None,
    pad: int = 0,
    lod: bool = False,
    threads: Optional[int] = None,
    max_memory: Optional[int] = None,
) -> Octree:
    """Bakes ``mesh`` (a ``Mesh`` or anything with ``vertices`` and ``faces``) into an
    octree holding exactly the cells its triangles touch."""
