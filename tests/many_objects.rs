//! Scenes of many objects. Beyond eight, and under empty-space skipping, a ray (primary, mirror
//! or shadow) and a voxelization's node find the objects they may meet through a tree of the
//! objects' world boxes instead of a look at every one: the images and the voxelized datasets
//! must be those of the look at every one (`Optimise::skip_empty` off), byte for byte, for
//! objects of every rendering algorithm, turned and stretched, with shadows and mirrors, and
//! with rays that run along the objects' faces; and each object must be seen where it is.

use vlib::{Attenuation, Camera, Feature, Fields, Library, Optimise, RenderType};

/// The camera on the z axis at z = −`distance`, looking at the origin: with an odd image side
/// the middle row and column of rays have x (y) components of exactly 0, so that they run
/// along the faces of boxes that lie on the planes x = 0 and y = 0.
fn camera(vl: &mut Library, distance: f32, fov: f32) {
    vl.camera(&Camera {
        eye: [0.0, 0.0, -distance],
        at: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov,
    })
    .unwrap();
}

/// Object `i` of the mixed scene: DVR of a constant medium, DVR of a density sphere, a DSR
/// sphere or a MIP of a density sphere, by `i % 4`; each turned about its own axis and
/// stretched, its colour its own. Opens and closes the object.
fn mixed_object(vl: &mut Library, i: usize, at: [f32; 3], size: f32) {
    let kind = i % 4;
    vl.render_type(match kind {
        2 => RenderType::Dsr,
        3 => RenderType::Mip,
        _ => RenderType::Dvr,
    })
    .unwrap();
    vl.surface(Fields::F, 0.5).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.scale(size, size * (1.0 + 0.1 * (i % 3) as f32), size * 0.8)
        .unwrap();
    vl.rotate(
        17.0 * i as f32,
        11.0 * (i % 5) as f32,
        29.0 * (i % 2) as f32,
    )
    .unwrap();
    vl.translate(at[0], at[1], at[2]).unwrap();
    if kind != 0 {
        vl.function(Fields::F | Fields::O, |s| {
            let v = vlib::vlaux::sphere(s.position());
            s.set(Fields::F, v).ok();
            s.set(Fields::O, v * 0.3).ok();
        })
        .unwrap();
    } else {
        vl.set(Fields::O, 0.08).unwrap();
    }
    if kind == 2 {
        vl.set(Fields::O, 1.0).unwrap();
    }
    let c = |k: usize| ((i * (k + 3)) % 7) as f32 / 6.0;
    vl.set(Fields::R, c(0)).unwrap();
    vl.set(Fields::G, c(1)).unwrap();
    vl.set(Fields::B, c(2)).unwrap();
    vl.set(Fields::KA, 0.4).unwrap();
    vl.set(Fields::KD, 0.6).unwrap();
    vl.set(Fields::KS, 0.3).unwrap();
    vl.end().unwrap();
}

/// Where [`mixed_scene`]'s point light is: up, left and in front of the objects, or among
/// them, inside the lattice's object at (−8, 8, 0), so that shadow rays from the others enter
/// that object just before they reach the light, and have objects beyond it that they must
/// not look at.
const LIGHT_OUTSIDE: [f32; 3] = [-150.0, 200.0, -250.0];
const LIGHT_AMONG: [f32; 3] = [-7.0, 9.0, 1.0];

/// A scene of 48 mixed objects on a 4 × 4 × 3 lattice and a wall of 16 constant boxes split
/// by the planes x = 0 and y = 0 behind it, with a point light at `light`, shadows and
/// mirrors as asked, and `skip_empty` as given; rendered at 49², or voxelized into `volume`
/// (a prefix) instead.
fn mixed_scene(
    skip_empty: bool,
    (shadows, light): (bool, [f32; 3]),
    mirrors: bool,
    volume: Option<&std::path::Path>,
) -> Option<Vec<u8>> {
    let mut vl = Library::new();
    vl.scene().unwrap();
    camera(&mut vl, 200.0, 18.0);
    vl.ambient(1.0, 1.0, 1.0, 0.5).unwrap();
    vl.point_light(light, Attenuation::None, [1.0; 3], 0.8)
        .unwrap();
    vl.step_size(0.7, 1.0).unwrap();
    vl.toggle(Feature::CastShadows, shadows).unwrap();
    vl.toggle(Feature::ReceiveShadows, shadows).unwrap();
    if mirrors {
        vl.recursion(2).unwrap();
        vl.toggle(Feature::ReceiveReflections, true).unwrap();
        vl.toggle(Feature::CastReflections, true).unwrap();
    }
    let mut i = 0;
    for x in 0..4 {
        for y in 0..4 {
            for z in 0..3 {
                let at = [
                    -24.0 + 16.0 * x as f32,
                    -24.0 + 16.0 * y as f32,
                    -16.0 + 16.0 * z as f32,
                ];
                mixed_object(&mut vl, i, at, 11.0);
                i += 1;
            }
        }
    }
    vl.render_type(RenderType::Dvr).unwrap();
    for x in -2..2 {
        for y in -2..2 {
            vl.object().unwrap();
            vl.scale(10.0, 10.0, 4.0).unwrap();
            vl.translate(10.0 * x as f32, 10.0 * y as f32, 40.0)
                .unwrap();
            vl.set(Fields::O, 0.5).unwrap();
            vl.set(Fields::R, (x + 2) as f32 / 3.0).unwrap();
            vl.set(Fields::G, (y + 2) as f32 / 3.0).unwrap();
            vl.set(Fields::B, 0.5).unwrap();
            vl.set(Fields::KA | Fields::KD, 0.5).unwrap();
            vl.end().unwrap();
        }
    }
    if let Some(prefix) = volume {
        vl.volume(
            prefix,
            Fields::O | Fields::R | Fields::F,
            [-40.0, -40.0, -30.0],
            [40.0, 40.0, 50.0],
            [33, 33, 33],
            2,
        )
        .unwrap();
    }
    vl.set_optimise(Optimise {
        skip_empty,
        ..Default::default()
    })
    .unwrap();
    if volume.is_some() {
        vl.end().unwrap();
        return None;
    }
    Some(vl.render_preview(49, 49, 1.0).unwrap().to_rgb8())
}

/// The same images through the tree as with every object tested: shadow rays to a light
/// outside the objects and to one among them (a shadow ray looks only at the objects before
/// its light: one that left out an object it enters before the light would lose its shadow).
#[test]
fn many_objects_render_as_when_every_object_is_tested() {
    for light in [LIGHT_OUTSIDE, LIGHT_AMONG] {
        let plain = mixed_scene(true, (false, light), false, None).unwrap();
        for (shadows, mirrors) in [(false, false), (true, false), (false, true)] {
            let found = mixed_scene(true, (shadows, light), mirrors, None).unwrap();
            // Shadow rays and mirror rays were traced (and change the image).
            assert_eq!(found != plain, shadows || mirrors);
            let scanned = mixed_scene(false, (shadows, light), mirrors, None).unwrap();
            assert!(
                found == scanned,
                "light {light:?}, shadows {shadows}, mirrors {mirrors}: the images differ"
            );
            // The image shows the scene, not the background alone.
            let lit = found.chunks(3).filter(|p| p.iter().any(|&c| c > 0)).count();
            assert!(lit > 49 * 49 / 2, "{lit} pixels lit");
        }
    }
}

#[test]
fn many_objects_voxelize_as_when_every_object_is_tested() {
    let dir = std::env::temp_dir().join(format!("vlib-many-objects-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (found, scanned) = (dir.join("found"), dir.join("scanned"));
    mixed_scene(true, (false, LIGHT_OUTSIDE), false, Some(&found));
    mixed_scene(false, (false, LIGHT_OUTSIDE), false, Some(&scanned));
    for field in ["o", "r", "f"] {
        let read = |prefix: &std::path::Path| {
            let name = format!(
                "{}_{field}.vlb",
                prefix.file_name().unwrap().to_str().unwrap()
            );
            std::fs::read(dir.join(name)).unwrap()
        };
        let (a, b) = (read(&found), read(&scanned));
        assert!(a == b, "field {field}: the voxelizations differ");
        // Some nodes lie in objects (not every voxel is 0).
        assert!(a[40..].iter().any(|&v| v != 0), "field {field}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A wall of 16 × 16 opaque boxes, each of its own colour, seen head-on through a narrow field
/// of view: the ray through the middle of each box's face shows that box's colour exactly (the
/// first sample, of opacity 1, hides what lies behind; ambient light 1, KA 1).
#[test]
fn each_of_many_objects_is_seen_where_it_is() {
    const N: usize = 16;
    let colour =
        |x: usize, y: usize| [x as f32 / 15.0, y as f32 / 15.0, ((x + y) % 4) as f32 / 3.0];
    let mut vl = Library::new();
    vl.scene().unwrap();
    camera(&mut vl, 4000.0, 2.0);
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    vl.step_size(0.5, 1.0).unwrap();
    // Box (x, y) spans [8x − 64, 8x − 57] × [8y − 64, 8y − 57] × [0, 8]: 7 wide, 1 apart.
    for x in 0..N {
        for y in 0..N {
            vl.object().unwrap();
            vl.scale(7.0, 7.0, 8.0).unwrap();
            vl.translate(8.0 * x as f32 - 64.0, 8.0 * y as f32 - 64.0, 0.0)
                .unwrap();
            vl.set(Fields::O | Fields::KA, 1.0).unwrap();
            let [r, g, b] = colour(x, y);
            vl.set(Fields::R, r).unwrap();
            vl.set(Fields::G, g).unwrap();
            vl.set(Fields::B, b).unwrap();
            vl.end().unwrap();
        }
    }
    // 2° at 4000 spans ±69.8 world units; at 257² a pixel is 0.543 wide.
    let side = 257u32;
    let img = vl.render_preview(side, side, 1.0).unwrap();
    let half = 4000.0 * (1.0f64.to_radians()).tan();
    let pixel = |w: f64| ((w + half) / (2.0 * half) * side as f64 - 0.5).round() as u32;
    for x in 0..N {
        for y in 0..N {
            // The middle of box (x, y)'s front face, in world units; image rows run down.
            let (wx, wy) = (8.0 * x as f64 - 60.5, 8.0 * y as f64 - 60.5);
            let (px, py) = (pixel(wx), side - 1 - pixel(wy));
            let got = img.pixel(px, py);
            let want = colour(x, y);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-5,
                    "box ({x}, {y}) at pixel ({px}, {py}): {got:?}, not {want:?}"
                );
            }
        }
    }
}

/// A needle (stretched 7·10⁵ times along one axis between two turns: a condition number near
/// 10⁶) 10⁸ from the origin, whose clip in its own space rounding moves by up to 10⁴ world
/// units, and eight more objects: a ray that passes its tip by a hair, and a line of nodes
/// beside it, find it as when every object is tested (found by a search for rays that tell
/// the two apart; such an object is tested by every ray, outside the tree).
#[test]
fn an_ill_conditioned_object_far_away_is_found_as_when_every_object_is_tested() {
    let scene = |vl: &mut Library| {
        vl.scene().unwrap();
        vl.camera(&Camera {
            eye: [-97391420.0, 41802892.0, -3875505.3],
            at: [2571477.3, 44526500.0, -3862560.0],
            up: [0.0, 0.0, 1.0],
            fov: 1.0,
        })
        .unwrap();
        vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
        vl.object().unwrap();
        vl.rotate(78.0, -135.0, 160.0).unwrap();
        vl.scale(7.0e5, 1.0, 1.0).unwrap();
        vl.rotate(114.0, 111.0, -105.0).unwrap();
        vl.translate(-97391360.0, 41803028.0, -3875870.0).unwrap();
        vl.set(Fields::O | Fields::KA | Fields::R, 1.0).unwrap();
        vl.end().unwrap();
        for i in 0..8 {
            vl.object().unwrap();
            vl.translate(10.0 * i as f32, 0.0, 0.0).unwrap();
            vl.set(Fields::O | Fields::KA | Fields::G, 1.0).unwrap();
            vl.end().unwrap();
        }
    };
    let optimise = |vl: &mut Library, skip_empty| {
        vl.set_optimise(Optimise {
            skip_empty,
            ..Default::default()
        })
        .unwrap();
    };
    let render = |skip_empty| {
        let mut vl = Library::new();
        scene(&mut vl);
        optimise(&mut vl, skip_empty);
        vl.render_preview(1, 1, 1.0).unwrap().to_rgb8()
    };
    assert_eq!(render(true), render(false));
    let dir = std::env::temp_dir().join(format!("vlib-needle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let voxelize = |skip_empty: bool| {
        let prefix = dir.join(format!("n{skip_empty}"));
        let mut vl = Library::new();
        scene(&mut vl);
        vl.volume(
            &prefix,
            Fields::O,
            [-97391400.0, 41802896.0, -3875514.0],
            [-97391392.0, 41802896.0, -3875514.0],
            [20001, 1, 1],
            1,
        )
        .unwrap();
        optimise(&mut vl, skip_empty);
        vl.end().unwrap();
        std::fs::read(dir.join(format!("n{skip_empty}_o.vlb"))).unwrap()
    };
    assert!(voxelize(true) == voxelize(false));
    std::fs::remove_dir_all(&dir).unwrap();
}
