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
    fn fetch_add(&self, n: u64) -> Result<u64> {
        Ok(self.hub.counter.fetch_add(n, Ordering::SeqCst))
    }
    fn gather_u64(&self, mine: &[u64]) -> Result<Vec<u64>> {
        let bytes = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
        Ok(self
            .gather_bytes(bytes)
            .concat()
            .chunks_exact(8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap()))
            .collect())
    }
    fn gather_f32(&self, mine: &[f32], counts: &[usize], out: &mut [f32]) -> Result<()> {
        assert_eq!(mine.len(), counts[self.rank]);
        let bytes = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
        let all = self.gather_bytes(bytes).concat();
        assert_eq!(all.len(), out.len() * 4);
        for (o, b) in out.iter_mut().zip(all.chunks_exact(4)) {
            *o = f32::from_le_bytes(b.try_into().unwrap());
        }
        Ok(())
    }
    fn gather_u8(&self, mine: &[u8], counts: &[usize], out: &mut [u8]) -> Result<()> {
        assert_eq!(mine.len(), counts[self.rank]);
        out.copy_from_slice(&self.gather_bytes(mine.to_vec()).concat());
        Ok(())
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
                    pool.install(|| {
                        body(Team::from_link(Box::new(ThreadLink { hub, rank })).unwrap())
                    })
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
        let a = map(Some(&team), n, &|| false, None, item).unwrap();
        let b = map(Some(&team), n, &|| false, None, item).unwrap();
        // A smaller step after them, through the buffers they left.
        let c = map(Some(&team), 7, &|| false, None, item).unwrap();
        assert_eq!(c, (0..7).map(item).collect::<Vec<_>>());
        (a, b, team.stats(), team.threads())
    });
    for (a, b, stats, threads) in &results {
        assert_eq!(a, &expected);
        assert_eq!(b, &expected);
        // Each item was done by exactly one rank in each step.
        assert_eq!(stats.iter().map(|s| s.items).sum::<u64>(), 2 * n as u64 + 7);
        assert_eq!(*threads, 6, "three ranks of two threads");
    }
    // Every rank holds the same statistics.
    assert!(results.windows(2).all(|w| w[0].2 == w[1].2));
}

#[test]
fn a_team_of_one_and_no_team_give_the_same_items() {
    let n = 37;
    let alone = map::<[f32; 2], _>(None, n, &|| false, None, item).unwrap();
    let one = on_ranks(1, |team| {
        map(Some(&team), n, &|| false, None, item).unwrap()
    });
    assert_eq!(alone, one[0]);
    assert_eq!(alone, (0..n).map(item).collect::<Vec<_>>());
}

#[test]
fn a_stop_on_one_rank_stops_every_rank() {
    let results = on_ranks(3, |team| {
        let stop = || team.rank() == 1;
        let cancelled = map(Some(&team), 500, &stop, None, item);
        // The next step starts cleanly after a stopped one.
        let next = map(Some(&team), 20, &|| false, None, item);
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
        map(Some(&team), 100, &|| false, None, f)
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
    let roots = on_ranks(3, |team| {
        from_root(Some(&team), 10 + team.rank() as u64).unwrap()
    });
    assert_eq!(roots, vec![10; 3]);
}

#[test]
fn a_condition_holds_for_the_team_only_where_it_holds_on_every_rank() {
    // Rank 1 alone lacks it (a host without the packet march's instructions): every rank
    // hears false; where every rank has it, every rank hears true.
    let one_lacks = on_ranks(3, |team| all(Some(&team), team.rank() != 1).unwrap());
    assert_eq!(one_lacks, vec![false; 3]);
    let all_have = on_ranks(3, |team| all(Some(&team), true).unwrap());
    assert_eq!(all_have, vec![true; 3]);
    assert!(!all(None, false).unwrap() && all(None, true).unwrap());
}

#[test]
fn an_error_one_rank_holds_fails_the_step_on_every_rank() {
    // Rank 1 met an error between steps (it could not allocate a strip of the image, say):
    // it takes no item, and every rank's step fails with its error; the next step is whole.
    let results = on_ranks(3, |team| {
        let held =
            (team.rank() == 1).then(|| Error::new(ErrorCode::NoMemory, "a strip of the image"));
        let failed = map(Some(&team), 300, &|| false, held, item);
        let next = map(Some(&team), 30, &|| false, None, item);
        (
            failed.map(|_| ()).map_err(|e| (e.code, e.message)),
            next.unwrap(),
        )
    });
    let expected: Vec<Vec<[f32; 2]>> = (0..30).map(item).collect();
    for (rank, (failed, next)) in results.into_iter().enumerate() {
        let message = match rank {
            1 => "a strip of the image".to_string(),
            _ => "a strip of the image (on rank 1)".to_string(),
        };
        assert_eq!(failed, Err((ErrorCode::NoMemory, message)));
        assert_eq!(next, expected);
    }
}

#[test]
fn an_error_raised_in_an_item_keeps_its_code_on_every_rank() {
    // A cache that cannot be allocated inside an item unwinds with `NoMemory`
    // (`crate::error::raise`): every rank fails with that code, not `Internal`.
    let results = on_ranks(2, |team| {
        let f = |i: usize| {
            if i == 3 {
                crate::error::raise(Error::new(ErrorCode::NoMemory, "a cell mask"));
            }
            item(i)
        };
        map(Some(&team), 50, &|| false, None, f)
            .map(|_| ())
            .map_err(|e| e.code)
    });
    assert_eq!(results, vec![Err(ErrorCode::NoMemory); 2]);
}

#[test]
fn a_rank_that_cannot_hold_an_exchange_fails_it_on_every_rank() {
    // Rank 1 is asked for more than any address space holds (its allocation fails), rank 0
    // for a few bytes: both fail with `NoMemory` before any data moves, and neither waits for
    // the other; the next exchange goes through.
    let results = on_ranks(2, |team| {
        let link = &*team.0.link;
        let counts = match team.rank() {
            0 => vec![2, 2],
            _ => vec![usize::MAX / 2, 2],
        };
        let mine = [team.rank() as u8; 2];
        let failed = exchange(link, &mine, &counts, |m, c, o| link.gather_u8(m, c, o));
        let next = exchange(link, &mine, &[2, 2], |m, c, o| link.gather_u8(m, c, o));
        (failed.map_err(|e| e.code), next.unwrap())
    });
    for (failed, next) in results {
        assert_eq!(failed, Err(ErrorCode::NoMemory));
        assert_eq!(next, vec![0, 0, 1, 1]);
    }
}

#[test]
fn a_step_keeps_its_exchange_buffers_for_the_next() {
    let results = on_ranks(2, |team| {
        let n = 60;
        let expected: Vec<Vec<[f32; 2]>> = (0..n).map(item).collect();
        assert_eq!(
            map(Some(&team), n, &|| false, None, item).unwrap(),
            expected
        );
        let kept = |team: &Team| {
            let s = team.state();
            (s.buffers.recv.as_ptr(), s.buffers.recv.len())
        };
        let first = kept(&team);
        // Every item's two floats, (i % 5 + 1) values an item, from both ranks.
        let floats: usize = (0..n).map(|i| (i % 5 + 1) * 2).sum();
        assert_eq!(first.1, floats);
        assert_eq!(
            map(Some(&team), n, &|| false, None, item).unwrap(),
            expected
        );
        kept(&team) == first
    });
    assert_eq!(
        results,
        vec![true; 2],
        "the second step reused the first's buffer"
    );
}

#[test]
fn a_steps_buffers_are_kept_and_a_rank_that_cannot_hold_them_fails_every_rank() {
    let results = on_ranks(2, |team| {
        let link = &*team.0.link;
        // Rank 0 sends 3 values, rank 1 sends 5: 8 received.
        let floats = 3 + 2 * team.rank();
        let first = buffers_for(link, Buffers::default(), floats, &[3, 5]).unwrap();
        let (send, recv) = (first.send.as_ptr(), first.recv.as_ptr());
        assert_eq!((first.send.len(), first.recv.len()), (floats, 8));
        // The next step of the same size or smaller takes the same memory.
        let again = buffers_for(link, first, floats, &[3, 5]).unwrap();
        assert_eq!((again.send.as_ptr(), again.recv.as_ptr()), (send, recv));
        let smaller = buffers_for(link, again, 1, &[1, 1]).unwrap();
        assert_eq!((smaller.send.len(), smaller.recv.len()), (1, 2));
        assert_eq!(smaller.recv.as_ptr(), recv);
        // Rank 1 is told of more values than an address space holds: both fail before any
        // data moves, naming rank 1, and the next step goes through.
        let counts = match team.rank() {
            0 => vec![1, 1],
            _ => vec![1, usize::MAX / 8],
        };
        let failed = buffers_for(link, smaller, 1, &counts)
            .map(|_| ())
            .unwrap_err();
        let next = buffers_for(link, Buffers::default(), 1, &[1, 1]).unwrap();
        (failed.code, failed.message, next.recv.len())
    });
    for (code, message, next) in results {
        assert_eq!(code, ErrorCode::NoMemory);
        assert!(message.contains("(on rank 1)"), "{message}");
        assert_eq!(next, 2);
    }
}

/// [`on_ranks`] on another thread, failing the test where the ranks do not all return
/// within two minutes: a rank left waiting for one that has gone is what the tests below
/// look for.
fn on_ranks_within<R: Send + 'static>(
    size: usize,
    body: impl Fn(Team) -> R + Sync + Send + 'static,
) -> Vec<R> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(on_ranks(size, body));
    });
    rx.recv_timeout(Duration::from_secs(120))
        .expect("the ranks did not all return: one waits for another that has left")
}

/// A library of `team` with a scene of one constant medium open, whose progress function
/// panics at its first call on rank `panics_on` (a rank-local failure between steps).
fn constant_medium(team: Team, panics_on: usize) -> crate::Library {
    use crate::types::Fields;
    let rank = team.rank();
    let mut vl = crate::Library::new();
    vl.set_team(Some(team));
    if rank == panics_on {
        let first = std::sync::atomic::AtomicBool::new(true);
        let progress: crate::ProgressFn = Arc::new(move |_| {
            if first.swap(false, std::sync::atomic::Ordering::Relaxed) {
                panic!("the progress function failed");
            }
            true
        });
        vl.set_render_control(crate::RenderControl {
            cancel: None,
            progress: Some(progress),
        });
    }
    vl.scene().unwrap();
    vl.object().unwrap();
    vl.set(Fields::O, 0.05).unwrap();
    vl.set(Fields::R, 1.0).unwrap();
    vl.end().unwrap();
    vl
}

#[test]
fn a_rank_whose_progress_function_panics_fails_the_render_on_every_rank() {
    // Rank 1's progress function panics after its first strip: rank 1 holds the error and
    // goes on to the second strip's step, which fails on both ranks with it (1024 × 1100
    // pixels are two strips of about 2²⁰). Then the team renders the next image whole.
    let results = on_ranks_within(2, |team| {
        let vl = constant_medium(team, 1);
        let failed = vl.render_preview(1024, 1100, 1.0).map(|_| ());
        let next = vl.render_preview(8, 8, 1.0).unwrap();
        (failed.map_err(|e| (e.code, e.message)), next.pixels)
    });
    let panicked = "the progress function stopped by a panic (in a field function?): the \
                    progress function failed";
    assert_eq!(
        results[1].0,
        Err((ErrorCode::Internal, panicked.to_string()))
    );
    assert_eq!(
        results[0].0,
        Err((ErrorCode::Internal, format!("{panicked} (on rank 1)")))
    );
    assert_eq!(
        results[0].1, results[1].1,
        "the next image is the same on both"
    );
    // One strip: the error is held past the last step and settled at the image's end.
    let one_strip = on_ranks_within(2, |team| {
        let vl = constant_medium(team, 0);
        vl.render_preview(16, 16, 1.0)
            .map(|_| ())
            .map_err(|e| e.code)
    });
    assert_eq!(one_strip, vec![Err(ErrorCode::Internal); 2]);
}

#[test]
fn a_rank_whose_progress_function_panics_fails_a_voxelization_and_writes_nothing() {
    // A voxelization of 64³ nodes (slabs of 2¹⁶ nodes: several steps); rank 1's progress
    // function panics after its first slab. Every rank fails with that error, rank 0 commits
    // no file.
    let dir = std::env::temp_dir().join(format!("vlib-team-voxel-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let prefix = dir.join("medium");
    let results = on_ranks_within(2, move |team| {
        let mut vl = constant_medium(team, 1);
        vl.volume(
            &prefix,
            crate::types::Fields::O,
            [0.0; 3],
            [1.0; 3],
            [64; 3],
            1,
        )
        .unwrap();
        vl.end().map(|_| ()).map_err(|e| (e.code, e.message))
    });
    // (The step's agreed error is agreed again at the voxelization's end; it keeps naming
    // the rank it came from.)
    for r in &results {
        let (code, message) = r.as_ref().unwrap_err();
        assert_eq!(*code, ErrorCode::Internal);
        assert!(message.ends_with("failed (on rank 1)"), "{message}");
    }
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(left.is_empty(), "files left: {left:?}");
}

#[test]
fn a_rank_whose_buffer_is_short_fails_render_into_on_every_rank() {
    // `render_into` checks the caller's buffer on each rank; rank 1's is one byte short. Its
    // check is agreed with the compiled scene, so both ranks fail with `BadValue` (rank 0's
    // message naming rank 1) instead of rank 0 waiting for a rank that has left; the next
    // render goes through on both.
    let results = on_ranks_within(2, |team| {
        let rank = team.rank();
        let vl = constant_medium(team, usize::MAX);
        let format = crate::PixelFormat::Rgb8;
        let need = format.image_bytes(8, 8).unwrap();
        let mut buffer = vec![0u8; if rank == 1 { need - 1 } else { need }];
        let failed = vl.render_into(8, 8, 1.0, format, &mut buffer);
        let mut whole = vec![0u8; need];
        let next = vl.render_into(8, 8, 1.0, format, &mut whole);
        (
            failed.map_err(|e| (e.code, e.message.ends_with("(on rank 1)"))),
            next.is_ok(),
        )
    });
    assert_eq!(results[0], (Err((ErrorCode::BadValue, true)), true));
    assert_eq!(results[1], (Err((ErrorCode::BadValue, false)), true));
}

#[test]
fn a_call_refused_before_the_library_fails_every_rank_with_its_error() {
    // Rank 1's render call is refused before it reaches the library (as the C layer refuses a
    // NULL buffer): `refuse_render` takes part in the first agreement with that error, so
    // rank 0's render fails with rank 1's code, not some other; where both refuse, both report
    // rank 0's error; the next render goes through on both.
    let results = on_ranks_within(2, |team| {
        let rank = team.rank();
        let vl = constant_medium(team, usize::MAX);
        let format = crate::PixelFormat::Rgb8;
        let mut buffer = vec![0u8; format.image_bytes(8, 8).unwrap()];
        let null = || Error::new(ErrorCode::NullPointer, "buf is NULL");
        let one = if rank == 1 {
            Err(vl.refuse_render(null()))
        } else {
            vl.render_into(8, 8, 1.0, format, &mut buffer)
        };
        let own = Error::new(ErrorCode::BadEnum, format!("rank {rank}'s format"));
        let both = vl.refuse_render(own);
        let next = vl.render_into(8, 8, 1.0, format, &mut buffer);
        (
            one.map_err(|e| e.code),
            both.code,
            both.message,
            next.is_ok(),
        )
    });
    for (rank, (one, both, message, next)) in results.into_iter().enumerate() {
        assert_eq!(one, Err(ErrorCode::NullPointer), "rank {rank}");
        assert_eq!(both, ErrorCode::BadEnum, "rank {rank}");
        assert!(
            message.starts_with("rank 0's format"),
            "rank {rank}: {message}"
        );
        assert!(next, "rank {rank}");
    }
}

#[test]
fn a_rank_whose_arguments_are_refused_fails_every_rank() {
    // Rank 1 asks for a view plane of aspect −1 (refused before any render): it takes part in
    // the first agreement with that error, so both ranks fail with `BadValue` instead of rank
    // 0 waiting for it in the render; the same for `render` with a side of 0; the next render
    // goes through on both.
    let results = on_ranks_within(2, |team| {
        let rank = team.rank();
        let vl = constant_medium(team, usize::MAX);
        let format = crate::PixelFormat::Rgb8;
        let mut buffer = vec![0u8; format.image_bytes(8, 8).unwrap()];
        let aspect = if rank == 1 { -1.0 } else { 1.0 };
        let into = vl.render_into(8, 8, aspect, format, &mut buffer);
        let side = if rank == 1 { 0 } else { 8 };
        let image = vl.render(side, 8, 1.0, crate::Backdrop::Background);
        let next = vl.render_into(8, 8, 1.0, format, &mut buffer);
        (
            into.map_err(|e| e.code),
            image.map(|_| ()).map_err(|e| e.code),
            next.is_ok(),
        )
    });
    for r in &results {
        assert_eq!(
            *r,
            (Err(ErrorCode::BadValue), Err(ErrorCode::BadValue), true)
        );
    }
}
