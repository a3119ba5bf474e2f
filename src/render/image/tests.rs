//! Unit tests of the quantisation of pixels: 16 bits against 8, alpha and straight colour,
//! and the byte layouts of every [`PixelFormat`].

use super::*;

/// The 16-bit value rounds to the 8-bit one (`round(v16 / 257)`, the usual 16-to-8 bit
/// conversion `(v16·255 + 32767) / 65535`) and is within one unit of `65535·v` beyond the
/// rounding: for every `f32` within 64 units in the last place of each 8-bit half step
/// `(k + ½) / 255` (where single-precision rounding of `255·v` can cross it), for a sweep of
/// [0, 1] in steps of 2⁻²⁰, and for 0, 1 and values outside [0, 1]. Some values near half
/// steps need the clamp that keeps the relation (without it they would fail it).
#[test]
fn sixteen_bits_round_to_eight() {
    let mut values: Vec<f32> = (0..=1 << 20).map(|i| i as f32 / (1 << 20) as f32).collect();
    for k in 0..255 {
        let half = ((k as f64 + 0.5) / 255.0) as f32;
        for d in -64i32..=64 {
            values.push(f32::from_bits((half.to_bits() as i32 + d) as u32));
        }
    }
    values.extend([
        0.0,
        1.0,
        -0.0,
        -1.0,
        2.0,
        1.0 + f32::EPSILON,
        f32::MIN_POSITIVE,
    ]);
    let mut clamped = 0;
    for v in values {
        let (q8, q16) = (to_u8(v), to_u16(v));
        let back = ((q16 as u32 * 255 + 32767) / 65535) as u8;
        assert_eq!(
            back, q8,
            "{v}: {q16} rounds to {back}, the 8-bit value is {q8}"
        );
        assert_eq!(((q16 as f64) / 257.0).round() as u8, q8, "{v}");
        let exact = v.clamp(0.0, 1.0) as f64 * 65535.0;
        let off = (q16 as f64 - exact).abs();
        assert!(off <= 1.5, "{v}: {q16} against {exact}");
        clamped += (off > 0.5) as usize;
    }
    assert!(clamped > 0, "no value near a half step needed the clamp");
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!((to_u8(bad), to_u16(bad)), (0, 0));
    }
}

/// Alpha is `1 − T` against a transparent backdrop and 1 against the background, in [0, 1]
/// whatever `T` is; straight colour times alpha is the premultiplied colour where that is at
/// most alpha, 1 where it is more, 0 where alpha is 0; nothing non-finite comes out.
#[test]
fn alpha_and_straight_colour() {
    for t in [0.0f32, 0.25, 0.5, 1.0] {
        assert_eq!(alpha(t, Backdrop::Transparent), 1.0 - t);
        assert_eq!(alpha(t, Backdrop::Background), 1.0);
    }
    for t in [f32::NAN, f32::INFINITY, -1.0, 2.0] {
        let a = alpha(t, Backdrop::Transparent);
        assert!((0.0..=1.0).contains(&a), "{t}: {a}");
    }
    for (c, a) in [
        (0.1f32, 0.5f32),
        (0.3, 0.3),
        (0.0, 0.7),
        (0.25, 1.0),
        (1e-30, 1e-30),
    ] {
        let s = straight(c, a);
        assert!(
            (s * a - c).abs() <= 2.0 * f32::EPSILON * c,
            "{c} / {a} = {s}"
        );
    }
    assert_eq!(straight(0.6, 0.5), 1.0, "light beyond the coverage");
    assert_eq!(straight(0.2, 0.0), 0.0);
    assert_eq!(straight(0.2, f32::MIN_POSITIVE / 4.0), 1.0);
    assert_eq!(straight(f32::NAN, 0.5), 0.0);
}

/// Each format lays a pixel out as its channels in the machine's byte order: the 8-bit and
/// 16-bit values of the same colour, alpha last, straight for integers and premultiplied
/// for floats; RGB formats drop the transmittance.
#[test]
fn pixel_layouts() {
    let (rgb, t) = ([0.2f32, 0.4, 0.1], 0.5f32);
    let a = 0.5f32;
    let put = |f: PixelFormat| {
        let mut out = vec![0u8; f.pixel_bytes()];
        f.put(rgb, t, f.backdrop(), &mut out);
        out
    };
    assert_eq!(put(PixelFormat::Rgb8), rgb.map(to_u8));
    let s = rgb.map(|c| c / a);
    assert_eq!(
        put(PixelFormat::Rgba8),
        [to_u8(s[0]), to_u8(s[1]), to_u8(s[2]), 128]
    );
    let u16s = |b: Vec<u8>| -> Vec<u16> {
        b.chunks(2)
            .map(|v| u16::from_ne_bytes([v[0], v[1]]))
            .collect()
    };
    let f32s = |b: Vec<u8>| -> Vec<f32> {
        b.chunks(4)
            .map(|v| f32::from_ne_bytes([v[0], v[1], v[2], v[3]]))
            .collect()
    };
    assert_eq!(u16s(put(PixelFormat::Rgb16)), rgb.map(to_u16));
    assert_eq!(
        u16s(put(PixelFormat::Rgba16)),
        [to_u16(s[0]), to_u16(s[1]), to_u16(s[2]), 32768]
    );
    assert_eq!(f32s(put(PixelFormat::Rgb32F)), rgb);
    assert_eq!(f32s(put(PixelFormat::Rgba32F)), [0.2, 0.4, 0.1, 0.5]);
    for f in PixelFormat::ALL {
        assert_eq!(f.pixel_bytes(), f.channels() * f.channel_bytes());
        assert_eq!(f.has_alpha(), f.backdrop() == Backdrop::Transparent);
    }
    assert_eq!(PixelFormat::Rgba32F.image_bytes(3, 5), Some(240));
    assert_eq!(PixelFormat::Rgba32F.image_bytes(u32::MAX, u32::MAX), None);
}

/// An image's helpers are its bytes in each format; against the background its RGBA is
/// opaque and its colour as it is.
#[test]
fn image_helpers_are_the_layouts() {
    let image = |backdrop| Image {
        width: 2,
        height: 1,
        pixels: vec![[0.2, 0.4, 0.1], [0.0, 0.0, 0.0]],
        transmittance: vec![0.5, 1.0],
        backdrop,
    };
    let clear = image(Backdrop::Transparent);
    assert_eq!(clear.to_rgba8(), clear.to_bytes(PixelFormat::Rgba8));
    assert_eq!(clear.to_rgb8(), clear.to_bytes(PixelFormat::Rgb8));
    let ne = |v: Vec<u16>| v.iter().flat_map(|x| x.to_ne_bytes()).collect::<Vec<u8>>();
    assert_eq!(ne(clear.to_rgb16()), clear.to_bytes(PixelFormat::Rgb16));
    assert_eq!(ne(clear.to_rgba16()), clear.to_bytes(PixelFormat::Rgba16));
    let f = clear.to_rgba_f32();
    assert_eq!(f, [0.2, 0.4, 0.1, 0.5, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!((clear.alpha(0, 0), clear.alpha(1, 0)), (0.5, 0.0));
    let opaque = image(Backdrop::Background);
    assert_eq!(opaque.to_rgba8()[..4], [51, 102, 26, 255]);
    assert_eq!(opaque.alpha(1, 0), 1.0);
}

/// The formats' integers are 1 … 6 in the order of `ALL`; any other is `BadEnum`.
#[test]
fn formats_from_raw() {
    for (i, f) in PixelFormat::ALL.iter().enumerate() {
        assert_eq!(f.raw(), i as i32 + 1);
        assert_eq!(PixelFormat::from_raw(f.raw()).unwrap(), *f);
    }
    for bad in [0, 7, -1, i32::MIN, i32::MAX] {
        let e = PixelFormat::from_raw(bad).unwrap_err();
        assert_eq!(e.code, crate::error::ErrorCode::BadEnum);
    }
}

/// The message of the panic `f` raises (nothing where it returns).
fn panic_message<R>(f: impl FnOnce() -> R) -> Option<String> {
    let p = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).err()?;
    Some(
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default(),
    )
}

/// An image whose `pixels` or `transmittance` is not `width × height` long, or whose size the
/// library does not render, is `BadValue` for `check`; every conversion of an image whose
/// lengths disagree panics, naming itself and the lengths, instead of converting another
/// image (a 2 × 1 image without transmittance gave 8 zero bytes from `to_rgba8`).
#[test]
fn check_refuses_images_that_disagree_with_themselves() {
    use crate::error::ErrorCode;
    let image = Image::with_lengths;
    for (bad, why) in [
        (
            image(4, 4, 3, 3),
            "3 pixels and 3 transmittance values for a 4x4 image (16 of each)",
        ),
        (
            image(2, 1, 2, 0),
            "2 pixels and 0 transmittance values for a 2x1 image (2 of each)",
        ),
        (
            image(2, 1, 3, 2),
            "3 pixels and 2 transmittance values for a 2x1 image (2 of each)",
        ),
        (
            image(0, 3, 0, 3),
            "0 pixels and 3 transmittance values for a 0x3 image (0 of each)",
        ),
    ] {
        let e = bad.check().unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue, "{why}");
        assert_eq!(e.message, format!("Image: {why}"));
        for (name, f) in [
            (
                "to_bytes",
                &(|i: &Image| drop(i.to_bytes(PixelFormat::Rgb16))) as &dyn Fn(&Image),
            ),
            ("to_rgb8", &|i: &Image| drop(i.to_rgb8())),
            ("to_rgb16", &|i: &Image| drop(i.to_rgb16())),
            ("to_rgba8", &|i: &Image| drop(i.to_rgba8())),
            ("to_rgba16", &|i: &Image| drop(i.to_rgba16())),
            ("to_rgba_f32", &|i: &Image| drop(i.to_rgba_f32())),
        ] {
            assert_eq!(
                panic_message(|| f(&bad)).as_deref(),
                Some(&*format!("Image::{name}: {why}"))
            );
        }
    }
    // Lengths that agree with a size the library does not render (zeroed memory: mapped, not
    // touched).
    let image = |width, height, n: usize| Image {
        width,
        height,
        pixels: vec![[0.0; 3]; n],
        transmittance: vec![0.0; n],
        backdrop: Backdrop::Background,
    };
    for (w, h) in [
        (0, 0),
        (0, 5),
        (7, 0),
        (32769, 1),
        (1, 32769),
        (16385, 16384),
    ] {
        let n = w as usize * h as usize;
        let e = image(w, h, n).check().unwrap_err();
        assert_eq!(e.code, ErrorCode::BadValue, "{w}x{h}");
        assert_eq!(
            e.message,
            format!("Image: size {w}x{h} (each side 1 … 32768, at most 268435456 pixels)")
        );
    }
    for (w, h) in [(1, 1), (3, 2), (32768, 1), (1, 32768), (16384, 16384)] {
        let n = w as usize * h as usize;
        assert!(image(w, h, n).check().is_ok(), "{w}x{h}");
    }
}

/// `pixel` and `alpha` outside the image panic with the coordinates and the size, where
/// `pixel(2, 0)` of a 2 × 2 image gave pixel (0, 1) and `alpha` panicked only past the end.
#[test]
fn pixels_outside_the_image_panic() {
    let image = Image {
        width: 2,
        height: 2,
        pixels: vec![[0.1; 3], [0.2; 3], [0.3; 3], [0.4; 3]],
        transmittance: vec![0.5, 0.25, 0.75, 1.0],
        backdrop: Backdrop::Transparent,
    };
    assert_eq!(image.pixel(1, 1), [0.4; 3]);
    assert_eq!(image.pixel(0, 1), [0.3; 3]);
    assert_eq!(image.alpha(0, 1), 0.25);
    for (x, y) in [(2, 0), (0, 2), (2, 1), (5, 5), (u32::MAX, 0), (0, u32::MAX)] {
        for (name, f) in [
            ("pixel", &(|| _ = image.pixel(x, y)) as &dyn Fn()),
            ("alpha", &|| _ = image.alpha(x, y)),
        ] {
            assert_eq!(
                panic_message(f).as_deref(),
                Some(&*format!(
                    "Image::{name}: ({x}, {y}) is outside the 2x2 image"
                )),
            );
        }
    }
}
