//! Running a job on its own pool of a chosen number of worker threads (rayon, with the
//! `parallel` feature), with the thread count checked first: the one place the bake and
//! render jobs start threads.

use thiserror::Error;

/// The most worker threads a job starts.
pub(crate) const MAX_THREADS: usize = 1024;

/// The requested pool could not be made.
#[derive(Debug, Error, PartialEq, Eq)]
#[error("cannot start {threads} threads: {message}")]
pub struct ThreadsError {
    /// Requested threads.
    pub threads: usize,
    /// Why not.
    pub message: String,
}

/// Runs `f` with the number of threads it gets: on a new pool of `threads` workers, or with
/// `None` on the pool the caller runs in (rayon's global pool: all cores unless
/// `RAYON_NUM_THREADS` says otherwise), whose threads, started once, a program that runs
/// job after job keeps warm; without the `parallel` feature, on the calling thread with 1.
/// A count of 0 or above 1024 is refused.
pub fn with_threads<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce(usize) -> R + Send,
) -> Result<R, ThreadsError> {
    if threads.is_some_and(|n| n == 0 || n > MAX_THREADS) {
        return Err(ThreadsError {
            threads: threads.unwrap_or(0),
            message: format!("expected 1..={MAX_THREADS}"),
        });
    }
    #[cfg(feature = "parallel")]
    {
        let Some(threads) = threads else {
            return Ok(f(rayon::current_num_threads()));
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| ThreadsError {
                threads,
                message: e.to_string(),
            })?;
        let n = pool.current_num_threads();
        Ok(pool.install(|| f(n)))
    }
    #[cfg(not(feature = "parallel"))]
    Ok(f(1))
}
