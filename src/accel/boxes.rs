//! A bounding volume hierarchy over a scene's boxes: which of many objects a ray or a point may
//! meet, found in time that grows with the logarithm of their number and the number met,
//! instead of a look at every one.
//!
//! [`BoxTree`] holds axis-aligned boxes by the index of their item (the renderer's root objects,
//! their world boxes padded by more than rounding can move a clip by) and answers, for a ray
//! `o + t·d` (0 ≤ t ≤ a reach: infinite, or a shadow ray's distance to its light) or a point,
//! the items whose box it meets, in increasing order: a superset of those the caller's own
//! exact test then finds, so that the tree changes which items are looked at, never what is
//! found. An item whose box is not known (`None`: not finite, or a transform too
//! ill-conditioned to pad for) is in every answer. The module owns the tree, not the boxes: the
//! renderer decides them (`render::compile`).

use crate::error::Result;
use crate::num::try_with_capacity;
use glam::DVec3;

/// Items a leaf holds at most.
const LEAF: usize = 4;

/// One node: a leaf (`count > 0`: items `items[first..first + count]`) or an interior node
/// (`count == 0`: its children are the next node and node `first`).
#[derive(Clone, Copy, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    first: usize,
    count: usize,
}

/// A bounding volume hierarchy over boxes (see the module's opening).
#[derive(Debug)]
pub(crate) struct BoxTree {
    nodes: Vec<Node>,
    /// The items with a box, in the order of the leaves, each with its box.
    items: Vec<(usize, DVec3, DVec3)>,
    /// The items without a box, in increasing order: in every answer.
    always: Vec<usize>,
}

impl BoxTree {
    /// The tree of `boxes` (item i's `(min, max)`, or `None`), by median splits along the
    /// longest axis of the boxes' centres. `NoMemory` where its nodes cannot be allocated.
    pub(crate) fn build(boxes: &[Option<(DVec3, DVec3)>]) -> Result<BoxTree> {
        let mut items = try_with_capacity(boxes.len(), "the scene's box tree")?;
        let mut always = Vec::new();
        for (i, b) in boxes.iter().enumerate() {
            match *b {
                Some((min, max)) if min.is_finite() && max.is_finite() && min.cmple(max).all() => {
                    items.push((i, min, max))
                }
                _ => always.push(i),
            }
        }
        // A leaf holds at least one item, and each interior node has two children: fewer than
        // 2n nodes.
        let mut nodes = try_with_capacity(2 * items.len(), "the scene's box tree")?;
        if !items.is_empty() {
            let n = items.len();
            split(&mut nodes, &mut items, 0, n);
        }
        Ok(BoxTree {
            nodes,
            items,
            always,
        })
    }

    /// Appends to `out` (cleared first), in increasing order, every item whose box, widened by
    /// `slack` on every side, the ray `o + t·d` meets at some t in [0, `reach`], and every item
    /// without a box. A ray of a coordinate that is not finite gets every item; a `reach` that
    /// is not a number bounds nothing.
    pub(crate) fn ray(&self, o: DVec3, d: DVec3, slack: f64, reach: f64, out: &mut Vec<usize>) {
        out.clear();
        if !(o.is_finite() && d.is_finite()) {
            out.extend(0..self.items.len() + self.always.len());
            return;
        }
        let inv = d.recip();
        let reach = if reach.is_nan() { f64::INFINITY } else { reach };
        self.visit(
            |min, max| meets(min - slack, max + slack, o, d, inv, reach),
            out,
        );
    }

    /// Appends to `out` (cleared first), in increasing order, every item whose box, widened by
    /// `slack` on every side, holds `p` (its faces included), and every item without a box.
    pub(crate) fn point(&self, p: DVec3, slack: f64, out: &mut Vec<usize>) {
        out.clear();
        self.visit(
            |min, max| p.cmpge(min - slack).all() && p.cmple(max + slack).all(),
            out,
        );
    }

    /// The items whose box passes `test` (found through the nodes whose boxes pass it), and the
    /// items without a box, into `out`, sorted.
    fn visit(&self, test: impl Fn(DVec3, DVec3) -> bool, out: &mut Vec<usize>) {
        // A median split halves the items, so the depth is at most log2(n) + 1 < 64.
        let mut stack = [0usize; 64];
        let mut top = 0;
        if !self.nodes.is_empty() {
            stack[0] = 0;
            top = 1;
        }
        while top > 0 {
            top -= 1;
            let at = stack[top];
            let node = self.nodes[at];
            if !test(node.min, node.max) {
                continue;
            }
            if node.count > 0 {
                let leaf = &self.items[node.first..node.first + node.count];
                out.extend(leaf.iter().filter(|b| test(b.1, b.2)).map(|b| b.0));
            } else {
                stack[top] = node.first;
                stack[top + 1] = at + 1;
                top += 2;
            }
        }
        out.extend_from_slice(&self.always);
        out.sort_unstable();
    }
}

/// Builds the subtree of `items[start..end]` (at least one item) as the next node and its
/// descendants.
fn split(nodes: &mut Vec<Node>, items: &mut [(usize, DVec3, DVec3)], start: usize, end: usize) {
    let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut cmin, mut cmax) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for &(_, lo, hi) in &items[start..end] {
        min = min.min(lo);
        max = max.max(hi);
        let c = (lo + hi) * 0.5;
        cmin = cmin.min(c);
        cmax = cmax.max(c);
    }
    let at = nodes.len();
    nodes.push(Node {
        min,
        max,
        first: start,
        count: end - start,
    });
    if end - start <= LEAF {
        return;
    }
    let extent = cmax - cmin;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = start + (end - start) / 2;
    let centre = |b: &(usize, DVec3, DVec3)| (b.1[axis] + b.2[axis]) * 0.5;
    items[start..end].select_nth_unstable_by(mid - start, |a, b| {
        centre(a).total_cmp(&centre(b)).then(a.0.cmp(&b.0))
    });
    split(nodes, items, start, mid);
    let right = nodes.len();
    split(nodes, items, mid, end);
    nodes[at].first = right;
    nodes[at].count = 0;
}

/// Whether the ray `o + t·d` (0 ≤ t ≤ `reach`; `inv` = 1 / d) meets the box [min, max], its
/// faces included. An axis where the ray's parameters are not numbers (d = 0 or a subnormal d
/// whose inverse is infinite, with o on a face) puts no bound on t but o's own within the slab
/// where d = 0: the answer errs only towards meeting.
#[inline]
pub(super) fn meets(min: DVec3, max: DVec3, o: DVec3, d: DVec3, inv: DVec3, reach: f64) -> bool {
    let (mut lo, mut hi) = (0.0f64, reach);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < min[a] || o[a] > max[a] {
                return false;
            }
            continue;
        }
        let (t1, t2) = ((min[a] - o[a]) * inv[a], (max[a] - o[a]) * inv[a]);
        if t1.is_nan() || t2.is_nan() {
            continue;
        }
        lo = lo.max(t1.min(t2));
        hi = hi.min(t1.max(t2));
    }
    lo <= hi
}
