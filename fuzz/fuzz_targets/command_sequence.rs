//! Random command sequences on `vlib::Library`, the state machine behind the C interface:
//! no panic, scopes enforced, refused calls change nothing, outputs complete or absent (see
//! `fuzz/src/driver.rs` for the checks).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    vlib_fuzz::driver::run(
        data,
        vlib_fuzz::scratch_dir(),
        vlib_fuzz::driver::Config::default(),
    );
});
