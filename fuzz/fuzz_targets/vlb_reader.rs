//! `.vlb` reader: `Dataset::from_vlb_bytes` on arbitrary bytes never panics, refuses with one of
//! the reader's codes, re-encodes an accepted file to the same bytes, and agrees with
//! `Dataset::load` reading the same bytes from a file.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = vlib_fuzz::scratch_dir();
    let _ = std::fs::create_dir_all(dir);
    vlib_fuzz::driver::check_vlb(data, Some(&dir.join("input.vlb")));
});
