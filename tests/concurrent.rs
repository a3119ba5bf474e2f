//! Renders that run at the same time share what they may and give the bytes they give alone.
//! One dataset (an `Arc`, its caches unmade: node values, brick ranges, cell masks) is added to
//! three libraries of different scenes (pre-integrated, the nearest filter, the trilinear
//! filter with node gradients and a light); two threads each render every library's scene at
//! once, all six released together, so that each cache is asked for by several renders while
//! it is being made (`pool::try_once`: one is kept), and each library's own scene caches (its
//! pre-integration tables, skip grid) are made by two renders of it at once. Every image must
//! equal, byte for byte, the one a fresh library with its own copy of the dataset renders
//! alone; three rounds, each with a fresh shared dataset.

#[path = "common/two_balls.rs"]
mod two_balls;

use std::sync::{Arc, Barrier};
use vlib::{
    Camera, Dataset, DatasetId, Fields, Interpolation, Library, MappingId, MappingType, Optimise,
};

/// The scenes: 0 pre-integrated, 1 the nearest filter, 2 trilinear, lit.
const SCENES: usize = 3;

/// A library holding `data` as dataset 1 with scene `which` open and built.
fn library(data: Arc<Dataset>, which: usize) -> Library {
    let mut vl = Library::new();
    vl.add_dataset(DatasetId(1), data).unwrap();
    vl.mapping(MappingId(1), MappingType::Ramp, 2, 1, &[0.3, 0.0, 0.5, 1.0])
        .unwrap();
    vl.mapping(
        MappingId(2),
        MappingType::Ramp,
        2,
        3,
        &[0.3, 1.0, 0.4, 0.2, 0.9, 0.3, 0.8, 1.0],
    )
    .unwrap();
    vl.scene().unwrap();
    vl.set_optimise(Optimise {
        preintegrate: which == 0,
        ..Optimise::default()
    })
    .unwrap();
    if which == 1 {
        vl.interpolation(Interpolation::Nearest).unwrap();
    }
    vl.camera(&Camera {
        eye: [0.3, 0.2, -2.5],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 30.0,
    })
    .unwrap();
    vl.ambient(1.0, 1.0, 1.0, 1.0).unwrap();
    if which == 2 {
        vl.directional_light([1.0, -1.0, 1.0], [1.0, 1.0, 1.0], 1.0)
            .unwrap();
    }
    vl.step_size(0.005, 0.05).unwrap();
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, -0.5).unwrap();
    vl.dataset(Fields::F, DatasetId(1)).unwrap();
    vl.map(Fields::O, Fields::F, MappingId(1), 1).unwrap();
    vl.map(Fields::R, Fields::F, MappingId(2), 1).unwrap();
    vl.map(Fields::G, Fields::F, MappingId(2), 2).unwrap();
    vl.map(Fields::B, Fields::F, MappingId(2), 3).unwrap();
    vl.set(Fields::KA, 0.3).unwrap();
    vl.set(Fields::KD, 0.7).unwrap();
    vl.end().unwrap();
    vl
}

/// The library's scene's image, 64², as 8-bit RGB.
fn render(vl: &Library) -> Vec<u8> {
    vl.render_preview(64, 64, 1.0).unwrap().to_rgb8()
}

#[test]
fn renders_at_once_share_caches_and_give_the_bytes_they_give_alone() {
    let alone: Vec<Vec<u8>> = (0..SCENES)
        .map(|which| render(&library(Arc::new(two_balls::two_balls(96)), which)))
        .collect();
    for (which, img) in alone.iter().enumerate() {
        assert!(
            img.iter().filter(|&&b| b > 0).count() > img.len() / 10,
            "scene {which} shows the balls: max {:?}",
            img.iter().max()
        );
    }
    assert_ne!(alone[0], alone[1], "the scenes differ");
    assert_ne!(alone[1], alone[2], "the scenes differ");
    for round in 0..3 {
        let shared = Arc::new(two_balls::two_balls(96));
        let libraries: Vec<Library> = (0..SCENES)
            .map(|which| library(shared.clone(), which))
            .collect();
        let start = Barrier::new(2 * SCENES);
        let images: Vec<(usize, Vec<u8>)> = std::thread::scope(|s| {
            let threads: Vec<_> = (0..2 * SCENES)
                .map(|t| {
                    let (vl, start) = (&libraries[t % SCENES], &start);
                    s.spawn(move || {
                        start.wait();
                        (t % SCENES, render(vl))
                    })
                })
                .collect();
            threads.into_iter().map(|t| t.join().unwrap()).collect()
        });
        for (which, img) in images {
            assert!(
                img == alone[which],
                "round {round}: scene {which} rendered at once with the others differs from \
                 its render alone"
            );
        }
    }
}
