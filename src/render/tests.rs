//! Unit tests of the renderer: compiling, cursors, shading, the integrators and tiles, each against a
//! closed form or an independent computation.

use super::*;
use crate::testing::Xorshift;
use crate::types::{DatasetId, MappingId};

/// The packet march's tiles are 32×32 where the image has at least 16 of them a thread,
/// else 16×16; and `tiles` with either side covers the image once, row-major.
#[test]
fn packet_tiles_are_large_only_where_there_are_many() {
    let threads = rayon::current_num_threads();
    assert_eq!(packet_tile(64, 48), TILE, "4 tiles of 32");
    // Exactly 16 a thread: a row of 16·threads tiles of 32, the last one partial.
    let w = 32 * 16 * threads as u32 - 5;
    assert_eq!(packet_tile(w, 32), PACKET_TILE);
    assert_eq!(packet_tile(w - 32, 32), TILE);
    for side in [TILE, PACKET_TILE] {
        let (w, h) = (101u32, 67u32);
        let t = tiles(w, 0..h, side);
        assert_eq!(t.len(), (w.div_ceil(side) * h.div_ceil(side)) as usize);
        let mut covered = vec![0u8; (w * h) as usize];
        for &(tx, ty) in &t {
            for y in ty..(ty + side).min(h) {
                for x in tx..(tx + side).min(w) {
                    covered[(y * w + x) as usize] += 1;
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1), "side {side}");
        assert!(t.windows(2).all(|p| (p[0].1, p[0].0) < (p[1].1, p[1].0)));
    }
}

/// `try_normalize` is glam's `DVec3::try_normalize`, bit for bit and in when it declines:
/// zero, tiny (a square that underflows), huge (one that overflows), infinite and NaN
/// components, and ordinary vectors of every sign.
#[test]
fn try_normalize_is_glams() {
    let special = [
        0.0,
        -0.0,
        1e-320,
        -1e-200,
        1e-150,
        3.0,
        -0.25,
        1e150,
        -1e200,
        f64::MAX,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ];
    let mut checked = 0;
    for &x in &special {
        for &y in &special {
            for &z in &special {
                let v = DVec3::new(x, y, z);
                let bits = |n: Option<DVec3>| n.map(|n| n.to_array().map(f64::to_bits));
                assert_eq!(bits(try_normalize(v)), bits(v.try_normalize()), "{v:?}");
                checked += usize::from(v.try_normalize().is_some());
            }
        }
    }
    assert!(checked > 100, "only {checked} normalisable vectors");
}

#[test]
fn fast_powers_agree_with_powf() {
    for i in 0..=1000 {
        let t = i as f64 / 1000.0;
        for e in [1.0, 0.5, 0.25, 2.0, 0.125, 4.0, 0.37, 7.0] {
            assert!((transmit(t, e) - t.powf(e)).abs() < 1e-15, "{t}^{e}");
        }
        for e in [0.0, 1.0, 10.0, 20.5, 128.0] {
            let want = t.powf(e);
            assert!(
                (Specular::new(e).pow(t) - want).abs() <= 1e-12 * want.max(1e-300) + 1e-300,
                "{t}^{e}"
            );
        }
    }
}

/// The inlined binary exponentiation gives `f64::powi`'s bits (the library routine it
/// replaces), for every exponent the specular term can take and a spread of bases; the
/// exponent test takes exactly the integers in range and sends the rest to `powf`.
#[test]
fn powi_is_the_library_powi() {
    let mut x = 1e-3f64;
    while x < 1.0 {
        for k in 0..=MAX_SPECULAR as u32 {
            let (ours, lib) = (powi(x, k), x.powi(std::hint::black_box(k as i32)));
            assert_eq!(ours.to_bits(), lib.to_bits(), "{x}^{k}");
            assert_eq!(
                Specular::new(k as f64).pow(x).to_bits(),
                lib.to_bits(),
                "{x}^{k}"
            );
        }
        x = x * 1.37 + 1e-4;
    }
    for e in [
        -1.0,
        0.5,
        10.25,
        MAX_SPECULAR as f64 + 1.0,
        1e30,
        f64::INFINITY,
    ] {
        assert_eq!(
            Specular::new(e).pow(0.7).to_bits(),
            0.7f64.powf(e).to_bits(),
            "0.7^{e}"
        );
    }
    assert_eq!(
        Specular::new(f64::NAN).pow(0.7).to_bits(),
        0.7f64.powf(f64::NAN).to_bits()
    );
}

/// A scene of one object of opacity ½ (receiving and casting shadows if `shadows`) under
/// `lights`, compiled.
fn lit_scene(lights: Vec<Light>, shadows: bool) -> Compiled {
    let mut state = crate::model::scene::RenderState::default();
    state.toggles[Feature::CastShadows as usize] = shadows;
    state.toggles[Feature::ReceiveShadows as usize] = shadows;
    let mut object = ObjectDesc::new(state);
    // (An object of opacity 0 everywhere would be left out of what rays meet.)
    object.program.push(Instr::Set {
        fields: Fields::O,
        value: 0.5,
    });
    Compiled::new(
        &SceneDesc {
            settings: Settings {
                ambient: [0.3, 0.5, 1.0],
                ..Settings::default()
            },
            lights,
            images: Vec::new(),
            volumes: Vec::new(),
            objects: vec![object],
            datasets: Default::default(),
        },
        &Caches::default(),
    )
}

/// [`Headlit`] gives [`Compiled::illuminate_colour`]'s colour bit for bit, and asks for the
/// normal exactly when it does: for one and several directional lights and none, normals
/// and none (a vanishing gradient), coefficients at and above 0, integer and other
/// exponents, colours from 0 to above 1, any view direction. It is refused for a point
/// light and where a shadow may fall on the object.
#[test]
fn headlit_is_the_illumination_model() {
    let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
    let (next, unit) = (|| rng.next(), || unit_dir(&|| rng.next()));
    let light = |to_light: DVec3, radiance: [f32; 3]| Light::Directional { to_light, radiance };
    let configurations = [
        vec![light(DVec3::new(0.0, -1.0, 0.0), [1.0; 3])],
        vec![
            light(unit(), [0.9, 0.2, 0.4]),
            light(unit(), [2.0, 1.0, 0.5]),
            light(unit(), [0.0, 0.1, 0.0]),
        ],
        vec![],
    ];
    let mut compared = 0;
    let mut lit = 0;
    for lights in configurations {
        let scene = lit_scene(lights, false);
        let obj = &scene.objects[0];
        for k in [
            [0.2, 0.7, 0.3],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.5],
            [0.1, 0.9, 0.0],
        ] {
            for e in [10.0, 0.0, 20.5, 128.0].map(Specular::new) {
                for _ in 0..200 {
                    let dir = unit();
                    let c = DVec3::new(next(), next() * 2.0, if next() < 0.2 { 0.0 } else { 1.0 });
                    let n = (next() < 0.9).then(unit);
                    let h = Headlit::new(&scene, obj, dir, k, e).expect("directional");
                    let (calls, want_calls) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
                    let got = h.colour(c, || {
                        calls.set(calls.get() + 1);
                        n
                    });
                    let want = scene.illuminate_colour(obj, DVec3::ZERO, dir, c, k, e, || {
                        want_calls.set(want_calls.get() + 1);
                        n
                    });
                    assert_eq!(
                        got.to_array().map(f64::to_bits),
                        want.to_array().map(f64::to_bits)
                    );
                    assert_eq!(calls.get(), want_calls.get());
                    compared += 1;
                    lit += calls.get();
                }
            }
        }
    }
    assert_eq!(compared, 3 * 4 * 4 * 200);
    assert!(lit > 1000, "{lit}");
    let point = Light::Point {
        position: DVec3::ZERO,
        attenuation: Attenuation::None,
        radiance: [1.0; 3],
    };
    let k = [0.2, 0.7, 0.3];
    let e = Specular::new(10.0);
    let scene = lit_scene(vec![light(DVec3::Y, [1.0; 3]), point], false);
    assert!(Headlit::new(&scene, &scene.objects[0], DVec3::X, k, e).is_none());
    let scene = lit_scene(vec![light(DVec3::Y, [1.0; 3])], true);
    assert!(scene.plan.shadows);
    assert!(Headlit::new(&scene, &scene.objects[0], DVec3::X, k, e).is_none());
}

/// The lighting lanes' diagonal form of a matrix whose entries off the diagonal are ±0
/// (`ToWorld::Diagonal`) lights every sample as the general product with that matrix
/// (`ToWorld::General`, glam's `m * g`), bit for bit: gradients with components of every
/// kind (±0, subnormal, tiny, huge, infinite, NaN, random bits), diagonals with negative,
/// zero and huge entries, lights and views along the axes and not, flipped or not. And
/// the sign of a zero component of a gradient changes no colour, in either form or in
/// world space.
#[test]
fn diagonal_to_world_is_the_matrix_product() {
    let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15);
    let (next, unit) = (|| rng.next(), || unit_dir(&|| rng.next()));
    let comp = || match (next() * 10.0) as usize {
        0 => 0.0,
        1 => -0.0,
        2 => 1e-310,
        3 => -1e-8,
        4 => 1e300,
        5 => f64::INFINITY,
        6 => f64::NAN,
        7 => f64::from_bits(rng.bits()),
        _ => next() - 0.5,
    };
    let axis = |v: f64| {
        let mut d = DVec3::ZERO;
        d[(next() * 3.0) as usize] = v;
        d
    };
    let mut compared = 0;
    for round in 0..400 {
        let to_light = if round % 2 == 0 { axis(1.0) } else { unit() };
        let scene = lit_scene(
            vec![Light::Directional {
                to_light,
                radiance: [1.0, 0.7, 0.3],
            }],
            false,
        );
        let dir = if round % 3 == 0 { -axis(1.0) } else { unit() };
        let e = Specular::new([10.0, 1.0, 0.0][round % 3]);
        let h = Headlit::new(&scene, &scene.objects[0], dir, [0.2, 0.7, 0.3], e).unwrap();
        let z = || if next() < 0.5 { 0.0 } else { -0.0 };
        let d = || match (next() * 4.0) as usize {
            0 => -1.0,
            1 => 0.0,
            2 => 1e300,
            _ => (next() - 0.5) * 300.0,
        };
        let m = glam::DMat3::from_cols(
            DVec3::new(d(), z(), z()),
            DVec3::new(z(), d(), z()),
            DVec3::new(z(), z(), d()),
        );
        for flip in [false, true] {
            let diagonal = HeadlitLanes::new(&h, flip, Some(m)).unwrap();
            assert!(matches!(diagonal.to_world, ToWorld::Diagonal(_)));
            let mut general = HeadlitLanes::new(&h, flip, Some(m)).unwrap();
            let splat = |v: DVec3| v.to_array().map(Lanes::splat);
            general.to_world =
                ToWorld::General([splat(m.x_axis), splat(m.y_axis), splat(m.z_axis)]);
            let mut cs = [[0.0f32; 8]; 3];
            let mut grads = [[0.0; 8]; 3];
            for j in 0..8 {
                for a in 0..3 {
                    cs[a][j] = next() as f32;
                    grads[a][j] = if next() < 0.3 { z() } else { comp() };
                }
            }
            let view = h.view.to_array().map(Lanes::splat);
            let (mut a, mut b) = ([[0.0; 8]; 3], [[0.0; 8]; 3]);
            diagonal.colours(8, &view, &cs, &mut a, &grads);
            general.colours(8, &view, &cs, &mut b, &grads);
            assert_eq!(
                a.map(|c| c.map(f64::to_bits)),
                b.map(|c| c.map(f64::to_bits)),
                "{m:?} {grads:?}"
            );
            // Nor does the sign of a zero component of the gradient change a colour
            // (`Dataset::trilinear_gradient_in` may give either), in object space or in
            // world space.
            let flipped = grads.map(|a| a.map(|x| if x == 0.0 { -x } else { x }));
            let mut world = HeadlitLanes::new(&h, flip, None).unwrap();
            for lanes in [&diagonal, &general, &mut world] {
                let (mut a, mut b) = ([[0.0; 8]; 3], [[0.0; 8]; 3]);
                lanes.colours(8, &view, &cs, &mut a, &grads);
                lanes.colours(8, &view, &cs, &mut b, &flipped);
                assert_eq!(
                    a.map(|c| c.map(f64::to_bits)),
                    b.map(|c| c.map(f64::to_bits)),
                    "{grads:?}"
                );
            }
            compared += 8;
        }
    }
    assert!(compared > 6000);
}

/// [`HeadlitLanes`] gives [`Headlit::colour`]'s colour bit for bit, the normal made by
/// [`normal_of_gradient`] as [`CObj::gradient_normal`] makes it: for runs of 1 to 8
/// samples, random lights, views and gradients (N·L and R·V of either sign, exactly ±0,
/// vanishing, NaN and subnormal gradients), kd or ks 0 or negative, integer exponents,
/// normals flipped or not, colours from 0 to overflowing. It is refused for several lights,
/// none (kd and ks 0) and other exponents, which the scalar path keeps.
#[test]
fn headlit_lanes_are_headlit() {
    let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
    let (next, unit) = (|| rng.next(), || unit_dir(&|| rng.next()));
    let light = |to_light: DVec3, radiance: [f32; 3]| Light::Directional { to_light, radiance };
    // What the scalar colours exercised: lit with a specular term, lit without, facing
    // away, no normal, and not finite.
    let mut seen = [0usize; 5];
    let mut compared = 0;
    for round in 0..12 {
        let to_light = match round % 3 {
            0 => DVec3::new(0.0, -1.0, 0.0),
            _ => unit(),
        };
        let radiance = [1.0, 0.5 + next() as f32, 2.0 * next() as f32];
        let scene = lit_scene(vec![light(to_light, radiance)], false);
        let obj = &scene.objects[0];
        for k in [
            [0.2, 0.7, 0.3],
            [1.0, 0.0, 0.5],
            [0.1, 0.9, 0.0],
            [0.3, -0.5, 0.4],
        ] {
            for e in [10.0, 0.0, 1.0, 7.0, 128.0].map(Specular::new) {
                for flip in [false, true] {
                    for _ in 0..60 {
                        let dir = match round % 3 {
                            0 => DVec3::new(0.0, 1.0, 0.0),
                            _ => unit(),
                        };
                        let h = Headlit::new(&scene, obj, dir, k, e).expect("directional");
                        // Gradients in world space, or in object space for the lanes to
                        // transform (a random matrix, as `CObj::field_gradient` would, or
                        // a diagonal one, a flip or scale along the axes, with +0 and −0
                        // off the diagonal).
                        let to_world = match (next() * 4.0) as usize {
                            0 | 1 => None,
                            2 => Some(glam::DMat3::from_cols(unit() * 3.0, unit(), unit() * 0.1)),
                            _ => {
                                let z = || if next() < 0.5 { 0.0 } else { -0.0 };
                                let d = || match (next() * 5.0) as usize {
                                    0 => -1.0,
                                    1 => 0.0,
                                    2 => 196.0,
                                    _ => (next() - 0.5) * 300.0,
                                };
                                Some(glam::DMat3::from_cols(
                                    DVec3::new(d(), z(), z()),
                                    DVec3::new(z(), d(), z()),
                                    DVec3::new(z(), z(), d()),
                                ))
                            }
                        };
                        let lanes = HeadlitLanes::new(&h, flip, to_world).expect("one light");
                        let count = 1 + (next() * 8.0) as usize;
                        let (mut cs, mut grads) = ([[0.0f32; 8]; 3], [[0.0; 8]; 3]);
                        let mut want = Vec::new();
                        for j in 0..count {
                            // Colours in f32, as the tables give them (the largest, and
                            // an infinite one, included).
                            let v = next();
                            let c32 = if v < 0.03 {
                                [f32::MAX, next() as f32, 0.0]
                            } else if v < 0.05 {
                                [next() as f32, f32::INFINITY, 0.0]
                            } else {
                                let b = (next() < 0.8) as u8 as f32;
                                [next() as f32, next() as f32 * 2.0, b]
                            };
                            let c = DVec3::from_array(c32.map(f64::from));
                            let u = next();
                            let (g, zero) = if u < 0.05 {
                                (DVec3::ZERO, true)
                            } else if u < 0.1 {
                                (unit(), true)
                            } else if u < 0.13 {
                                (DVec3::new(f64::NAN, 1.0, 0.0), false)
                            } else if u < 0.16 {
                                (DVec3::new(1e-320, 0.0, 0.0), false)
                            } else if u < 0.22 {
                                // About the threshold of a vanishing gradient.
                                let t = ZERO_GRADIENT;
                                let tiny = [0.0, -0.0, t, -t, t.next_up(), -t.next_up()];
                                let pick = || match (next() * 9.0) as usize {
                                    k @ 0..6 => tiny[k],
                                    6 => 1e-320,
                                    7 => t * next(),
                                    _ => -t * next(),
                                };
                                let g = DVec3::new(pick(), pick(), pick());
                                (g, vanishing(g.to_array()).1)
                            } else if u < 0.25 {
                                // Along an axis: N·L exactly ±0 or ±1 for the axis light
                                // (the other components +0 or −0).
                                let z = || if next() < 0.5 { 0.0 } else { -0.0 };
                                let mut g = DVec3::new(z(), z(), z());
                                g[(next() * 3.0) as usize] = next() - 0.5;
                                (g, false)
                            } else {
                                (unit() * (0.001 + 100.0 * next()), false)
                            };
                            // An object-space gradient is a dataset's: it vanishes as
                            // `vanishing` finds, and the lanes test that themselves
                            // (given as it is, or as NaN where it vanishes, as the march
                            // passes a gradient from `CObj::field_gradient_in`).
                            let (g, zero, as_it_is) = match to_world {
                                Some(_) => (g, vanishing(g.to_array()).1, next() < 0.5),
                                None => (g, zero, false),
                            };
                            let view = -dir;
                            let world = to_world.map_or(g, |m| m * g);
                            let n = normal_of_gradient(world, zero, view, flip);
                            let col = h.colour(c, || n);
                            want.push(col);
                            let case = match n {
                                _ if col == DVec3::ZERO && c != DVec3::ZERO => 4,
                                None => 3,
                                Some(n) if n.dot(to_light) <= 0.0 => 2,
                                Some(n)
                                    if (2.0 * n.dot(to_light) * n - to_light).dot(view) > 0.0 =>
                                {
                                    0
                                }
                                Some(_) => 1,
                            };
                            seen[case] += 1;
                            let g = if zero && !as_it_is {
                                [f64::NAN; 3]
                            } else {
                                g.to_array()
                            };
                            for a in 0..3 {
                                cs[a][j] = c32[a];
                                grads[a][j] = g[a];
                            }
                        }
                        let view = h.view.to_array().map(Lanes::splat);
                        let mut out = [[0.0; 8]; 3];
                        lanes.colours(count, &view, &cs, &mut out, &grads);
                        for (j, want) in want.iter().enumerate() {
                            let got = [out[0][j], out[1][j], out[2][j]];
                            assert_eq!(
                                got.map(f64::to_bits),
                                want.to_array().map(f64::to_bits),
                                "{got:?} {want:?}"
                            );
                            compared += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(compared > 40_000, "{compared}");
    assert!(seen.iter().all(|&n| n > 500), "{seen:?}");
    // Refused: several lights, none (kd and ks 0), an exponent that is not an integer.
    let one = lit_scene(vec![light(DVec3::Y, [1.0; 3])], false);
    let two = lit_scene(
        vec![light(DVec3::Y, [1.0; 3]), light(DVec3::X, [1.0; 3])],
        false,
    );
    let (k, e) = ([0.2, 0.7, 0.3], Specular::new(10.0));
    let headlit = |scene, k, e| Headlit::new(scene, &scene.objects[0], DVec3::X, k, e);
    assert!(HeadlitLanes::new(&headlit(&one, k, e).unwrap(), false, None).is_some());
    assert!(HeadlitLanes::new(&headlit(&two, k, e).unwrap(), false, None).is_none());
    let dark = headlit(&one, [0.2, 0.0, 0.0], e).unwrap();
    assert!(HeadlitLanes::new(&dark, false, None).is_none());
    let e = Specular::new(20.5);
    assert!(HeadlitLanes::new(&headlit(&one, k, e).unwrap(), false, None).is_none());
}

/// The march in lanes is the march without them and the sample-by-sample loop, bit for
/// bit, ray for ray, through a lit random volume opaque enough that most rays end inside
/// a run (the transmittance falls below the threshold at a sample with others after it):
/// no sample after the end is lit, and the gradient cache is read in the same order.
#[test]
fn lanes_march_is_the_march() {
    use crate::types::MappingType;
    let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
    let next = || rng.next();
    let n = 24usize;
    // Smooth blobs, with flat (zero-gradient) patches at 0 and 255.
    let centres: Vec<[f64; 4]> = (0..6)
        .map(|_| {
            [
                next() * 24.0,
                next() * 24.0,
                next() * 24.0,
                3.0 + next() * 5.0,
            ]
        })
        .collect();
    let voxels: Vec<u8> = (0..n * n * n)
        .map(|i| {
            let p = [(i % n) as f64, (i / n % n) as f64, (i / n / n) as f64];
            let v: f64 = centres
                .iter()
                .map(|c| {
                    let d2 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f64>();
                    300.0 * (-d2 / (c[3] * c[3])).exp()
                })
                .sum();
            v.min(255.0) as u8
        })
        .collect();
    let data = Dataset::new([n; 3], crate::data::Voxels::U8(voxels), 0.0, 1.0).unwrap();
    let mut terminated = 0;
    for (ks, exponent) in [(0.3, 10.0), (0.0, 10.0), (0.6, 3.0), (0.3, 20.5)] {
        let mut vl = crate::Library::new();
        vl.add_dataset(DatasetId(1), data.clone()).unwrap();
        vl.mapping(
            MappingId(2),
            MappingType::Ramp,
            3,
            1,
            &[0.15, 0.0, 0.5, 0.6, 1.0, 0.95],
        )
        .unwrap();
        let colour = [0.2, 0.55, 0.35, 0.3, 0.6, 0.9, 0.7, 0.5, 1.0, 1.0, 1.0, 1.0];
        vl.mapping(MappingId(3), MappingType::Ramp, 3, 3, &colour)
            .unwrap();
        vl.scene().unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.directional_light([0.3, -1.0, 0.2], [1.0, 0.9, 0.8], 1.0)
            .unwrap();
        vl.step_size(0.5, 1.0).unwrap();
        vl.object().unwrap();
        vl.scale(23.0, 23.0, 23.0).unwrap();
        vl.dataset(Fields::F, DatasetId(1)).unwrap();
        vl.map(Fields::O, Fields::F, MappingId(2), 1).unwrap();
        vl.map(Fields::R, Fields::F, MappingId(3), 1).unwrap();
        vl.map(Fields::G, Fields::F, MappingId(3), 2).unwrap();
        vl.map(Fields::B, Fields::F, MappingId(3), 3).unwrap();
        vl.set(Fields::KA, 0.2).unwrap();
        vl.set(Fields::KD, 0.7).unwrap();
        vl.set(Fields::KS, ks).unwrap();
        vl.set(Fields::N, crate::types::specular_to_field(exponent))
            .unwrap();
        vl.end().unwrap();
        let scene = vl.compiled().unwrap();
        let obj = &scene.objects[0];
        let lean = obj.lean.as_ref().expect("lean");
        let (data, z) = lean.value_head().expect("a value head");
        assert!(lean.direct_shading().is_some());
        let stop = scene.settings.optimise.stop_below();
        for _ in 0..400 {
            let at = DVec3::new(next(), next(), next()) * 23.0;
            let dir = unit_dir(&next);
            let origin = at - 60.0 * dir;
            let (o, d) = obj.object_ray(origin, dir);
            let Some((t0, t1)) = obj.clip(o, d) else {
                continue;
            };
            let cursor = || Cursor::new(&scene, obj, 0, (o, d), (t0, t1), f64::NEG_INFINITY);
            let (mut a, mut b, mut c) = (cursor(), cursor(), cursor());
            let lanes = scene.march_batched::<true>(obj, lean, data, z, &mut a, origin, dir);
            let plain = scene.march_batched::<false>(obj, lean, data, z, &mut b, origin, dir);
            // The sample-by-sample loop (`march_one`'s general one).
            let (mut col, mut t) = (DVec3::ZERO, 1.0f64);
            while let Some(mid) = c.peek(obj.skip.as_deref()) {
                let len = c.take();
                if len <= 0.0 {
                    continue;
                }
                let (w, p) = (origin + mid * dir, c.object_point(mid));
                if let Some((alpha, colour)) = scene.shade(obj, w, p, dir, len) {
                    col += t * alpha * colour;
                    t *= 1.0 - alpha;
                    if t < stop {
                        t = 0.0;
                        break;
                    }
                }
            }
            let bits = |(c, t): (DVec3, f64)| (c.to_array().map(f64::to_bits), t.to_bits());
            assert_eq!(bits(lanes), bits(plain));
            assert_eq!(bits(lanes), bits((col, t)));
            terminated += (lanes.1 == 0.0) as usize;
        }
    }
    assert!(terminated > 300, "{terminated}");
}

/// A scene of one DVR volume with a skip grid: random spheres in a 20³ dataset, scaled
/// to a box 19 wide.
fn sphere_scene() -> Compiled {
    let scene = sphere_library().compiled().unwrap();
    assert!(scene.objects[0].skip.is_some(), "a skip grid");
    scene
}

/// The library of [`sphere_scene`], its scene open.
fn sphere_library() -> crate::Library {
    sphere_library_with(false)
}

/// [`sphere_library`], and where `lit`, the spheres lit by ambient light (KA 1) and seen from
/// above and in front.
fn sphere_library_with(lit: bool) -> crate::Library {
    use crate::types::MappingType;
    let n = 20usize;
    let centres = [
        [5.0, 6.0, 7.0, 3.0],
        [14.0, 12.0, 9.0, 4.0],
        [8.0, 15.0, 15.0, 2.5],
    ];
    let voxels: Vec<u8> = (0..n * n * n)
        .map(|i| {
            let p = [(i % n) as f64, (i / n % n) as f64, (i / n / n) as f64];
            let inside = centres
                .iter()
                .any(|c| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f64>() < c[3] * c[3]);
            if inside {
                200
            } else {
                0
            }
        })
        .collect();
    let data = Dataset::new([n; 3], crate::data::Voxels::U8(voxels), 0.0, 1.0).unwrap();
    let mut vl = crate::Library::new();
    vl.add_dataset(DatasetId(1), data).unwrap();
    vl.mapping(
        MappingId(2),
        MappingType::Ramp,
        3,
        1,
        &[0.3, 0.0, 0.5, 0.6, 1.0, 0.95],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    if lit {
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.camera(&crate::Camera {
            eye: [9.5, 30.0, -40.0],
            at: [9.5; 3],
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
        })
        .unwrap();
    }
    vl.object().unwrap();
    vl.scale(19.0, 19.0, 19.0).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(2), 1).unwrap();
    vl.set(Fields::R, 1.0).unwrap();
    if lit {
        vl.set(Fields::KA, 1.0).unwrap();
    }
    vl.end().unwrap();
    vl
}

/// Ray parts that make trouble: zeros of both signs, magnitudes below 10⁻³⁰⁸ (whose
/// reciprocals overflow), huge values, infinities and NaN, and ordinary ones.
const AWKWARD: [f64; 14] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.37,
    -2.5,
    1e-310,
    -1e-310,
    1e300,
    -1e300,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
    19.0,
];

/// [`CObj::clip`] as it was, with `f64::min` / `f64::max`.
fn clip_reference(min: DVec3, max: DVec3, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for i in 0..3 {
        if d[i] == 0.0 {
            if o[i] < min[i] || o[i] > max[i] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[i];
        let (a, b) = ((min[i] - o[i]) * inv, (max[i] - o[i]) * inv);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 < t1 && t1.is_finite()).then_some((t0, t1))
}

/// The clip is the NaN-aware one, bit for bit: rays from outside, inside, on faces and
/// edges, parallel to faces, with zero, tiny, huge, infinite and NaN parts, through
/// ordinary, flat (one axis of zero width) and signed-zero boxes.
#[test]
fn clip_is_the_nan_aware_clip() {
    let mut scene = sphere_scene();
    let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
    let next = || rng.next();
    let boxes = [
        (DVec3::ZERO, DVec3::ONE),
        (DVec3::new(-0.0, 0.0, -0.0), DVec3::new(2.0, 0.0, 1.0)),
        (DVec3::new(-3.0, 1e-310, -1.0), DVec3::new(-1.0, 1.0, 1e300)),
    ];
    let (mut some, mut none) = (0, 0);
    for (min, max) in boxes {
        scene.objects[0].box_min = min;
        scene.objects[0].box_max = max;
        let obj = &scene.objects[0];
        let mut check = |o: DVec3, d: DVec3| {
            let bits = |r: Option<(f64, f64)>| r.map(|(a, b)| (a.to_bits(), b.to_bits()));
            let got = obj.clip(o, d);
            assert_eq!(bits(got), bits(clip_reference(min, max, o, d)), "{o} {d}");
            // The packet march's clip in lanes, the same numbers.
            #[cfg(target_arch = "x86_64")]
            if is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 was detected.
                let lanes = unsafe {
                    use std::arch::x86_64::_mm256_set1_pd as splat;
                    let (t0, t1, ok) =
                        simd::clip_lanes(o, &[splat(d.x), splat(d.y), splat(d.z)], min, max);
                    (ok & 1 != 0).then(|| (simd::st4d(t0)[0], simd::st4d(t1)[0]))
                };
                assert_eq!(bits(lanes), bits(got), "lanes: {o} {d}");
            }
            if got.is_some() {
                some += 1;
            } else {
                none += 1;
            }
        };
        let mut parts: Vec<f64> = AWKWARD.to_vec();
        parts.extend([min.x, max.y, min.z, max.x]);
        let inside = (min + max) * 0.5;
        for &a in &parts {
            for &b in &parts {
                for &c in &parts {
                    let v = DVec3::new(a, b, c);
                    check(inside, v);
                    check(v, DVec3::new(0.3, -0.5, 0.8));
                    check(v, DVec3::new(b, c, a));
                    check(DVec3::new(-5.0, c, b), v);
                }
            }
        }
        for _ in 0..20_000 {
            let o = DVec3::new(next() * 8.0 - 4.0, next() * 8.0 - 4.0, next() * 8.0 - 4.0);
            let mut d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            // Some parallel to a face.
            let axis = (next() * 6.0) as usize;
            if axis < 3 {
                d[axis] = 0.0;
            }
            check(o, d);
        }
    }
    assert!(some > 10_000 && none > 10_000, "{some} / {none}");
}

/// The packet march's ray starts in lanes are the scalar ones, bit for bit: the directions
/// of `Pinhole::ray` and their object-space directions (random cameras and placements,
/// every pixel of small images), segment counts of `segment_count` (where the lanes give
/// one), and first segments of `Cursor::start_at` (where the lanes give one: at bounds
/// before, on and between midpoints, past the end, at awkward values).
#[cfg(target_arch = "x86_64")]
#[test]
fn ray_start_lanes_are_the_scalar_starts() {
    use std::arch::x86_64::*;
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    let rng = Xorshift::new(0x5a77_1e5f_0ca5_7e11);
    let next = || rng.next();
    // Directions.
    for case in 0..200 {
        let (w, h) = (5 + (next() * 40.0) as u32, 3 + (next() * 30.0) as u32);
        let view = Pinhole {
            eye: DVec3::ZERO,
            forward: unit_dir(&next) * (0.5 + next() * 3.0),
            right: unit_dir(&next) * (0.1 + next()),
            up: unit_dir(&next) * (0.1 + next()),
            width: w,
            height: h,
        };
        let to_object = glam::DMat4::from_cols_array(&std::array::from_fn(|i| {
            if i % 5 == 0 || case % 3 != 0 {
                next() * 4.0 - 2.0
            } else {
                0.0
            }
        }));
        for y in 0..h {
            for x0 in (0..w).step_by(4) {
                // SAFETY: AVX2 was detected above.
                let (dir, d) = unsafe { simd::ray_lanes(&view, &to_object, x0, y) };
                let (dir, d) = unsafe { (dir.map(|v| simd::st4d(v)), d.map(|v| simd::st4d(v))) };
                for l in 0..4 {
                    let want = view.ray((x0 + l as u32) as f64 + 0.5, y as f64 + 0.5);
                    let want_d = to_object.transform_vector3(want);
                    for c in 0..3 {
                        assert_eq!(
                            dir[c][l].to_bits(),
                            want[c].to_bits(),
                            "{case} {x0}+{l} {y}"
                        );
                        assert_eq!(
                            d[c][l].to_bits(),
                            want_d[c].to_bits(),
                            "{case} {x0}+{l} {y}"
                        );
                    }
                }
            }
        }
    }
    // Counts and first segments.
    let mut values: Vec<f64> = AWKWARD.to_vec();
    values.extend([0.25, 0.5, 1.0 / 3.0, 7.5, 1e-3, 1e-12, 3e15]);
    let (mut counted, mut found, mut searched) = (0, 0, 0);
    for case in 0..20_000 {
        let pick = || values[(next() * values.len() as f64) as usize % values.len()];
        // A cursor's span and step are finite and positive (`CObj::clip`, the state's
        // checks); here its segments below 2⁴⁰ and its step resolvable at its ends (a
        // step below their spacing of numbers has no midpoints to search among, and
        // the cursor's own search walks them one by one).
        let (t0, len, step) = if case % 4 == 0 {
            let (t0, len, step) = (pick().abs(), pick().abs(), pick().abs());
            if !(t0.is_finite() && len > 0.0 && step > 0.0 && (t0 + len).is_finite())
                || len / step >= (1u64 << 40) as f64
                || step < (t0 + len) * 1e-9
            {
                continue;
            }
            (t0, len, step)
        } else {
            let step = [0.5, 1.0 / 3.0, 0.01, 2.0, 1e-9][case % 5] * (0.5 + next());
            (next() * 50.0, next() * [1.0, 100.0, 1e-6][case % 3], step)
        };
        let t1 = t0 + len;
        let lanes = |x: [f64; 4]| unsafe { _mm256_loadu_pd(x.as_ptr()) };
        let n_scalar = segment_count((t1 - t0) / step);
        // SAFETY: AVX2 was detected above.
        let n = unsafe { simd::count_lanes(lanes([t0; 4]), lanes([t1; 4]), step) };
        if n[0] != 0 {
            assert_eq!(n[0], n_scalar, "{t0} {t1} {step}");
            counted += 1;
        }
        let c = cursor(t0, t1, step, n_scalar, 0, f64::NEG_INFINITY);
        let mid = |k: u64| c.mid(k.min(n_scalar - 1));
        let k = (next() * n_scalar.min(1 << 20) as f64) as u64;
        let ts = [
            t0 - 1.0,
            mid(k),
            mid(k) + step * 0.25,
            mid(k + 1) - step * 1e-9,
            t1 + step,
            pick(),
            f64::NEG_INFINITY,
            t0 + (next() - 0.2) * len * 1.3,
        ];
        for chunk in ts.chunks(4) {
            let t: [f64; 4] = chunk.try_into().unwrap();
            // SAFETY: AVX2 was detected above.
            let got = unsafe {
                simd::first_segments(lanes([t0; 4]), lanes([t1; 4]), step, [n[0]; 4], lanes(t))
            };
            for (l, &t) in t.iter().enumerate() {
                let mut want = cursor(t0, t1, step, n_scalar, 0, f64::NEG_INFINITY);
                want.start_at(t);
                match got[l] {
                    Some(k) => {
                        assert_eq!(k, want.k, "{t0} {t1} {step} n {n_scalar} t {t}");
                        found += 1;
                    }
                    None => searched += 1,
                }
            }
        }
    }
    assert!(
        counted > 15_000 && found > 80_000,
        "{counted} {found} {searched}"
    );
}

/// A ray whose entry bound is +∞ shows the background as the clip and march would give
/// it, bit for bit (`background` where it misses the box, `0 + 1·background` where it
/// meets it): through a background with −0 parts too (where the two differ), infinite
/// and NaN parts, and rays with zero, tiny, infinite and NaN parts.
#[test]
fn unbounded_rays_show_the_background() {
    let mut scene = sphere_scene();
    let (mut checked, mut known) = (0, 0);
    for background in [
        [0.2f32, 0.5, 0.9],
        [-0.0, 0.5, 0.0],
        [f32::NAN, f32::INFINITY, -0.0],
    ] {
        scene.settings.background = background;
        let bg = crate::model::scene::v3(background);
        let obj = &scene.objects[0];
        for &a in &AWKWARD {
            for &b in &AWKWARD {
                for (origin, dir) in [
                    (DVec3::new(-30.0, a, 9.0), DVec3::new(1.0, b, 0.01)),
                    (DVec3::new(a, b, 5.0), DVec3::new(0.2, 0.3, 0.9)),
                    (DVec3::new(9.0, 9.0, 9.0), DVec3::new(a, b, 1.0)),
                    (DVec3::new(9.0, 40.0, a), DVec3::new(0.0, -1.0, b)),
                ] {
                    let (o, d) = obj.object_ray(origin, dir);
                    let want = match obj.clip(o, d) {
                        None => bg,
                        Some(_) => DVec3::ZERO + 1.0 * bg,
                    };
                    let (got, t) = scene.trace_ray(origin, None, dir, Ray::PRIMARY, f64::INFINITY);
                    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                    assert_eq!(bits(got), bits(want), "{origin} {dir} {background:?}");
                    assert_eq!(t, 1.0, "{origin} {dir}: the background shows whole");
                    let image = scene.image_rays(origin, Backdrop::Background);
                    let (per_image, _) = scene.trace(origin, &image, dir, f64::INFINITY);
                    assert_eq!(bits(per_image), bits(want), "{origin} {dir} {background:?}");
                    // The per-pixel loop's answer without the ray, where it has one.
                    if let Some(c) = scene.unbounded_colour(&image) {
                        assert_eq!(bits(c), bits(got), "{origin} {dir} {background:?}");
                        known += 1;
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 2000 && known > 700, "{checked} {known}");
}

/// The one-volume path, whose cursor is built in place ([`Cursor::unstarted`] and
/// [`Cursor::start`]), is [`Cursor::new`] and [`Compiled::march_one`], bit for bit, for
/// entry bounds of −∞, NaN, the clip's t0, and points inside the box's span.
#[test]
fn cursor_started_in_place_is_the_new_cursor() {
    let mut scene = sphere_scene();
    scene.settings.background = [0.1, 0.2, 0.3];
    let bg = crate::model::scene::v3(scene.settings.background);
    let obj = &scene.objects[0];
    let rng = Xorshift::new(0x9e37_79b9_7f4a_7c15u64);
    let next = || rng.next();
    let (mut hits, mut checked) = (0, 0);
    for i in 0..3000 {
        let at = DVec3::new(next(), next(), next()) * 19.0;
        let mut dir = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
        if i % 7 == 0 {
            dir[i % 3] = 0.0;
        }
        let origin = at - 50.0 * dir;
        let (o, d) = obj.object_ray(origin, dir);
        let Some((t0, t1)) = obj.clip(o, d) else {
            continue;
        };
        for bound in [f64::NEG_INFINITY, f64::NAN, t0, t0 + (t1 - t0) * next()] {
            let mut c = Cursor::new(&scene, obj, 0, (o, d), (t0, t1), bound);
            let (col, t) = scene.march_one(&mut c, origin, dir);
            let want = col + t * bg;
            let (got, got_t) = scene.trace_ray(origin, None, dir, Ray::PRIMARY, bound);
            let bits = |v: DVec3| v.to_array().map(f64::to_bits);
            assert_eq!(bits(got), bits(want), "{origin} {dir} {bound}");
            assert_eq!(got_t.to_bits(), t.to_bits(), "{origin} {dir} {bound}");
            // And with the origin and background made once per image (`Compiled::trace`).
            let image = scene.image_rays(origin, Backdrop::Background);
            let (per_image, _) = scene.trace_ray(origin, Some(&image), dir, Ray::PRIMARY, bound);
            assert_eq!(bits(per_image), bits(want), "{origin} {dir} {bound}");
            hits += (t < 1.0) as usize;
            checked += 1;
        }
    }
    assert!(checked > 2000 && hits > 500, "{checked} / {hits}");
}

/// `index_f64` is `k as f64` bit for bit, for counts n ≥ k below and above 2⁶³: small
/// numbers, around 2⁵³ (where the conversion starts rounding), 2⁶³ and 2⁶⁴, and random bit
/// patterns of every width.
#[test]
fn index_f64_is_the_unsigned_conversion() {
    let mut ks = vec![0u64, 1, 2, 3, 1000, u64::MAX, u64::MAX - 1];
    for e in [52u32, 53, 54, 62, 63] {
        let b = 1u64 << e;
        ks.extend([b - 2, b - 1, b, b + 1, b + 2, b + 3]);
    }
    let rng = Xorshift::new(0x2545_f491_4f6c_dd1du64);
    for i in 0..4000 {
        ks.push(rng.bits() >> (i % 64));
    }
    for &k in &ks {
        for n in [
            k,
            k.saturating_add(1),
            k | (1 << 62),
            i64::MAX as u64,
            u64::MAX,
        ] {
            let (k, n) = std::hint::black_box((k, n.max(k)));
            assert_eq!(
                index_f64(k, n).to_bits(),
                (k as f64).to_bits(),
                "{k} of {n}"
            );
        }
    }
}

/// `transmit_at_most_one` is the opaque medium's test, then `transmit`, bit for bit on
/// opacities of [0, 1] (±0, subnormal, near 1, 1), below 0, −∞ and NaN, each against the
/// common exponents, their neighbours, 0, ±subnormal, negative, huge, ±∞, NaN and random
/// exponents; and random opacity bits with the sign of a number not above 1.
#[test]
fn transmit_at_most_one_is_the_tested_transmit() {
    // (The opaque medium's test first, then `transmit`.)
    let tested = |o: f64, e: f64| if o >= 1.0 { 0.0 } else { transmit(1.0 - o, e) };
    let rng = Xorshift::new(0x2545_f491_4f6c_dd1d);
    let mut os = vec![
        0.0,
        -0.0,
        1.0,
        1.0 - f64::EPSILON / 2.0,
        1.0 - f64::EPSILON,
        0.5,
        0.25,
        1e-310,
        f64::MIN_POSITIVE,
        -1e-310,
        -1.0,
        -1e300,
        f64::NEG_INFINITY,
        f64::NAN,
        -f64::NAN,
        f32::MIN_POSITIVE as f64,
        (1.0f32 - f32::EPSILON / 2.0) as f64,
    ];
    os.extend((0..2000).map(|_| rng.next()));
    os.extend((0..2000).map(|_| rng.next() as f32 as f64));
    os.extend((0..2000).map(|_| {
        let o = f64::from_bits(rng.bits());
        if o > 1.0 {
            -o
        } else {
            o
        }
    }));
    let mut es = vec![
        0.0,
        -0.0,
        1.0,
        0.5,
        0.25,
        2.0,
        -0.5,
        -1.0,
        -2.0,
        1e-310,
        -1e-310,
        1e300,
        -1e300,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        3.0,
        0.125,
        4.0,
        8.0,
        0.0625,
    ];
    for e in [1.0f64, 0.5, 0.25, 2.0, 0.125, 4.0] {
        es.extend([e.next_up(), e.next_down()]);
    }
    es.extend((0..40).map(|_| rng.next() * 4.0));
    es.extend((0..40).map(|_| f64::from_bits(rng.bits())));
    for &o in &os {
        for &e in &es {
            let (a, b) = (transmit_at_most_one(o, e), tested(o, e));
            assert!(
                a.to_bits() == b.to_bits(),
                "o {o:e} e {e:e}: {a:e} against {b:e}"
            );
        }
    }
}

/// The segment count is ⌈x⌉ clamped as it was, at integers and next to them, in (0, 1),
/// around 2⁵² and 2⁶⁴, at zeros, negatives, infinities and NaN.
#[test]
fn segment_count_is_the_rounded_up_span() {
    let reference = |x: f64| {
        let n = crate::num::ceil(x).max(1.0);
        if n.is_finite() && n < u64::MAX as f64 {
            n as u64
        } else {
            u64::MAX
        }
    };
    let mut xs = vec![
        0.0,
        -0.0,
        -1.0,
        1e-310,
        0.5,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        1e300,
        u64::MAX as f64,
        (1u64 << 63) as f64,
    ];
    for base in [
        1.0f64,
        2.0,
        3.0,
        17.0,
        1e6,
        4_503_599_627_370_496.0,
        9e15,
        1.8e19,
    ] {
        let mut x = base;
        for _ in 0..4 {
            x = x.next_down();
        }
        for _ in 0..9 {
            xs.extend([x, -x, x + 0.5]);
            x = x.next_up();
        }
    }
    let rng = Xorshift::new(0x1234_5678_9abc_def1u64);
    for _ in 0..100_000 {
        let bits = rng.bits();
        xs.push(f64::from_bits(bits));
        xs.push((bits >> 11) as f64 / (1u64 << 40) as f64);
    }
    for x in xs {
        assert_eq!(segment_count(x), reference(x), "{x:e}");
    }
}

/// A random unit direction from `next` (uniform in [0, 1)).
fn unit_dir(next: &impl Fn() -> f64) -> DVec3 {
    DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5)
        .try_normalize()
        .unwrap_or(DVec3::Y)
}

/// A cursor over [t0, t1] in steps of `step`, with no walk.
fn cursor(t0: f64, t1: f64, step: f64, n: u64, k: u64, occupied_until: f64) -> Cursor {
    Cursor {
        object: 0,
        t0,
        t1,
        step,
        k,
        n,
        walk: None,
        o: DVec3::ZERO,
        d: DVec3::X,
        occupied_until,
        probe_at: super::cursor::PROBE_EVERY,
    }
}

/// A run that ends where the walk's block does, the next `Cursor::peek` asking the walk
/// about the sample past it (the oracle of `joined_runs_are_peek_and_run`, which
/// `Cursor::next_run` joins across occupied blocks): from the sample `Cursor::peek` chose, the samples
/// after it in the occupied block the walk last reported (all unless `unbounded`), up to
/// eight; their number, their midpoints and lengths written into `mids` and `lens`.
fn run(c: &Cursor, unbounded: bool, mids: &mut [f64; 8], lens: &mut [f64; 8]) -> usize {
    let left = c.segments(mids, lens);
    // The first sample is in the block (peek chose it); the run ends at the first other
    // one that is not.
    if unbounded {
        left
    } else {
        (1..left)
            .find(|&j| mids[j].partial_cmp(&c.occupied_until) != Some(std::cmp::Ordering::Less))
            .unwrap_or(left)
    }
}

/// `Cursor::segments` with the last segment's end set in its lane of the ends (rather than
/// its sample made again from its start): the oracle of
/// `segments_last_lane_apart_is_the_lane_set_run`.
fn segments_lane_set(c: &Cursor, mids: &mut [f64; 8], lens: &mut [f64; 8]) -> usize {
    let left = (c.n - c.k).min(8) as usize; // k < n
    let last = c.k + left as u64 == c.n; // the run may reach the last segment
    let k = index_f64(c.k, c.n);
    if k < (1u64 << 53) as f64 - 16.0 {
        let next: [f64; 8] = std::array::from_fn(|j| c.boundary(k + (j + 1) as f64));
        let a: [f64; 8] = std::array::from_fn(|j| if j == 0 { c.boundary(k) } else { next[j - 1] });
        let mut b = next.map(|x| at_most(x, c.t1));
        if last {
            b[left - 1] = c.t1;
        }
        *mids = std::array::from_fn(|j| 0.5 * (a[j] + b[j]));
        *lens = std::array::from_fn(|j| b[j] - a[j]);
    } else {
        let mut a = c.boundary(k);
        let mut kf = k;
        for j in 0..left {
            kf += 1.0;
            let next = c.boundary(kf);
            let b = c.end(next, last && j + 1 == left);
            mids[j] = 0.5 * (a + b);
            lens[j] = b - a;
            a = next;
        }
    }
    left
}

/// The bits of `x`, every NaN as one: which operand's NaN an addition passes on depends on
/// the order the compiler gives its operands (it may swap them), and a march's ends and
/// step are never NaN.
fn nan_any(x: f64) -> u64 {
    if x.is_nan() {
        u64::MAX
    } else {
        x.to_bits()
    }
}

/// A cursor's span and step for the segment tests' case `case`: ordinary (even cases) or
/// awkward (±0, subnormal, huge, infinite, NaN, random bits: every third case's parts are
/// random bits).
fn segment_span(rng: &Xorshift, case: usize) -> (f64, f64, f64) {
    let mut values: Vec<f64> = AWKWARD.to_vec();
    values.extend([0.25, 0.5, 1.0 / 3.0, 7.5, 1e-3]);
    let pick = || {
        if case.is_multiple_of(3) {
            f64::from_bits(rng.bits())
        } else {
            values[(rng.next() * values.len() as f64) as usize % values.len()]
        }
    };
    if case.is_multiple_of(2) {
        let t0 = rng.next() * 10.0;
        (t0, t0 + rng.next() * 20.0, 0.01 + rng.next())
    } else {
        (pick(), pick(), pick())
    }
}

/// The run's segments with the last lane made apart are those of the lane set in place bit for
/// bit ([`segments_lane_set`]): every
/// run length, near the start, the end and 2⁵³, for ordinary and awkward ends and steps
/// (±0, subnormal, huge, infinite, NaN, random bits). A NaN is any NaN ([`nan_any`]).
#[test]
fn segments_last_lane_apart_is_the_lane_set_run() {
    let rng = Xorshift::new(0x0dd5_e9e5_1a57_1a9e);
    let mut checked = 0;
    for case in 0..4000 {
        let (t0, t1, step) = segment_span(&rng, case);
        let n = [1u64, 2, 7, 8, 9, 17, 1 << 20, (1 << 53) + 5, u64::MAX][case % 9];
        for k in [
            0,
            n / 2,
            n.saturating_sub(9),
            n.saturating_sub(8),
            n - 1,
            n.saturating_sub(3),
        ] {
            if k >= n {
                continue;
            }
            let c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
            let (mut m0, mut l0) = ([0.5; 8], [0.5; 8]);
            let (mut m1, mut l1) = ([0.5; 8], [0.5; 8]);
            let a = segments_lane_set(&c, &mut m0, &mut l0);
            let b = c.segments(&mut m1, &mut l1);
            assert_eq!(a, b);
            assert_eq!(m0.map(nan_any), m1.map(nan_any), "{t0} {t1} {step} {k}/{n}");
            assert_eq!(l0.map(nan_any), l1.map(nan_any), "{t0} {t1} {step} {k}/{n}");
            checked += 1;
        }
    }
    assert!(checked > 15_000, "{checked}");
}

/// The packet march's segments in lanes are the cursor's, bit for bit, on the cases of
/// `segments_last_lane_apart_is_the_lane_set_run` (every run length, near the start, the end
/// and 2⁵³, ordinary and awkward ends and steps). A NaN is any NaN ([`nan_any`]).
#[cfg(target_arch = "x86_64")]
#[test]
fn lanes_segments_are_the_cursors() {
    if !is_x86_feature_detected!("avx2") {
        return;
    }
    let rng = Xorshift::new(0x5e9_3e47_1a9e_5eed);
    let mut checked = 0;
    for case in 0..4000 {
        let (t0, t1, step) = segment_span(&rng, case);
        let n = [1u64, 2, 7, 8, 9, 17, 1 << 20, (1 << 53) + 5, u64::MAX][case % 9];
        for k in [
            0,
            n / 2,
            n.saturating_sub(17),
            n.saturating_sub(9),
            n.saturating_sub(8),
            n - 1,
            n.saturating_sub(3),
            ((1u64 << 53) - 17).min(n - 1),
        ] {
            let c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
            let (mut m0, mut l0) = ([0.5; 8], [0.5; 8]);
            let (mut m1, mut l1) = ([0.5; 8], [0.5; 8]);
            let a = c.segments(&mut m0, &mut l0);
            // SAFETY: AVX2 was detected above.
            let b = unsafe { simd::segments_lanes(&c, &mut m1, &mut l1) };
            assert_eq!(a, b);
            let bits = |x: &[f64; 8]| x[..a].iter().map(|&v| nan_any(v)).collect::<Vec<_>>();
            assert_eq!(bits(&m0), bits(&m1), "{t0} {t1} {step} {k}/{n}");
            assert_eq!(bits(&l0), bits(&l1), "{t0} {t1} {step} {k}/{n}");
            checked += 1;
        }
    }
    assert!(checked > 30_000, "{checked}");
}

/// The sixteen-lane march's runs of sixteen segments are the cursor's, bit for bit: two
/// runs of eight from k and k + 8, on `lanes_segments_are_the_cursors`' cases (a NaN is
/// any NaN, as there), every starting segment below 2⁵³ − 32.
#[cfg(target_arch = "x86_64")]
#[test]
fn wide_segments_are_the_cursors() {
    if !simd::detected() {
        return;
    }
    let rng = Xorshift::new(0x51de_5e9e_a11e_0016);
    let mut checked = 0;
    for case in 0..4000 {
        let (t0, t1, step) = segment_span(&rng, case);
        let n = [
            1u64,
            2,
            7,
            8,
            9,
            16,
            17,
            33,
            1 << 20,
            (1 << 53) + 5,
            u64::MAX,
        ][case % 11];
        for k in [
            0,
            n / 2,
            n.saturating_sub(17),
            n.saturating_sub(16),
            n.saturating_sub(9),
            n - 1,
            ((1u64 << 53) - 33).min(n - 1),
        ] {
            if k as f64 >= (1u64 << 53) as f64 - 32.0 {
                continue;
            }
            let c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
            let mut run = simd::Run16::default();
            // SAFETY: every feature the function enables was detected above.
            let m = unsafe { simd::segments16(&c, &mut run) };
            assert_eq!(m, (n - k).min(16) as usize);
            for (h, from) in [(0, k), (8, k + 8)] {
                if from >= n {
                    continue;
                }
                let c = cursor(t0, t1, step, n, from, f64::NEG_INFINITY);
                let (mut mids, mut lens) = ([0.5; 8], [0.5; 8]);
                let a = c.segments(&mut mids, &mut lens);
                for j in 0..a {
                    assert_eq!(
                        nan_any(run.mids[h + j]),
                        nan_any(mids[j]),
                        "{t0} {t1} {step} {k}+{h}+{j}/{n}"
                    );
                    assert_eq!(
                        nan_any(run.lens[h + j]),
                        nan_any(lens[j]),
                        "{t0} {t1} {step} {k}+{h}+{j}/{n}"
                    );
                }
            }
            checked += 1;
        }
    }
    assert!(checked > 20_000, "{checked}");
}

/// A run in lanes has the segments of the sample-by-sample cursor, bit for bit, ends
/// at the first sample past the occupied block, and never passes the last segment: near the
/// start, the end and 2⁵³ (where the boundary numbers stop being exact and the run goes
/// sample by sample), for uneven steps and ends.
#[test]
fn runs_are_the_cursors_segments() {
    let big = (1u64 << 53) as f64;
    let cases = [
        (0.25, 9.9, 0.5, None),
        (-3.0, 4.0, 0.1, None),
        (1e-3, 1.0, 1.0 / 3.0, None),
        (0.0, 2.0, 0.7, None),
        (0.0, big * 0.5, 0.5, Some(1u64 << 53)),
        (5.0, 5.0 + 1e-9, 1e-15, Some(1u64 << 53)),
    ];
    let mut checked = 0;
    for (t0, t1, step, n_cap) in cases {
        let n = n_cap.unwrap_or(((t1 - t0) / step).ceil() as u64).max(1);
        let starts: Vec<u64> = (0..n.min(12))
            .chain(n.saturating_sub(12)..n)
            .chain(
                [(1 << 53) - 20, (1 << 53) - 17, (1 << 53) - 9]
                    .into_iter()
                    .filter(|&k| k < n),
            )
            .collect();
        for k in starts {
            for occupied in [
                f64::NEG_INFINITY,
                f64::INFINITY,
                t0 + (k as f64 + 3.2) * step,
            ] {
                for unbounded in [false, true] {
                    let c = cursor(t0, t1, step, n, k, occupied);
                    let (mut mids, mut lens) = ([0.0; 8], [0.0; 8]);
                    let m = run(&c, unbounded, &mut mids, &mut lens);
                    let left = (n - k).min(8) as usize;
                    assert!(m >= 1 && m <= left, "{k} of {n}: {m}");
                    for j in 0..m {
                        let (a, b) = c.segment(k + j as u64);
                        assert_eq!(mids[j].to_bits(), c.mid(k + j as u64).to_bits());
                        assert_eq!(lens[j].to_bits(), (b - a).to_bits(), "{k}+{j} of {n}");
                        assert!(j == 0 || unbounded || mids[j] < occupied);
                    }
                    // The run stops only at the block's end or its eight samples.
                    if m < left {
                        let mid = c.mid(k + m as u64);
                        assert!(
                            !unbounded
                                && mid.partial_cmp(&occupied) != Some(std::cmp::Ordering::Less)
                        );
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 300, "{checked}");
}

/// The batched march's runs (`Cursor::next_run`, joined across occupied blocks) take
/// exactly the samples of `Cursor::peek` and the run (`run`, the oracle), in the same order, bit for bit: on random grids of every fill,
/// for rays from outside and inside the grid, along axes and diagonals (zero direction
/// parts), with entry bounds before, inside and past the span, small and large steps, and
/// without a walk or a grid.
#[test]
fn joined_runs_are_peek_and_run() {
    let rng = Xorshift::new(0x1234_5678_9abc_def1);
    let next = || rng.next();
    let mut runs = [0usize; 2];
    let mut taken = 0usize;
    for case in 0..3000 {
        let dims = [
            1 + (next() * 9.0) as usize,
            1 + (next() * 9.0) as usize,
            1 + (next() * 9.0) as usize,
        ];
        let fill = [0.0, 0.1, 0.5, 0.9, 1.0][case % 5];
        let occupied: Vec<bool> = (0..dims.iter().product::<usize>())
            .map(|_| next() < fill)
            .collect();
        let cell = DVec3::new(0.5 + next(), 0.5 + next(), 0.5 + next()) * 0.25;
        let origin = DVec3::new(next(), next(), next()) - 0.5;
        let grid = SkipGrid::of_occupied(dims, origin, cell, &occupied);
        let size = DVec3::from_array(dims.map(|n| n as f64)) * cell;
        let mut d = unit_dir(&next);
        // Some rays along an axis or in a coordinate plane.
        match case % 7 {
            0 => {
                d = DVec3::new(d.x, 0.0, 0.0)
                    .try_normalize()
                    .unwrap_or(DVec3::X)
            }
            1 => {
                d = DVec3::new(d.x, d.y, 0.0)
                    .try_normalize()
                    .unwrap_or(DVec3::Y)
            }
            2 => {
                d = DVec3::new(0.0, -0.0, d.z)
                    .try_normalize()
                    .unwrap_or(DVec3::Z)
            }
            _ => {}
        }
        // From inside the grid, or outside it.
        let inside = origin + size * DVec3::new(next(), next(), next());
        let o = if case % 3 == 0 {
            inside
        } else {
            inside - d * (size.length() * (0.5 + next()))
        };
        let t0 = next() * 0.3;
        let t1 = t0 + size.length() * (0.2 + 2.0 * next());
        let step = [0.5, 0.25, 0.125, 0.7, 2.0, 0.03][case % 6] * cell.x * (0.9 + 0.2 * next());
        let n = segment_count((t1 - t0) / step);
        let from = match case % 4 {
            0 => f64::NEG_INFINITY,
            1 => t0 + (t1 - t0) * next(),
            2 => t0 - 1.0,
            _ => t0 + (t1 - t0) * next() * 0.2,
        };
        let start = || {
            let mut c = cursor(t0, t1, step, n, 0, f64::NEG_INFINITY);
            c.o = o;
            c.d = d;
            if case % 11 != 10 {
                c.start_walk(&grid, from.max(t0));
            }
            c
        };
        let have_grid = case % 13 != 12;
        let g = have_grid.then_some(&grid);
        // The march before: peek, then the run in the walk's block.
        let (mut want, mut got) = (Vec::new(), Vec::new());
        let mut c = start();
        let unbounded = c.walk.is_none() || !have_grid;
        while c.peek(g).is_some() {
            let (mut mids, mut lens) = ([0.0; 8], [0.0; 8]);
            let m = run(&c, unbounded, &mut mids, &mut lens);
            for j in 0..m {
                want.push((mids[j].to_bits(), lens[j].to_bits()));
            }
            c.k += m as u64;
            runs[0] += 1;
        }
        let mut c = start();
        loop {
            let (mut mids, mut lens) = ([f64::NAN; 8], [f64::NAN; 8]);
            let m = c.next_run(g, &mut mids, &mut lens);
            if m == 0 {
                break;
            }
            assert!(m <= 8 && c.k <= c.n);
            for j in 0..m {
                got.push((mids[j].to_bits(), lens[j].to_bits()));
            }
            runs[1] += 1;
        }
        // (A segment's midpoint and length name it: midpoints increase.)
        assert_eq!(got, want, "case {case}");
        assert_eq!(c.k, c.n, "case {case}");
        taken += want.len();
    }
    // Joined runs are fewer; every kind of case came up.
    assert!(runs[1] < runs[0] && taken > 100_000, "{runs:?} {taken}");
}

/// `at_most` is `f64::min` wherever the bound is not NaN (a cursor's end never is): for
/// NaN, infinite, tiny, equal and neighbouring values (bit for bit, except that of two
/// equal zeros `f64::min` may return either).
#[test]
fn at_most_is_the_minimum_below_a_bound_that_is_not_nan() {
    let values = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        0.0,
        -0.0,
        1.0,
        1.0 + f64::EPSILON,
        1.0 - f64::EPSILON / 2.0,
        -1.0,
        1e300,
        f64::MIN_POSITIVE,
        -f64::MIN_POSITIVE,
        5e-324,
        f64::MAX,
    ];
    for t1 in values.into_iter().filter(|t| !t.is_nan()) {
        for x in values {
            let (got, want) = (at_most(x, t1), x.min(t1));
            if x == 0.0 && t1 == 0.0 {
                assert_eq!(got, want);
            } else {
                assert_eq!(got.to_bits(), want.to_bits(), "{x} {t1}");
            }
        }
    }
}

/// The pass bits in lanes are the comparisons sample by sample, NaN included.
/// Starting at a parameter passes over the segments before it and stops at the first
/// whose midpoint is not before it (or at the end), from any start, for targets before,
/// on, between and beyond the midpoints.
#[test]
fn starting_stops_at_the_first_midpoint_not_before() {
    let mut checked = 0;
    for (t0, t1, step) in [
        (0.25f64, 9.9, 0.5),
        (-3.0, 4.0, 0.1),
        (1e-3, 1.0, 1.0 / 3.0),
    ] {
        let n = ((t1 - t0) / step).ceil() as u64;
        for k in 0..n {
            let probe = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
            let mut targets: Vec<f64> = (0..n).map(|j| probe.mid(j)).collect();
            targets.extend(targets.clone().iter().map(|m| m + step * 0.5));
            targets.extend([t0 - 1.0, t0, t1, t1 + 1.0, 1e300, f64::INFINITY]);
            for t in targets {
                let mut c = cursor(t0, t1, step, n, k, f64::NEG_INFINITY);
                c.start_at(t);
                let want = (k..n).find(|&j| c.mid(j) >= t).unwrap_or(n);
                assert_eq!(c.k, want, "from {k} of {n} to {t}");
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked}");
}

#[test]
fn pass_bits_are_the_comparisons() {
    let lens = [0.5, 0.0, -1.0, f64::NAN, 1e-300, f64::INFINITY, 2.0, -0.0];
    let values = [
        0.0,
        0.3,
        f32::from_bits(0.3f32.to_bits() + 1),
        f32::NAN,
        1.0,
        -0.0,
        f32::from_bits(0.3f32.to_bits() - 1),
        f32::INFINITY,
    ];
    for z in [0.0, 0.3, -1.0, 1.0, f32::NAN] {
        for rot in 0..8 {
            let mut vs = values;
            vs.rotate_left(rot);
            let want = (0..8).fold(0u32, |bits, i| {
                bits | u32::from(!(lens[i] <= 0.0 || vs[i] <= z)) << i
            });
            assert_eq!(pass_bits(&lens, &vs, z), want, "z {z} rotation {rot}");
        }
    }
}

/// Snell's law at a surface, and total internal reflection beyond the critical angle, against
/// the closed forms.
#[test]
fn snell_and_total_internal_reflection() {
    let n = DVec3::Z;
    for deg in [0.0f64, 10.0, 30.0, 41.0, 60.0, 85.0] {
        let th = deg.to_radians();
        let d = DVec3::new(th.sin(), 0.0, -th.cos()); // towards the surface from above
                                                      // Into glass (1 → 1.5): n1 sin θ1 = n2 sin θ2, and the ray goes on through.
        let t = refract(d, n, 1.0, 1.5);
        assert!((t.x - th.sin() / 1.5).abs() < 1e-12, "{deg}: {t:?}");
        assert!(t.z < 0.0 && (t.length() - 1.0).abs() < 1e-12);
        // Out of glass (1.5 → 1): beyond the critical angle asin(1/1.5) = 41.8° it reflects.
        let t = refract(d, n, 1.5, 1.0);
        if 1.5 * th.sin() > 1.0 {
            assert_eq!(t, reflect(d, n), "{deg}°: total internal reflection");
            assert!(t.z > 0.0);
        } else {
            assert!((t.x - 1.5 * th.sin()).abs() < 1e-12, "{deg}°: {t:?}");
        }
    }
    // The normal's orientation does not matter.
    let d = DVec3::new(0.6, 0.0, -0.8);
    assert_eq!(
        refract(d, DVec3::Z, 1.0, 1.33),
        refract(d, -DVec3::Z, 1.0, 1.33)
    );
}

/// The empty-space grid of a closed object is built once per scene and shared by every later
/// compilation of that scene (the state machine's `Caches`); a fresh `Caches` builds its own.
#[test]
fn skip_grids_are_built_once_per_scene() {
    let vl = sphere_library();
    let (a, b) = (vl.compiled().unwrap(), vl.compiled().unwrap());
    let grid = |c: &Compiled| c.objects[0].skip.clone().expect("a skip grid");
    assert!(Arc::ptr_eq(&grid(&a), &grid(&b)), "one grid for the scene");
    let desc = vl.open_scene("test").unwrap();
    let fresh = Compiled::new(&desc, &Caches::default());
    assert!(
        !Arc::ptr_eq(&grid(&a), &grid(&fresh)),
        "a fresh cache builds its own"
    );
}

/// The pixel buffers a render gives back (the scene's `Caches`, [`Recycled`]) are handed to
/// the scene's next render, which gives the same pixels as a render from fresh buffers: again
/// at the same size, at a smaller size after a larger one, and super-sampled. (That they are
/// handed out as zeros: `recycle::tests`.)
#[test]
fn pixel_buffers_kept_between_renders_change_no_pixel() {
    let same = |a: &crate::Image, b: &crate::Image| {
        a.pixels == b.pixels && a.transmittance == b.transmittance
    };
    for ss in [1, 2] {
        let mut vl = sphere_library_with(true);
        vl.super_sample(ss).unwrap();
        let first = vl.render_preview(64, 48, 1.0).unwrap();
        let kept = vl.compiled().unwrap().recycled.kept();
        assert!(
            kept >= 64 * 48,
            "the strip's and the tiles' buffers are kept: {kept}"
        );
        let again = vl.render_preview(64, 48, 1.0).unwrap();
        assert!(
            same(&first, &again),
            "super-sampling {ss}: a second frame differs"
        );
        let small = vl.render_preview(20, 10, 1.0).unwrap();
        let mut fresh = sphere_library_with(true);
        fresh.super_sample(ss).unwrap();
        let fresh = fresh.render_preview(20, 10, 1.0).unwrap();
        assert!(
            same(&small, &fresh),
            "super-sampling {ss}: kept buffers changed a pixel"
        );
    }
}

/// Without a team, a tile's pixels go into the strip as the tile ends and its buffer back at
/// once: after a render of a 512² image (256 tiles of 32², or 1024 of 16²) the buffers kept
/// are the strip's and at least one, at most one a thread, of the tiles' (with every tile's
/// buffer held until the strip is assembled, every tile's would be kept, up to 2²⁰ pixels),
/// and the image is that of one thread.
#[test]
fn tiles_buffers_go_back_as_each_tile_ends() {
    let vl = sphere_library_with(true);
    let (w, h) = (512u32, 512u32);
    let image = vl.render_preview(w, h, 1.0).unwrap();
    let tile = (PACKET_TILE * PACKET_TILE) as usize;
    let threads = rayon::current_num_threads();
    let kept = vl.compiled().unwrap().recycled.kept();
    let strip = (w * h) as usize;
    assert!(
        kept > strip && kept <= strip + threads * tile,
        "kept {kept} pixels: the strip's {strip} and at most {threads} tiles' of {tile}"
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let alone = one.install(|| sphere_library_with(true).render_preview(w, h, 1.0).unwrap());
    assert!(image.pixels == alone.pixels && image.transmittance == alone.transmittance);
}

/// `Bytes::values3` (three points in SSE lanes) is `Bytes::value` at each point, bit for bit
/// (a zero's sign apart): points inside the grid, on and just past its faces, outside it and
/// NaN, a normalisation that clamps at both ends, and voxels cut short (the cells whose last
/// node is missing read 0 there, in both).
#[test]
#[cfg(target_arch = "x86_64")]
fn bytes_read_three_at_once_as_one_by_one() {
    use crate::render::integrate::Bytes;
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        eprintln!("no AVX2 and FMA: nothing to compare");
        return;
    }
    let dims = [7usize, 9, 6];
    let mut seed = 12345u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as u32
    };
    let voxels: Vec<u8> = (0..dims.iter().product()).map(|_| next() as u8).collect();
    let data = Dataset::new(dims, crate::data::Voxels::U8(voxels.clone()), 0.0, 255.0).unwrap();
    let edge = crate::data::FACE_TOLERANCE;
    let mut points: Vec<[f32; 3]> = (0..3000)
        .map(|_| std::array::from_fn(|_| next() as f32 / u32::MAX as f32 * 1.2 - 0.1))
        .collect();
    for x in [
        0.0,
        1.0,
        -edge,
        1.0 + edge,
        -2.0 * edge,
        1.0 + 2.0 * edge,
        f32::NAN,
    ] {
        points.push([x, 0.5, 0.5]);
        points.push([0.3, x, 0.7]);
        points.push([0.6, 0.2, x]);
        points.push([x, x, x]);
    }
    let (mut compared, mut zeros) = (0, 0);
    for (raw, scale, offset) in [
        (&voxels[..], 1.0 / 255.0, 0.0),
        (&voxels[..], 1.0 / 200.0, -0.1),
        (&voxels[..voxels.len() - 40], 1.0 / 255.0, 0.0),
    ] {
        let bytes = Bytes {
            raw,
            scale,
            offset,
            last: dims.map(|n| (n - 1) as f32),
            top: dims.map(|n| (n - 2) as f32),
            sy: dims[0],
            sz: dims[0] * dims[1],
        };
        for three in points.chunks_exact(3) {
            let ps = [three[0], three[1], three[2]];
            // SAFETY: the processor has AVX2 and FMA (tested above).
            let got = unsafe { bytes.values3(&data, ps) };
            for (p, v) in ps.iter().zip(got) {
                let one = bytes.value(&data, *p);
                assert!(
                    v.to_bits() == one.to_bits() || (v == 0.0 && one == 0.0),
                    "{p:?}: {v} against {one}"
                );
                compared += 1;
                zeros += (one == 0.0) as usize;
            }
        }
    }
    assert_eq!(compared, 3 * (points.len() / 3 * 3), "three voxel sets");
    // Some points are outside or clamp to 0, most are not.
    assert!(zeros > 0 && zeros < compared / 2, "{zeros} of {compared}");
}

/// A pre-integrated object's tables are built by the first compilation of its scene and shared
/// by later ones, as its empty-space grid; a fresh `Caches` builds its own, with the same
/// entries (the tables depend on the closed object and its step alone).
#[test]
fn preintegration_tables_are_built_once_per_scene() {
    use crate::types::MappingType;
    let n = 8usize;
    let voxels: Vec<u8> = (0..n * n * n).map(|i| (i % n * 36) as u8).collect();
    let data = Dataset::new([n; 3], crate::data::Voxels::U8(voxels), 0.0, 255.0).unwrap();
    let mut vl = crate::Library::new();
    vl.add_dataset(DatasetId(1), data).unwrap();
    vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[0.2, 0.0, 0.8, 0.9])
        .unwrap();
    let colours = [0.0, 1.0, 0.5, 0.0, 1.0, 0.0, 0.5, 1.0];
    vl.mapping(MappingId(2), MappingType::Ramp, 2, 3, &colours)
        .unwrap();
    vl.scene().unwrap();
    vl.set_optimise(crate::model::scene::Optimise {
        preintegrate: true,
        ..Default::default()
    })
    .unwrap();
    vl.step_size(0.7, 1.0).unwrap();
    vl.object().unwrap();
    vl.scale(7.0, 7.0, 7.0).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    for (k, f) in [Fields::R, Fields::G, Fields::B].into_iter().enumerate() {
        vl.map(f, Fields::F, MappingId(2), k as i32 + 1).unwrap();
    }
    vl.end().unwrap();
    let (a, b) = (vl.compiled().unwrap(), vl.compiled().unwrap());
    let tables = |c: &Compiled| c.objects[0].preint.clone().expect("pre-integrated");
    assert!(
        Arc::ptr_eq(&tables(&a), &tables(&b)),
        "one set of tables for the scene"
    );
    let desc = vl.open_scene("test").unwrap();
    let fresh = Compiled::new(&desc, &Caches::default());
    assert!(
        !Arc::ptr_eq(&tables(&a), &tables(&fresh)),
        "a fresh cache builds its own"
    );
    for level in 0..=crate::render::preint::REFINE_LEVELS {
        for (vf, vb) in [(0.0, 1.0), (0.3, 0.7), (0.9, 0.25), (0.5, 0.5)] {
            let (x, y) = (
                tables(&a).lookup(level, vf, vb),
                tables(&fresh).lookup(level, vf, vb),
            );
            assert_eq!(
                x.map(f32::to_bits),
                y.map(f32::to_bits),
                "level {level}, {vf} to {vb}"
            );
        }
    }
    // Pre-integration off: no tables, none kept.
    vl.set_optimise(Default::default()).unwrap();
    assert!(vl.compiled().unwrap().objects[0].preint.is_none());
}

/// The image of `scene` at `size`, rendered in strips of `step` rows; with the strips' first
/// rows as the sink saw them.
pub(super) fn in_strips(scene: &Compiled, (w, h): (u32, u32), step: u32) -> (Vec<Pixel>, Vec<u32>) {
    let mut pixels = Vec::new();
    let mut starts = Vec::new();
    let progress = crate::control::Progress::none();
    let backdrop = Backdrop::Background;
    render_in_strips(scene, (w, h, 1.1), backdrop, step, &progress, |y, rows| {
        assert_eq!(y as usize * w as usize, pixels.len(), "strips in order");
        starts.push(y);
        pixels.extend_from_slice(rows);
        Ok(())
    })
    .unwrap();
    (pixels, starts)
}

/// Strips change no pixel: every pixel is computed on its own, so an image rendered in strips
/// of 32 rows (the last one partial) is the one-strip image bit for bit: one ray a pixel (the
/// scalar march, with the strips' entry maps), and super-sampling, whose refinement compares
/// each pixel with the rows above and below across the strips' edges. (The packet march's
/// strips: `simd::tests`.)
#[test]
fn strips_change_no_pixel() {
    let bits = |p: &[Pixel]| p.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    let size = (45, 101);
    let mut images = Vec::new();
    for (packets, super_sample) in [(false, 1), (false, 3)] {
        let mut vl = sphere_library_with(true);
        vl.set_optimise(crate::Optimise {
            packets,
            ..Default::default()
        })
        .unwrap();
        vl.super_sample(super_sample).unwrap();
        let scene = vl.compiled().unwrap();
        let (whole, starts) = in_strips(&scene, size, 128);
        assert_eq!(starts, [0]);
        let (strips, starts) = in_strips(&scene, size, 32);
        assert_eq!(starts, [0, 32, 64, 96]);
        assert_eq!(whole.len(), 45 * 101);
        assert!(
            bits(&whole) == bits(&strips),
            "packets {packets}, super-sampling {super_sample}"
        );
        // And some pixels were refined, some showed the spheres: the comparison means
        // something.
        let (lo, hi) = whole
            .iter()
            .fold((f32::MAX, 0f32), |(l, h), p| (l.min(p[0]), h.max(p[0])));
        assert!(hi - lo > 0.1, "{lo} … {hi}");
        assert!(scene
            .entry_marks(&view(&scene.settings, 45, 101, 1.1))
            .is_some());
        images.push(bits(&whole));
    }
    let refined = images[0]
        .iter()
        .zip(&images[1])
        .filter(|(a, b)| a != b)
        .count();
    assert!(refined > 10, "super-sampling refined {refined} channels");
}

/// A strip is at least a row of packet tiles and at most about [`STRIP_PIXELS`] beyond one.
#[test]
fn strips_hold_about_a_million_pixels() {
    assert_eq!(strip_rows(256, 256), 256, "a small image is one strip");
    assert_eq!(strip_rows(8192, 8192), 128);
    assert_eq!(strip_rows(1 << 15, 1 << 15), 32, "a row of tiles at least");
    assert_eq!(strip_rows(1000, 5), 5);
    for w in [1u32, 7, 1000, 3000, 32768] {
        let rows = strip_rows(w, 1 << 15);
        assert_eq!(rows % PACKET_TILE, 0);
        assert!(rows as u64 * w as u64 <= STRIP_PIXELS + PACKET_TILE as u64 * w as u64);
    }
}

/// Progress counts every pixel once, strip by strip (and the tiles of a strip as they end, in
/// between), and reaches 1; a progress function that returns false stops the render with
/// `Cancelled` before the next strip, and so does a cancel flag set before (or during) the
/// render.
#[test]
fn progress_reaches_one_and_cancels() {
    use crate::control::{CancelFlag, Progress, RenderControl};
    use std::sync::{Arc, Mutex};
    let scene = sphere_scene();
    let (w, h) = (40u32, 100u32);
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    let control = RenderControl {
        cancel: None,
        progress: Some(Arc::new(move |f| {
            log.lock().unwrap().push(f);
            true
        })),
    };
    let progress = Progress::new(&control, (w * h) as u64);
    let mut strips = 0;
    render_in_strips(
        &scene,
        (w, h, 1.0),
        Backdrop::Background,
        32,
        &progress,
        |_, _| {
            strips += 1;
            Ok(())
        },
    )
    .unwrap();
    let want: Vec<f32> = [32u32, 64, 96, 100]
        .iter()
        .map(|&rows| (rows as f64 / 100.0) as f32)
        .collect();
    // Each strip's end, in order; between them (the tiles of a strip as they end) only
    // fractions past the strip before and short of the strip's end.
    let seen_now = seen.lock().unwrap().clone();
    let mut ends: Vec<f32> = seen_now
        .iter()
        .copied()
        .filter(|f| want.contains(f))
        .collect();
    ends.dedup();
    assert_eq!(ends, want, "{seen_now:?}");
    assert!(seen_now.windows(2).all(|p| p[0] <= p[1]), "{seen_now:?}");
    assert_eq!(seen_now.last(), Some(&1.0));
    assert_eq!(strips, 4);
    // Stop at the second strip's end (the tiles' fractions before it are below it).
    let calls = Arc::new(Mutex::new(0));
    let count = calls.clone();
    let second = want[1];
    let control = RenderControl {
        cancel: None,
        progress: Some(Arc::new(move |f| {
            *count.lock().unwrap() += 1;
            f < second
        })),
    };
    let progress = Progress::new(&control, (w * h) as u64);
    let mut strips = 0;
    let e = render_in_strips(
        &scene,
        (w, h, 1.0),
        Backdrop::Background,
        32,
        &progress,
        |_, _| {
            strips += 1;
            Ok(())
        },
    )
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled);
    assert_eq!(strips, 2);
    assert!(*calls.lock().unwrap() >= 2);
    // A flag set before: nothing rendered.
    let flag = CancelFlag::new();
    flag.cancel();
    let control = RenderControl {
        cancel: Some(flag.clone()),
        progress: None,
    };
    let progress = Progress::new(&control, 1);
    let e = render_in_strips(
        &scene,
        (w, h, 1.0),
        Backdrop::Background,
        32,
        &progress,
        |_, _| panic!("no strip after a cancel"),
    )
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled);
    // A flag set by a field function, in the middle of the first strip: the render stops
    // within the strip (the tiles not started are skipped), and the sink sees nothing.
    flag.reset();
    let mut vl = crate::Library::new();
    vl.scene().unwrap();
    vl.object().unwrap();
    let (trip, evaluations) = (flag.clone(), Arc::new(Mutex::new(0u64)));
    let counted = evaluations.clone();
    vl.function(Fields::O, move |s| {
        *counted.lock().unwrap() += 1;
        trip.cancel();
        let _ = s.set(Fields::O, 0.0);
    })
    .unwrap();
    vl.end().unwrap();
    let scene = vl.compiled().unwrap();
    let progress = Progress::new(&control, 1);
    let e = render_in_strips(
        &scene,
        (64, 64, 1.0),
        Backdrop::Background,
        64,
        &progress,
        |_, _| panic!("no strip after a cancel"),
    )
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::Cancelled);
    // Each thread finishes the pixel it is on (its ray: at most √3 / step + 2 samples, each
    // one evaluation here), and starts no other.
    let step = scene.objects[0].step;
    let per_ray = (3f64.sqrt() / step).ceil() as u64 + 2;
    let most = rayon::current_num_threads() as u64 * per_ray;
    let n = *evaluations.lock().unwrap();
    assert!(n <= most, "{n} evaluations, at most {most}");
}

/// A step finer than 2⁻³² of an object's world diagonal is refused before any pixel, with
/// `BadValue`; the same object at a step just coarser renders.
#[test]
fn absurd_sample_counts_are_refused() {
    let build = |step: f32| {
        let mut vl = crate::Library::new();
        vl.scene().unwrap();
        vl.step_size(step, 1.0).unwrap();
        vl.object().unwrap();
        vl.scale(100.0, 100.0, 100.0).unwrap();
        vl.set(Fields::O, 0.0).unwrap();
        vl.end().unwrap();
        vl.compiled().unwrap()
    };
    // The diagonal is 100·√3.
    let diagonal = 100.0 * 3f64.sqrt();
    let fine = (diagonal / MAX_SAMPLES_PER_RAY * 0.9) as f32;
    let e = build(fine).check_work().unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
    assert!(e.message.contains("samples"), "{}", e.message);
    assert!(build((diagonal / MAX_SAMPLES_PER_RAY * 1.1) as f32)
        .check_work()
        .is_ok());
    let e = build(1e-9).check_work().unwrap_err();
    assert_eq!(e.code, ErrorCode::BadValue);
}

/// `preint::absorbed`: a constant medium's α and depth against the closed forms, from nearly
/// clear to opaque. The depth's reference is ∫₀¹ s·k·e^(−k·s) ds by the composite midpoint rule
/// in f64 over 10⁵ steps (relative error about k²/(24·10¹⁰), under 10⁻⁹ for k ≤ 10), α's
/// is 1 − e^(−k) where that does not cancel (k ≥ 10⁻³) and its series to k⁴ below. The depth over α,
/// where a piece is lit, tends to ½ as the medium clears (k/2 over k).
#[test]
fn a_constant_medium_is_lit_at_its_depth_however_clear() {
    use crate::render::preint::absorbed;
    let depth_of = |k: f64| {
        let n = 100_000;
        (0..n)
            .map(|i| {
                let s = (i as f64 + 0.5) / n as f64;
                s * k * (-k * s).exp()
            })
            .sum::<f64>()
            / n as f64
    };
    for k in [
        1e-300, 1e-30, 1e-15, 1e-9, 1e-6, 9.99e-4, 1e-3, 0.01, 0.5, 1.0, 4.0, 10.0,
    ] {
        let (a, depth) = absorbed(k);
        let want_a = if k >= 1e-3 {
            1.0 - (-k).exp()
        } else {
            k * (1.0 - k * (0.5 - k * (1.0 / 6.0 - k / 24.0)))
        };
        assert!(
            (a - want_a).abs() <= 1e-12 * want_a,
            "k {k}: α {a} against {want_a}"
        );
        let want = depth_of(k);
        assert!(
            (depth - want).abs() <= 1e-9 * want,
            "k {k}: depth {depth} against {want}"
        );
        let at = depth / a;
        assert!((0.0..=0.5).contains(&at), "k {k}: lit at {at}");
        if k <= 1e-6 {
            assert!((at - 0.5).abs() < 1e-6, "k {k}: lit at {at}");
        }
    }
    assert_eq!(absorbed(0.0), (0.0, 0.0));
    assert_eq!(absorbed(-0.0), (0.0, 0.0));
    assert_eq!(absorbed(f64::INFINITY), (1.0, 0.0));
    assert_eq!(absorbed(f64::NAN), (0.0, 0.0));
    let (a, depth) = absorbed(700.0);
    assert_eq!(a, 1.0);
    assert!((depth - 1.0 / 700.0).abs() < 1e-15, "{depth}");
}
