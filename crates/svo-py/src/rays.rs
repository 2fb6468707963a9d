//! `Octree.cast`: many rays from NumPy arrays through the library's traversal
//! (`Octree::cast_with`, as `Octree::cast_many` casts them), in parallel with the GIL
//! released, each hit written straight into its rows of the output arrays.

use crate::arrays;
use crate::errors::threads_error;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use svo::{HitMode, Octree, Ray};

/// Where rays hit, as arrays (row ``i``: ray ``i``): ``t`` ``(N,)`` float64 (the hit is
/// ``origin + t * direction``, a distance for unit directions; NaN on a miss), ``point`` and
/// ``normal`` ``(N, 3)`` float64 (NaN on a miss; the normal faces the ray: the cell face
/// entered or the contour plane met), ``leaf`` ``(N,)`` int64 (the leaf's index, -1 on a
/// miss) and ``hit`` ``(N,)`` bool.
#[pyclass(name = "Hits", module = "svo", frozen, get_all)]
pub(crate) struct PyHits {
    t: Py<PyArray1<f64>>,
    point: Py<PyArray2<f64>>,
    normal: Py<PyArray2<f64>>,
    leaf: Py<PyArray1<i64>>,
    hit: Py<PyArray1<bool>>,
}

#[pymethods]
impl PyHits {
    /// How many rays.
    fn __len__(&self, py: Python<'_>) -> usize {
        numpy::PyUntypedArrayMethods::len(self.t.bind(py))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let hits = self.hit.bind(py).readonly();
        let hits = hits.as_array();
        format!(
            "svo.Hits({} rays, {} hits)",
            hits.len(),
            hits.iter().filter(|&&h| h).count()
        )
    }
}

/// The hit mode named `mode`: `contour` or `cube` (the library's `exact` needs the mesh,
/// which a tree does not keep).
pub(crate) fn hit_mode(mode: &str) -> PyResult<HitMode> {
    match mode {
        "contour" => Ok(HitMode::Contour),
        "cube" => Ok(HitMode::Cube),
        _ => Err(PyValueError::new_err(format!(
            "unknown hit mode {mode:?} (expected contour or cube)"
        ))),
    }
}

/// Casts `origins` along `directions` through `tree` (see `Octree.cast` for the rules).
pub(crate) fn cast(
    tree: &Octree,
    py: Python<'_>,
    origins: &Bound<'_, PyAny>,
    directions: &Bound<'_, PyAny>,
    t_max: f64,
    mode: &str,
    threads: Option<usize>,
) -> PyResult<PyHits> {
    let mode = hit_mode(mode)?;
    if t_max.is_nan() {
        return Err(PyValueError::new_err("t_max must be a number, not NaN"));
    }
    let o = arrays::points(origins, "origins", true)?;
    let d = arrays::points(directions, "directions", true)?;
    let n = match (o.len(), d.len()) {
        (a, b) if a == b => a,
        (1, b) => b,
        (a, 1) => a,
        (a, b) => {
            return Err(PyValueError::new_err(format!(
                "{a} origins and {b} directions: give as many of each, or one of either"
            )));
        }
    };
    let pick = |v: &[glam::DVec3], i: usize| if v.len() == 1 { v[0] } else { v[i] };
    // Each ray cast straight into its rows of the output arrays, in parallel: no list of
    // rays or of hits in between.
    let mut t = vec![f64::NAN; n];
    let mut point = vec![[f64::NAN; 3]; n];
    let mut normal = vec![[f64::NAN; 3]; n];
    let mut leaf = vec![-1i64; n];
    py.detach(|| {
        svo::with_threads(threads, |_| {
            use rayon::prelude::*;
            t.par_iter_mut()
                .zip(point.par_iter_mut())
                .zip(normal.par_iter_mut())
                .zip(leaf.par_iter_mut())
                .enumerate()
                .for_each(|(i, (((t, p), nm), l))| {
                    let ray = Ray::new(pick(&o, i), pick(&d, i));
                    if let Some(h) = tree.cast_with(ray, mode).filter(|h| h.t <= t_max) {
                        *t = h.t;
                        *p = h.point.to_array();
                        *nm = h.normal.to_array();
                        *l = i64::from(h.leaf);
                    }
                });
        })
    })
    .map_err(threads_error)?;
    let hit = leaf.iter().map(|&l| l >= 0).collect();
    Ok(PyHits {
        t: arrays::vector(py, t).unbind(),
        point: arrays::rows(py, point).unbind(),
        normal: arrays::rows(py, normal).unbind(),
        leaf: arrays::vector(py, leaf).unbind(),
        hit: arrays::vector(py, hit).unbind(),
    })
}
