//! Tests of the pool's helpers.

use super::*;
use std::mem::MaybeUninit;
use std::sync::Mutex;
use std::thread::ThreadId;
use std::time::Duration;

/// `fill` over `len` elements (each set to a marker first, so that an element no part writes
/// is seen, not read uninitialised) in parts of `chunk` on `threads` threads, each element
/// written with its index squared; also every part's start, in the order they were written.
fn squares(len: usize, chunk: usize, threads: usize) -> (Vec<u64>, Vec<usize>) {
    let mut out: Vec<MaybeUninit<u64>> = (0..len).map(|_| MaybeUninit::new(u64::MAX)).collect();
    let starts = Mutex::new(Vec::new());
    fill(&mut out, chunk, threads, |part, from| {
        starts.lock().unwrap().push(from);
        for (i, o) in part.iter_mut().enumerate() {
            o.write(((from + i) as u64).pow(2));
        }
    });
    // SAFETY: every element was initialised with the marker, and `fill` writes only values.
    let values = out
        .into_iter()
        .map(|x| unsafe { x.assume_init() })
        .collect();
    (values, starts.into_inner().unwrap())
}

#[test]
fn fill_writes_every_element_once_on_any_number_of_threads() {
    for (len, chunk, threads) in [
        (0, 4, 4),
        (1, 4, 4),
        (10, 3, 4),
        (10, 3, 0),
        (10, 3, 1),
        (1000, 7, 3),
        (64, 64, 8),
        (100, 0, 2),
    ] {
        let want: Vec<u64> = (0..len as u64).map(|i| i * i).collect();
        let (values, mut starts) = squares(len, chunk, threads);
        assert_eq!(values, want, "{len} {chunk} {threads}");
        // Each part written once: the parts' starts, each once.
        starts.sort_unstable();
        let step = chunk.max(1);
        let parts: Vec<usize> = (0..len.div_ceil(step)).map(|k| k * step).collect();
        assert_eq!(starts, parts, "{len} {chunk} {threads}");
    }
}

/// The thread that wrote each of 100 elements, in parts of 10 on up to four threads, each
/// part taking 5 ms (so that threads that start take some of them), spawns failing where
/// `fail`.
fn writers(fail: bool) -> Vec<ThreadId> {
    FAIL_SPAWNS.with(|f| f.set(fail));
    let mut out: Vec<MaybeUninit<Option<ThreadId>>> =
        (0..100).map(|_| MaybeUninit::new(None)).collect();
    fill(&mut out, 10, 4, |part, _| {
        std::thread::sleep(Duration::from_millis(5));
        for o in part {
            o.write(Some(std::thread::current().id()));
        }
    });
    FAIL_SPAWNS.with(|f| f.set(false));
    // SAFETY: every element was initialised with `None`, and `fill` writes only values.
    out.into_iter()
        .map(|x| unsafe { x.assume_init() }.expect("every element written"))
        .collect()
}

#[test]
fn fill_writes_everything_on_the_callers_thread_where_no_thread_starts() {
    let caller = std::thread::current().id();
    // Threads that start take parts: the test below can tell.
    assert!(writers(false).iter().any(|&t| t != caller));
    assert!(writers(true).iter().all(|&t| t == caller));
}

#[test]
fn the_pool_has_the_threads_asked_for_up_to_four_a_core() {
    // Unset, empty, zero, negative or not a number: one a core, at least one.
    for asked in [
        None,
        Some(""),
        Some("0"),
        Some("-1"),
        Some("abc"),
        Some("2.5"),
    ] {
        assert_eq!(threads_for(asked, 2), 2, "{asked:?}");
        assert_eq!(threads_for(asked, 0), 1, "{asked:?} with no core known");
    }
    // A positive number: that many, spaces around it allowed, up to four a core.
    assert_eq!(threads_for(Some("1"), 2), 1);
    assert_eq!(threads_for(Some(" 3\n"), 2), 3);
    assert_eq!(threads_for(Some("8"), 2), 8);
    assert_eq!(threads_for(Some("9"), 2), 8);
    assert_eq!(threads_for(Some("100000"), 2), 8);
    assert_eq!(threads_for(Some("100000"), 64), 256);
    assert_eq!(threads_for(Some("5"), 1), 4);
    assert_eq!(threads_for(Some("5"), 0), 4, "no core known counts as one");
    assert_eq!(
        threads_for(Some("18446744073709551615"), usize::MAX),
        usize::MAX
    );
    assert_eq!(
        threads_for(Some("18446744073709551616"), 2),
        2,
        "not a usize"
    );
}
