//! The integrators: what a ray shows. [`Compiled::trace_ray`] gathers, for every object the
//! ray meets, DVR samples through cursors, DSR surface hits ([`surface`], with mirror and
//! refracted secondary rays) and MIP layers ([`mip`]), and composites them front to back in
//! depth order, following a refracting surface's bent ray; a scene of one DVR volume takes the
//! DVR march ([`dvr`]) directly. Also the per-image preparations of primary rays
//! ([`ImageRays`], the [`EntryMap`] bound, the colour of rays that meet nothing). Where samples
//! lie is the cursor's, what colour a sample has is `shade`'s; the packet march (primary rays
//! of one volume in SIMD lanes) is `simd`'s.

use crate::render::*;

mod dvr;
mod mip;
mod preint;
mod surface;

pub(in crate::render) use dvr::*;
pub(in crate::render) use preint::{Bytes, PieceLighting, PreMarch, PreRay};

/// What kind of ray is being traced: how many bounces it has made, whether it is a mirror ray
/// (it then sees only objects that cast reflections), what it shows where it escapes
/// (`background`: the background colour, unless the image's backdrop is `transparent`, where
/// no ray of it shows that colour), and what its colour weighs in the pixel (1 for a primary
/// ray; the products of transmittances, opacities and KS along the ray tree for a secondary
/// one).
#[derive(Clone, Copy, Debug)]
pub(in crate::render) struct Ray {
    pub(in crate::render) depth: i32,
    pub(in crate::render) mirror: bool,
    pub(in crate::render) background: bool,
    pub(in crate::render) transparent: bool,
    pub(in crate::render) weight: f64,
}

impl Ray {
    pub(in crate::render) const PRIMARY: Ray = Ray {
        depth: 0,
        mirror: false,
        background: true,
        transparent: false,
        weight: 1.0,
    };
}

/// The mirror ray of a surface hit: it starts at `from` along `dir`, and its colour adds `ks`
/// times itself to the hit's; `background`: whether it shows the background where it escapes.
#[derive(Clone, Copy, Debug)]
pub(in crate::render) struct Mirror {
    pub(in crate::render) from: DVec3,
    pub(in crate::render) dir: DVec3,
    pub(in crate::render) ks: f64,
    pub(in crate::render) background: bool,
}

/// A contribution at one depth along a ray: a surface hit or a MIP layer; `bend` is the new
/// direction of a refracting surface (the ray continues that way behind it), `mirror` the
/// mirror ray of a reflecting one. Both are traced only when the compositing reaches the layer
/// and their branch weighs enough in the pixel ([`Compiled::branch`]).
#[derive(Clone, Copy, Debug)]
pub(in crate::render) struct Layer {
    pub(in crate::render) t: f64,
    pub(in crate::render) alpha: f64,
    pub(in crate::render) colour: DVec3,
    pub(in crate::render) bend: Option<(DVec3, DVec3)>,
    pub(in crate::render) mirror: Option<Mirror>,
}

/// What [`Compiled::trace_ray`] makes of the scene, the origin of an image's primary rays
/// (the eye) and its backdrop on each of them ([`Compiled::image_rays`]), made once per
/// image: the same numbers.
pub(in crate::render) struct ImageRays {
    /// The origin in the coordinates of the scene's object where it has one only
    /// ([`CObj::object_ray`]; zero, not read, otherwise).
    pub(in crate::render) origin_o: DVec3,
    /// What the primary rays show where they escape: the background colour, or zero for a
    /// transparent backdrop.
    pub(in crate::render) background: DVec3,
    /// Whether the backdrop is transparent (no ray of the image shows the background colour).
    pub(in crate::render) transparent: bool,
}

impl Compiled {
    /// The [`EntryMarks`] of an image (its [`EntryMap`]s are made of them): for a scene of one
    /// DVR volume with a skip grid (the only case [`Compiled::trace_ray`] uses a map), when
    /// the map can be built.
    pub(in crate::render) fn entry_marks(&self, camera: &Pinhole) -> Option<EntryMarks> {
        let [obj] = self.objects.as_slice() else {
            return None;
        };
        if !(self.settings.optimise.skip_empty
            && obj.seen_by(Ray::PRIMARY)
            && obj.render_type == RenderType::Dvr)
        {
            return None;
        }
        let grid = obj.skip.as_deref()?;
        // Where the batched march consults a cell mask, the boxes of the cells that can pass
        // its zero test bound where rays meet opacity more tightly than the shell's blocks.
        let passing = match (&obj.cells, obj.lean.as_ref().and_then(Lean::value_head)) {
            (Some(mask), Some((data, _))) => {
                let most = EntryMarks::most_boxes(camera);
                grid.passing_boxes(data, mask, (obj.box_min, obj.box_max), most)
            }
            _ => None,
        };
        // (Too many of them for the image: the shell's blocks, which may be fewer.)
        passing
            .and_then(|boxes| EntryMarks::of_boxes(&boxes, obj.to_world, camera))
            .or_else(|| EntryMarks::build(grid, obj.to_world, camera))
    }

    /// The colour [`Compiled::trace`] gives every primary ray of `image` whose bound is +∞
    /// (its transmittance is 1), whatever its origin and direction, where
    /// [`Compiled::trace_ray`]'s one-volume path answers it without looking at the ray
    /// (`None` where it does look): the per-pixel loop then neither makes the ray nor calls
    /// the trace for such a pixel.
    pub(in crate::render) fn unbounded_colour(&self, image: &ImageRays) -> Option<DVec3> {
        let ray = Ray::PRIMARY;
        let background = image.background;
        let [obj] = self.objects.as_slice() else {
            return None;
        };
        if !(obj.seen_by(ray) && obj.render_type == RenderType::Dvr) {
            return None;
        }
        // `trace_ray`'s test, the same numbers.
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        let shown = DVec3::ZERO + 1.0 * background;
        (bits(shown) == bits(background)).then_some(shown)
    }

    /// Traces one primary ray whose pixel has the [`EntryMap`] bound `bound` (−∞ without a
    /// map); returns the pixel colour and the ray's transmittance ([`Compiled::trace_ray`]).
    ///
    /// `image`: [`Compiled::image_rays`] of `origin` (the same for every ray of an image).
    pub(in crate::render) fn trace(
        &self,
        origin: DVec3,
        image: &ImageRays,
        dir: DVec3,
        bound: f64,
    ) -> (DVec3, f64) {
        let ray = Ray {
            transparent: image.transparent,
            ..Ray::PRIMARY
        };
        self.trace_ray(origin, Some(image), dir, ray, bound)
    }

    /// What [`Compiled::trace_ray`] makes of the scene, the ray origin `origin` and the
    /// backdrop on every primary ray from it, made once per image.
    pub(in crate::render) fn image_rays(&self, origin: DVec3, backdrop: Backdrop) -> ImageRays {
        let transparent = backdrop == Backdrop::Transparent;
        ImageRays {
            origin_o: match self.objects.as_slice() {
                [obj] => obj.object_ray(origin, DVec3::ZERO).0,
                _ => DVec3::ZERO,
            },
            background: if transparent {
                DVec3::ZERO
            } else {
                crate::model::scene::v3(self.settings.background)
            },
            transparent,
        }
    }

    /// Whether a secondary ray whose colour weighs `weight` in the pixel is traced: where that
    /// weight is positive and at least the termination threshold (with early termination
    /// off, wherever it is positive); returns the weight then. A branch cut off adds nothing,
    /// as the rest of a terminated ray does: each bounce's ray traces its own further rays
    /// only where its composite reaches, so the tree's size is bounded by the number of
    /// branches that can weigh that much, not by 2 to the recursion depth.
    fn branch(&self, weight: f64) -> Option<f64> {
        (weight > 0.0 && weight >= self.settings.optimise.stop_below()).then_some(weight)
    }

    /// Traces a ray. DVR objects contribute their samples, DSR objects their surface hits and
    /// MIP objects their maximum-intensity layer, all composited front to back in depth order.
    /// At a refracting surface the rest of the ray continues along the refracted direction.
    ///
    /// `bound`: no block of the scene's one object that may hold opacity meets the ray before
    /// this parameter (its [`EntryMap`] bound; −∞ when nothing is known): the walk starts
    /// there, and a ray whose bound is +∞ shows the background. Only a primary ray of a scene
    /// of one DVR volume is given a bound.
    ///
    /// `image`: what is made of `origin` and the scene once per image where known
    /// ([`Compiled::image_rays`]; `None`: made here).
    ///
    /// Returns the colour the ray shows and its transmittance `T`: the weight of what it
    /// shows where it escapes (the background) in that colour, which is `col + T·background`
    /// for the light `col` it gathers; 0 where it ends early or a branch behind a refracting
    /// surface weighs too little to be traced. Mirror rays add colour, not transmittance.
    pub(in crate::render) fn trace_ray(
        &self,
        origin: DVec3,
        image: Option<&ImageRays>,
        dir: DVec3,
        ray: Ray,
        bound: f64,
    ) -> (DVec3, f64) {
        // A render that is to stop starts no more rays (a super-sampled pixel's next ray, a
        // mirror's, a refracted one): its pixels are discarded. Rays under way look again
        // every `PROBE_EVERY` segments.
        if crate::control::stop_requested() {
            return (DVec3::ZERO, 0.0);
        }
        let background = if ray.background && !ray.transparent {
            match image {
                Some(i) => i.background,
                None => crate::model::scene::v3(self.settings.background),
            }
        } else {
            DVec3::ZERO
        };
        if let [obj] = self.objects.as_slice() {
            // A scene of one volume (the usual scanned-data case): what the general path below
            // does for it, without building its lists.
            if obj.seen_by(ray) && obj.render_type == RenderType::Dvr {
                // What the march gives when it takes no sample.
                let unsampled = || DVec3::ZERO + 1.0 * background;
                if bound == f64::INFINITY {
                    // Without the clip: a ray that misses the box shows `background`, one that
                    // meets it takes no sample (its bound is past t1, which is finite) and shows
                    // `unsampled`. The two differ only in a component that is −0 (0 + −0 is
                    // +0); where none is, either is the answer.
                    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                    let shown = unsampled();
                    if bits(shown) == bits(background) {
                        return (shown, 1.0);
                    }
                }
                let (o, d) = match image {
                    Some(i) => (i.origin_o, obj.to_object.transform_vector3(dir)),
                    None => obj.object_ray(origin, dir),
                };
                let Some((t0, t1)) = obj.clip(o, d) else {
                    return (background, 1.0);
                };
                if bound >= t1 {
                    return (unsampled(), 1.0);
                }
                // In place (see `Cursor::unstarted`).
                let mut c = Cursor::unstarted(obj, 0, (o, d), (t0, t1));
                c.start(self, obj, bound);
                let (col, t) = self.march_one(&mut c, origin, dir);
                return (col + t * background, t);
            }
        }
        let mut cursors: Vec<Cursor> = Vec::new();
        let mut layers: Vec<Layer> = Vec::new();
        for i in self.met_by_ray(origin, dir, f64::INFINITY) {
            let obj = &self.objects[i];
            if !obj.seen_by(ray) {
                continue;
            }
            let (o, d) = obj.object_ray(origin, dir);
            if let Some((t0, t1)) = obj.clip(o, d) {
                let mut c = Cursor::new(self, obj, i, (o, d), (t0, t1), f64::NEG_INFINITY);
                match obj.render_type {
                    RenderType::Dvr => cursors.push(c),
                    RenderType::Dsr => {
                        layers.extend(self.surface_hits(obj, &c, origin, dir, ray, true))
                    }
                    RenderType::Mip => layers.extend(self.mip_layer(obj, &mut c, origin, dir)),
                }
            }
        }
        if layers.is_empty() && cursors.len() == 1 {
            // One volume along the ray and nothing else: its own tight loop.
            let mut c = cursors.pop().expect("one cursor");
            let (col, t) = self.march_one(&mut c, origin, dir);
            return (col + t * background, t);
        }
        layers.sort_by(|a, b| a.t.total_cmp(&b.t));
        let mut layers = layers.into_iter().peekable();
        let mut acc = Integral::new(self);
        // Among many volumes along the ray, each cursor's next segment waits in a heap, and
        // a cursor is looked at again only once a segment is taken from it: a sample costs
        // O(log k) among k, not a look at every one (k² per ray). A few are scanned.
        let mut heap = (cursors.len() > SCANNED_CURSORS).then(|| {
            let mut heap = std::collections::BinaryHeap::with_capacity(cursors.len());
            for (ci, c) in cursors.iter_mut().enumerate() {
                if let Some(mid) = c.peek(self.objects[c.object].skip.as_deref()) {
                    heap.push(Next::new(mid, ci));
                }
            }
            heap
        });
        'march: loop {
            // The next segment in depth order (ties: object order).
            let mut best: Option<(usize, f64)> = None;
            match &heap {
                Some(heap) => best = heap.peek().map(|n| (n.cursor, n.mid)),
                None => {
                    for (ci, c) in cursors.iter_mut().enumerate() {
                        let grid = self.objects[c.object].skip.as_deref();
                        if let Some(mid) = c.peek(grid) {
                            if best.is_none_or(|(_, m)| mid < m) {
                                best = Some((ci, mid));
                            }
                        }
                    }
                }
            }
            // Layers in front of that sample come first.
            while let Some(&layer) = layers.peek() {
                if best.is_some_and(|(_, m)| layer.t > m) {
                    break;
                }
                layers.next();
                // The layer's weight in the pixel, before it is composited.
                let reached = ray.weight * acc.transmittance() * layer.alpha;
                let mut colour = layer.colour;
                if let Some(m) = layer.mirror {
                    if let Some(weight) = self.branch(reached * m.ks) {
                        let mirror = Ray {
                            depth: ray.depth + 1,
                            mirror: true,
                            background: m.background,
                            transparent: ray.transparent,
                            weight,
                        };
                        colour += m.ks
                            * self
                                .trace_ray(m.from, None, m.dir, mirror, f64::NEG_INFINITY)
                                .0;
                    }
                }
                if acc.add(layer.alpha, colour) {
                    break 'march;
                }
                if let Some((from, to)) = layer.bend {
                    // Everything behind a refracting surface is seen along the bent ray.
                    let (col, t) = acc.result();
                    let Some(weight) = self.branch(ray.weight * t) else {
                        return (col, 0.0);
                    };
                    let (behind, t_behind) = self.trace_ray(
                        from,
                        None,
                        to,
                        Ray {
                            depth: ray.depth + 1,
                            weight,
                            ..ray
                        },
                        f64::NEG_INFINITY,
                    );
                    return (col + t * behind, t * t_behind);
                }
            }
            let Some((ci, mid)) = best else { break };
            let c = &mut cursors[ci];
            let len = c.take();
            let obj = &self.objects[c.object];
            if let Some(mut heap) = heap.as_mut().and_then(|h| h.peek_mut()) {
                // The cursor's next segment takes the place of the one taken.
                match c.peek(obj.skip.as_deref()) {
                    Some(next) => *heap = Next::new(next, ci),
                    None => drop(std::collections::binary_heap::PeekMut::pop(heap)),
                }
            }
            if len <= 0.0 {
                continue;
            }
            if let Some((alpha, colour)) =
                self.shade(obj, origin + mid * dir, c.object_point(mid), dir, len)
            {
                if acc.add(alpha, colour) {
                    break;
                }
            }
        }
        let (col, t) = acc.result();
        (col + t * background, t)
    }
}

/// Up to this many DVR volumes along a ray, [`Compiled::trace_ray`] finds the next sample by
/// looking at every volume's next segment; beyond, through a heap ([`Next`]).
const SCANNED_CURSORS: usize = 8;

/// A cursor's next segment in [`Compiled::trace_ray`]'s heap: its midpoint and the cursor's
/// index, ordered so that the heap's greatest is the nearest midpoint, of the first cursor
/// where several are as near (what the scan in cursor order, keeping the first strictly
/// nearer one, picks). Midpoints are finite (a cursor's ends are); −0 is taken as 0, which
/// `<` does not tell apart.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Next {
    mid: f64,
    cursor: usize,
}

impl Next {
    fn new(mid: f64, cursor: usize) -> Next {
        Next {
            mid: mid + 0.0,
            cursor,
        }
    }
}

impl Eq for Next {}

impl PartialOrd for Next {
    fn partial_cmp(&self, other: &Next) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Next {
    fn cmp(&self, other: &Next) -> std::cmp::Ordering {
        // Reversed: the nearest, then the first cursor, is the greatest.
        (other.mid.total_cmp(&self.mid)).then(other.cursor.cmp(&self.cursor))
    }
}
