//! Small 3-vector arithmetic for the readers' placements (NRRD, MetaImage, DICOM).

/// The cross product a × b.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The dot product a · b.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The unit normal of the plane of `a` and `b` (a × b, normalised); `None` when they are
/// parallel (or a product is not finite).
pub fn unit_normal(a: [f64; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let n = cross(a, b);
    let len = dot(n, n).sqrt();
    (len > 0.0 && len.is_finite()).then(|| n.map(|v| v / len))
}
