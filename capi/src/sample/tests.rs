//! Unit tests of the sample context.

use super::*;

#[test]
fn sample_scope_is_left_even_by_unwinding() {
    let mut s = Sample::new([0.5; 3], [0.0; 3]);
    let p: *mut Sample = &mut s;
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let _outer = Enter::new(p);
        assert!(active());
        {
            let _inner = Enter::new(p);
        }
        assert!(active(), "leaving a nested scope restores the outer one");
        panic!("unwind through the guard");
    }));
    assert!(r.is_err());
    assert!(!active());
    assert!(with_current(|_| ()).is_none());
}
