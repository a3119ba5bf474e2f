//! The scope state machine through the C interface, exhaustively: every command in each of the 5
//! scopes, called with valid arguments so that the scope is the only possible
//! error. Illegal calls must record exactly `VL_BADSCOPE` and change nothing; legal calls must not
//! record `VL_BADSCOPE`. The legality table is the core's (`vlib_core::scope::legal`).
//!
//! Then misuse: NULL pointers, bad enumerations, bad field masks, Figure 2's bad mapping output,
//! a field function that calls an illegal command from a worker thread, the bounded error queue
//! and non-UTF-8 paths. Two wrong arguments at once are `error_order`'s, with these helpers.
//!
//! The C interface's state is global, so every test holds `common::serial()`.

use super::common::{drain, serial, TempDir};
use crate::*;
use std::ffi::{CStr, CString};
use std::os::raw::c_void;
use std::path::Path;
use std::ptr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock};
use vlib_core::scope::legal;
use vlib_core::{Command, Scope};

const CAMERA: VLCAMERA = VLCAMERA {
    eye: [0.5, 0.5, -2.0],
    at: [0.5, 0.5, 0.5],
    up: [0.0, 1.0, 0.0],
    fov: 45.0,
};
const IDENTITY: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];
/// Figure 2's table: 2 points, 1 output.
const TABLE: [f32; 4] = [0.001, 1.0, 1.0, 0.3];

/// Files the commands name, in a directory that lives for the whole test binary.
pub(super) struct Files {
    _dir: TempDir,
    pub(super) image: CString,
    pub(super) volume: CString,
    dataset: CString,
}

pub(super) fn files() -> &'static Files {
    static FILES: OnceLock<Files> = OnceLock::new();
    FILES.get_or_init(|| {
        let dir = TempDir::new("scopes");
        // A valid 2×2×2 `.vlb` dataset: magic, nx ny nz, bytes per voxel, a, b, voxels.
        let mut vlb = b"VLB1".to_vec();
        for v in [2u32, 2, 2, 1] {
            vlb.extend_from_slice(&v.to_le_bytes());
        }
        for v in [0.0f32, 255.0] {
            vlb.extend_from_slice(&v.to_le_bytes());
        }
        vlb.extend_from_slice(&[0, 32, 64, 96, 128, 160, 192, 255]);
        let dataset = dir.path().join("cube.vlb");
        std::fs::write(&dataset, vlb).expect("write cube.vlb");
        let c = |p: &Path| CString::new(p.to_str().expect("UTF-8 temp dir")).expect("no NUL");
        Files {
            image: c(&dir.path().join("scope.ppm")),
            volume: c(&dir.path().join("vol")),
            dataset: c(&dataset),
            _dir: dir,
        }
    })
}

extern "C" fn set_opaque(_p: *mut vlfloat, _misc: *mut c_void) {
    vlSet(VL_O, 1.0)
}

extern "C" fn spatial_identity(_p: *mut vlfloat, _misc: *mut c_void) {}

extern "C" fn keep_normal(_n: *mut vlfloat, _p: *mut vlfloat, _misc: *mut c_void) {}

/// Calls `cmd` with valid arguments (valid wherever the command is legal).
fn call(cmd: Command) {
    let f = files();
    let mut buf = [0.0f32; 3];
    // SAFETY: every pointer is valid for what its command reads or writes: the file names live
    // for the whole test binary, the camera and the tables are constants, `buf` holds 3 floats,
    // and the C functions may be called from any thread.
    unsafe {
        match cmd {
            Command::Init => vlInit(),
            Command::End => vlEnd(),
            Command::Error => {
                vlError();
            }
            Command::ErrorString => {
                vlErrorString(VL_BADSCOPE);
            }
            Command::Scene => vlScene(),
            Command::Image => vlImage(f.image.as_ptr(), 1.0, 2, 2),
            Command::Volume => vlVolume(
                f.volume.as_ptr(),
                VL_O,
                0.0,
                0.0,
                0.0,
                1.0,
                1.0,
                1.0,
                2,
                2,
                2,
                1,
            ),
            Command::Camera => vlCamera(&CAMERA),
            Command::Background => vlBackground(0.1, 0.2, 0.3),
            Command::SuperSample => vlSuperSample(2),
            Command::Ambient => vlAmbient(1.0, 1.0, 1.0, 0.5),
            Command::PointLight => vlPointLight(0.0, 0.0, -5.0, VL_INVERSE, 1.0, 1.0, 1.0, 1.0),
            Command::DirectionalLight => vlDirectionalLight(0.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0),
            Command::RenderType => vlRenderType(VL_DVR),
            Command::StepSize => vlStepSize(0.5, 1.0),
            Command::Surface => vlSurface(VL_F, 0.5),
            Command::Toggle => vlToggle(VL_VISIBLE, VL_TRUE),
            Command::Recursion => vlRecursion(2),
            Command::InterpolationType => vlInterpolationType(VL_TRICUBIC),
            Command::CubicFilter => vlCubicFilter(1.0 / 3.0, 1.0 / 3.0),
            Command::Neighborhood => vlNeighborhood(0.1, 0.1, 0.1),
            Command::Load => vlLoad(7, f.dataset.as_ptr()),
            Command::Unload => vlUnload(7),
            Command::Sample => {
                vlSample(7, 0.5, 0.5, 0.5);
            }
            Command::Mapping => vlMapping(2, VL_RAMP, 2, 1, TABLE.as_ptr()),
            Command::Object => vlObject(),
            Command::Scale => vlScale(2.0, 2.0, 2.0),
            Command::Translate => vlTranslate(1.0, 2.0, 3.0),
            Command::Rotate => vlRotate(10.0, 20.0, 30.0),
            Command::Flip => vlFlip(VL_X | VL_Z),
            Command::Matrix => vlMatrix(IDENTITY.as_ptr()),
            Command::Boundary => vlBoundary(1.5, 1.5, 1.5),
            Command::Spatial => vlSpatial(Some(spatial_identity), ptr::null_mut()),
            Command::Set => vlSet(VL_KA, 0.3),
            Command::Function => vlFunction(VL_O, Some(set_opaque), ptr::null_mut()),
            Command::Dataset => vlDataset(VL_O, 7),
            Command::Map => vlMap(VL_O, VL_F, 1, 1),
            Command::Normal => vlNormal(Some(keep_normal), ptr::null_mut()),
            Command::Field => {
                vlField(VL_O);
            }
            Command::Position => vlPosition(buf.as_mut_ptr()),
            Command::ChildCount => {
                vlChildCount();
            }
            Command::ChildHit => {
                vlChildHit(1);
            }
            Command::ChildField => {
                vlChildField(1, VL_O);
            }
            Command::ChildNormal => vlChildNormal(1, buf.as_mut_ptr()),
        }
    }
}

/// Closes whatever is open, then opens `scope` (with mapping 1 = Figure 2's table declared, so
/// that `vlMap(VL_O, VL_F, 1, 1)` is valid). Not for the sample scope.
pub(super) fn reset_to(scope: Scope) {
    for _ in 0..8 {
        if state_fingerprint() == "uninitialised" {
            break;
        }
        vlEnd();
    }
    assert_eq!(
        state_fingerprint(),
        "uninitialised",
        "could not close the library"
    );
    drain();
    if scope != Scope::Uninitialised {
        vlInit();
        // SAFETY: TABLE holds the 2 points × (1 + 1) floats declared.
        unsafe { vlMapping(1, VL_LOOKUP, 2, 1, TABLE.as_ptr()) };
    }
    if matches!(scope, Scope::Scene | Scope::Object) {
        vlScene();
    }
    if scope == Scope::Object {
        vlObject();
    }
    assert_eq!(drain(), Vec::<i32>::new(), "setting up {scope:?} scope");
}

/// Checks one call's errors against the table; `None` when it passes.
fn judge(cmd: Command, scope: Scope, errors: &[i32], unchanged: bool) -> Option<String> {
    if legal(cmd, scope) {
        errors.contains(&VL_BADSCOPE).then(|| {
            format!(
                "{} is legal in {scope:?} scope but recorded {errors:?}",
                cmd.name()
            )
        })
    } else if errors != [VL_BADSCOPE] {
        Some(format!(
            "{} in {scope:?} scope recorded {errors:?}, not [VL_BADSCOPE]",
            cmd.name()
        ))
    } else if !unchanged {
        Some(format!(
            "{} in {scope:?} scope was refused but changed the state",
            cmd.name()
        ))
    } else {
        None
    }
}

#[test]
fn every_command_in_every_scope_outside_sample_scope() {
    let _g = serial();
    let mut failures = Vec::new();
    let mut checked = 0;
    for scope in [
        Scope::Uninitialised,
        Scope::Library,
        Scope::Scene,
        Scope::Object,
    ] {
        for &cmd in Command::ALL {
            reset_to(scope);
            let before = state_fingerprint();
            call(cmd);
            let errors = drain();
            let unchanged = state_fingerprint() == before;
            failures.extend(judge(cmd, scope, &errors, unchanged));
            checked += 1;
        }
    }
    reset_to(Scope::Uninitialised);
    assert_eq!(checked, 4 * COMMAND_COUNT);
    assert!(
        failures.is_empty(),
        "{} failure(s):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// What the probe field function saw, filled in on a worker thread.
#[derive(Default)]
struct ProbeLog {
    /// For each command, the errors its call recorded in sample scope.
    calls: Vec<(Command, Vec<i32>)>,
    /// Misuse in sample scope: (what, expected code, recorded codes).
    misuse: Vec<(&'static str, i32, Vec<i32>)>,
    /// Values read back.
    field_o: f32,
    world: [f32; 3],
}

static PROBED: AtomicBool = AtomicBool::new(false);
static PROBE_LOG: Mutex<Option<ProbeLog>> = Mutex::new(None);

/// The field function of the sample-scope test: the first call (on whichever worker thread gets
/// there first) makes every call of the exhaustive test and the sample-scope misuse cases; all
/// calls make the object opaque.
extern "C" fn probe(_p: *mut vlfloat, _misc: *mut c_void) {
    // SAFETY: called by the renderer in sample scope; all arguments valid or deliberately NULL.
    unsafe {
        if !PROBED.swap(true, Ordering::SeqCst) {
            let mut log = ProbeLog::default();
            drain();
            for &cmd in Command::ALL {
                call(cmd);
                log.calls.push((cmd, drain()));
            }
            let mut misuse = |what: &'static str, want: i32, f: &dyn Fn()| {
                drain();
                f();
                log.misuse.push((what, want, drain()));
            };
            misuse("vlPosition(NULL)", VL_NULLPOINTER, &|| {
                vlPosition(ptr::null_mut())
            });
            // (A field function may not take child normals: scope first, whatever its
            // arguments.)
            misuse("vlChildNormal(1, NULL)", VL_BADSCOPE, &|| {
                vlChildNormal(1, ptr::null_mut())
            });
            misuse("vlSet(0, …)", VL_BADFIELD, &|| vlSet(0, 1.0));
            misuse("vlSet(1 << 10, …)", VL_BADFIELD, &|| vlSet(1 << 10, 1.0));
            misuse("vlField(VL_O | VL_R)", VL_BADFIELD, &|| {
                vlField(VL_O | VL_R);
            });
            misuse("vlChildField(1, 0)", VL_BADFIELD, &|| {
                vlChildField(1, 0);
            });
            misuse(
                "vlChildHit(1) of an object without children",
                VL_BADINDEX,
                &|| {
                    vlChildHit(1);
                },
            );
            misuse("vlChildField(0, VL_O)", VL_BADINDEX, &|| {
                vlChildField(0, VL_O);
            });
            misuse("VL_PARAB1(NULL)", VL_NULLPOINTER, &|| {
                VL_PARAB1(ptr::null_mut(), ptr::null_mut())
            });
            vlSet(VL_O, 0.75);
            log.field_o = vlField(VL_O);
            vlPosition(log.world.as_mut_ptr());
            *PROBE_LOG.lock().unwrap() = Some(log);
        }
        vlSet(VL_O, 1.0);
    }
}

#[test]
fn every_command_in_sample_scope() {
    let _g = serial();
    let dir = TempDir::new("sample");
    let image = CString::new(dir.path().join("probe.ppm").to_str().unwrap()).unwrap();
    reset_to(Scope::Library);
    let library_state = state_fingerprint();
    PROBED.store(false, Ordering::SeqCst);
    *PROBE_LOG.lock().unwrap() = None;
    // SAFETY: valid arguments.
    unsafe {
        vlScene();
        vlCamera(&CAMERA);
        vlImage(image.as_ptr(), 1.0, 4, 4);
        vlStepSize(0.1, 0.1);
        vlObject();
        vlFunction(VL_ALLFIELDS, Some(probe), ptr::null_mut());
        vlEnd();
        assert_eq!(drain(), Vec::<i32>::new());
        vlEnd(); // renders: the probe runs on worker threads while this thread holds the state
    }
    let render_errors = drain();
    assert!(
        dir.path().join("probe.ppm").is_file(),
        "the render did not complete"
    );
    assert_eq!(
        render_errors,
        Vec::<i32>::new(),
        "errors outside the probe's bookkeeping"
    );
    assert_eq!(
        state_fingerprint(),
        library_state,
        "sample-scope calls changed the library"
    );

    let log = PROBE_LOG.lock().unwrap().take().expect("the probe ran");
    assert_eq!(log.calls.len(), COMMAND_COUNT);
    let failures: Vec<String> = log
        .calls
        .iter()
        // vlChildNormal is legal in sample scope but only inside normal functions: checked below.
        .filter(|(cmd, _)| *cmd != Command::ChildNormal)
        .filter_map(|(cmd, errors)| judge(*cmd, Scope::Sample, errors, true))
        .chain(
            log.misuse
                .iter()
                .filter(|(_, want, got)| got != &[*want])
                .map(|(what, want, got)| {
                    format!("{what} in sample scope recorded {got:?}, want [{want}]")
                }),
        )
        .collect();
    assert!(
        failures.is_empty(),
        "{} failure(s):\n{}",
        failures.len(),
        failures.join("\n")
    );
    // The probe object has no children: vlChildCount is 0, child 1 does not exist, and
    // vlChildNormal belongs in normal functions, not field functions.
    for (cmd, errors) in &log.calls {
        let want: &[i32] = match cmd {
            Command::ChildCount => &[],
            Command::ChildHit | Command::ChildField => &[VL_BADINDEX],
            Command::ChildNormal => &[VL_BADSCOPE],
            _ => continue,
        };
        assert_eq!(errors, want, "{}", cmd.name());
    }
    assert_eq!(log.field_o, 0.75, "vlField reads what vlSet wrote");
    assert!(
        log.world.iter().all(|c| (-0.01..=1.01).contains(c)),
        "world position {:?}",
        log.world
    );
    reset_to(Scope::Uninitialised);
}

/// Runs `f` in `scope` and checks it records exactly `want` and leaves the state unchanged.
pub(super) fn refused(scope: Scope, what: &str, want: i32, f: impl FnOnce()) {
    reset_to(scope);
    let before = state_fingerprint();
    f();
    let got = drain();
    assert_eq!(got, vec![want], "{what} in {scope:?} scope");
    assert_eq!(state_fingerprint(), before, "{what} changed the state");
}

#[test]
fn null_pointers_are_refused() {
    let _g = serial();
    // SAFETY: the pointers are NULL on purpose; everything else is valid.
    unsafe {
        refused(Scope::Scene, "vlImage(NULL)", VL_NULLPOINTER, || {
            vlImage(ptr::null(), 1.0, 2, 2)
        });
        refused(Scope::Scene, "vlVolume(NULL)", VL_NULLPOINTER, || {
            vlVolume(ptr::null(), VL_O, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2, 2, 2, 1)
        });
        refused(Scope::Scene, "vlCamera(NULL)", VL_NULLPOINTER, || {
            vlCamera(ptr::null())
        });
        refused(Scope::Library, "vlCamera(NULL)", VL_NULLPOINTER, || {
            vlCamera(ptr::null())
        });
        refused(Scope::Library, "vlLoad(1, NULL)", VL_NULLPOINTER, || {
            vlLoad(1, ptr::null())
        });
        refused(Scope::Library, "vlMapping(NULL)", VL_NULLPOINTER, || {
            vlMapping(3, VL_LOOKUP, 2, 1, ptr::null())
        });
        refused(Scope::Object, "vlMatrix(NULL)", VL_NULLPOINTER, || {
            vlMatrix(ptr::null())
        });
        refused(Scope::Object, "vlSpatial(NULL)", VL_NULLPOINTER, || {
            vlSpatial(None, ptr::null_mut())
        });
        refused(Scope::Object, "vlFunction(NULL)", VL_NULLPOINTER, || {
            vlFunction(VL_O, None, ptr::null_mut())
        });
        refused(Scope::Object, "vlNormal(NULL)", VL_NULLPOINTER, || {
            vlNormal(None, ptr::null_mut())
        });
        // vlaux: no scope of its own.
        refused(Scope::Library, "vluNoise(NULL)", VL_NULLPOINTER, || {
            assert_eq!(vluNoise(ptr::null(), 1.0, 0), 0.0);
        });
        refused(
            Scope::Library,
            "vluTurbulence(NULL)",
            VL_NULLPOINTER,
            || {
                assert_eq!(vluTurbulence(ptr::null(), 1.0, 3, 0), 0.0);
            },
        );
        refused(Scope::Library, "vluSpline(NULL)", VL_NULLPOINTER, || {
            assert_eq!(vluSpline(0.5, 3, ptr::null()), 0.0);
        });
        refused(Scope::Object, "VLU_SPHERE(NULL)", VL_NULLPOINTER, || {
            VLU_SPHERE(ptr::null_mut(), ptr::null_mut())
        });
        // The NULL checks come after the scope check.
        refused(
            Scope::Library,
            "vlImage(NULL) at library scope",
            VL_BADSCOPE,
            || vlImage(ptr::null(), 1.0, 2, 2),
        );
    }
    reset_to(Scope::Uninitialised);
}

#[test]
fn bad_enumerations_values_and_fields_are_refused() {
    let _g = serial();
    // SAFETY: valid pointers; the integers are bad on purpose.
    unsafe {
        refused(Scope::Scene, "vlRenderType(3)", VL_BADENUM, || {
            vlRenderType(3)
        });
        refused(Scope::Scene, "vlRenderType(-1)", VL_BADENUM, || {
            vlRenderType(-1)
        });
        refused(
            Scope::Scene,
            "vlPointLight attenuation 3",
            VL_BADENUM,
            || vlPointLight(0.0, 0.0, 0.0, 3, 1.0, 1.0, 1.0, 1.0),
        );
        refused(Scope::Scene, "vlToggle(8, VL_TRUE)", VL_BADENUM, || {
            vlToggle(8, VL_TRUE)
        });
        refused(Scope::Scene, "vlToggle(VL_VISIBLE, 2)", VL_BADVALUE, || {
            vlToggle(VL_VISIBLE, 2)
        });
        refused(
            Scope::Scene,
            "vlToggle(VL_VISIBLE, -1)",
            VL_BADVALUE,
            || vlToggle(VL_VISIBLE, -1),
        );
        refused(Scope::Library, "vlInterpolationType(3)", VL_BADENUM, || {
            vlInterpolationType(3)
        });
        refused(Scope::Library, "vlMapping type 2", VL_BADENUM, || {
            vlMapping(3, 2, 2, 1, TABLE.as_ptr())
        });
        refused(Scope::Object, "vlFlip(8)", VL_BADENUM, || vlFlip(8));
        // Sizes are checked before the table is read: no huge slice is formed.
        refused(
            Scope::Library,
            "vlMapping with 0 points",
            VL_BADVALUE,
            || vlMapping(3, VL_LOOKUP, 0, 1, TABLE.as_ptr()),
        );
        refused(
            Scope::Library,
            "vlMapping with i32::MAX points",
            VL_BADVALUE,
            || vlMapping(3, VL_LOOKUP, i32::MAX, 1, TABLE.as_ptr()),
        );
        refused(
            Scope::Library,
            "vlMapping with 1000 outputs",
            VL_BADVALUE,
            || vlMapping(3, VL_LOOKUP, 2, 1000, TABLE.as_ptr()),
        );
        refused(Scope::Library, "vluSpline(-1 knots)", VL_BADVALUE, || {
            vluSpline(0.5, -1, TABLE.as_ptr());
        });
        refused(Scope::Library, "vluSpline(2^20 knots)", VL_BADVALUE, || {
            vluSpline(0.5, 1 << 20, TABLE.as_ptr());
        });
        // Field masks.
        refused(Scope::Object, "vlSet(0)", VL_BADFIELD, || vlSet(0, 1.0));
        refused(Scope::Object, "vlSet(1 << 10)", VL_BADFIELD, || {
            vlSet(1 << 10, 1.0)
        });
        refused(Scope::Object, "vlSet(-1)", VL_BADFIELD, || vlSet(-1, 1.0));
        refused(Scope::Object, "vlFunction(0)", VL_BADFIELD, || {
            vlFunction(0, Some(set_opaque), ptr::null_mut())
        });
        refused(Scope::Object, "vlMap from two fields", VL_BADFIELD, || {
            vlMap(VL_O, VL_O | VL_F, 1, 1)
        });
        refused(Scope::Object, "vlMap to no field", VL_BADFIELD, || {
            vlMap(0, VL_F, 1, 1)
        });
        refused(Scope::Object, "vlDataset(2048)", VL_BADFIELD, || {
            vlDataset(2048, 7)
        });
        refused(Scope::Scene, "vlSurface(two fields)", VL_BADFIELD, || {
            vlSurface(VL_O | VL_F, 0.5)
        });
        refused(Scope::Scene, "vlVolume(fields 0)", VL_BADFIELD, || {
            vlVolume(
                files().volume.as_ptr(),
                0,
                0.0,
                0.0,
                0.0,
                1.0,
                1.0,
                1.0,
                2,
                2,
                2,
                1,
            )
        });
        refused(Scope::Scene, "vlImage(.gif)", VL_BADFILE, || {
            vlImage(c"x.gif".as_ptr(), 1.0, 2, 2)
        });
        refused(Scope::Scene, "vlBackground(NaN)", VL_BADVALUE, || {
            vlBackground(f32::NAN, 0.0, 0.0)
        });
    }
    reset_to(Scope::Uninitialised);
}

/// Figure 2, line 20: `vlMap(VL_KS, VL_F, 1, 2)` with a one-output table.
#[test]
fn figure2_bad_mapping_output_is_skipped() {
    let _g = serial();
    refused(
        Scope::Object,
        "vlMap(VL_KS, VL_F, 1, 2)",
        VL_BADINDEX,
        || vlMap(VL_KS, VL_F, 1, 2),
    );
    refused(Scope::Object, "vlMap through mapping 9", VL_BADID, || {
        vlMap(VL_KS, VL_F, 9, 1)
    });
    // The valid line 19 is accepted and changes the object.
    reset_to(Scope::Object);
    let before = state_fingerprint();
    vlMap(VL_O, VL_F, 1, 1);
    assert_eq!(drain(), Vec::<i32>::new());
    assert_ne!(state_fingerprint(), before);
    reset_to(Scope::Uninitialised);
}

static SCENE_CALLED: AtomicBool = AtomicBool::new(false);
static SCENE_THREAD: Mutex<Option<std::thread::ThreadId>> = Mutex::new(None);

extern "C" fn calls_vl_scene(_p: *mut vlfloat, _misc: *mut c_void) {
    // In sample scope: each must be refused without touching the locked state.
    if !SCENE_CALLED.swap(true, Ordering::SeqCst) {
        *SCENE_THREAD.lock().unwrap() = Some(std::thread::current().id());
        vlScene();
        vlEnd();
        vlInit();
    }
    vlSet(VL_O, 1.0);
}

/// A field function calling scope-changing commands: each records VL_BADSCOPE from the worker
/// thread, nothing deadlocks (the rendering vlEnd holds the state lock), the render completes.
#[test]
fn field_function_calling_vl_scene_records_badscope_without_deadlock() {
    let _g = serial();
    let dir = TempDir::new("vlscene");
    let image = CString::new(dir.path().join("scene.ppm").to_str().unwrap()).unwrap();
    reset_to(Scope::Library);
    let library_state = state_fingerprint();
    SCENE_CALLED.store(false, Ordering::SeqCst);
    // SAFETY: valid arguments.
    unsafe {
        vlScene();
        vlCamera(&CAMERA);
        vlImage(image.as_ptr(), 1.0, 8, 8);
        vlStepSize(0.1, 0.1);
        vlObject();
        vlFunction(VL_O, Some(calls_vl_scene), ptr::null_mut());
        vlEnd();
        vlEnd();
    }
    assert_eq!(drain(), vec![VL_BADSCOPE; 3]);
    assert!(
        dir.path().join("scene.ppm").is_file(),
        "the render completed"
    );
    assert!(
        SCENE_THREAD.lock().unwrap().is_some(),
        "the field function ran"
    );
    assert_eq!(
        state_fingerprint(),
        library_state,
        "back in the library scope, unchanged"
    );
    reset_to(Scope::Uninitialised);
}

#[test]
fn error_queue_is_bounded_and_fifo() {
    let _g = serial();
    reset_to(Scope::Uninitialised);
    vlScene(); // VL_BADSCOPE first
    vlInit();
    for _ in 0..2000 {
        vlRenderType(99); // VL_BADENUM
    }
    let errors = drain();
    assert_eq!(
        errors.len(),
        MAX_QUEUED,
        "bounded at {MAX_QUEUED}: newer errors dropped"
    );
    assert_eq!(errors[0], VL_BADSCOPE, "oldest first");
    assert!(errors[1..].iter().all(|e| *e == VL_BADENUM));
    assert!(last_error_message().is_some_and(|m| m.contains("render type")));
    assert_eq!(vlError(), VL_NOERROR);
    reset_to(Scope::Uninitialised);
}

#[test]
fn error_strings_are_static_and_total() {
    let _g = serial();
    for code in vlib_core::ErrorCode::ALL {
        // SAFETY: vlErrorString returns a static NUL-terminated string.
        let s = unsafe { CStr::from_ptr(vlErrorString(code as i32)) };
        assert_eq!(s.to_str().unwrap(), code.description());
    }
    for bad in [-1, 19, 1000, i32::MIN, i32::MAX] {
        // SAFETY: as above.
        let s = unsafe { CStr::from_ptr(vlErrorString(bad)) };
        assert_eq!(s.to_str().unwrap(), "unknown error code");
    }
    assert_eq!(drain(), Vec::<i32>::new(), "vlErrorString records nothing");
}

#[test]
fn vlu_camera_is_vl_camera_with_y_up_and_default_fov() {
    let _g = serial();
    reset_to(Scope::Library);
    vluCamera(1.0, 2.0, -3.0, 0.5, 0.5, 0.5);
    let a = state_fingerprint();
    reset_to(Scope::Library);
    let cam = VLCAMERA {
        eye: [1.0, 2.0, -3.0],
        at: [0.5, 0.5, 0.5],
        up: [0.0, 1.0, 0.0],
        fov: 60.0,
    };
    // SAFETY: valid pointer.
    unsafe { vlCamera(&cam) };
    assert_eq!(state_fingerprint(), a);
    assert_eq!(drain(), Vec::<i32>::new());
    reset_to(Scope::Uninitialised);
}

/// Paths are bytes: a file name that is not UTF-8 is written as given.
#[cfg(unix)]
#[test]
fn non_utf8_image_paths_work() {
    use std::os::unix::ffi::OsStrExt;
    let _g = serial();
    let dir = TempDir::new("latin1");
    let mut bytes = dir.path().as_os_str().as_bytes().to_vec();
    bytes.extend_from_slice(b"/caf\xe9.ppm");
    let path = std::ffi::OsStr::from_bytes(&bytes).to_owned();
    let c = CString::new(bytes).unwrap();
    reset_to(Scope::Library);
    // SAFETY: valid arguments.
    unsafe {
        vlScene();
        vlImage(c.as_ptr(), 1.0, 2, 2);
        vlEnd();
    }
    assert_eq!(drain(), Vec::<i32>::new());
    assert!(
        Path::new(&path).is_file(),
        "the non-UTF-8 file name was written"
    );
    reset_to(Scope::Uninitialised);
}

#[test]
fn gradient_filter_is_validated_and_recorded() {
    let _g = serial();
    refused(
        Scope::Library,
        "vlGradientFilter(2, …)",
        VL_BADENUM,
        || vlGradientFilter(2, 1.0, 0.0),
    );
    refused(
        Scope::Scene,
        "vlGradientFilter(-1, …)",
        VL_BADENUM,
        || vlGradientFilter(-1, 1.0, 0.0),
    );
    refused(Scope::Scene, "vlGradientFilter B NaN", VL_BADVALUE, || {
        vlGradientFilter(VL_GRADIENT_CUBIC, f32::NAN, 0.0)
    });
    refused(
        Scope::Library,
        "vlGradientFilter C ∞",
        VL_BADVALUE,
        || vlGradientFilter(VL_GRADIENT_CUBIC, 1.0, f32::INFINITY),
    );
    refused(
        Scope::Object,
        "vlGradientFilter in an object",
        VL_BADSCOPE,
        || vlGradientFilter(VL_GRADIENT_CUBIC, 1.0, 0.0),
    );
    refused(
        Scope::Uninitialised,
        "vlGradientFilter before vlInit",
        VL_BADSCOPE,
        || vlGradientFilter(VL_GRADIENT_CUBIC, 1.0, 0.0),
    );
    // Legal at library and scene scope: recorded, and back to the paper's with
    // VL_GRADIENT_NODES (whose B and C are ignored, even when not finite).
    for scope in [Scope::Library, Scope::Scene] {
        reset_to(scope);
        let before = state_fingerprint();
        vlGradientFilter(VL_GRADIENT_CUBIC, 1.0, 0.0);
        assert_eq!(drain(), Vec::<i32>::new());
        let cubic = state_fingerprint();
        assert!(
            cubic.contains("gradient: Cubic { b: 1.0, c: 0.0 }"),
            "{cubic}"
        );
        vlGradientFilter(VL_GRADIENT_NODES, f32::NAN, 0.0);
        assert_eq!(drain(), Vec::<i32>::new());
        assert_eq!(state_fingerprint(), before);
    }
}
