//! `svo.Mesh`: triangles from a file or from NumPy arrays (or any object with `vertices`
//! and `faces`, such as a `trimesh.Trimesh`), validated as they are made.

use crate::arrays;
use crate::errors::mesh_error;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// A triangle mesh: vertex positions (float64) and triangles (indices into them), with the
/// materials, textures, lights and camera views a file brings.
///
/// ``Mesh(vertices, faces)`` takes an ``(N, 3)`` float array and an ``(M, 3)`` integer
/// array; ``Mesh(obj)`` takes any object with ``vertices`` and ``faces`` (a
/// ``trimesh.Trimesh``). The arrays are copied once. A mesh without triangles, with a
/// non-finite coordinate or with an index past the vertices raises ``svo.MeshError``.
#[pyclass(name = "Mesh", module = "svo", frozen)]
pub(crate) struct PyMesh {
    pub(crate) mesh: svo::Mesh,
}

impl PyMesh {
    /// The mesh of `obj`: a `Mesh` as it is, or anything with `vertices` and `faces`.
    pub(crate) fn from_object(obj: &Bound<'_, PyAny>) -> PyResult<Py<PyMesh>> {
        if let Ok(m) = obj.cast::<PyMesh>() {
            return Ok(m.clone().unbind());
        }
        let py = obj.py();
        let mesh = Self::from_arrays(py, obj, None)?;
        Py::new(py, mesh)
    }

    /// A mesh of `vertices` and `faces`, or of `vertices.vertices` and `vertices.faces`.
    fn from_arrays(
        py: Python<'_>,
        vertices: &Bound<'_, PyAny>,
        faces: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (v, f) = match faces {
            Some(f) => (vertices.clone(), f.clone()),
            None => {
                if !(vertices.hasattr("vertices")? && vertices.hasattr("faces")?) {
                    return Err(PyTypeError::new_err(
                        "Mesh() takes vertices and faces arrays, or one object with `vertices` \
                         and `faces` (such as a trimesh.Trimesh)",
                    ));
                }
                (vertices.getattr("vertices")?, vertices.getattr("faces")?)
            }
        };
        let positions = arrays::points(&v, "vertices", false)?;
        let triangles = arrays::triangles(&f, "faces")?;
        let mesh = svo::Mesh::from_triangles(positions, triangles);
        py.detach(|| mesh.validate()).map_err(mesh_error)?;
        Ok(Self { mesh })
    }
}

#[pymethods]
impl PyMesh {
    #[new]
    #[pyo3(signature = (vertices, faces = None))]
    fn new(
        py: Python<'_>,
        vertices: &Bound<'_, PyAny>,
        faces: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        Self::from_arrays(py, vertices, faces)
    }

    /// Loads a mesh file: ``.obj`` (with its MTL materials), ``.obj.gz``, ``.ply``,
    /// ``.gltf`` or ``.glb``. A missing file raises ``FileNotFoundError``; a file that does
    /// not parse or holds no valid triangles, ``svo.MeshError``.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let mesh = py.detach(|| svo::Mesh::load(&path)).map_err(mesh_error)?;
        Ok(Self { mesh })
    }

    /// The vertex positions, an ``(N, 3)`` float64 array (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        arrays::rows(
            py,
            self.mesh
                .positions
                .iter()
                .map(glam::DVec3::to_array)
                .collect(),
        )
    }

    /// The triangles, an ``(M, 3)`` uint32 array of vertex indices (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<u32>> {
        arrays::rows(py, self.mesh.triangles.clone())
    }

    /// The bounds of the vertices the triangles use: ``((xmin, ymin, zmin), (xmax, ymax,
    /// zmax))``.
    #[getter]
    fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let (lo, hi) = self.mesh.bounds().unwrap_or_default();
        (lo.to_array(), hi.to_array())
    }

    /// How many triangles.
    fn __len__(&self) -> usize {
        self.mesh.triangles.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "svo.Mesh({} vertices, {} triangles, {} materials)",
            self.mesh.positions.len(),
            self.mesh.triangles.len(),
            self.mesh.materials.len().max(1)
        )
    }
}
