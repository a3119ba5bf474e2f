//! Inputs the `vlconvert_readers` fuzz target found (or that stand for what it found, made
//! minimal here), each refused with exit 1 and a message naming the file, in an address space
//! of [`MEMORY`]: what the readers did with them before their fix (an allocation of what a
//! header declares, a panic) fails these tests. docs/dev/robustness.md, *Fuzzing*.

mod common;

use common::{fixture, tmp};
use std::path::Path;

/// The address space `vlconvert` runs in here (KiB): far less than the allocations these
/// inputs asked for, enough for a conversion.
const MEMORY: u64 = 128 * 1024;

/// `vlconvert args… input` refused in an address space of [`MEMORY`]
/// ([`common::refused_within`]).
fn refused(args: &[&str], input: &Path, says: &[&str]) {
    common::refused_within(MEMORY, args, input, says);
}

/// [`refused`] both by subcommand `sub` and by the format its first bytes tell.
fn refused_as_and_detected(sub: &str, input: &Path, says: &[&str]) {
    refused(&[sub], input, says);
    refused(&[], input, says);
}

/// A little-endian classic TIFF whose first page directory is `entries` (tag, type, count,
/// value or offset), right after the header.
fn tiff(entries: &[(u16, u16, u32, u32)]) -> Vec<u8> {
    let mut f = b"II*\0".to_vec();
    f.extend(8u32.to_le_bytes());
    f.extend((entries.len() as u16).to_le_bytes());
    for &(tag, ty, count, value) in entries {
        f.extend(tag.to_le_bytes());
        f.extend(ty.to_le_bytes());
        f.extend(count.to_le_bytes());
        f.extend(value.to_le_bytes());
    }
    f.extend(0u32.to_le_bytes());
    f
}

/// The first page directory is read by the `tiff` crate as it opens the file, under its
/// default limits: a tag of 2²³ − 1 values in a file of 26 bytes made it allocate 2²³ − 1
/// decoded values (256 MiB) before finding the file short. The directory is now checked
/// first: each tag's values must fit in the file, its entries read as the crate reads them.
/// (Found by the fuzz target as ImageWidth of a fixture with its count set to 0x7fffff, and
/// in a BigTIFF after an entry of an unknown type.)
#[test]
fn a_first_page_directory_tag_is_checked_before_the_tiff_crate_reads_it() {
    let d = tmp("hostile-tiff");
    for (name, ty, size) in [("long.tif", 4u16, "4 bytes"), ("short.tif", 3, "2 bytes")] {
        let p = d.join(name);
        // ImageWidth, of 2^23 - 1 values at byte 8.
        std::fs::write(&p, tiff(&[(256, ty, (1 << 23) - 1, 8)])).unwrap();
        let says = [
            "a tag of its page directory counts more values than the file holds",
            "tag 256: 8388607 values of",
            size,
            "in a file of 26 bytes",
        ];
        refused_as_and_detected("tiff", &p, &says);
    }
    // A BigTIFF whose first entry is of a type the crate does not know: it skips 8 bytes of
    // it, not its 20, and reads the next entry from inside it (the check reads it so too).
    let mut big = b"II+\0\x08\0\0\0".to_vec();
    big.extend(16u64.to_le_bytes()); // the directory, of 2 entries
    big.extend(2u64.to_le_bytes());
    big.extend([0, 1, 0, 0]); // tag 256 of type 0
    big.extend(0u64.to_le_bytes());
    big.extend([0, 1, 4, 0]); // (as the crate reads it) ImageWidth, LONG, 2^23 - 1 values
    big.extend(((1u64 << 23) - 1).to_le_bytes());
    big.extend(8u64.to_le_bytes());
    big.extend(0u64.to_le_bytes());
    let p = d.join("big.tif");
    std::fs::write(&p, big).unwrap();
    let says = ["tag 256: 8388607 values of 4 bytes, in a file of 64 bytes"];
    refused(&["tiff"], &p, &says);
    std::fs::remove_dir_all(&d).unwrap();
}

/// A PNG chunk: length, type, data, CRC-32 of type and data.
fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut crc = flate2::Crc::new();
    crc.update(kind);
    crc.update(data);
    let mut c = (data.len() as u32).to_be_bytes().to_vec();
    c.extend(kind);
    c.extend(data);
    c.extend(crc.sum().to_be_bytes());
    c
}

/// The `image` crate allocates the pixels a header declares before decoding them: a PNG of
/// 10⁷ x 10 16-bit pixels (200 MB) in 65 bytes, and a PGM of 10⁵ x 10³ 16-bit pixels in 21,
/// made it allocate 200 MB (the process aborted in a smaller address space). A header the
/// file's bytes cannot fill is now refused first (a PNG holds at most 8 x 1032 pixels a
/// byte, a PNM 8). (Found by the fuzz target as a PNG of 3211268 x 3 pixels in 150 bytes.)
#[test]
fn an_image_header_its_bytes_cannot_fill_is_refused_before_decoding() {
    let d = tmp("hostile-image");
    let mut ihdr = 10_000_000u32.to_be_bytes().to_vec();
    ihdr.extend(10u32.to_be_bytes());
    ihdr.extend([16, 0, 0, 0, 0]); // 16-bit grey, deflate, no filter method, no interlace
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IDAT", &[0x78, 0x9c, 3, 0, 0, 0, 0, 1]));
    png.extend(chunk(b"IEND", &[]));
    let pgm = b"P5\n100000 1000\n65535\n".to_vec();
    for (name, bytes, says) in [
        (
            "big.png",
            png,
            "10000000 x 10 pixels, more than its 65 bytes can hold",
        ),
        (
            "big.pgm",
            pgm,
            "100000 x 1000 pixels, more than its 21 bytes can hold",
        ),
    ] {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        refused_as_and_detected("image", &p, &[says]);
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// The DICOM parser reads a binary element's whole values and goes on after them: an element
/// whose length is not a whole number of them (BitsStored, US, of 3 bytes) left a byte it
/// read the next element's header from, which the structure check (`dicom/scan.rs`), reading
/// the file as written, had passed. Here that header declares an OD element of 2³¹ − 256
/// bytes, which the parser set out to allocate in a file of 1 KB; the check now refuses such
/// a length. (Found by the fuzz target as BitsStored of 43 bytes in a big-endian slice,
/// whose misread header declared 89 MB.)
#[test]
fn a_dicom_element_of_part_of_a_value_is_refused() {
    let d = tmp("hostile-dicom");
    let mut b = std::fs::read(fixture("dicom/ct_tilt/t0.dcm")).unwrap();
    // (0028,0101) US of 2 bytes, explicit VR little endian.
    let at = b
        .windows(8)
        .position(|w| w == [0x28, 0, 1, 1, b'U', b'S', 2, 0])
        .unwrap();
    let bits = [b[at + 8], b[at + 9]];
    // As written: BitsStored of 3 bytes, then (0029,4F00) DS of 16 bytes. As the parser read
    // it: a header from the third byte on, (2900,0000) OD of 0x7FFFFF00 bytes.
    let mut patch = vec![0x28, 0, 1, 1, b'U', b'S', 3, 0, bits[0], bits[1], 0];
    patch.extend([0x29, 0, 0, b'O', b'D', b'S', 16, 0, 0xFF, 0xFF, 0x7F]);
    patch.extend([b' '; 13]);
    b.splice(at..at + 10, patch);
    let p = d.join("odd.dcm");
    std::fs::write(&p, b).unwrap();
    let says = [
        "element (0028,0101)",
        "3 bytes of US, not a whole number of its 2-byte values",
    ];
    refused_as_and_detected("dicom", &p, &says);
    std::fs::remove_dir_all(&d).unwrap();
}

/// `dicom-pixeldata`'s RLE decoder allocates as many segment offsets as a fragment's first
/// word says before it reads them: 2³⁰ (4 GiB) from a fragment of 136 bytes, which aborted
/// the process where the memory could not be had (the decoder's panics are caught, an
/// allocation failure is not). RLE Lossless allows 15 segments in a 64-byte header, which
/// each fragment is now checked to be before decoding. (Found by the fuzz target as a
/// segment count of 2³² − 1 in a fixture's fragment: 16 GiB.)
#[test]
fn an_rle_fragment_counting_more_than_15_segments_is_refused() {
    let d = tmp("hostile-rle");
    let mut b = std::fs::read(fixture("dicom/ct_rle/rle0.dcm")).unwrap();
    // The pixel data's basic offset table (an item of 4 bytes), then the fragment's item:
    // its first word counts the segments (2 in the fixture, 16-bit samples).
    let pixels = b
        .windows(4)
        .position(|w| w == [0xe0, 0x7f, 0x10, 0])
        .unwrap();
    let count = pixels + 12 + 8 + 4 + 8;
    assert_eq!(b[count..count + 4], 2u32.to_le_bytes());
    b[count..count + 4].copy_from_slice(&(1u32 << 30).to_le_bytes());
    let p = d.join("rle0.dcm");
    std::fs::write(&p, b).unwrap();
    let says =
        ["pixel data fragment 0: 136 bytes, 1073741824 segments: not an RLE Lossless header"];
    refused_as_and_detected("dicom", &p, &says);
    std::fs::remove_dir_all(&d).unwrap();
}

/// The DICOM parser reads the file meta group up to the length its group length (0002,0000)
/// gives, and the data set from there; the structure check had read it while the group was
/// 0002. A group 0002 element after that length (here of 126 bytes, in a big-endian slice)
/// was read by the parser as a data set element whose length, big-endian, is 0x7E000000, and
/// it set out to allocate 2 GiB in a file of 1 KB; the check now ends the group where the
/// parser does, and refuses that length. (Found by the fuzz target as a slice whose meta
/// group had two copies of its elements.)
#[test]
fn a_dicom_meta_group_longer_than_its_group_length_is_refused() {
    let d = tmp("hostile-meta");
    let mut b = std::fs::read(fixture("dicom/be_signed12/s0")).unwrap();
    // (0002,0000) UL: the group's length, from byte 144.
    assert_eq!(b[132..140], [2, 0, 0, 0, b'U', b'L', 4, 0]);
    let end = 144 + u32::from_le_bytes([b[140], b[141], b[142], b[143]]) as usize;
    let mut extra = vec![2, 0, 0xEE, 0x0E, b'O', b'B', 0, 0, 0x7E, 0, 0, 0];
    extra.extend([0; 0x7E]);
    b.splice(end..end, extra);
    let p = d.join("meta.dcm");
    std::fs::write(&p, b).unwrap();
    let says = [format!(
        "element (0200,EE0E) at byte {end} declares 2113929216 bytes"
    )];
    refused_as_and_detected("dicom", &p, &[&says[0]]);
    std::fs::remove_dir_all(&d).unwrap();
}
