//! Running the library's work with the GIL released: thread pools by size, and a watcher that
//! turns Ctrl-C into a prompt stop.

use pyo3::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex, OnceLock};
use std::time::Duration;

/// A rayon pool of `threads` workers, made on first use and kept (so each call does not start
/// threads again).
pub fn pool(threads: usize) -> Arc<rayon::ThreadPool> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    pools
        .entry(threads)
        .or_insert_with(|| {
            Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .thread_name(|i| format!("texgraph-{i}"))
                    .build()
                    .expect("a thread pool starts"),
            )
        })
        .clone()
}

/// Runs `work` with the GIL released. `watch`: on another thread, while this one checks for
/// signals every 50 ms (Python runs its signal handlers only on the main thread, with the GIL);
/// a handler's exception (KeyboardInterrupt) sets the flag `work` is given, waits for `work`
/// to stop at its next check, and is returned.
pub fn interruptible<R: Send>(
    py: Python<'_>,
    watch: bool,
    work: impl FnOnce(&Arc<AtomicBool>) -> R + Send,
) -> PyResult<R> {
    let cancel = Arc::new(AtomicBool::new(false));
    if !watch {
        return Ok(py.detach(|| work(&cancel)));
    }
    py.detach(|| {
        std::thread::scope(|scope| {
            let (done, result) = mpsc::channel();
            let flag = cancel.clone();
            scope.spawn(move || {
                let _ = done.send(work(&flag));
            });
            loop {
                match result.recv_timeout(Duration::from_millis(50)) {
                    Ok(r) => return Ok(r),
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        if let Err(e) = Python::attach(|py| py.check_signals()) {
                            cancel.store(true, Ordering::Relaxed);
                            let _ = result.recv();
                            return Err(e);
                        }
                    }
                    // The worker panicked: leaving the scope raises its panic here (pyo3 turns
                    // it into a PanicException).
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(pyo3::exceptions::PyRuntimeError::new_err(
                            "texgraph: the evaluation stopped unexpectedly",
                        ))
                    }
                }
            }
        })
    })
}
