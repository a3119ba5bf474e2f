//! The head-on view of a slab that the DVR and pre-integration tests share: the camera on the
//! z axis at z = −100 looking at the origin (a 20° field of view, so the image spans ±17.6
//! world units at z = 0), and an object whose box is the slab [−200, 200]² × [0, depth].

use vlib::{Camera, Library};

/// Sets the camera on the z axis at z = −100, looking at the origin with a 20° field of view.
pub fn head_on(vl: &mut Library) {
    vl.camera(&Camera {
        eye: [0.0, 0.0, -100.0],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov: 20.0,
    })
    .unwrap();
}

/// Opens an object whose unit box is the slab [−200, 200]² × [0, depth].
pub fn slab_object(vl: &mut Library, depth: f32) {
    vl.object().unwrap();
    vl.translate(-0.5, -0.5, 0.0).unwrap();
    vl.scale(400.0, 400.0, depth).unwrap();
}
