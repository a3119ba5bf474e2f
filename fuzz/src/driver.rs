//! The command-sequence interpreter shared by the `command_sequence` fuzz target and the bounded
//! CI run in `tests/fuzz_props.rs` (which includes this file by path, so it may use only `std`
//! and `vlib`).
//!
//! An input is a byte string read as a sequence of API calls on [`vlib::Library`], the state
//! machine that the C interface is a thin layer over: one byte picks the command, the following
//! bytes its arguments. Numbers come from tables of interesting values (0, −0, ±1, NaN, ±Inf,
//! huge, tiny, the limits of each range) or, for most float arguments, from raw bits. Arguments
//! that set how long a render takes (step size, scale, boundary, image size, super-sampling,
//! voxel grid) are drawn from tables whose valid entries are small, so that every input runs in
//! milliseconds; their invalid entries are as wild as anywhere else.
//!
//! After every call the driver checks the robustness contract of `docs/dev/robustness.md`:
//! - nothing panics (a panic is a crash for the fuzzer and a failure for the CI run);
//! - a command outside its scopes is refused with `BadScope`, and a command inside them is never
//!   refused with `BadScope`;
//! - a refused call leaves `Library::fingerprint()` unchanged (the one documented exception: the
//!   `vlEnd` that closes a scene closes it even when an output fails);
//! - no refused call reports `NoError`, and `Internal` only where a panicking callback ran;
//! - when a scene closes, no temporary file is left behind; every output requested on a
//!   writable path exists and is complete (PPM and PNG headers and sizes, `.vlb` files that load
//!   back with the requested grid); an output on an unwritable path fails with `IoError`; every
//!   `.ppm` in the output directory is always complete, never truncated.

#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use vlib::limits::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_VOLUME_NODES};
use vlib::{
    Attenuation, Camera, Closed, Command, ErrorCode, Feature, Fields, Interpolation, Library,
    MappingType, RenderType, Sample, Scope,
};
use vlib::{Dataset, DatasetId, MappingId, Voxels};

/// How the interpreter behaves.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Whether field functions may panic (the core must catch the panic and report
    /// `Internal`). Off under libFuzzer, whose panic hook aborts on any panic, caught or not.
    pub allow_panics: bool,
    /// The most calls one input makes.
    pub max_calls: usize,
}

impl Default for Config {
    fn default() -> Config {
        Config {
            allow_panics: false,
            max_calls: 96,
        }
    }
}

/// What a run did (for the summary a bounded run prints).
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    /// Calls made.
    pub calls: u64,
    /// Calls refused with an error.
    pub refused: u64,
    /// Scenes closed (rendered).
    pub scenes: u64,
    /// Images written and checked.
    pub images: u64,
    /// Voxel files written and checked.
    pub volumes: u64,
    /// Scenes whose outputs failed as expected (unwritable paths, panicking callbacks).
    pub failed_outputs: u64,
    /// Refusals with `Internal`: panics of callbacks, caught.
    pub caught_panics: u64,
}

impl std::ops::AddAssign for Stats {
    fn add_assign(&mut self, o: Stats) {
        self.calls += o.calls;
        self.refused += o.refused;
        self.scenes += o.scenes;
        self.images += o.images;
        self.volumes += o.volumes;
        self.failed_outputs += o.failed_outputs;
        self.caught_panics += o.caught_panics;
    }
}

/// Reads arguments from the input; past its end every read gives 0.
struct Input<'a> {
    data: &'a [u8],
    pos: usize,
}

const F_TABLE: [f32; 24] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    0.25,
    2.0,
    0.1,
    0.9,
    1.5,
    100.0,
    -100.0,
    1e-30,
    1e30,
    f32::MAX,
    f32::MIN_POSITIVE,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.001,
    180.0,
    60.0,
    3.0,
    1.0000001,
];

const I_TABLE: [i32; 22] = [
    0,
    1,
    2,
    3,
    -1,
    4,
    5,
    7,
    8,
    16,
    17,
    64,
    65,
    1023,
    1024,
    1 << 12,
    1 << 20,
    (1 << 20) + 1,
    1 << 30,
    i32::MAX,
    i32::MIN,
    -2,
];

impl<'a> Input<'a> {
    fn new(data: &'a [u8]) -> Input<'a> {
        Input { data, pos: 0 }
    }

    fn done(&self) -> bool {
        self.pos >= self.data.len()
    }

    fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }

    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    fn bool(&mut self) -> bool {
        self.u8() & 1 == 1
    }

    /// A float: mostly from the table, sometimes raw bits.
    fn f(&mut self) -> f32 {
        let b = self.u8();
        if b >= 224 {
            f32::from_bits(self.u32())
        } else {
            F_TABLE[b as usize % F_TABLE.len()]
        }
    }

    /// An integer: mostly from the table, sometimes raw bits.
    fn i(&mut self) -> i32 {
        let b = self.u8();
        if b >= 240 {
            self.u32() as i32
        } else {
            I_TABLE[b as usize % I_TABLE.len()]
        }
    }

    /// One of `table`.
    fn pick<T: Copy>(&mut self, table: &[T]) -> T {
        table[self.u8() as usize % table.len()]
    }

    /// An id: usually one of the few that are used, sometimes anything.
    fn id(&mut self) -> i32 {
        let b = self.u8();
        match b {
            0..=199 => (b % 3) as i32,
            200..=219 => -1,
            220..=229 => i32::MAX,
            230..=239 => i32::MIN,
            _ => self.u32() as i32,
        }
    }

    /// A raw field mask: a single field, a common combination, or wrong bits.
    fn fields(&mut self) -> i32 {
        let b = self.u8();
        match b {
            0..=119 => 1 << (b % 10),
            120..=199 => [
                0b1110,  // colours
                0x3ff,   // all
                1 | 512, // o | f
                16 | 32 | 64,
                0,
                1 << 10,
                -1,
                0x3ff | (1 << 15),
            ][(b % 8) as usize],
            _ => self.u32() as i32,
        }
    }
}

/// Steps: invalid ones, and valid ones no smaller than 0.05 world units.
const STEPS: [f32; 12] = [
    0.0,
    -0.0,
    -1.0,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.05,
    0.1,
    0.25,
    1.0,
    15.0,
    f32::MAX,
];
/// Scale factors: invalid ones, and valid ones of magnitude at most 2.
const SCALES: [f32; 12] = [
    0.0,
    -0.0,
    f32::NAN,
    f32::INFINITY,
    1e-30,
    0.5,
    2.0,
    -1.0,
    1.0,
    1.5,
    -2.0,
    f32::MIN_POSITIVE,
];
/// Boundary factors: invalid ones, and valid ones up to 3.
const BOUNDS: [f32; 10] = [
    0.0,
    -1.0,
    f32::NAN,
    f32::INFINITY,
    0.5,
    1.0,
    2.0,
    3.0,
    1e-20,
    -0.0,
];
/// Matrix entries: invalid ones, and valid ones of magnitude at most 1.
const MATRIX: [f32; 10] = [
    0.0,
    1.0,
    -1.0,
    0.5,
    f32::NAN,
    f32::INFINITY,
    1e-30,
    0.0,
    1.0,
    0.0,
];
/// Image sides: invalid ones (including the largest accepted side with too many pixels in all)
/// and small valid ones.
const SIDES: [i32; 11] = [0, -1, 1, 2, 3, 4, 5, 32769, i32::MAX, i32::MIN, 32768];
/// Super-sampling: invalid ones and small valid ones.
const SUPER: [i32; 7] = [0, -1, 1, 2, 3, 17, i32::MIN];
/// Voxel grid sides: invalid ones, small valid ones, and sides whose product is too large
/// (2^22 three times wraps to 0 in u64).
const NODES: [i32; 11] = [
    0,
    -1,
    1,
    2,
    3,
    4,
    i32::MAX,
    i32::MIN,
    1 << 16,
    1 << 11,
    1 << 22,
];

/// How many enlarging transforms (a scale factor above 1 in magnitude, a matrix) one input may
/// issue; later ones are skipped. Each doubles an object's extent at most (a matrix: quadruples),
/// and a ray takes extent / step samples: valid but ever larger objects (vlScale(2, 2, 2) thirty
/// times) would make one input render for minutes, for no more coverage.
const GROWTH_BUDGET: u32 = 3;

/// Image and volume paths, relative to the output directory: valid, unwritable (a missing
/// directory, an existing directory as the file), and unsupported names.
const IMAGE_PATHS: [&str; 9] = [
    "a.ppm",
    "b.png",
    "C.PPM",
    "a.ppm",
    "missing/x.ppm",
    "sub.ppm",
    "x.gif",
    "noext",
    "",
];
const VOLUME_PREFIXES: [&str; 5] = ["v", "w", "missing/v", "", "sub.ppm/v"];

/// An argument converted by the C layer (an enumeration or field mask arriving as an integer):
/// as in `capi`, the scope is checked before the conversion, so an illegal call always reports
/// `BadScope`.
fn c_arg<T>(lib: &Library, cmd: Command, r: vlib::Result<T>) -> vlib::Result<T> {
    vlib::scope::require(cmd, lib.scope())?;
    r
}

/// Whether writing to `rel` must fail: a missing directory, or an existing directory as the file.
fn unwritable(rel: &str) -> bool {
    rel.starts_with("missing/") || rel == "sub.ppm"
}

/// `rel` inside `dir`; the empty name stays empty (so the command sees an empty path).
fn rel_path(dir: &Path, rel: &str) -> PathBuf {
    if rel.is_empty() {
        PathBuf::new()
    } else {
        dir.join(rel)
    }
}

/// Whether sizes `n` are each valid (1 ..= `side`) with a product that is accepted (at most
/// `total`) but larger than `cheap`.
fn valid_but_large(n: &[i32], side: u64, total: u64, cheap: u64) -> bool {
    let valid = n.iter().all(|&v| v >= 1 && v as u64 <= side);
    let product: u128 = n.iter().map(|&v| v.max(0) as u128).product();
    valid && product > cheap as u128 && product <= total as u128
}

#[derive(Clone, Debug)]
enum Output {
    Image {
        path: PathBuf,
        width: u32,
        height: u32,
    },
    Volume {
        prefix: PathBuf,
        fields: Fields,
        nodes: [usize; 3],
        bytes: u32,
    },
}

/// One interpreter run over one input.
pub struct Driver<'d> {
    dir: &'d Path,
    cfg: Config,
    lib: Option<Library>,
    /// Outputs requested in the open scene (accepted calls only), with whether they are on an
    /// unwritable path.
    outputs: Vec<(Output, bool)>,
    /// Whether a callback that may panic was added to the open scene.
    may_panic: bool,
    /// Transforms left that may enlarge an object (see [`GROWTH_BUDGET`]).
    growth: u32,
    stats: Stats,
}

/// Prepares `dir` for a run: empty, with a subdirectory `sub.ppm` (an image path that is a
/// directory, so writing it fails at the rename).
pub fn prepare_dir(dir: &Path) {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir.join("sub.ppm")).expect("create the output directory");
}

/// Runs one input in `dir` (emptied first).
pub fn run(data: &[u8], dir: &Path, cfg: Config) -> Stats {
    prepare_dir(dir);
    let mut d = Driver {
        dir,
        cfg,
        lib: Some(Library::new()),
        outputs: Vec::new(),
        may_panic: false,
        growth: GROWTH_BUDGET,
        stats: Stats::default(),
    };
    let mut input = Input::new(data);
    let first = input.u8();
    if first & 3 != 0 {
        d.preamble(first);
    }
    while !input.done() && (d.stats.calls as usize) < cfg.max_calls {
        d.step(&mut input);
    }
    // Close whatever is open, as a program ending with vlEnd calls would.
    while d
        .lib
        .as_ref()
        .is_some_and(|l| l.scope() != Scope::Uninitialised)
    {
        d.call(Command::End, |lib, _| lib.end().map(|_| ()));
        if d.stats.calls as usize > cfg.max_calls + 80 {
            panic!("vlEnd does not close the library");
        }
    }
    d.stats
}

/// A field function of one of several kinds: well-behaved ones, ones that misuse the sample
/// (bad masks, bad child indices, moving the point outside a spatial function), NaN writers and,
/// if allowed, one that panics.
fn field_fn(kind: u8, c: f32, id: i32, allow_panic: bool) -> vlib::FieldFn {
    match kind % 9 {
        0 => Arc::new(move |s: &mut Sample| {
            s.set(Fields::ALL, c).expect("set in a field function");
        }),
        1 => Arc::new(|s: &mut Sample| {
            let p = s.position();
            let d = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
            s.set(Fields::ALL, 1.0 - 2.0 * d).expect("set");
        }),
        2 => Arc::new(move |s: &mut Sample| {
            let v = s.field(Fields::F).expect("one field");
            assert_eq!(
                s.field(Fields::O | Fields::F).unwrap_err().code,
                ErrorCode::BadField
            );
            s.set(Fields::O, v * c).expect("set");
        }),
        3 => Arc::new(move |s: &mut Sample| {
            assert_eq!(
                s.set(Fields::NONE, c).unwrap_err().code,
                ErrorCode::BadField
            );
            // Unknown bits are ignored by the mask inside a field function.
            let _ = s.set(Fields::from_bits_unchecked(1 << 12 | 1), c);
            assert_eq!(
                s.set_position([c; 3]).unwrap_err().code,
                ErrorCode::BadScope,
                "only spatial functions move points"
            );
            assert_eq!(
                s.child_normal(1).unwrap_err().code,
                ErrorCode::BadScope,
                "vlChildNormal in a field function"
            );
        }),
        4 => Arc::new(move |s: &mut Sample| {
            let p = s.position();
            match s.dataset(DatasetId(id), p) {
                Ok(v) => {
                    assert!((0.0..=1.0).contains(&v), "dataset value {v}");
                    s.set(Fields::ALL, v).expect("set");
                }
                Err(e) => assert!(
                    matches!(e.code, ErrorCode::BadId | ErrorCode::BadValue),
                    "{e}"
                ),
            }
            let _ = s.dataset(DatasetId(id), [f32::NAN, c, 0.5]);
        }),
        5 => Arc::new(move |s: &mut Sample| {
            let n = s.child_count() as i32;
            for i in [-1, 0, 1, 2, n, n + 1, i32::MAX] {
                let inside = i >= 1 && i <= n;
                let hit = s.child_hit(i);
                let field = s.child_field(i, Fields::F);
                assert_eq!(hit.is_ok(), inside, "child {i} of {n}");
                assert_eq!(field.is_ok(), inside, "child {i} of {n}");
                if let Ok(v) = field {
                    assert!((0.0..=1.0).contains(&v), "child field {v}");
                }
                let _ = s.child_fields(i);
                let _ = s.child_field(i, Fields::ALL);
            }
            let v = s.child_field(1, Fields::O).unwrap_or(c);
            s.set(Fields::ALL, v).expect("set");
        }),
        6 => Arc::new(move |s: &mut Sample| {
            s.set(Fields::ALL, f32::NAN).expect("set NaN");
            s.set(Fields::O, c * 1e30).expect("set huge");
        }),
        7 => Arc::new(move |s: &mut Sample| {
            let w = s.world_position();
            let v = (w[0] * c).sin() * 0.5 + 0.5;
            s.set(Fields::O | Fields::F, v).expect("set");
            s.set(Fields::COLORS | Fields::KA | Fields::KD, 0.8)
                .expect("set");
        }),
        _ if allow_panic => Arc::new(|s: &mut Sample| {
            if s.position()[0] > 0.5 {
                panic!("a field function panics (fuzz)");
            }
        }),
        _ => Arc::new(move |s: &mut Sample| {
            s.set(Fields::O, c).expect("set");
        }),
    }
}

/// A spatial transfer function: scales, shifts, sends the point to NaN or infinity.
fn spatial_fn(kind: u8, c: f32) -> vlib::FieldFn {
    Arc::new(move |s: &mut Sample| {
        let p = s.position();
        let q = match kind % 5 {
            0 => p.map(|v| v * c),
            1 => p.map(|v| v + c),
            2 => [f32::NAN, p[1], p[2]],
            3 => [f32::INFINITY; 3],
            _ => [p[1], p[2], p[0]],
        };
        match s.set_position(q) {
            Ok(()) => assert!(q.iter().all(|v| v.is_finite())),
            Err(e) => assert_eq!(e.code, ErrorCode::BadValue, "{e}"),
        }
        assert_eq!(
            s.set(Fields::O, 1.0).unwrap_err().code,
            ErrorCode::BadScope,
            "vlSet in a spatial function"
        );
    })
}

/// A normal function: constant, NaN, zero, a child's normal, or one that tries to write fields.
fn normal_fn(kind: u8, c: f32) -> vlib::NormalFn {
    Arc::new(move |n: &mut [f32; 3], s: &mut Sample| match kind % 5 {
        0 => *n = [c, 1.0, 0.0],
        1 => *n = [f32::NAN; 3],
        2 => *n = [0.0; 3],
        3 => {
            if let Ok(m) = s.child_normal(1) {
                *n = m;
            }
        }
        _ => {
            assert_eq!(
                s.set(Fields::O, c).unwrap_err().code,
                ErrorCode::BadScope,
                "vlSet in a normal function"
            );
            let _ = s.field(Fields::F);
        }
    })
}

/// A `.vlb` file for `vlLoad`: valid, or broken in one of the ways the reader must refuse, or
/// raw bytes from the input.
fn vlb_bytes(input: &mut Input) -> Vec<u8> {
    let kind = input.u8() % 8;
    if kind == 7 {
        let n = input.u8() as usize % 48;
        return (0..n).map(|_| input.u8()).collect();
    }
    let dims = [
        1 + input.u8() as u32 % 4,
        1 + input.u8() as u32 % 3,
        1 + input.u8() as u32 % 3,
    ];
    let width = 1 + input.u8() as u32 % 2;
    let (a, b) = (input.f(), input.f());
    let mut v = b"VLB1".to_vec();
    let dims = match kind {
        1 => [dims[0], 0, dims[2]],
        2 if dims[0].is_multiple_of(2) => [100_000, 100_000, 100_000],
        2 => [1 << 22, 1 << 22, 1 << 22], // the product wraps to 0 in u64
        _ => dims,
    };
    for d in dims {
        v.extend_from_slice(&d.to_le_bytes());
    }
    v.extend_from_slice(&(if kind == 3 { 3 } else { width }).to_le_bytes());
    v.extend_from_slice(&a.to_le_bytes());
    v.extend_from_slice(&(if kind == 4 { a } else { b }).to_le_bytes());
    let voxels = dims
        .iter()
        .fold(1u64, |acc, &d| acc.saturating_mul(d as u64));
    let body = voxels.min(64) as usize * width as usize;
    v.extend((0..body).map(|i| input.u8().wrapping_add(i as u8)));
    match kind {
        5 => {
            v.pop();
        }
        6 => v.push(0),
        _ => {}
    }
    if input.u8().is_multiple_of(16) {
        v[0] = b'X';
    }
    v
}

/// A mapping table of `points` rows of `outputs + 1` values: increasing inputs in [0, 1] and
/// outputs in [0, 1] (valid), or one of several defects.
fn table(input: &mut Input, points: i32, outputs: i32) -> Vec<f32> {
    let len = if points > 0 && outputs >= 0 {
        (points as i64 * (outputs as i64 + 1)).min(256) as usize
    } else {
        0
    };
    let mut t: Vec<f32> = Vec::with_capacity(len + 1);
    let cols = (outputs.max(0) as usize + 1).max(1);
    for i in 0..len {
        let row = i / cols;
        if i % cols == 0 {
            t.push((row as f32 + 0.5) / points.max(1) as f32);
        } else {
            t.push((input.u8() as f32) / 255.0);
        }
    }
    match input.u8() % 8 {
        0 if !t.is_empty() => t[0] = f32::NAN,
        1 if t.len() > cols => t.swap(0, cols), // inputs not increasing
        2 if !t.is_empty() => {
            let i = t.len() - 1;
            t[i] = 1.5; // out of range
        }
        3 => t.push(0.5), // too long
        4 => {
            t.pop(); // too short
        }
        _ => {}
    }
    t
}

/// The operations by weight: opening and closing scopes, outputs and field instructions come
/// up more often than the other settings.
const OPS: [u8; 64] = [
    0, 0, 1, 1, 2, 3, 2, 4, 4, 4, 5, 5, 6, 7, 8, 9, 9, 10, 10, 11, 12, 13, 13, 14, 15, 16, 17, 18,
    19, 20, 20, 21, 21, 22, 23, 24, 24, 25, 25, 26, 26, 27, 27, 28, 28, 29, 30, 31, 32, 33, 34, 34,
    34, 34, 35, 35, 35, 36, 36, 37, 37, 38, 39, 39,
];

impl<'d> Driver<'d> {
    /// A valid start for most inputs, so that random bytes reach rendering often: a scene with
    /// a small image, and by the bits of `b` an ambient light, a voxelization and an open object.
    fn preamble(&mut self, b: u8) {
        self.call(Command::Scene, |lib, _| lib.scene());
        let path = self.dir.join(if b & 4 == 0 { "a.ppm" } else { "b.png" });
        self.call(Command::Image, |lib, _| lib.image(&path, 1.0, 3, 3));
        self.outputs.push((
            Output::Image {
                path,
                width: 3,
                height: 3,
            },
            false,
        ));
        if b & 8 != 0 {
            self.call(Command::Ambient, |lib, _| lib.ambient(1.0, 1.0, 1.0, 1.0));
        }
        if b & 16 != 0 {
            let prefix = self.dir.join("v");
            let fields = Fields::O | Fields::F;
            self.call(Command::Volume, |lib, _| {
                lib.volume(
                    &prefix,
                    fields,
                    [0.0; 3],
                    [1.0; 3],
                    [2, 3, 2],
                    1 + (b >> 7) as i32,
                )
            });
            self.outputs.push((
                Output::Volume {
                    prefix,
                    fields,
                    nodes: [2, 3, 2],
                    bytes: 1 + (b >> 7) as u32,
                },
                false,
            ));
        }
        if b & 32 != 0 {
            self.call(Command::Object, |lib, _| lib.object());
            self.call(Command::Set, |lib, _| lib.set(Fields::ALL, 0.5));
        }
        assert_eq!(self.stats.refused, 0, "the preamble is valid");
    }
    /// Makes one call of command `cmd` through `f` and checks the contract around it.
    fn call(&mut self, cmd: Command, f: impl FnOnce(&mut Library, &Path) -> vlib::Result<()>) {
        self.stats.calls += 1;
        let Some(lib) = self.lib.as_mut() else {
            return;
        };
        let scope = lib.scope();
        let before = lib.fingerprint();
        let start = std::time::Instant::now();
        let result = f(lib, self.dir);
        if std::env::var_os("VLIB_FUZZ_TRACE").is_some() {
            eprintln!(
                "{:>9.3} ms {} in {scope:?}: {result:?}",
                start.elapsed().as_secs_f64() * 1e3,
                cmd.name()
            );
        }
        let legal = vlib::scope::legal(cmd, scope);
        match &result {
            Ok(()) => assert!(legal, "{} accepted in {scope:?}", cmd.name()),
            Err(e) => {
                self.stats.refused += 1;
                if !legal {
                    assert_eq!(
                        e.code,
                        ErrorCode::BadScope,
                        "{} in {scope:?}: {e}",
                        cmd.name()
                    );
                } else {
                    assert_ne!(
                        e.code,
                        ErrorCode::BadScope,
                        "{} in {scope:?}: {e}",
                        cmd.name()
                    );
                }
                assert_ne!(e.code, ErrorCode::NoError, "{}: {e}", cmd.name());
                assert!(
                    e.code != ErrorCode::Internal || self.may_panic,
                    "{}: {e}",
                    cmd.name()
                );
                if e.code == ErrorCode::Internal {
                    self.stats.caught_panics += 1;
                }
                let closes_scene = cmd == Command::End && scope == Scope::Scene;
                if !closes_scene {
                    assert_eq!(
                        lib.fingerprint(),
                        before,
                        "{} refused ({e}) but changed the state",
                        cmd.name()
                    );
                }
            }
        }
        if cmd == Command::End && scope == Scope::Scene {
            let lib = self.lib.as_ref().expect("library");
            assert_eq!(lib.scope(), Scope::Library, "vlEnd closes the scene");
            self.scene_closed(&result);
        }
        if cmd == Command::Scene && result.is_ok() {
            self.outputs.clear();
            self.may_panic = false;
        }
        if cmd == Command::End
            && scope == Scope::Library
            && self
                .lib
                .as_ref()
                .is_some_and(|l| l.scope() == Scope::Uninitialised)
        {
            self.lib = None;
        }
    }

    /// Checks the outputs of the scene that just closed with `result`.
    fn scene_closed(&mut self, result: &vlib::Result<()>) {
        self.stats.scenes += 1;
        let outputs = std::mem::take(&mut self.outputs);
        let any_unwritable = outputs.iter().any(|(_, bad)| *bad);
        match result {
            Ok(()) => assert!(!any_unwritable, "an output on an unwritable path succeeded"),
            Err(e) => {
                assert!(
                    any_unwritable || self.may_panic,
                    "the scene failed without cause: {e}"
                );
                assert!(
                    matches!(e.code, ErrorCode::IoError)
                        || (self.may_panic && e.code == ErrorCode::Internal),
                    "a failed output reports {e}"
                );
                self.stats.failed_outputs += 1;
            }
        }
        // No temporary file anywhere.
        for dir in [self.dir.to_path_buf(), self.dir.join("sub.ppm")] {
            for entry in std::fs::read_dir(&dir).expect("read the output directory") {
                let name = entry.expect("entry").file_name();
                let name = name.to_string_lossy();
                assert!(!name.ends_with(".tmp"), "temporary file {name} left behind");
            }
        }
        assert!(!self.dir.join("missing").exists());
        // The last request for each path decides what the file holds.
        let mut last: BTreeMap<PathBuf, &Output> = BTreeMap::new();
        for (o, bad) in &outputs {
            if let Output::Image { path, .. } = o {
                if !bad {
                    last.insert(path.clone(), o);
                }
            }
        }
        if result.is_ok() || !self.may_panic {
            for o in last.values() {
                if let Output::Image {
                    path,
                    width,
                    height,
                } = o
                {
                    check_image(path, *width, *height);
                    self.stats.images += 1;
                }
            }
            // As for images, the last request for a file decides what it holds.
            let mut files: BTreeMap<std::ffi::OsString, ([usize; 3], u32)> = BTreeMap::new();
            for (o, bad) in &outputs {
                if let (
                    Output::Volume {
                        prefix,
                        fields,
                        nodes,
                        bytes,
                    },
                    false,
                ) = (o, bad)
                {
                    for i in fields.indices() {
                        let mut name = prefix.as_os_str().to_owned();
                        name.push(format!("_{}.vlb", vlib::types::FIELD_NAMES[i]));
                        files.insert(name, (*nodes, *bytes));
                    }
                }
            }
            for (name, (nodes, bytes)) in files {
                let d = Dataset::load(Path::new(&name))
                    .unwrap_or_else(|e| panic!("{name:?} does not load: {e}"));
                assert_eq!(d.dims(), nodes, "{name:?}");
                assert_eq!(d.raw().width(), bytes, "{name:?}");
                self.stats.volumes += 1;
            }
        }
        // Every PPM in the directory is complete, whatever happened.
        for entry in std::fs::read_dir(self.dir).expect("read the output directory") {
            let path = entry.expect("entry").path();
            if path.is_file()
                && path
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("ppm"))
            {
                check_ppm_complete(&path);
            }
        }
    }

    fn step(&mut self, input: &mut Input) {
        if self.lib.is_none() {
            // After the final vlEnd: the next command is vlInit, the only legal one (the C layer
            // refuses the others before any library exists; capi's own tests cover that).
            input.u8();
            self.lib = Some(Library::new());
            self.stats.calls += 1;
            return;
        }
        let allow_panics = self.cfg.allow_panics;
        let op = OPS[input.u8() as usize % OPS.len()];
        match op {
            0 | 1 => self.call(Command::End, |lib, _| lib.end().map(|_: Closed| ())),
            2 | 3 => self.call(Command::Scene, |lib, _| lib.scene()),
            4 => {
                let rel = input.pick(&IMAGE_PATHS);
                let (aspect, mut w, mut h) = (input.f(), input.pick(&SIDES), input.pick(&SIDES));
                if valid_but_large(&[w, h], MAX_IMAGE_SIDE as u64, MAX_IMAGE_PIXELS, 64) {
                    // Valid, but it would take long to render: keep the inputs fast.
                    (w, h) = (4, 4);
                }
                let path = rel_path(self.dir, rel);
                let mut accepted = None;
                self.call(Command::Image, |lib, _| {
                    let r = lib.image(&path, aspect, w, h);
                    if r.is_ok() {
                        accepted = Some(Output::Image {
                            path: path.clone(),
                            width: w as u32,
                            height: h as u32,
                        });
                    }
                    r
                });
                if let Some(o) = accepted {
                    self.outputs.push((o, unwritable(rel)));
                }
            }
            5 => {
                let rel = input.pick(&VOLUME_PREFIXES);
                let fields = input.fields();
                let c0 = [input.f(), input.f(), input.f()];
                let c1 = [input.f(), input.f(), input.f()];
                let mut nodes = [input.pick(&NODES), input.pick(&NODES), input.pick(&NODES)];
                if valid_but_large(&nodes, vlib::limits::MAX_VOXELS, MAX_VOLUME_NODES, 64) {
                    nodes = [4, 2, 3];
                }
                let bytes = input.pick(&[1, 2, 0, 3, -1]);
                let prefix = rel_path(self.dir, rel);
                let mut accepted = None;
                self.call(Command::Volume, |lib, _| {
                    let f = c_arg(lib, Command::Volume, Fields::from_raw(fields))?;
                    let r = lib.volume(&prefix, f, c0, c1, nodes, bytes);
                    if r.is_ok() {
                        accepted = Some(Output::Volume {
                            prefix: prefix.clone(),
                            fields: f,
                            nodes: nodes.map(|n| n as usize),
                            bytes: bytes as u32,
                        });
                    }
                    r
                });
                if let Some(o) = accepted {
                    self.outputs.push((o, unwritable(rel)));
                }
            }
            6 => {
                let c = Camera {
                    eye: [input.f(), input.f(), input.f()],
                    at: [input.f(), input.f(), input.f()],
                    up: [input.f(), input.f(), input.f()],
                    fov: input.f(),
                };
                let c = if input.bool() {
                    Camera {
                        eye: [0.5, 0.5, -2.0],
                        ..c
                    }
                } else {
                    c
                };
                self.call(Command::Camera, |lib, _| lib.camera(&c));
            }
            7 => {
                let (r, g, b) = (input.f(), input.f(), input.f());
                self.call(Command::Background, |lib, _| lib.background(r, g, b));
            }
            8 => {
                let n = input.pick(&SUPER);
                self.call(Command::SuperSample, |lib, _| lib.super_sample(n));
            }
            9 => {
                let (r, g, b, i) = (input.f(), input.f(), input.f(), input.f());
                self.call(Command::Ambient, |lib, _| lib.ambient(r, g, b, i));
            }
            10 => {
                let p = [input.f(), input.f(), input.f()];
                let att = input.i();
                let c = [input.f(), input.f(), input.f()];
                let i = input.f();
                self.call(Command::PointLight, |lib, _| {
                    lib.point_light(
                        p,
                        c_arg(lib, Command::PointLight, Attenuation::from_raw(att))?,
                        c,
                        i,
                    )
                });
            }
            11 => {
                let d = [input.f(), input.f(), input.f()];
                let c = [input.f(), input.f(), input.f()];
                let i = input.f();
                self.call(Command::DirectionalLight, |lib, _| {
                    lib.directional_light(d, c, i)
                });
            }
            12 => {
                let t = input.i();
                self.call(Command::RenderType, |lib, _| {
                    lib.render_type(c_arg(lib, Command::RenderType, RenderType::from_raw(t))?)
                });
            }
            13 => {
                let (s, r) = (input.pick(&STEPS), input.f());
                self.call(Command::StepSize, |lib, _| lib.step_size(s, r));
            }
            14 => {
                let (f, t) = (input.fields(), input.f());
                self.call(Command::Surface, |lib, _| {
                    lib.surface(Fields::from_bits_unchecked(f as u32), t)
                });
            }
            15 => {
                let (feature, state) = (input.i(), input.bool());
                self.call(Command::Toggle, |lib, _| {
                    lib.toggle(
                        c_arg(lib, Command::Toggle, Feature::from_raw(feature))?,
                        state,
                    )
                });
            }
            16 => {
                let d = input.i();
                self.call(Command::Recursion, |lib, _| lib.recursion(d));
            }
            17 => {
                let t = input.i();
                self.call(Command::InterpolationType, |lib, _| {
                    lib.interpolation(c_arg(
                        lib,
                        Command::InterpolationType,
                        Interpolation::from_raw(t),
                    )?)
                });
            }
            18 => {
                let (b, c) = (input.f(), input.f());
                self.call(Command::CubicFilter, |lib, _| lib.cubic_filter(b, c));
            }
            19 => {
                let (x, y, z) = (input.f(), input.f(), input.f());
                self.call(Command::Neighborhood, |lib, _| lib.neighborhood(x, y, z));
            }
            20 => {
                let id = input.id();
                let which = input.u8() % 4;
                let path = match which {
                    0 => self.dir.join("missing/in.vlb"),
                    1 => self.dir.join("sub.ppm"),
                    _ => {
                        let p = self.dir.join("in.vlb");
                        let bytes = vlb_bytes(input);
                        std::fs::write(&p, bytes).expect("write in.vlb");
                        p
                    }
                };
                self.call(Command::Load, |lib, _| {
                    match lib.load(DatasetId(id), &path) {
                        Ok(()) => Ok(()),
                        Err(e) => {
                            assert!(
                                matches!(
                                    e.code,
                                    ErrorCode::BadScope
                                        | ErrorCode::IoError
                                        | ErrorCode::BadMagic
                                        | ErrorCode::BadDimensions
                                        | ErrorCode::BadVoxelWidth
                                        | ErrorCode::BadRange
                                        | ErrorCode::BadSize
                                ),
                                "vlLoad: {e}"
                            );
                            Err(e)
                        }
                    }
                });
            }
            21 => {
                let id = input.id();
                let dims = [
                    1 + input.u8() as usize % 4,
                    1 + input.u8() as usize % 4,
                    1 + input.u8() as usize % 4,
                ];
                let n = dims.iter().product::<usize>();
                let raw = if input.bool() {
                    Voxels::U8((0..n).map(|_| input.u8()).collect())
                } else {
                    Voxels::U16((0..n).map(|_| input.u8() as u16 * 257).collect())
                };
                let (a, b) = (input.f(), input.f());
                if let Ok(d) = Dataset::new(dims, raw, a, b) {
                    self.call(Command::Load, |lib, _| lib.add_dataset(DatasetId(id), d));
                }
            }
            22 => {
                let id = input.id();
                self.call(Command::Unload, |lib, _| lib.unload(DatasetId(id)));
            }
            23 => {
                let id = input.id();
                let p = [input.f(), input.f(), input.f()];
                self.call(Command::Sample, |lib, _| {
                    let v = lib.sample(DatasetId(id), p[0], p[1], p[2])?;
                    assert!((0.0..=1.0).contains(&v), "vlSample gave {v}");
                    Ok(())
                });
            }
            24 => {
                let id = input.id();
                let kind = input.i();
                let points = input.pick(&[0, 1, 2, 3, 5, -1, 1 << 20, (1 << 20) + 1, i32::MAX]);
                let outputs = input.pick(&[0, 1, 2, 3, 64, 65, -1, i32::MAX]);
                let t = table(input, points, outputs);
                self.call(Command::Mapping, |lib, _| {
                    let kind = c_arg(lib, Command::Mapping, MappingType::from_raw(kind))?;
                    lib.mapping(MappingId(id), kind, points, outputs, &t)
                });
            }
            25 | 26 => self.call(Command::Object, |lib, _| lib.object()),
            27 => {
                let s = [
                    input.pick(&SCALES),
                    input.pick(&SCALES),
                    input.pick(&SCALES),
                ];
                if s.iter().any(|v| v.abs() > 1.0 && v.is_finite()) {
                    if self.growth == 0 {
                        return;
                    }
                    self.growth -= 1;
                }
                self.call(Command::Scale, |lib, _| lib.scale(s[0], s[1], s[2]));
            }
            28 => {
                let t = [input.f(), input.f(), input.f()];
                self.call(Command::Translate, |lib, _| lib.translate(t[0], t[1], t[2]));
            }
            29 => {
                let r = [input.f(), input.f(), input.f()];
                self.call(Command::Rotate, |lib, _| lib.rotate(r[0], r[1], r[2]));
            }
            30 => {
                let axes = input.i();
                self.call(Command::Flip, |lib, _| lib.flip(axes));
            }
            31 => {
                let mut m = [0.0f32; 16];
                for (i, v) in m.iter_mut().enumerate() {
                    *v = if input.u8().is_multiple_of(4) {
                        input.pick(&MATRIX)
                    } else if i % 5 == 0 {
                        1.0
                    } else {
                        0.0
                    };
                }
                if input.bool() {
                    m[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
                }
                if self.growth == 0 {
                    return;
                }
                self.growth -= 1;
                self.call(Command::Matrix, |lib, _| lib.matrix(&m));
            }
            32 => {
                let b = [
                    input.pick(&BOUNDS),
                    input.pick(&BOUNDS),
                    input.pick(&BOUNDS),
                ];
                self.call(Command::Boundary, |lib, _| lib.boundary(b[0], b[1], b[2]));
            }
            33 => {
                let (kind, c) = (input.u8(), input.f());
                self.call(Command::Spatial, |lib, _| {
                    lib.spatial_arc(spatial_fn(kind, c))
                });
            }
            34 => {
                let (f, v) = (input.fields(), input.f());
                self.call(Command::Set, |lib, _| {
                    lib.set(Fields::from_bits_unchecked(f as u32), v)
                });
            }
            35 => {
                let (f, kind, c, id) = (input.fields(), input.u8(), input.f(), input.id());
                let panics = allow_panics && kind % 9 == 8;
                let mut ok = false;
                self.call(Command::Function, |lib, _| {
                    let r = lib.function_arc(
                        Fields::from_bits_unchecked(f as u32),
                        field_fn(kind, c, id, allow_panics),
                    );
                    ok = r.is_ok();
                    r
                });
                self.may_panic |= panics && ok;
            }
            36 => {
                let (f, id) = (input.fields(), input.id());
                self.call(Command::Dataset, |lib, _| {
                    lib.dataset(Fields::from_bits_unchecked(f as u32), DatasetId(id))
                });
            }
            37 => {
                let (t, s, m, o) = (input.fields(), input.fields(), input.id(), input.i());
                self.call(Command::Map, |lib, _| {
                    lib.map(
                        Fields::from_bits_unchecked(t as u32),
                        Fields::from_bits_unchecked(s as u32),
                        MappingId(m),
                        o,
                    )
                });
            }
            38 => {
                let (kind, c) = (input.u8(), input.f());
                self.call(Command::Normal, |lib, _| lib.normal_arc(normal_fn(kind, c)));
            }
            _ => {
                // A preview render (not a C command): at scene scope only, small sizes.
                let (w, h, aspect) = (input.u8() as u32 % 5, input.u8() as u32 % 5, input.f());
                self.stats.calls += 1;
                let lib = self.lib.as_ref().expect("library");
                let may_panic = self.may_panic_in_open_scene();
                match lib.render_preview(w, h, aspect) {
                    Ok(img) => {
                        assert_eq!((img.width, img.height), (w, h));
                        let rgb = img.to_rgb8();
                        assert_eq!(rgb.len(), (w * h * 3) as usize);
                    }
                    Err(e) => assert!(
                        e.code != ErrorCode::Internal || may_panic,
                        "render_preview: {e}"
                    ),
                }
            }
        }
    }

    fn may_panic_in_open_scene(&self) -> bool {
        self.may_panic
    }
}

/// Checks that `path` holds a complete image of `width` × `height` pixels.
fn check_image(path: &Path, width: u32, height: u32) {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let data = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match ext.as_deref() {
        Some("ppm") => {
            let header = format!("P6\n{width} {height}\n255\n");
            assert!(data.starts_with(header.as_bytes()), "{}", path.display());
            assert_eq!(
                data.len(),
                header.len() + (width * height * 3) as usize,
                "{}",
                path.display()
            );
        }
        Some("png") => {
            assert!(data.starts_with(b"\x89PNG\r\n\x1a\n"), "{}", path.display());
            let w = u32::from_be_bytes(data[16..20].try_into().unwrap());
            let h = u32::from_be_bytes(data[20..24].try_into().unwrap());
            assert_eq!((w, h), (width, height), "{}", path.display());
            assert!(
                data.ends_with(b"IEND\xaeB`\x82"),
                "{}: truncated",
                path.display()
            );
        }
        _ => panic!("unexpected image {}", path.display()),
    }
}

/// Checks that a PPM file is complete: its pixel data is exactly as long as its header says.
fn check_ppm_complete(path: &Path) {
    let data = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = String::from_utf8_lossy(&data[..data.len().min(40)]).into_owned();
    let mut fields = text.split_ascii_whitespace();
    assert_eq!(fields.next(), Some("P6"), "{}", path.display());
    let w: usize = fields.next().and_then(|v| v.parse().ok()).expect("width");
    let h: usize = fields.next().and_then(|v| v.parse().ok()).expect("height");
    let header = format!("P6\n{w} {h}\n255\n");
    assert_eq!(
        data.len(),
        header.len() + w * h * 3,
        "{} is incomplete",
        path.display()
    );
}

/// The `vlb_reader` property: parsing arbitrary bytes never panics; a refusal carries one of the
/// reader's codes; an accepted file re-encodes to the same bytes and its values lie in [0, 1];
/// and reading the bytes from a file (`vlLoad`'s path) gives the same outcome.
pub fn check_vlb(data: &[u8], scratch: Option<&Path>) {
    let parsed = Dataset::from_vlb_bytes(data);
    match &parsed {
        Ok(d) => {
            assert_eq!(d.to_vlb_bytes().unwrap(), data, "re-encoding differs");
            assert!(d.values().iter().all(|v| (0.0..=1.0).contains(v)));
            for kind in Interpolation::ALL {
                let f = vlib::Filter::new(*kind, (0.0, 0.5)).expect("finite B, C");
                for p in [
                    [0.0; 3],
                    [0.5; 3],
                    [1.0; 3],
                    [0.3, 0.7, f32::NAN],
                    [-1.0, 2.0, 0.5],
                ] {
                    let v = d.sample(p, f);
                    assert!((0.0..=1.0).contains(&v), "sample {v} at {p:?}");
                    let g = d.gradient(p, f);
                    assert!(g.iter().all(|c| c.is_finite()), "gradient {g:?}");
                }
                d.precompute(f).expect("threads");
            }
        }
        Err(e) => assert!(
            matches!(
                e.code,
                ErrorCode::BadMagic
                    | ErrorCode::BadDimensions
                    | ErrorCode::BadVoxelWidth
                    | ErrorCode::BadRange
                    | ErrorCode::BadSize
            ),
            "from_vlb_bytes: {e}"
        ),
    }
    if let Some(path) = scratch {
        std::fs::write(path, data).expect("write the scratch file");
        let loaded = Dataset::load(path);
        match (&parsed, &loaded) {
            (Ok(a), Ok(b)) => assert_eq!(a, b),
            (Err(a), Err(b)) => assert_eq!(a.code, b.code, "from bytes: {a}; from a file: {b}"),
            _ => panic!(
                "from bytes: {:?}; from a file: {:?}",
                parsed.as_ref().map(|_| ()),
                loaded.as_ref().map(|_| ())
            ),
        }
    }
}
