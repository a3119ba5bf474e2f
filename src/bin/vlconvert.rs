//! `vlconvert`: converts raw volumes, 2D images and NIfTI files to vlib's `.vlb` datasets, and
//! describes `.vlb` files.
//!
//! ```text
//! vlconvert nifti brain.nii.gz brain.vlb
//! vlconvert raw ct.raw ct.vlb --dims 256 256 113 --bytes 2 --endian big
//! vlconvert image word.png word.vlb        # grey: word.vlb; colour: word_r/_g/_b.vlb
//! vlconvert info brain.vlb
//! ```
//!
//! Exit codes: 0 success, 1 the conversion failed (unreadable or malformed input, unwritable
//! output, a report that cannot be written), 2 bad command line. A report whose reader has
//! closed the pipe (`vlconvert info f.vlb | head -1`) ends quietly: not a failure.

use clap::{Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use vlib::{Dataset, Voxels};

#[derive(Parser)]
#[command(
    name = "vlconvert",
    version,
    about = "Convert volumes and images to vlib .vlb datasets"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

/// Normalisation written to the output: voxel v maps to clamp((v − a)/(b − a), 0, 1).
#[derive(clap::Args, Clone, Copy)]
struct Norm {
    /// The voxel value that maps to 0 (default: 0).
    #[arg(long, allow_negative_numbers = true)]
    a: Option<f32>,
    /// The voxel value that maps to 1 (default: the largest voxel value of the output width).
    #[arg(long, allow_negative_numbers = true)]
    b: Option<f32>,
}

#[derive(Clone, Copy, ValueEnum)]
enum Endian {
    Little,
    Big,
}

#[derive(Subcommand)]
enum Cmd {
    /// A headerless raw volume, x fastest, then y, then z.
    Raw {
        input: PathBuf,
        output: PathBuf,
        /// Dimensions nx ny nz.
        #[arg(long, num_args = 3, required = true, value_names = ["NX", "NY", "NZ"])]
        dims: Vec<u32>,
        /// Bytes per voxel (1 or 2).
        #[arg(long, default_value_t = 1)]
        bytes: u32,
        /// Byte order of 16-bit voxels.
        #[arg(long, value_enum, default_value_t = Endian::Little)]
        endian: Endian,
        /// Bytes to skip at the start of the file.
        #[arg(long, default_value_t = 0)]
        skip: u64,
        #[command(flatten)]
        norm: Norm,
    },
    /// A 2D image (PGM, PPM or PNG): grey → one slab dataset; colour → OUTPUT_r/_g/_b.vlb.
    Image {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        norm: Norm,
    },
    /// A NIfTI-1 volume (.nii or .nii.gz).
    Nifti {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        norm: Norm,
    },
    /// Print a .vlb file's dimensions, voxel width, normalisation and value range.
    Info { file: PathBuf },
}

type Res<T> = Result<T, String>;

fn norm_for(norm: Norm, bytes: u32) -> (f32, f32) {
    let max = if bytes == 1 { 255.0 } else { 65535.0 };
    (norm.a.unwrap_or(0.0), norm.b.unwrap_or(max))
}

/// Writes a line to standard output. A reader that has gone away (a closed pipe, as in
/// `vlconvert info f.vlb | head -1`) is not an error: what it did not read, it did not want.
/// Any other failure to write is (a full disk behind a redirection).
fn say(line: std::fmt::Arguments) -> Res<()> {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{line}") {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(format!("writing to standard output: {e}"))
        }
        _ => Ok(()),
    }
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

fn raw(
    input: &Path,
    output: &Path,
    dims: &[u32],
    bytes: u32,
    endian: Endian,
    skip: u64,
    norm: Norm,
) -> Res<()> {
    if bytes != 1 && bytes != 2 {
        return Err(format!("--bytes {bytes}: must be 1 or 2"));
    }
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
    let need = n * bytes as u64 + skip;
    if len < need {
        return Err(format!(
            "{}: {len} bytes, but {need} are needed for {dims:?} x {bytes} byte(s) + {skip}",
            input.display()
        ));
    }
    let data = std::fs::read(input).map_err(|e| format!("{}: {e}", input.display()))?;
    let body = &data[skip as usize..need as usize];
    let voxels = if bytes == 1 {
        Voxels::U8(body.to_vec())
    } else {
        Voxels::U16(
            body.chunks_exact(2)
                .map(|c| match endian {
                    Endian::Little => u16::from_le_bytes([c[0], c[1]]),
                    Endian::Big => u16::from_be_bytes([c[0], c[1]]),
                })
                .collect(),
        )
    };
    if len > need {
        eprintln!(
            "vlconvert: note: {} has {} bytes after the volume (ignored)",
            input.display(),
            len - need
        );
    }
    save(&build(dims, voxels, norm_for(norm, bytes))?, output)
}

/// Image rows run top to bottom; object y runs upwards, so row 0 becomes the top slab row.
fn image(input: &Path, output: &Path, norm: Norm) -> Res<()> {
    let img = image::open(input).map_err(|e| format!("{}: {e}", input.display()))?;
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
    for (suffix, plane) in channels {
        let voxels = if sixteen {
            Voxels::U16(plane)
        } else {
            Voxels::U8(plane.iter().map(|&v| (v >> 8) as u8).collect())
        };
        let path = if suffix.is_empty() {
            output.to_path_buf()
        } else {
            with_suffix(output, &suffix)
        };
        save(&build(dims, voxels, norm_for(norm, bytes))?, &path)?;
    }
    Ok(())
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

fn nifti(input: &Path, output: &Path, norm: Norm) -> Res<()> {
    use nifti::{NiftiObject, NiftiType, NiftiVolume, ReaderOptions};
    let obj = ReaderOptions::new()
        .read_file(input)
        .map_err(|e| format!("{}: {e}", input.display()))?;
    let header = obj.header().clone();
    let volume = obj.into_volume();
    let dim = volume.dim().to_vec();
    if dim.len() < 3 || dim[3..].iter().any(|&d| d != 1) {
        return Err(format!(
            "{}: a {}-dimensional volume {dim:?}; only 3D volumes convert",
            input.display(),
            dim.len()
        ));
    }
    let dims = [dim[0] as usize, dim[1] as usize, dim[2] as usize];
    let identity = (header.scl_slope == 0.0 || header.scl_slope == 1.0) && header.scl_inter == 0.0;
    if volume.data_type() == NiftiType::Uint8 && identity {
        let raw = volume.into_raw_data();
        return save(&build(dims, Voxels::U8(raw), norm_for(norm, 1))?, output);
    }
    // Anything else: real values (NIfTI order is x fastest, as in .vlb), scaled by the header's
    // slope and intercept, quantised to 16 bits over [min, max].
    let n: usize = dims.iter().product();
    let typed = volume
        .into_nifti_typed_data::<f64>()
        .map_err(|e| format!("{}: {e}", input.display()))?;
    let (slope, inter) = if header.scl_slope == 0.0 {
        (1.0, 0.0)
    } else {
        (header.scl_slope as f64, header.scl_inter as f64)
    };
    let values: Vec<f64> = typed
        .iter()
        .take(n)
        .map(|&v| {
            let v = v * slope + inter;
            if v.is_finite() {
                v
            } else {
                0.0
            }
        })
        .collect();
    if values.len() != n {
        return Err(format!(
            "{}: {} values for {dims:?}",
            input.display(),
            values.len()
        ));
    }
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let span = if hi > lo { hi - lo } else { 1.0 };
    let q: Vec<u16> = values
        .iter()
        .map(|&v| (((v - lo) / span) * 65535.0).round() as u16)
        .collect();
    say(format_args!("quantised values {lo} … {hi} to 0 … 65535"))?;
    save(&build(dims, Voxels::U16(q), norm_for(norm, 2))?, output)
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
    say(format_args!("raw values:  {lo} … {hi}"))
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let result = match &cli.command {
        Cmd::Raw {
            input,
            output,
            dims,
            bytes,
            endian,
            skip,
            norm,
        } => raw(input, output, dims, *bytes, *endian, *skip, *norm),
        Cmd::Image {
            input,
            output,
            norm,
        } => image(input, output, *norm),
        Cmd::Nifti {
            input,
            output,
            norm,
        } => nifti(input, output, *norm),
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
