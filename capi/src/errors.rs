//! The error queue behind `vlError`. It stores the codes and the last message; which code an
//! error has is the core's decision.
//!
//! Every failed command appends its code here; `vlError` pops the oldest. The queue has its own
//! mutex, separate from the library state, and it is held only for a push or a pop, never while
//! user code runs, so field functions on worker threads can record errors while the renderer
//! holds the state lock. Errors from every thread share the one queue.
//!
//! The queue is bounded at [`MAX_QUEUED`] entries: a program that never calls `vlError` must not
//! grow memory without limit. When it is full, newer errors are dropped and the oldest kept (the
//! first error is usually the informative one). The message of the most recent error is kept for
//! Rust callers ([`last_error_message`]).

use std::collections::VecDeque;
use std::sync::{Mutex, MutexGuard};
use vlib_core::{Error, ErrorCode};

/// The most errors the queue holds; later ones are dropped until `vlError` makes room.
pub const MAX_QUEUED: usize = 1024;

struct Queue {
    codes: VecDeque<ErrorCode>,
    last_message: Option<String>,
    /// Codes pushed since the process started (the last of them is the queue's back).
    pushed: u64,
}

static QUEUE: Mutex<Queue> = Mutex::new(Queue {
    codes: VecDeque::new(),
    last_message: None,
    pushed: 0,
});

fn queue() -> MutexGuard<'static, Queue> {
    // A panic cannot happen while the lock is held (push and pop only), but recover anyway.
    QUEUE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Records an error for `vlError`.
pub(crate) fn record(e: Error) {
    let mut q = queue();
    if q.codes.len() < MAX_QUEUED {
        q.codes.push_back(e.code);
        q.pushed += 1;
    }
    q.last_message = Some(e.message);
}

/// A mark of the queue's end, for [`take_since`].
#[cfg(feature = "mpi")]
pub(crate) fn mark() -> u64 {
    queue().pushed
}

/// Removes and returns the codes recorded after `mark` that are still queued, oldest first.
#[cfg(feature = "mpi")]
pub(crate) fn take_since(mark: u64) -> Vec<ErrorCode> {
    let mut q = queue();
    let newer = (q.pushed.saturating_sub(mark) as usize).min(q.codes.len());
    let at = q.codes.len() - newer;
    q.pushed -= newer as u64;
    q.codes.split_off(at).into()
}

/// Removes and returns the oldest recorded error code.
pub(crate) fn pop() -> ErrorCode {
    queue().codes.pop_front().unwrap_or(ErrorCode::NoError)
}

/// The message of the most recently recorded error (Rust only: C programs see codes and
/// `vlErrorString`). It stays available after `vlError` has returned the code.
pub fn last_error_message() -> Option<String> {
    queue().last_message.clone()
}
