//! `vlconvert`: converts NIfTI, NRRD, MetaImage, DICOM series, TIFF stacks and raw volumes and
//! 2D images to
//! vlib's `.vlb` datasets (with a geometry sidecar where the source places its voxels), and
//! describes `.vlb` files.
//!
//! ```text
//! vlconvert brain.nii.gz brain.vlb                    # the format from the file's first bytes
//! vlconvert nifti brain.nii.gz brain.vlb                # or a .hdr with its .img
//! vlconvert nifti ct.nii.gz ct.vlb --window -1000 2000   # Hounsfield units to 0 … 1
//! vlconvert nrrd ct.nrrd ct.vlb                        # raw, gzip or ascii; .nhdr too
//! vlconvert metaimage ct.mha ct.vlb        # MetaImage: .mha, or .mhd with its .raw/.zraw
//! vlconvert dicom ct/ ct.vlb               # a folder of DICOM slices (or one of its files)
//! vlconvert ct/ ct.vlb --series 1.2.840.…  # one series of a folder that holds several
//! vlconvert tiff stack.tif stack.vlb       # a multi-page TIFF, one z slice a page
//! vlconvert slices/ stack.vlb              # a folder of single-page TIFFs, natural order
//! vlconvert raw ct.raw ct.vlb --dims 256 256 113 --type i16 --endian big
//! vlconvert image word.png word.vlb        # grey: word.vlb; colour: word_r/_g/_b.vlb
//! vlconvert info brain.vlb
//! ```
//!
//! Volumes (raw, NIfTI, NRRD, MetaImage, DICOM, TIFF) of any element type become datasets whose
//! normalised value is clamp((value − A)/(B − A), 0, 1) for a window A … B of data values, by
//! default the data's smallest and largest value (`volume`: 8-bit sources in 8-bit voxels,
//! others in 16-bit ones). A DICOM series' values are its modality values (Hounsfield units
//! for CT: RescaleSlope and RescaleIntercept applied per slice); its slices are ordered along
//! their normal and placed by their position, orientation and pixel spacing (`dicom`). TIFF
//! stacks: `tiffstack`; NIfTI-1 files: `nifti`.
//!
//! Long steps (reading, decompressing, decoding slices, converting voxels) draw a progress
//! line on standard error when it is a terminal, blanked out when the step ends; `--quiet`
//! draws none, and nothing is drawn into a pipe or a file (`progress`).
//!
//! Exit codes: 0 success, 1 the conversion failed (unreadable or malformed input, unwritable
//! output, a report that cannot be written), 2 bad command line. A report whose reader has
//! closed the pipe (`vlconvert info f.vlb | head -1`) ends quietly: not a failure.

use clap::{Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use vlib::{Dataset, Voxels};

mod detect;
mod dicom;
#[doc(hidden)]
pub mod fuzzing;
mod gunzip;
mod metaimage;
mod nifti;
mod nrrd;
mod progress;
mod tiffstack;
mod vector;
mod volume;

use volume::{Type, Volume};

#[derive(Parser)]
#[command(
    name = "vlconvert",
    version,
    about = "Convert volumes and images to vlib .vlb datasets"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
    /// Draw no progress bar (it is drawn on standard error only when that is a terminal).
    #[arg(long, short, global = true)]
    quiet: bool,
}

/// Normalisation written to the output: voxel v maps to clamp((v − a)/(b − a), 0, 1).
#[derive(clap::Args, Clone, Copy)]
struct Norm {
    /// The voxel value that maps to 0 (default: 0).
    #[arg(long, allow_hyphen_values = true)]
    a: Option<f32>,
    /// The voxel value that maps to 1 (default: the largest voxel value of the output width).
    #[arg(long, allow_hyphen_values = true)]
    b: Option<f32>,
}

/// The window of data values a volume's normalised values span: A maps to 0, B to 1.
#[derive(clap::Args, Clone)]
struct Window {
    /// The data value that maps to 0 (default: the data's smallest value).
    #[arg(long, allow_hyphen_values = true)]
    a: Option<f64>,
    /// The data value that maps to 1 (default: the data's largest value).
    #[arg(long, allow_hyphen_values = true)]
    b: Option<f64>,
    /// Both ends at once (as a CT window: --window -1000 2000).
    #[arg(
        long,
        num_args = 2,
        value_names = ["A", "B"],
        allow_hyphen_values = true,
        conflicts_with_all = ["a", "b"]
    )]
    window: Vec<f64>,
}

impl Window {
    /// The ends given, each `None` for the data's own.
    fn ends(&self) -> (Option<f64>, Option<f64>) {
        match self.window.as_slice() {
            [a, b] => (Some(*a), Some(*b)),
            _ => (self.a, self.b),
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum Endian {
    Little,
    Big,
}

#[derive(Subcommand)]
enum Cmd {
    /// Any volume or image whose format its first bytes tell (NIfTI-1, NRRD, MetaImage, DICOM,
    /// TIFF, PNG, PNM and PAM), or a folder (of TIFFs: a stack; of DICOM files: a series):
    /// `vlconvert IN OUT.vlb` is short for `vlconvert convert IN OUT.vlb`.
    Convert {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        window: Window,
        /// The DICOM series to convert (its SeriesInstanceUID), where the folder holds several.
        #[arg(long, value_name = "UID")]
        series: Option<String>,
    },
    /// A DICOM series: a folder of single-frame slices, or one of its files (which chooses its
    /// series); RescaleSlope and RescaleIntercept applied per slice.
    Dicom {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        window: Window,
        /// The series to convert (its SeriesInstanceUID), where the folder holds several.
        #[arg(long, value_name = "UID")]
        series: Option<String>,
    },
    /// A headerless raw volume, x fastest, then y, then z.
    Raw {
        input: PathBuf,
        output: PathBuf,
        /// Dimensions nx ny nz.
        #[arg(long, num_args = 3, required = true, value_names = ["NX", "NY", "NZ"])]
        dims: Vec<u32>,
        /// The element type (default u8; --bytes 2 alone means u16).
        #[arg(long = "type", value_enum, conflicts_with = "bytes")]
        ty: Option<Type>,
        /// Bytes per voxel, 1 (u8) or 2 (u16): the same as --type u8 or u16.
        #[arg(long)]
        bytes: Option<u32>,
        /// Byte order of elements wider than a byte.
        #[arg(long, value_enum, default_value_t = Endian::Little)]
        endian: Endian,
        /// Bytes to skip at the start of the file.
        #[arg(long, default_value_t = 0)]
        skip: u64,
        #[command(flatten)]
        window: Window,
    },
    /// A 2D image (PNG, or PBM, PGM, PPM or PAM): grey → one slab dataset; colour →
    /// OUTPUT_r/_g/_b.vlb.
    Image {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        norm: Norm,
    },
    /// A NIfTI-1 volume (.nii, .nii.gz, or a .hdr with its .img) of any integer or float type,
    /// its voxels at vox_offset, its scl_slope and scl_inter applied.
    Nifti {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        window: Window,
    },
    /// A MetaImage (.mha, or .mhd with its .raw or .zraw) of any integer or float type, 2D or 3D.
    Metaimage {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        window: Window,
    },
    /// A NRRD volume (.nrrd, or a detached .nhdr with its data file; raw, gzip or ascii).
    Nrrd {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        window: Window,
    },
    /// A TIFF stack: a multi-page TIFF (ImageJ or plain; one z slice a page) or a folder of
    /// single-page TIFFs (in the natural order of their names), grey, of any sample type.
    Tiff(tiffstack::Args),
    /// Print a .vlb file's dimensions, voxel width, normalisation and value range.
    Info { file: PathBuf },
}

type Res<T> = Result<T, String>;

/// The normalisation `norm` gives a dataset of `bytes`-byte voxels (its ends, by default 0
/// and the width's largest value); an error naming `--a` and `--b` where an end is not a
/// finite f32 (a number beyond ±3.4·10³⁸ reads as infinite) or the two are equal, before any
/// file is written.
fn norm_for(norm: Norm, bytes: u32) -> Res<(f32, f32)> {
    let max = if bytes == 1 { 255.0 } else { 65535.0 };
    let (a, b) = (norm.a.unwrap_or(0.0), norm.b.unwrap_or(max));
    if !a.is_finite() || !b.is_finite() || a == b {
        return Err(format!(
            "--a {a} and --b {b}: the ends of the normalisation must be finite (at most \
             3.4e38 in size) and differ"
        ));
    }
    Ok((a, b))
}

/// Writes a line to standard output. A reader that has gone away (a closed pipe, as in
/// `vlconvert info f.vlb | head -1`) is not an error: what it did not read, it did not want.
/// Any other failure to write is (a full disk behind a redirection). Nothing is written
/// while the readers are called in-process ([`fuzzing`]).
fn say(line: std::fmt::Arguments) -> Res<()> {
    use std::io::Write;
    if fuzzing::SILENT.load(std::sync::atomic::Ordering::Relaxed) {
        return Ok(());
    }
    match writeln!(std::io::stdout().lock(), "{line}") {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(format!("writing to standard output: {e}"))
        }
        _ => Ok(()),
    }
}

/// `n` and the thing it counts, `noun` (given in the singular), in the plural but for 1:
/// "1 byte", "0 bytes", "48 bytes".
fn counted<N: std::fmt::Display + PartialEq + From<u8>>(n: N, noun: &str) -> String {
    let s = if n == N::from(1) { "" } else { "s" };
    format!("{n} {noun}{s}")
}

fn save(d: &Dataset, path: &Path) -> Res<()> {
    d.save(path).map_err(|e| e.to_string())?;
    let [nx, ny, nz] = d.dims();
    say(format_args!(
        "wrote {} ({nx}x{ny}x{nz}, {} byte(s) per voxel)",
        path.display(),
        d.raw().width()
    ))
}

fn build(dims: [usize; 3], raw: Voxels, (a, b): (f32, f32)) -> Res<Dataset> {
    Dataset::new(dims, raw, a, b).map_err(|e| e.to_string())
}

/// Converts a volume's elements and writes the dataset, with its physical geometry (in the
/// sidecar `OUTPUT.geom`) where the volume has one.
fn convert(volume: &Volume, window: &Window, output: &Path) -> Res<()> {
    let converted = volume.source().convert(window.ends())?;
    if let Some(note) = &converted.note {
        eprintln!("vlconvert: note: {note}");
    }
    say(format_args!("{}", converted.report))?;
    let d = match volume.geometry {
        Some(g) => {
            let [sx, sy, sz] = g.spacing();
            say(format_args!(
                "spacing {sx} x {sy} x {sz} mm, node 0 at {:?} (RAS)",
                g.origin()
            ))?;
            converted.dataset.with_geometry(g)
        }
        None => converted.dataset,
    };
    save(&d, output)
}

fn raw(
    input: &Path,
    output: &Path,
    dims: &[u32],
    ty: Type,
    endian: Endian,
    skip: u64,
    window: &Window,
) -> Res<()> {
    let v = raw_volume(input, dims, ty, endian, skip)?;
    convert(&v, window, output)
}

/// The headerless volume `input` of `dims` elements of `ty` after `skip` bytes.
fn raw_volume(input: &Path, dims: &[u32], ty: Type, endian: Endian, skip: u64) -> Res<Volume> {
    let bytes = ty.bytes() as u64;
    let dims = [dims[0] as usize, dims[1] as usize, dims[2] as usize];
    let n = dims
        .iter()
        .try_fold(1u64, |a, &d| a.checked_mul(d as u64))
        .ok_or("dimensions overflow")?;
    if n == 0 {
        return Err("dimensions must be positive".into());
    }
    let len = std::fs::metadata(input)
        .map_err(|e| format!("{}: {e}", input.display()))?
        .len();
    let need = n
        .checked_mul(bytes)
        .and_then(|v| v.checked_add(skip))
        .ok_or("dimensions overflow")?;
    if len < need {
        return Err(format!(
            "{}: {}, but {need} are needed for {dims:?} x {bytes} byte(s) + {skip}",
            input.display(),
            counted(len, "byte")
        ));
    }
    let mut data = volume::read_regular(input, Some(need))?;
    if len > need {
        eprintln!(
            "vlconvert: note: {} has {} after the volume (ignored)",
            input.display(),
            counted(len - need, "byte")
        );
    }
    if (data.len() as u64) < need {
        return Err(format!(
            "{}: {}, but {need} are needed (it shrank while it was read)",
            input.display(),
            counted(data.len(), "byte")
        ));
    }
    data.drain(..skip as usize);
    Ok(Volume {
        dims,
        bytes: data,
        ty,
        big: matches!(endian, Endian::Big),
        slope: 1.0,
        inter: 0.0,
        geometry: None,
    })
}

/// Image rows run top to bottom; object y runs upwards, so row 0 becomes the top slab row.
fn image(input: &Path, output: &Path, norm: Norm) -> Res<()> {
    for (suffix, d) in image_datasets(input, norm)? {
        let path = if suffix.is_empty() {
            output.to_path_buf()
        } else {
            with_suffix(output, &suffix)
        };
        save(&d, &path)?;
    }
    Ok(())
}

/// The datasets of the image `input`: one for a grey image (suffix ""), three for a colour
/// one (suffixes "_r", "_g", "_b").
fn image_datasets(input: &Path, norm: Norm) -> Res<Vec<(String, Dataset)>> {
    let at = |e: image::ImageError| format!("{}: {e}", input.display());
    let bytes = volume::read_regular(input, None)?;
    let len = bytes.len() as u64;
    // The format from the name, as image::open does, else from the first bytes.
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
    match image::ImageFormat::from_path(input) {
        Ok(format) => reader.set_format(format),
        Err(_) => reader = reader.with_guessed_format().map_err(|e| at(e.into()))?,
    }
    // The decoder allocates the pixels its header declares before it decodes them: a header
    // the file's bytes cannot fill is refused first. A PNG's pixels are at most 8 a byte of
    // its zlib stream (1-bit samples) and that stream inflates at most 1032-fold; a PNM's at
    // most 8 a byte (P4's bits).
    let png = reader.format() == Some(image::ImageFormat::Png);
    let decoder = reader.into_decoder().map_err(at)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    let most = len.saturating_mul(if png { 8 * 1032 } else { 8 });
    if w as u64 * h as u64 > most {
        return Err(format!(
            "{}: {w} x {h} pixels, more than its {} can hold",
            input.display(),
            counted(len, "byte")
        ));
    }
    let img = image::DynamicImage::from_decoder(decoder).map_err(at)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let dims = [w, h, 1];
    let sixteen = matches!(
        img.color(),
        image::ColorType::L16
            | image::ColorType::La16
            | image::ColorType::Rgb16
            | image::ColorType::Rgba16
    );
    let grey = !img.color().has_color();
    let flip = |plane: Vec<u16>| -> Vec<u16> {
        let mut out = Vec::with_capacity(plane.len());
        for y in (0..h).rev() {
            out.extend_from_slice(&plane[y * w..(y + 1) * w]);
        }
        out
    };
    let channels: Vec<(String, Vec<u16>)> = if grey {
        let g = img.to_luma16().into_raw();
        vec![(String::new(), flip(g))]
    } else {
        let rgb = img.to_rgb16().into_raw();
        ["r", "g", "b"]
            .iter()
            .enumerate()
            .map(|(c, name)| {
                (
                    format!("_{name}"),
                    flip(rgb.iter().skip(c).step_by(3).copied().collect()),
                )
            })
            .collect()
    };
    let bytes = if sixteen { 2 } else { 1 };
    let mut out = Vec::new();
    for (suffix, plane) in channels {
        let voxels = if sixteen {
            Voxels::U16(plane)
        } else {
            Voxels::U8(plane.iter().map(|&v| (v >> 8) as u8).collect())
        };
        out.push((suffix, build(dims, voxels, norm_for(norm, bytes)?)?));
    }
    Ok(out)
}

/// `dir/name.vlb` + `_r` → `dir/name_r.vlb`.
fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    path.with_file_name(format!("{stem}{suffix}{ext}"))
}

fn info(path: &Path) -> Res<()> {
    let d = Dataset::load(path).map_err(|e| e.to_string())?;
    let [nx, ny, nz] = d.dims();
    let (a, b) = d.range();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = d.raw_node(i, j, k);
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    say(format_args!("file:        {}", path.display()))?;
    say(format_args!(
        "dimensions:  {nx} x {ny} x {nz} ({} voxels)",
        nx * ny * nz
    ))?;
    say(format_args!("voxel width: {} byte(s)", d.raw().width()))?;
    say(format_args!("a, b:        {a} {b}"))?;
    say(format_args!("raw values:  {lo} … {hi}"))?;
    if d.raw().width() == 2 && a.min(b) < 0.0 && hi >= 32768.0 {
        // Signed data written as they are: −1024 reads as 64 512.
        say(format_args!(
            "note:        16-bit voxels are unsigned (0 … 65535), yet this window starts below 0 \
             and voxels reach {hi}, as signed voxels written as they are would (-1024 reads as \
             64512); if they are signed, convert the file: vlconvert raw {} OUT.vlb --skip 28 \
             --type i16 --dims {nx} {ny} {nz} --window {a} {b}",
            path.display()
        ))?;
    }
    match d.geometry() {
        Some(g) => {
            let [sx, sy, sz] = g.spacing();
            say(format_args!("spacing:     {sx} x {sy} x {sz} mm"))?;
            say(format_args!("node 0 at:   {:?} (RAS, mm)", g.origin()))?;
            for row in &g.affine() {
                say(format_args!("affine row:  {row:?}"))?;
            }
            Ok(())
        }
        None => say(format_args!(
            "geometry:    none (no sidecar {})",
            vlib::Geometry::sidecar(path).display()
        )),
    }
}

/// The names of the subcommands (a first argument that is none of them, nor an option, is an
/// input file: `vlconvert IN OUT.vlb`).
const SUBCOMMANDS: [&str; 10] = [
    "convert",
    "dicom",
    "raw",
    "image",
    "nifti",
    "nrrd",
    "metaimage",
    "tiff",
    "info",
    "help",
];

/// Converts the NRRD file `input`.
fn nrrd_file(input: &Path, output: &Path, window: &Window) -> Res<()> {
    let v = nrrd::read(input)?;
    convert(&v, window, output)
}

/// Converts `input`, whose format its first bytes tell (a folder: a TIFF stack or a DICOM
/// series, `detect`).
fn auto(input: &Path, output: &Path, window: &Window, series: Option<&str>) -> Res<()> {
    let format = detect::format(input)?;
    if series.is_some() && format != detect::Format::Dicom {
        return Err(format!(
            "{}: --series chooses a DICOM series, and this is {format:?}",
            input.display()
        ));
    }
    match format {
        detect::Format::Dicom => dicom::convert(input, output, window, series),
        detect::Format::Nifti => nifti::convert(input, output, window),
        detect::Format::Nrrd => nrrd_file(input, output, window),
        detect::Format::MetaImage => metaimage::convert(input, output, window),
        detect::Format::Tiff => tiffstack::convert_auto(input, output, window),
        detect::Format::Image => {
            if window.ends() != (None, None) {
                return Err("an image's voxels take --a/--b of the image subcommand".into());
            }
            image(input, output, Norm { a: None, b: None })
        }
    }
}

/// The command line's conversion or report (`src/main.rs` is this alone): what `vlconvert`
/// does with its arguments, and its exit code.
#[doc(hidden)]
pub fn run() -> ExitCode {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    // The first argument after a leading --quiet.
    let at = args
        .iter()
        .skip(1)
        .position(|a| a != "--quiet" && a != "-q")
        .map_or(args.len(), |i| i + 1);
    if args.len() >= at + 2 {
        let first = args[at].to_string_lossy();
        if !first.starts_with('-') && !SUBCOMMANDS.contains(&first.as_ref()) {
            args.insert(at, "convert".into());
        }
    }
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    progress::set_quiet(cli.quiet);
    let result = match &cli.command {
        Cmd::Raw {
            input,
            output,
            dims,
            ty,
            bytes,
            endian,
            skip,
            window,
        } => match (ty, bytes) {
            (Some(t), _) => raw(input, output, dims, *t, *endian, *skip, window),
            (None, None | Some(1)) => raw(input, output, dims, Type::U8, *endian, *skip, window),
            (None, Some(2)) => raw(input, output, dims, Type::U16, *endian, *skip, window),
            (None, Some(b)) => Err(format!("--bytes {b}: must be 1 or 2 (or use --type)")),
        },
        Cmd::Image {
            input,
            output,
            norm,
        } => image(input, output, *norm),
        Cmd::Nifti {
            input,
            output,
            window,
        } => nifti::convert(input, output, window),
        Cmd::Nrrd {
            input,
            output,
            window,
        } => nrrd_file(input, output, window),
        Cmd::Convert {
            input,
            output,
            window,
            series,
        } => auto(input, output, window, series.as_deref()),
        Cmd::Dicom {
            input,
            output,
            window,
            series,
        } => dicom::convert(input, output, window, series.as_deref()),
        Cmd::Metaimage {
            input,
            output,
            window,
        } => metaimage::convert(input, output, window),
        Cmd::Tiff(args) => tiffstack::convert(args),
        Cmd::Info { file } => info(file),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vlconvert: {e}");
            ExitCode::FAILURE
        }
    }
}
