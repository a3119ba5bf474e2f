//! Maximum-intensity projection: the one layer a MIP object contributes to a ray, the sample of
//! greatest opacity along its interval, shown as its colour. Compositing it is the caller's.

use crate::render::*;

impl Compiled {
    /// The maximum-intensity layer of a MIP object: the sample of greatest opacity along the
    /// interval (the first on ties), shown as `o·(r, g, b)`; returns (t, o, colour).
    pub(in crate::render) fn mip_layer(
        &self,
        obj: &CObj,
        c: &mut Cursor,
        origin: DVec3,
        dir: DVec3,
    ) -> Option<Layer> {
        let mut best: Option<(f64, f64)> = None;
        // Empty blocks hold no sample above 0: the walk passes over them exactly as for DVR.
        let grid = obj.skip.as_deref();
        while let Some(mid) = c.peek(grid) {
            c.k += 1;
            let o = obj.opacity_at(origin + mid * dir);
            if o > 0.0 && best.is_none_or(|(_, b)| o > b) {
                best = Some((mid, o));
                if o >= 1.0 {
                    break;
                }
            }
        }
        let (t, o) = best?;
        let mut s = obj.sample_at(origin + t * dir);
        run(&obj.program, &mut s);
        let f = s.values();
        Some(Layer {
            t: c.t1,
            alpha: o,
            colour: DVec3::new(f[1] as f64, f[2] as f64, f[3] as f64),
            bend: None,
            mirror: None,
        })
    }
}
