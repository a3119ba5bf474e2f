//! The error-order rule of `docs/errors.md` through the C interface: with two arguments wrong
//! at once, a command records the error of the one the rule puts first (its scope; then its
//! pointers, enumerations and field masks as this layer converts them; then its values in the
//! order of its parameters). The helpers are those of the scope tests (`scopes`).
//!
//! The C interface's state is global, so the test holds `common::serial()`.

use super::common::serial;
use super::scopes::{files, refused, reset_to};
use crate::*;
use std::ptr;
use vlib_core::Scope;

/// Two arguments wrong at once: the error recorded is the one `errors.md` puts first (scope;
/// then pointers, enumerations and field masks as this layer converts them; then values in
/// the order of the parameters).
#[test]
fn of_two_wrong_arguments_the_first_by_the_rule_is_reported() {
    let _g = serial();
    let f = files();
    let nan = f32::NAN;
    // SAFETY: every pointer is NULL on purpose or valid for what its command reads.
    unsafe {
        // Scope before everything.
        refused(
            Scope::Scene,
            "vlDataset(0, 9) in a scene",
            VL_BADSCOPE,
            || vlDataset(0, 9),
        );
        refused(
            Scope::Library,
            "vlImage(NULL, 0, …) in the library",
            VL_BADSCOPE,
            || vlImage(ptr::null(), 0.0, 0, 0),
        );
        // vlImage(file, aspect, width, height).
        refused(
            Scope::Scene,
            "vlImage(NULL, aspect 0)",
            VL_NULLPOINTER,
            || vlImage(ptr::null(), 0.0, 2, 2),
        );
        refused(Scope::Scene, "vlImage(.gif, aspect 0)", VL_BADFILE, || {
            vlImage(c"x.gif".as_ptr(), 0.0, 2, 2)
        });
        refused(
            Scope::Scene,
            "vlImage(aspect 0, 2^30 pixels)",
            VL_BADVALUE,
            || vlImage(f.image.as_ptr(), 0.0, 1 << 15, 1 << 15),
        );
        // vlVolume(prefix, fields, corners, nodes, bytes).
        let volume = |prefix: *const std::os::raw::c_char, fields, x0, z1, nodes: [i32; 3]| {
            vlVolume(
                prefix, fields, x0, 0.0, 0.0, 1.0, 1.0, z1, nodes[0], nodes[1], nodes[2], 1,
            )
        };
        refused(
            Scope::Scene,
            "vlVolume(NULL, no fields)",
            VL_NULLPOINTER,
            || volume(ptr::null(), 0, 0.0, 1.0, [2; 3]),
        );
        refused(
            Scope::Scene,
            "vlVolume(\"\", no fields)",
            VL_BADFIELD,
            || volume(c"".as_ptr(), 0, 0.0, 1.0, [2; 3]),
        );
        refused(Scope::Scene, "vlVolume(\"\", x0 NaN)", VL_BADFILE, || {
            volume(c"".as_ptr(), VL_O, nan, 1.0, [2; 3])
        });
        refused(
            Scope::Scene,
            "vlVolume(no fields, x0 NaN)",
            VL_BADFIELD,
            || volume(f.volume.as_ptr(), 0, nan, 1.0, [2; 3]),
        );
        refused(
            Scope::Scene,
            "vlVolume(flat box, 2^61 nodes)",
            VL_BADVALUE,
            || volume(f.volume.as_ptr(), VL_O, 0.0, 0.0, [1 << 30, 1 << 30, 2]),
        );
        // Enumerations before values.
        refused(
            Scope::Scene,
            "vlPointLight(x NaN, attenuation 3)",
            VL_BADENUM,
            || vlPointLight(nan, 0.0, 0.0, 3, 2.0, 0.0, 0.0, -1.0),
        );
        refused(Scope::Scene, "vlToggle(8, 2)", VL_BADENUM, || {
            vlToggle(8, 2)
        });
        refused(
            Scope::Scene,
            "vlGradientFilter(5, NaN, NaN)",
            VL_BADENUM,
            || vlGradientFilter(5, nan, nan),
        );
        // vlRenderBuffer checks its format, then its buffer, then its sizes
        // (extensions.md).
        refused(
            Scope::Scene,
            "vlRenderBuffer(NULL, format 99)",
            VL_BADENUM,
            || {
                assert_eq!(vlRenderBuffer(ptr::null_mut(), 0, 0, 0, nan, 99), VL_FALSE);
            },
        );
        refused(
            Scope::Scene,
            "vlRenderBuffer(NULL, size 0x0)",
            VL_NULLPOINTER,
            || {
                assert_eq!(
                    vlRenderBuffer(ptr::null_mut(), 0, 0, 0, nan, VL_RGB8),
                    VL_FALSE
                );
            },
        );
        // Field masks before values.
        refused(
            Scope::Scene,
            "vlSurface(no field, NaN)",
            VL_BADFIELD,
            || vlSurface(0, nan),
        );
        refused(
            Scope::Scene,
            "vlSurface(two fields, 2)",
            VL_BADFIELD,
            || vlSurface(VL_O | VL_F, 2.0),
        );
        // vlMapping(id, type, points, outputs, table).
        refused(
            Scope::Library,
            "vlMapping(type 2, 0 points, NULL)",
            VL_BADENUM,
            || vlMapping(3, 2, 0, 1, ptr::null()),
        );
        refused(
            Scope::Library,
            "vlMapping(0 points, NULL)",
            VL_NULLPOINTER,
            || vlMapping(3, VL_LOOKUP, 0, 1, ptr::null()),
        );
        // Ids before values.
        refused(
            Scope::Library,
            "vlSample(no dataset 9, NaN)",
            VL_BADID,
            || {
                assert_eq!(vlSample(9, nan, 0.5, 0.5), 0.0);
            },
        );
        // Object instructions: field masks, then ids, then indices.
        refused(
            Scope::Object,
            "vlFunction(no fields, NULL)",
            VL_BADFIELD,
            || vlFunction(0, None, ptr::null_mut()),
        );
        refused(
            Scope::Object,
            "vlDataset(no fields, no dataset 9)",
            VL_BADFIELD,
            || vlDataset(0, 9),
        );
        refused(
            Scope::Object,
            "vlMap(no targets, mapping 9)",
            VL_BADFIELD,
            || vlMap(0, VL_F, 9, 0),
        );
        refused(
            Scope::Object,
            "vlMap(two sources, mapping 9)",
            VL_BADFIELD,
            || vlMap(VL_O, VL_O | VL_F, 9, 0),
        );
        refused(
            Scope::Object,
            "vlMap(mapping 9, output 0)",
            VL_BADID,
            || vlMap(VL_O, VL_F, 9, 0),
        );
    }
    reset_to(Scope::Uninitialised);
}
