//! The soft limit of this process's address space (Linux, 64-bit), for the tests that run a
//! child under it to see allocations fail.

/// `struct rlimit` on 64-bit Linux.
#[repr(C)]
struct Rlimit {
    cur: u64,
    max: u64,
}

/// `RLIMIT_AS` on Linux.
const RLIMIT_AS: i32 = 9;

extern "C" {
    fn getrlimit(resource: i32, rlim: *mut Rlimit) -> i32;
    fn setrlimit(resource: i32, rlim: *const Rlimit) -> i32;
}

/// Sets the soft address-space limit to `bytes`, keeping the hard one.
pub fn limit_address_space(bytes: u64) {
    let mut lim = Rlimit { cur: 0, max: 0 };
    // SAFETY: `lim` is a valid `struct rlimit` for both calls.
    unsafe {
        assert_eq!(getrlimit(RLIMIT_AS, &mut lim), 0, "getrlimit");
        lim.cur = bytes.min(lim.max);
        assert_eq!(setrlimit(RLIMIT_AS, &lim), 0, "setrlimit");
    }
}
