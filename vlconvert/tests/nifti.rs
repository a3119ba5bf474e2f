//! NIfTI-1 reading beyond the plain single file: voxels at the header's `vox_offset` (nibabel's
//! fixtures: a single file with padding, a `.hdr` / `.img` pair), offsets that are none, gzip
//! streams that are corrupt or cut short, followed by other bytes or in two members, inputs
//! that are not regular files (refused without waiting, for every reader that opens a file by
//! its name), a qform quaternion that is no rotation, negative qform voxel sizes, and one
//! volume a file (axes beyond the third, NIfTI-2, a constant volume).
//! Malformed headers are nibabel's files with the field patched in the test: nibabel writes
//! none of them.

mod common;

use common::{converts_like_the_writer, fixture, run, run_within, s, text, tmp};
use std::io::Write;
use std::path::Path;
use std::process::Command;
use vlib::Dataset;

/// `bytes` gzipped.
fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

/// nibabel's 2-D image (dim[0] = 2) converts to a volume one node deep, with nibabel's values.
#[test]
fn a_2d_image_is_a_volume_one_node_deep() {
    converts_like_the_writer("nifti", "nifti/int16_2d.nii", [5, 4, 1], 2, true);
}

/// nibabel's files with voxels away from byte 352 (after 48 bytes of padding; 16 bytes into a
/// pair's `.img`) convert to nibabel's values, gzipped too (`.nii.gz`, `.img.gz`).
#[test]
fn voxels_are_read_at_vox_offset() {
    converts_like_the_writer("nifti", "nifti/int16_offset.nii", [5, 4, 3], 2, true);
    converts_like_the_writer("nifti", "nifti/uint8_pair.hdr", [5, 4, 3], 1, true);
    let d = tmp("nifti-offset-gz");
    let bytes = |name: &str| std::fs::read(fixture(name)).unwrap();
    std::fs::write(d.join("v.nii.gz"), gzip(&bytes("nifti/int16_offset.nii"))).unwrap();
    std::fs::write(d.join("p.hdr"), bytes("nifti/uint8_pair.hdr")).unwrap();
    std::fs::write(d.join("p.img.gz"), gzip(&bytes("nifti/uint8_pair.img"))).unwrap();
    for (gz, plain) in [
        ("v.nii.gz", fixture("nifti/int16_offset.nii")),
        ("p.hdr", fixture("nifti/uint8_pair.hdr")),
    ] {
        let (a, b) = (d.join("a.vlb"), d.join("b.vlb"));
        let o = run(&["nifti", s(&d.join(gz)), s(&a)]);
        assert!(o.status.success(), "{gz}: {}", text(&o.stderr));
        let o = run(&["nifti", s(&plain), s(&b)]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{gz}"
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// nibabel's `int16_offset.nii` with `vox_offset` (byte 108, little-endian float32) set to `v`.
fn with_vox_offset(v: f32) -> Vec<u8> {
    let mut b = std::fs::read(fixture("nifti/int16_offset.nii")).unwrap();
    b[108..112].copy_from_slice(&v.to_le_bytes());
    b
}

/// A vox_offset that is no byte offset of the voxels (NaN, negative, fractional, inside the
/// header of a single file, past the end of the data, or leaving too few bytes) is refused with
/// exit 1, naming it, and nothing is written. Bytes after the voxels are a note.
#[test]
fn vox_offsets_that_are_not_the_voxels_are_refused() {
    let d = tmp("nifti-offset-bad");
    for (v, says) in [
        (f32::NAN, "vox_offset NaN: not a byte offset"),
        (-4.0, "vox_offset -4: not a byte offset"),
        (400.5, "vox_offset 400.5: not a byte offset"),
        (0.0, "vox_offset 0: inside the 348-byte header"),
        (300.0, "vox_offset 300: inside the 348-byte header"),
        (
            1e6,
            "vox_offset 1000000 is past the end of the data (520 bytes)",
        ),
        (460.0, "60 bytes of voxels from vox_offset 460, 120 needed"),
    ] {
        let f = d.join("v.nii");
        std::fs::write(&f, with_vox_offset(v)).unwrap();
        let out = d.join("v.vlb");
        let o = run(&["nifti", s(&f), s(&out)]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{v}: {err}");
        assert!(err.contains(says), "{v}: {err}");
        assert!(!out.exists(), "{v}");
    }
    // The voxels at 352 (vox_offset 352, the 48 bytes of padding read as voxels): 48 bytes
    // are left after them.
    let f = d.join("v.nii");
    std::fs::write(&f, with_vox_offset(352.0)).unwrap();
    let o = run(&["nifti", s(&f), s(&d.join("v.vlb"))]);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("has 48 bytes after the voxels (ignored)"),
        "{err}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// A gzip stream whose checksum does not match, or that is cut short, is an error in words;
/// so is a folder given as the file.
#[test]
fn corrupt_or_cut_gzip_streams_and_folders_are_refused_in_words() {
    let d = tmp("nifti-gzip-bad");
    let gz = gzip(&std::fs::read(fixture("nifti/int16_ct.nii")).unwrap());
    let mut crc = gz.clone();
    let at = crc.len() - 8; // the CRC-32 of the member's trailer
    crc[at] ^= 0xff;
    let cut = &gz[..gz.len() - 6];
    for (name, bytes, says) in [
        ("crc.nii.gz", &crc[..], "does not have a matching checksum"),
        ("cut.nii.gz", cut, "the file ends inside the gzip stream"),
    ] {
        let f = d.join(name);
        std::fs::write(&f, bytes).unwrap();
        let out = d.join("v.vlb");
        for sub in [&["nifti"][..], &[]] {
            let o = run(&[sub, &[s(&f), s(&out)]].concat());
            let err = text(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "{name} {sub:?}: {err}");
            assert!(err.contains(says), "{name} {sub:?}: {err}");
            assert!(!out.exists(), "{name}");
        }
    }
    let o = run(&["nifti", s(&d), s(&d.join("v.vlb"))]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("{}: is a directory", d.display())),
        "{err}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// Bytes after a gzip stream that start no other member (nibabel's `.nii.gz` followed by 512
/// zero bytes or by text; nibabel's gzipped pair with 100 zero bytes after its `.img.gz`) are
/// ignored with a note counting them, as zlib's gzread and `gzip -d` ignore them, and a stream
/// of two members (Python's gzip module) is read whole: each converts, with its subcommand and
/// without, to the bytes of the plain file (`int16_ct.nii`, `uint8_pair.hdr`).
#[test]
fn bytes_after_a_gzip_stream_are_a_note_and_members_are_joined() {
    let d = tmp("nifti-gzip-after");
    let (want, got) = (d.join("want.vlb"), d.join("got.vlb"));
    for (file, plain, note) in [
        ("int16_ct.nii.gz", "int16_ct.nii", None),
        ("int16_ct_zeros.nii.gz", "int16_ct.nii", Some(("", 512))),
        ("int16_ct_junk.nii.gz", "int16_ct.nii", Some(("", 18))),
        ("int16_ct_members.nii.gz", "int16_ct.nii", None),
        (
            "uint8_pair_gz.hdr.gz",
            "uint8_pair.hdr",
            Some(("uint8_pair_gz.img.gz", 100)),
        ),
    ] {
        let input = fixture(&format!("nifti/{file}"));
        let o = run(&["nifti", s(&fixture(&format!("nifti/{plain}"))), s(&want)]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        for sub in [&["nifti"][..], &[]] {
            let o = run(&[sub, &[s(&input), s(&got)]].concat());
            let err = text(&o.stderr);
            assert!(o.status.success(), "{file} {sub:?}: {err}");
            assert_eq!(
                std::fs::read(&got).unwrap(),
                std::fs::read(&want).unwrap(),
                "{file}"
            );
            match note {
                Some((named, n)) => {
                    let named = if named.is_empty() { file } else { named };
                    let says = format!(
                        "{} has {n} bytes after its gzip stream (ignored)",
                        fixture(&format!("nifti/{named}")).display()
                    );
                    assert!(err.contains(&says), "{file}: {err}");
                }
                None => assert!(!err.contains("after its gzip stream"), "{file}: {err}"),
            }
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A FIFO with no writer and a link to /dev/zero, as a NIfTI file, a pair's `.img`, an image
/// and a TIFF, are refused at once ("not a regular file", exit 1), not waited on or read.
#[test]
fn files_that_are_not_regular_are_refused_without_waiting() {
    let d = tmp("nifti-fifo");
    let fifo = |name: &str| {
        let p = d.join(name);
        assert!(Command::new("mkfifo").arg(&p).status().unwrap().success());
        p
    };
    let zero = |name: &str| {
        let p = d.join(name);
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
        p
    };
    let hdr = std::fs::read(fixture("nifti/uint8_pair.hdr")).unwrap();
    std::fs::write(d.join("f.hdr"), &hdr).unwrap();
    std::fs::write(d.join("z.hdr"), &hdr).unwrap();
    let (fimg, zimg) = (fifo("f.img"), zero("z.img"));
    let (nii, png, zpng, tif) = (fifo("v.nii"), fifo("i.png"), zero("z.png"), fifo("t.tif"));
    // (subcommand, input, the file the message names)
    let cases = [
        ("nifti", nii.clone(), nii),
        ("nifti", d.join("f.hdr"), fimg),
        ("nifti", d.join("z.hdr"), zimg),
        ("image", png.clone(), png),
        ("image", zpng.clone(), zpng),
        ("tiff", tif.clone(), tif),
    ];
    for (sub, input, named) in &cases {
        let out = d.join("out.vlb");
        let o = run_within(&[sub, s(input), s(&out)]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{sub} {}: {err}", input.display());
        assert!(
            err.contains(&format!("{}: not a regular file", named.display())),
            "{sub} {}: {err}",
            input.display()
        );
        assert!(!out.exists());
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// nibabel's `uint8_qform.nii` (a qform alone) with its quaternion's b, c, d (bytes 256 … 267)
/// set.
fn with_quaternion(bcd: [f32; 3], d: &Path) -> std::path::PathBuf {
    let mut b = std::fs::read(fixture("nifti/uint8_qform.nii")).unwrap();
    for (i, v) in bcd.iter().enumerate() {
        b[256 + 4 * i..260 + 4 * i].copy_from_slice(&v.to_le_bytes());
    }
    let f = d.join("q.nii");
    std::fs::write(&f, b).unwrap();
    f
}

/// A qform quaternion with b² + c² + d² > 1 is no rotation: a note says the placement cannot
/// be made and the volume converts without a sidecar. One beyond 1 by float32 rounding only is
/// a 180° rotation: its axes stay orthogonal, with pixdim's lengths.
#[test]
fn a_qform_quaternion_that_is_no_rotation_is_no_placement() {
    let d = tmp("nifti-quaternion");
    let out = d.join("q.vlb");
    let o = run(&["nifti", s(&with_quaternion([5.0; 3], &d)), s(&out)]);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("no placement: qform quaternion b, c, d = 5, 5, 5: b² + c² + d² = 75"),
        "{err}"
    );
    assert!(Dataset::load(&out).unwrap().geometry().is_none());
    // (1 + 2⁻²³ as float32: b² is 1 + 2⁻²² + …)
    let b = 1.0 + f32::EPSILON;
    let o = run(&["nifti", s(&with_quaternion([b, 0.0, 0.0], &d)), s(&out)]);
    let err = text(&o.stderr);
    assert!(o.status.success() && !err.contains("no placement"), "{err}");
    let g = Dataset::load(&out).unwrap().geometry().cloned().unwrap();
    // pixdim 1, 2, 3 (nibabel's affine), about x by 180°: x kept, y and z reversed; the
    // columns orthogonal.
    let want = [[1.0, 0.0, 0.0], [0.0, -2.0, 0.0], [0.0, 0.0, -3.0]];
    for (row, want) in g.affine().iter().zip(want) {
        for (got, want) in row[..3].iter().zip(want) {
            assert!((got - want).abs() < 1e-9, "{:?}", g.affine());
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// nibabel's `uint8_qform.nii` with pixdim[1] and pixdim[3] (bytes 80 and 88) negated: a
/// negative voxel size mirrors no axis (only qfac does), so its absolute value is used, with a
/// note for each, and the placement is nibabel's (which warns and does the same): the
/// fixture's own affine.
#[test]
fn a_negative_qform_voxel_size_is_taken_as_its_absolute_value() {
    let d = tmp("nifti-negative-pixdim");
    let mut b = std::fs::read(fixture("nifti/uint8_qform.nii")).unwrap();
    for at in [80, 88] {
        let v = f32::from_le_bytes(b[at..at + 4].try_into().unwrap());
        b[at..at + 4].copy_from_slice(&(-v).to_le_bytes());
    }
    let (f, out) = (d.join("q.nii"), d.join("q.vlb"));
    std::fs::write(&f, b).unwrap();
    let o = run(&["nifti", s(&f), s(&out)]);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    for says in [
        "qform pixdim[1] = -1: a voxel size is not negative, so its absolute value 1 is used",
        "qform pixdim[3] = -3: a voxel size is not negative, so its absolute value 3 is used",
    ] {
        assert!(err.contains(says), "{err}");
    }
    let text = std::fs::read_to_string(fixture("nifti/uint8_qform.affine.txt")).unwrap();
    let want: Vec<Vec<f64>> = text
        .lines()
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect();
    let g = Dataset::load(&out).unwrap().geometry().cloned().unwrap();
    for (row, want) in g.affine().iter().zip(&want) {
        for (got, want) in row.iter().zip(want) {
            assert!((got - want).abs() < 1e-6, "{:?} vs {want:?}", g.affine());
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// One volume a file (nibabel's files from `int16_ct.nii`'s values): a fourth axis of size 1
/// converts to the 3-D file's bytes; a time axis of 2 and a 5-D vector image of 2 components
/// are refused by their dimensions; NIfTI-2 is not read (by name with `nifti`, as no format
/// without); a constant volume converts with every node 0.
#[test]
fn one_volume_a_file_of_nifti_1() {
    let d = tmp("nifti-one-volume");
    let (want, got) = (d.join("want.vlb"), d.join("got.vlb"));
    assert!(run(&["nifti", s(&fixture("nifti/int16_ct.nii")), s(&want)])
        .status
        .success());
    let o = run(&["nifti", s(&fixture("nifti/int16_ct_t1.nii")), s(&got)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(std::fs::read(&got).unwrap(), std::fs::read(&want).unwrap());
    let _ = std::fs::remove_file(&got);
    for (sub, file, says) in [
        (
            "nifti",
            "int16_ct_t2.nii",
            "a 4-dimensional volume [5, 4, 3, 2]; only 3D volumes convert",
        ),
        (
            "nifti",
            "int16_ct_v2.nii",
            "a 5-dimensional volume [5, 4, 3, 1, 2]; only 3D volumes convert",
        ),
        (
            "nifti",
            "int16_ct_nifti2.nii",
            "not a NIfTI-1 header (no n+1 or ni1 magic at byte 344)",
        ),
        (
            "convert",
            "int16_ct_nifti2.nii",
            "not a format vlconvert recognises",
        ),
    ] {
        let o = run(&[sub, s(&fixture(&format!("nifti/{file}"))), s(&got)]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{file}: {err}");
        assert!(err.contains(says), "{file}: {err}");
        assert!(!got.exists(), "{file}");
    }
    let o = run(&["nifti", s(&fixture("nifti/int16_constant.nii")), s(&got)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v = Dataset::load(&got).unwrap();
    assert!(common::normalised(&v).iter().all(|&n| n == 0.0));
    std::fs::remove_dir_all(&d).unwrap();
}
