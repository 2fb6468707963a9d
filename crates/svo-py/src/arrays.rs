//! NumPy in and out: `(N, 3)` arrays of points and of triangle indices read into the
//! library's types (one copy, whatever the strides; read-only arrays too), with a
//! `ValueError` for a wrong shape and a `TypeError` for a wrong dtype; and results handed
//! back as arrays that own their Rust buffers (no copy).

use glam::DVec3;
use numpy::ndarray::{Array, ArrayView2, Dimension, StrideShape};
use numpy::{
    IntoPyArray, PyArray, PyArray1, PyArray2, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// `obj` as a NumPy array: itself if it is one, else `numpy.asarray(obj, dtype)` (lists,
/// tuples, anything with `__array__`).
fn as_array<'py>(obj: &Bound<'py, PyAny>, dtype: &str) -> PyResult<Bound<'py, PyUntypedArray>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return Ok(a.clone());
    }
    let np = PyModule::import(obj.py(), "numpy")?;
    let a = np.call_method1("asarray", (obj, dtype))?;
    Ok(a.cast_into::<PyUntypedArray>()?)
}

/// Checks that `a` is `(N, 3)`, or with `single` also `(3,)` (one row); the rows.
fn rows_of_three(a: &Bound<'_, PyUntypedArray>, what: &str, single: bool) -> PyResult<usize> {
    match a.shape() {
        [n, 3] => Ok(*n),
        [3] if single => Ok(1),
        shape => Err(PyValueError::new_err(format!(
            "{what} must have shape (N, 3){}, not {shape:?}",
            if single { " or (3,)" } else { "" }
        ))),
    }
}

/// The rows of a 2-D array view of `T` as `f64` triples.
fn rows_f64<T: Copy + Into<f64>>(v: &ArrayView2<'_, T>) -> Vec<DVec3> {
    v.rows()
        .into_iter()
        .map(|r| DVec3::new(r[0].into(), r[1].into(), r[2].into()))
        .collect()
}

/// A `(3,)` array as a `(1, 3)` one.
fn two_d<'py>(a: &Bound<'py, PyUntypedArray>) -> PyResult<Bound<'py, PyUntypedArray>> {
    if a.ndim() == 2 {
        return Ok(a.clone());
    }
    Ok(a.call_method1("reshape", (1, 3))?
        .cast_into::<PyUntypedArray>()?)
}

/// Reads an `(N, 3)` array of float32 or float64 coordinates (`single`: or one `(3,)` row)
/// into points. Integer arrays are converted; other dtypes are a `TypeError`. The values are
/// not checked here (a mesh's are by its validation, a ray's by the cast).
pub(crate) fn points(obj: &Bound<'_, PyAny>, what: &str, single: bool) -> PyResult<Vec<DVec3>> {
    let a = as_array(obj, "float64")?;
    rows_of_three(&a, what, single)?;
    let a = two_d(&a)?;
    if let Ok(f) = a.cast::<PyArray2<f64>>() {
        return Ok(rows_f64(&f.readonly().as_array()));
    }
    if let Ok(f) = a.cast::<PyArray2<f32>>() {
        return Ok(rows_f64(&f.readonly().as_array()));
    }
    let dtype = a.dtype();
    if matches!(dtype.kind(), b'i' | b'u' | b'f') {
        // float16, float128 or integers: converted once to float64.
        let np = PyModule::import(a.py(), "numpy")?;
        let f = np.call_method1("asarray", (&a, "float64"))?;
        let f = f.cast::<PyArray2<f64>>()?;
        return Ok(rows_f64(&f.readonly().as_array()));
    }
    Err(PyTypeError::new_err(format!(
        "{what} must be an array of float32 or float64, not of {}",
        dtype.str()?
    )))
}

/// The rows of a 2-D array view of an integer type as `u32` triples, or the first value that
/// is not a `u32` (its row and column).
fn rows_u32<T: Copy + TryInto<u32> + Into<i128>>(
    v: &ArrayView2<'_, T>,
    what: &str,
) -> PyResult<Vec<[u32; 3]>> {
    let mut out = Vec::with_capacity(v.nrows());
    for (t, r) in v.rows().into_iter().enumerate() {
        let mut tri = [0u32; 3];
        for (c, slot) in tri.iter_mut().enumerate() {
            *slot = r[c].try_into().map_err(|_| {
                PyValueError::new_err(format!(
                    "{what}[{t}, {c}] = {} is not a vertex index",
                    r[c].into()
                ))
            })?;
        }
        out.push(tri);
    }
    Ok(out)
}

/// Reads an `(M, 3)` array of integer vertex indices (any integer dtype) into triangles.
/// Negative indices and indices past `u32` are a `ValueError`; indices past the vertices
/// are the mesh validation's.
pub(crate) fn triangles(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[u32; 3]>> {
    let a = as_array(obj, "int64")?;
    rows_of_three(&a, what, false)?;
    macro_rules! try_dtype {
        ($($t:ty),*) => {$(
            if let Ok(i) = a.cast::<PyArray2<$t>>() {
                return rows_u32(&i.readonly().as_array(), what);
            }
        )*};
    }
    try_dtype!(i64, i32, u32, u64, i16, u16, i8, u8);
    Err(PyTypeError::new_err(format!(
        "{what} must be an array of integers, not of {}",
        a.dtype().str()?
    )))
}

/// An owned array of `shape` over `data` (which must hold exactly that many values),
/// handed to NumPy without a copy.
pub(crate) fn array<'py, T: numpy::Element, D: Dimension>(
    py: Python<'py>,
    data: Vec<T>,
    shape: impl Into<StrideShape<D>>,
) -> Bound<'py, PyArray<T, D>> {
    Array::from_shape_vec(shape, data)
        .expect("the data fits the shape")
        .into_pyarray(py)
}

/// A 1-D array over `data`.
pub(crate) fn vector<T: numpy::Element>(py: Python<'_>, data: Vec<T>) -> Bound<'_, PyArray1<T>> {
    data.into_pyarray(py)
}

/// An `(N, 3)` array over `N` rows of three.
pub(crate) fn rows<T: numpy::Element + Copy>(
    py: Python<'_>,
    data: Vec<[T; 3]>,
) -> Bound<'_, PyArray2<T>> {
    let n = data.len();
    array(py, data.into_iter().flatten().collect(), (n, 3))
}
