//! `svo.Octree`: a baked or loaded tree with what its file records beside it; its files
//! (`.svo` read and written atomically, bytes, the `.binvox` and MagicaVoxel exports), and
//! its leaves as arrays (cells, a dense grid, the attribute channels, point queries).

use crate::arrays;
use crate::errors::{export_error, format_error};
use crate::rays::{self, PyHits};
use crate::render::{self, RenderArgs};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;
use svo::Octree;
use svo::io::BuildInfo;

/// The most cells ``Octree.dense`` makes by default: a 1024^3 grid (1 GiB of booleans).
const DENSE_CELLS: u64 = 1 << 30;

/// A sparse voxel octree: ``2**depth`` cells a side over its root cube, the leaves' cells
/// and their attribute channels (normal, contour, colour, reflectivity, refractivity,
/// IOR), with what made it and the scene's lights and views.
///
/// Made by ``svo.bake``, ``Octree.load`` or ``Octree.from_bytes``. Leaf ``i`` is row ``i``
/// of ``cells()`` and of every array of ``leaves()``, and the ``leaf`` a ray hits in
/// ``cast``.
#[pyclass(name = "Octree", module = "svo", frozen)]
pub(crate) struct PyOctree {
    pub(crate) tree: Octree,
    pub(crate) build: BuildInfo,
}

impl PyOctree {
    /// The tree and its build information.
    pub(crate) fn new(tree: Octree, build: BuildInfo) -> Self {
        Self { tree, build }
    }

    /// The channels stored (not absent) and how.
    fn stored_channels(&self) -> Vec<(&'static str, &'static str)> {
        self.tree
            .attributes
            .storage()
            .into_iter()
            .filter(|(_, s)| *s != svo::octree::ChannelStorage::Absent)
            .map(|(k, s)| (k.name(), s.name()))
            .collect()
    }
}

#[pymethods]
impl PyOctree {
    /// Reads an ``.svo`` file (any format version; a DAG file is expanded), checking every
    /// numbered check of the format. A missing file raises ``FileNotFoundError``; a corrupt,
    /// truncated or newer file, ``svo.FormatError``.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let (tree, build) = py
            .detach(|| svo::io::read_file(&path))
            .map_err(format_error)?;
        Ok(Self::new(tree, build))
    }

    /// Reads an ``.svo`` file held in memory (``bytes``), checked as ``load`` checks files.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let (tree, build) = py
            .detach(|| svo::io::from_bytes(data))
            .map_err(format_error)?;
        Ok(Self::new(tree, build))
    }

    /// Writes the tree as an ``.svo`` file, atomically (a failed write leaves no partial
    /// file); returns the bytes written.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<u64> {
        py.detach(|| svo::io::write_file(&self.tree, &self.build, &path))
            .map_err(format_error)
    }

    /// The ``.svo`` file's bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let bytes = py.detach(|| svo::io::to_bytes(&self.tree, &self.build));
        PyBytes::new(py, &bytes)
    }

    /// Writes the leaves as a ``.binvox`` grid (depth 10 at most), atomically; returns the
    /// bytes written.
    fn save_binvox(&self, py: Python<'_>, path: PathBuf) -> PyResult<u64> {
        py.detach(|| svo::io::write_binvox(&self.tree, &path))
            .map_err(export_error)
    }

    /// Writes the leaves as a MagicaVoxel ``.vox`` model with their colours (depth 8 at
    /// most), atomically; returns the bytes written.
    fn save_vox(&self, py: Python<'_>, path: PathBuf) -> PyResult<u64> {
        py.detach(|| svo::io::write_vox(&self.tree, &path))
            .map_err(export_error)
    }

    /// Levels below the root: the grid has ``2**depth`` cells a side.
    #[getter]
    fn depth(&self) -> u8 {
        self.tree.depth
    }

    /// How many leaves (cells with surface, or inside a solid).
    #[getter]
    fn leaf_count(&self) -> u32 {
        self.tree.leaf_count
    }

    /// How many nodes above the leaves.
    #[getter]
    fn node_count(&self) -> usize {
        self.tree.nodes.len()
    }

    /// The root cube: ``(origin, side)``, its minimum corner and side in scene units.
    #[getter]
    fn root(&self) -> ([f64; 3], f64) {
        (self.tree.root.origin.to_array(), self.tree.root.side)
    }

    /// A cell's side in scene units.
    #[getter]
    fn cell_size(&self) -> f64 {
        self.tree.root.side / (1u64 << self.tree.depth) as f64
    }

    /// The bounds of the leaves' cells in scene units, ``(min, max)`` (the root cube for a
    /// tree without leaves).
    #[getter]
    fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let (lo, hi) = self.tree.occupied_bounds();
        (lo.to_array(), hi.to_array())
    }

    /// The attribute channels stored, by name, each ``"constant"`` (one value in the
    /// header, for every leaf) or ``"per-leaf"``.
    #[getter]
    fn channels<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, s) in self.stored_channels() {
            d.set_item(k, s)?;
        }
        Ok(d)
    }

    /// What made the tree: ``{"generator", "strategy", "source_triangles"}``.
    #[getter]
    fn build<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("generator", &self.build.generator)?;
        d.set_item("strategy", &self.build.strategy)?;
        d.set_item("source_triangles", self.build.source_triangles)?;
        Ok(d)
    }

    /// The leaves' integer cells, an ``(N, 3)`` uint32 array (row ``i``: leaf ``i``; grid
    /// coordinates, the root cube being ``[0, 2**depth]**3``).
    fn cells<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let cells = py.detach(|| {
            let mut cells = vec![[0u32; 3]; self.tree.leaf_count as usize];
            for l in self.tree.leaves() {
                cells[l.index as usize] = l.cell.to_array();
            }
            cells
        });
        arrays::rows(py, cells)
    }

    /// The leaves as a dense boolean grid indexed ``[x, y, z]``, ``2**depth`` a side.
    /// Refused (``ValueError``) past ``max_cells`` cells (default ``2**30``, depth 10).
    #[pyo3(signature = (max_cells = DENSE_CELLS), text_signature = "(self, /, max_cells=1073741824)")]
    fn dense<'py>(&self, py: Python<'py>, max_cells: u64) -> PyResult<Bound<'py, PyArray3<bool>>> {
        let depth = u32::from(self.tree.depth);
        let cells = 1u128 << (3 * depth);
        if cells > u128::from(max_cells) {
            return Err(PyValueError::new_err(format!(
                "a dense grid of depth {depth} has {cells} cells, more than max_cells = \
                 {max_cells}: pass a larger max_cells, or use cells()"
            )));
        }
        let n = 1usize << depth;
        let grid = py.detach(|| {
            let mut grid = vec![false; n * n * n];
            for l in self.tree.leaves() {
                let [x, y, z] = l.cell.to_array().map(|c| c as usize);
                grid[(x * n + y) * n + z] = true;
            }
            grid
        });
        Ok(arrays::array(py, grid, (n, n, n)))
    }

    /// The leaves' attributes, decoded, as a dict of arrays (row ``i``: leaf ``i``):
    /// ``cell`` ``(N, 3)`` uint32, ``interior`` ``(N,)`` bool (inside a solid, no surface),
    /// and each stored channel: ``normal`` ``(N, 3)`` float32 unit vectors (NaN for interior
    /// leaves), ``contour`` ``(N, 2)`` float32 (near and far plane offsets along the normal
    /// from the cell's centre, in cells), ``colour`` ``(N, 4)`` uint8 sRGBA,
    /// ``reflectivity``, ``refractivity`` and ``ior`` ``(N,)`` float32.
    fn leaves<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let n = self.tree.leaf_count as usize;
        let a = &self.tree.attributes;
        let has = |k: svo::ChannelKind| {
            a.storage()
                .iter()
                .any(|(c, s)| *c == k && *s != svo::octree::ChannelStorage::Absent)
        };
        let mut cell = vec![[0u32; 3]; n];
        let mut interior = vec![false; n];
        let mut normal = vec![[f32::NAN; 3]; n];
        let mut contour = vec![[f32::NAN; 2]; n];
        let mut colour = vec![[0u8; 4]; n];
        let (mut refl, mut refr, mut ior) = (vec![0f32; n], vec![0f32; n], vec![0f32; n]);
        py.detach(|| {
            for l in self.tree.leaves() {
                let i = l.index as usize;
                cell[i] = l.cell.to_array();
                interior[i] = l.interior;
                let v = l.attributes;
                if let Some(nv) = v.normal {
                    normal[i] = nv.to_array();
                }
                if let Some((near, far)) = v.contour {
                    contour[i] = [near, far];
                }
                colour[i] = v.colour.unwrap_or_default();
                refl[i] = v.reflectivity.unwrap_or_default();
                refr[i] = v.refractivity.unwrap_or_default();
                ior[i] = v.ior.unwrap_or_default();
            }
        });
        let d = PyDict::new(py);
        d.set_item("cell", arrays::rows(py, cell))?;
        d.set_item("interior", arrays::vector(py, interior))?;
        use svo::ChannelKind as K;
        if has(K::Normal) {
            d.set_item("normal", arrays::rows(py, normal))?;
        }
        if has(K::Contour) {
            let flat = contour.into_iter().flatten().collect();
            d.set_item("contour", arrays::array(py, flat, (n, 2)))?;
        }
        if has(K::Colour) {
            let flat = colour.into_iter().flatten().collect();
            d.set_item("colour", arrays::array(py, flat, (n, 4)))?;
        }
        for (k, name, v) in [
            (K::Reflectivity, "reflectivity", refl),
            (K::Refractivity, "refractivity", refr),
            (K::Ior, "ior", ior),
        ] {
            if has(k) {
                d.set_item(name, arrays::vector(py, v))?;
            }
        }
        Ok(d)
    }

    /// Whether each point (an ``(N, 3)`` array, or one ``(3,)`` point) lies in a leaf's
    /// cell; an ``(N,)`` bool array. Points outside the root cube or not finite are not.
    fn contains<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let points = arrays::points(points, "points", true)?;
        let inside = py.detach(|| points.iter().map(|&p| self.tree.contains(p)).collect());
        Ok(arrays::vector(py, inside))
    }

    /// The index of the leaf whose cell holds each point, an ``(N,)`` int64 array (-1 where
    /// there is none).
    fn leaf_at<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let points = arrays::points(points, "points", true)?;
        let leaves = py.detach(|| {
            points
                .iter()
                .map(|&p| {
                    self.tree
                        .cell_at_point(p)
                        .and_then(|c| self.tree.leaf_at(c))
                        .map_or(-1, i64::from)
                })
                .collect()
        });
        Ok(arrays::vector(py, leaves))
    }

    /// Casts rays through the tree: ``origins`` and ``directions`` are ``(N, 3)`` arrays
    /// (either may be one ``(3,)`` row, shared by all rays), ``t_max`` the farthest hit
    /// wanted (in the units of the directions). ``mode``: ``"contour"`` (the default: the
    /// slab between a leaf's contour planes where the tree has contours, else its cube) or
    /// ``"cube"``. The traversal runs in float32 in the tree's grid, as on the GPU, and
    /// never misses a leaf a ray enters; rays with a zero or non-finite direction miss.
    /// Parallel over ``threads`` (default: all cores), the GIL released. Returns
    /// ``svo.Hits``: arrays ``t``, ``point``, ``normal``, ``leaf`` and ``hit``.
    #[pyo3(signature = (origins, directions, t_max = f64::INFINITY, mode = "contour", threads = None))]
    fn cast(
        &self,
        py: Python<'_>,
        origins: &Bound<'_, PyAny>,
        directions: &Bound<'_, PyAny>,
        t_max: f64,
        mode: &str,
        threads: Option<usize>,
    ) -> PyResult<PyHits> {
        rays::cast(&self.tree, py, origins, directions, t_max, mode, threads)
    }

    /// Ray traces the tree on the CPU (reflections, refractions, shadows through glass):
    /// an ``(height, width, 3)`` uint8 sRGB image. Without ``eye``, the first view stored
    /// in the file, else a camera framing the leaves; ``target`` defaults to the leaves'
    /// centre, ``up`` to +y; ``fov`` is vertical, in degrees. ``view`` names a stored view.
    /// ``lights``: point light positions (default: the file's, else one above the camera).
    /// ``mode``: ``"contour"`` or ``"cube"``; ``shadows``: ``"product"`` (light through
    /// glass), ``"max"``, ``"opaque"`` or ``"none"``; ``reflections`` and ``refractions``:
    /// bounce limits; ``lod``: stop at inner nodes this many pixels wide (trees baked with
    /// ``lod=True``; 0 walks to the leaves). The same image as ``svo-view --cpu``.
    #[pyo3(signature = (width = 640, height = 480, eye = None, target = None, up = None, fov = 40.0, view = None, lights = None, mode = "contour", shadows = "product", reflections = 3, refractions = 3, lod = 0.0, threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: i64,
        height: i64,
        eye: Option<[f64; 3]>,
        target: Option<[f64; 3]>,
        up: Option<[f64; 3]>,
        fov: f64,
        view: Option<String>,
        lights: Option<Vec<[f64; 3]>>,
        mode: &str,
        shadows: &str,
        reflections: u8,
        refractions: u8,
        lod: f32,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let args = RenderArgs {
            width,
            height,
            eye,
            target,
            up,
            fov,
            view,
            lights,
            mode: mode.to_string(),
            shadows: shadows.to_string(),
            reflections,
            refractions,
            lod,
            threads,
        };
        let f = render::frame(py, self, args)?;
        let (w, h) = (f.width as usize, f.height as usize);
        Ok(arrays::array(py, svo::render::colour_rgb8(&f), (h, w, 3)))
    }

    /// ``render``'s per-pixel outputs, as a dict of float arrays: ``colour``
    /// ``(height, width, 3)`` float32 linear RGB; ``depth`` ``(height, width)`` float32, the
    /// primary hit's distance (inf on a miss); ``normal`` ``(height, width, 3)`` float32,
    /// the shading normal (zero on a miss); ``leaf`` ``(height, width)`` int64, the leaf hit
    /// (-1 on a miss); ``cost`` ``(height, width)`` uint32, the primary ray's traversal
    /// steps. Takes ``render``'s arguments.
    #[pyo3(signature = (width = 640, height = 480, eye = None, target = None, up = None, fov = 40.0, view = None, lights = None, mode = "contour", shadows = "product", reflections = 3, refractions = 3, lod = 0.0, threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn render_aovs<'py>(
        &self,
        py: Python<'py>,
        width: i64,
        height: i64,
        eye: Option<[f64; 3]>,
        target: Option<[f64; 3]>,
        up: Option<[f64; 3]>,
        fov: f64,
        view: Option<String>,
        lights: Option<Vec<[f64; 3]>>,
        mode: &str,
        shadows: &str,
        reflections: u8,
        refractions: u8,
        lod: f32,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let args = RenderArgs {
            width,
            height,
            eye,
            target,
            up,
            fov,
            view,
            lights,
            mode: mode.to_string(),
            shadows: shadows.to_string(),
            reflections,
            refractions,
            lod,
            threads,
        };
        let f = render::frame(py, self, args)?;
        let (w, h) = (f.width as usize, f.height as usize);
        let vec3 = |v: Vec<glam::Vec3>| v.into_iter().flat_map(|c| c.to_array()).collect();
        let leaf = f
            .leaf
            .iter()
            .map(|&l| {
                if l == svo::render::NO_LEAF {
                    -1
                } else {
                    i64::from(l)
                }
            })
            .collect();
        let d = PyDict::new(py);
        d.set_item("colour", arrays::array(py, vec3(f.colour), (h, w, 3)))?;
        d.set_item("depth", arrays::array(py, f.depth, (h, w)))?;
        d.set_item("normal", arrays::array(py, vec3(f.normal), (h, w, 3)))?;
        d.set_item("leaf", arrays::array::<i64, _>(py, leaf, (h, w)))?;
        d.set_item("cost", arrays::array(py, f.cost, (h, w)))?;
        Ok(d)
    }

    fn __len__(&self) -> usize {
        self.tree.leaf_count as usize
    }

    fn __repr__(&self) -> String {
        let channels: Vec<_> = self.stored_channels().into_iter().map(|(k, _)| k).collect();
        format!(
            "svo.Octree(depth {}, {} leaves, {} nodes, channels [{}])",
            self.tree.depth,
            self.tree.leaf_count,
            self.tree.nodes.len(),
            channels.join(", ")
        )
    }
}
