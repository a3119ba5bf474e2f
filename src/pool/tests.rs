//! Tests of the pool's helpers.

use super::*;
use std::mem::MaybeUninit;

/// `fill` of 0, 1, … over `len` elements in parts of `chunk` on `threads` threads.
fn squares(len: usize, chunk: usize, threads: usize) -> Vec<u64> {
    let mut out: Vec<MaybeUninit<u64>> = (0..len).map(|_| MaybeUninit::uninit()).collect();
    fill(&mut out, chunk, threads, |part, from| {
        for (i, o) in part.iter_mut().enumerate() {
            o.write(((from + i) as u64).pow(2));
        }
    });
    // SAFETY: `fill` wrote every element.
    out.into_iter()
        .map(|x| unsafe { x.assume_init() })
        .collect()
}

#[test]
fn fill_writes_every_element_once_on_any_number_of_threads() {
    for (len, chunk, threads) in [
        (0, 4, 4),
        (1, 4, 4),
        (10, 3, 4),
        (1000, 7, 3),
        (64, 64, 8),
        (100, 0, 2),
    ] {
        let want: Vec<u64> = (0..len as u64).map(|i| i * i).collect();
        assert_eq!(
            squares(len, chunk, threads),
            want,
            "{len} {chunk} {threads}"
        );
    }
}

#[test]
fn fill_writes_everything_on_the_callers_thread_where_no_thread_starts() {
    FAIL_SPAWNS.with(|f| f.set(true));
    let caller = std::thread::current().id();
    let mut out: Vec<MaybeUninit<std::thread::ThreadId>> =
        (0..100).map(|_| MaybeUninit::uninit()).collect();
    fill(&mut out, 10, 4, |part, _| {
        for o in part {
            o.write(std::thread::current().id());
        }
    });
    FAIL_SPAWNS.with(|f| f.set(false));
    // SAFETY: `fill` wrote every element.
    assert!(out
        .into_iter()
        .all(|x| unsafe { x.assume_init() } == caller));
}
