//! The team's steps over a transport of threads: a team of ranks that are threads of this
//! process, each with a pool of its own, exchanging through shared memory and a barrier.

use super::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Barrier;

/// What the ranks of a thread team share.
struct Hub {
    size: usize,
    counter: AtomicU64,
    barrier: Barrier,
    slots: Mutex<Vec<Vec<u8>>>,
}

struct ThreadLink {
    hub: Arc<Hub>,
    rank: usize,
}

impl ThreadLink {
    /// Every rank's bytes, rank after rank (collective).
    fn gather_bytes(&self, mine: Vec<u8>) -> Vec<Vec<u8>> {
        self.hub.slots.lock().unwrap()[self.rank] = mine;
        self.hub.barrier.wait();
        let all = self.hub.slots.lock().unwrap().clone();
        self.hub.barrier.wait();
        all
    }
}

impl Link for ThreadLink {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.hub.size
    }
    fn fetch_add(&self, n: u64) -> u64 {
        self.hub.counter.fetch_add(n, Ordering::SeqCst)
    }
    fn gather_u64(&self, mine: &[u64]) -> Vec<u64> {
        let bytes = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.gather_bytes(bytes)
            .concat()
            .chunks_exact(8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap()))
            .collect()
    }
    fn gather_f32(&self, mine: &[f32], counts: &[usize]) -> Vec<f32> {
        assert_eq!(mine.len(), counts[self.rank]);
        let bytes = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.gather_bytes(bytes)
            .concat()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect()
    }
    fn gather_u8(&self, mine: &[u8], counts: &[usize]) -> Vec<u8> {
        assert_eq!(mine.len(), counts[self.rank]);
        self.gather_bytes(mine.to_vec()).concat()
    }
}

/// Runs `body(team)` on each of `size` ranks (threads, each with a pool of two threads) and
/// returns their results by rank.
fn on_ranks<R: Send>(size: usize, body: impl Fn(Team) -> R + Sync) -> Vec<R> {
    let hub = Arc::new(Hub {
        size,
        counter: AtomicU64::new(0),
        barrier: Barrier::new(size),
        slots: Mutex::new(vec![Vec::new(); size]),
    });
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..size)
            .map(|rank| {
                let hub = hub.clone();
                let body = &body;
                s.spawn(move || {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(2)
                        .build()
                        .unwrap();
                    pool.install(|| body(Team::from_link(Box::new(ThreadLink { hub, rank }))))
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// The value of item `i`: its length and contents depend on `i` alone (an edge tile is
/// shorter), so an exchange that put an item in the wrong place or dropped one is seen.
fn item(i: usize) -> Vec<[f32; 2]> {
    (0..(i % 5 + 1)).map(|k| [i as f32, k as f32]).collect()
}

#[test]
fn every_rank_gets_every_item_in_order_and_the_work_is_shared() {
    let n = 200;
    let expected: Vec<Vec<[f32; 2]>> = (0..n).map(item).collect();
    let results = on_ranks(3, |team| {
        // Two steps: the second starts where the first's counter ended.
        let a = map(Some(&team), n, &|| false, item).unwrap();
        let b = map(Some(&team), n, &|| false, item).unwrap();
        (a, b, team.stats(), team.threads())
    });
    for (a, b, stats, threads) in &results {
        assert_eq!(a, &expected);
        assert_eq!(b, &expected);
        // Each item was done by exactly one rank in each step.
        assert_eq!(stats.iter().map(|s| s.items).sum::<u64>(), 2 * n as u64);
        assert_eq!(*threads, 6, "three ranks of two threads");
    }
    // Every rank holds the same statistics.
    assert!(results.windows(2).all(|w| w[0].2 == w[1].2));
}

#[test]
fn a_team_of_one_and_no_team_give_the_same_items() {
    let n = 37;
    let alone = map::<[f32; 2], _>(None, n, &|| false, item).unwrap();
    let one = on_ranks(1, |team| map(Some(&team), n, &|| false, item).unwrap());
    assert_eq!(alone, one[0]);
    assert_eq!(alone, (0..n).map(item).collect::<Vec<_>>());
}

#[test]
fn a_stop_on_one_rank_stops_every_rank() {
    let results = on_ranks(3, |team| {
        let stop = || team.rank() == 1;
        let cancelled = map(Some(&team), 500, &stop, item);
        // The next step starts cleanly after a stopped one.
        let next = map(Some(&team), 20, &|| false, item);
        (
            cancelled.map(|_| ()).map_err(|e| e.code),
            next.unwrap().len(),
        )
    });
    for (cancelled, next) in results {
        assert_eq!(cancelled, Err(ErrorCode::Cancelled));
        assert_eq!(next, 20);
    }
}

#[test]
fn a_panic_on_one_rank_fails_every_rank_with_internal() {
    let results = on_ranks(2, |team| {
        // Whichever rank takes item 0 panics there.
        let f = |i: usize| {
            if i == 0 {
                panic!("a field function failed");
            }
            item(i)
        };
        map(Some(&team), 100, &|| false, f)
            .map(|_| ())
            .map_err(|e| e.code)
    });
    assert_eq!(results, vec![Err(ErrorCode::Internal); 2]);
}

#[test]
fn ranks_agree_on_the_first_failing_ranks_error() {
    let results = on_ranks(3, |team| {
        let mine: Result<u32> = match team.rank() {
            0 => Ok(7),
            r => Err(Error::new(ErrorCode::IoError, format!("disk {r} full"))),
        };
        agree(Some(&team), mine).map_err(|e| (e.code, e.message))
    });
    assert_eq!(results[1], Err((ErrorCode::IoError, "disk 1 full".into())));
    assert_eq!(
        results[0],
        Err((ErrorCode::IoError, "disk 1 full (on rank 1)".into()))
    );
    assert_eq!(
        results[2],
        Err((ErrorCode::IoError, "disk 1 full (on rank 1)".into()))
    );
    let roots = on_ranks(3, |team| from_root(Some(&team), 10 + team.rank() as u64));
    assert_eq!(roots, vec![10; 3]);
}

#[test]
fn a_condition_holds_for_the_team_only_where_it_holds_on_every_rank() {
    // Rank 1 alone lacks it (a host without the packet march's instructions): every rank
    // hears false; where every rank has it, every rank hears true.
    let one_lacks = on_ranks(3, |team| all(Some(&team), team.rank() != 1));
    assert_eq!(one_lacks, vec![false; 3]);
    let all_have = on_ranks(3, |team| all(Some(&team), true));
    assert_eq!(all_have, vec![true; 3]);
    assert!(!all(None, false) && all(None, true));
}
