//! The MNI ICBM152 brain rendered like the VTK peer benchmark (`../shared/bench/README.md`):
//! 512×512, sample distance 0.5 voxel, shaded.
//!
//! ```text
//! target/release/vlconvert nifti ../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz out/mni.vlb
//! cargo run --release --example mni -- out/mni.vlb out/mni.png [step] [--unshaded] [--size=N] \
//!     [--cubic] [--gradient=G] [--ss=N] [--termination=T] [--frames=N] [--no-packets] [--eight]
//!     [--test-every-run] [--fit] [--preintegrate] [--ramp=LO,HI]
//! ```
//!
//! `--gradient=G` chooses the normals' gradient filter: `bspline` (the default, the gallery's:
//! the exact gradient of the cubic B-spline of the voxels, smooth across cells), `catmull-rom`,
//! or `nodes` (the paper's trilinearly interpolated node differences, which the packet march
//! computes: the peer benchmark's and `benches/callgrind.sh`'s).
//! `--cubic` samples the dataset with the Catmull–Rom filter instead of trilinear, `--ss=N` turns
//! on adaptive N×N super-sampling: with a small step they make the converged reference that
//! `benches/peer.sh` measures both renderers against. `--termination=T` stops rays at
//! transmittance T instead of 1/512 (`Optimise::termination`; VTK's is 255/32767).
//! `--frames=N` first renders N more frames of the same scene to memory and prints the fastest
//! and the median of their times (the steady frame, without loading and precomputation).
//! `--no-packets` traces every ray by the scalar march (`Optimise::packets` off); `--eight`
//! keeps the packet march to AVX2's eight lanes where the processor has AVX-512
//! (`Optimise::wide_lanes` off); `--test-every-run` tests every run of samples against the cell
//! mask (`Optimise::trust_whole_runs` off). `--fit` treats a volume of other dimensions as the
//! template at (ny − 1)/232 voxels per millimetre (`benches/scaling.sh`): the camera and the
//! opacity's unit length scale with it.
//! `--preintegrate` renders with pre-integrated
//! transfer functions (`Optimise::preintegrate` on: the scalar pre-integrated march instead of
//! the packet march's midpoint samples). `--ramp=LO,HI` replaces the opacity table by the
//! accuracy study's steep ramp: 0 at and below F = LO, rising linearly to 1 at F = HI.
//! Built with `RUSTFLAGS="--cfg vlib_counters"`, it also prints how many samples the packet
//! march evaluated in the `--frames` frames (`docs/performance.md`, "Samples taken").

#[path = "common/mni_scene.rs"]
mod mni_scene;

#[path = "common/say.rs"]
mod say;
use std::time::Instant;

#[path = "common/flags.rs"]
mod flags;
use flags::flag;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    // Positional arguments first (vlb, png, step), flags anywhere.
    let args: Vec<String> = all
        .iter()
        .filter(|a| !a.starts_with("--"))
        .cloned()
        .collect();
    let vlb = args.first().map(String::as_str).unwrap_or("out/mni.vlb");
    let png = args.get(1).map(String::as_str).unwrap_or("out/mni.png");
    let step: f32 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(0.5);
    let shaded = !all.iter().any(|a| a == "--unshaded");
    let size: i32 = flag(&all, "--size=", 512)?;
    let cubic = all.iter().any(|a| a == "--cubic");
    let gradient = mni_scene::gradient_named(&flag(&all, "--gradient=", "bspline".to_string())?)?;
    let ss: i32 = flag(&all, "--ss=", 1)?;
    let termination: f64 = flag(&all, "--termination=", vlib::T_MIN)?;
    let frames: usize = flag(&all, "--frames=", 0)?;
    let packets = !all.iter().any(|a| a == "--no-packets");
    let wide_lanes = !all.iter().any(|a| a == "--eight");
    let trust_whole_runs = !all.iter().any(|a| a == "--test-every-run");
    let fit = all.iter().any(|a| a == "--fit");
    let preintegrate = all.iter().any(|a| a == "--preintegrate");
    let ramp: Option<(f32, f32)> = match flag(&all, "--ramp=", String::new())?.as_str() {
        "" => None,
        r => {
            let (lo, hi) = r.split_once(',').ok_or("--ramp=LO,HI")?;
            Some((lo.parse()?, hi.parse()?))
        }
    };
    let start = Instant::now();
    let mut vl = vlib::Library::new();
    vl.load(mni_scene::BRAIN, vlb)?;
    let loaded = start.elapsed().as_secs_f64();
    let dims = vl.dataset_of(mni_scene::BRAIN).expect("loaded").dims();
    mni_scene::mappings(&mut vl)?;
    if let Some((lo, hi)) = ramp {
        vl.mapping(
            mni_scene::OPACITY,
            vlib::MappingType::Ramp,
            2,
            1,
            &[lo, 0.0, hi, 1.0],
        )?;
    }
    vl.scene()?;
    vl.set_optimise(vlib::Optimise {
        termination,
        packets,
        wide_lanes,
        trust_whole_runs,
        preintegrate,
        ..vlib::Optimise::default()
    })?;
    vl.image(png, 1.0, size, size)?;
    vl.super_sample(ss)?;
    let filter = if cubic {
        vlib::Interpolation::Tricubic
    } else {
        vlib::Interpolation::Trilinear
    };
    vl.gradient_filter(gradient)?;
    // The template's y extent is 232 voxels of 1 mm.
    let scale = if fit {
        (dims[1] - 1) as f32 / 232.0
    } else {
        1.0
    };
    mni_scene::build_scaled(&mut vl, dims, step, shaded, filter, scale)?;
    if frames > 0 {
        let mut times: Vec<f64> = (0..frames)
            .map(|_| {
                let t = Instant::now();
                vl.render_preview(size as u32, size as u32, 1.0)
                    .map(|_| t.elapsed().as_secs_f64())
            })
            .collect::<Result<_, _>>()?;
        times.sort_by(f64::total_cmp);
        say::say(format_args!(
            "{frames} frames: fastest {:.1} ms, median {:.1} ms",
            times[0] * 1e3,
            times[frames / 2] * 1e3
        ))?;
    }
    #[cfg(all(vlib_counters, target_arch = "x86_64"))]
    {
        let [taken, above, shown] = vlib::sample_counts();
        say::say(format_args!(
            "the packet march's samples in the frames timed: {taken} taken, {above} above the \
             zero bound, {shown} with opacity"
        ))?;
    }
    vl.end()?;
    say::say(format_args!(
        "wrote {png} in {:.3} s (load {loaded:.3} s, then precomputation and render)",
        start.elapsed().as_secs_f64()
    ))?;
    Ok(())
}
