//! The volumes of the scaling table (`benches/scaling.sh`), written as `.vlb` files a z slab
//! at a time (never the whole output in memory):
//!
//! ```text
//! cargo run --release --example scaling_volumes -- repeat   IN.vlb OUT.vlb K        # K copies per axis
//! cargo run --release --example scaling_volumes -- resample IN.vlb OUT.vlb K 8|16  # K× finer, trilinear
//! cargo run --release --example scaling_volumes -- ct       OUT.vlb N               # N³ 16-bit CT-like phantom
//! ```
//!
//! `repeat` tiles the voxels K times along each axis (K·n nodes). `resample` puts K(n − 1) + 1
//! nodes on each axis, so that every K-th node is an input node and the others are the
//! input's trilinear interpolation: the same object at K times the resolution, in 8 bits
//! (rounded) or 16 bits (the 8-bit scale times 257, rounded; the normalisation a = 0,
//! b = 65535 keeps every transfer function's meaning). `ct` writes a 16-bit phantom in CT
//! numbers plus 1024 (normalised a = 0, b = 4095): air, a soft-tissue ellipsoid with a bone
//! shell 4 % of its size thick, two denser inner ellipsoids and a deterministic ±20 noise.

use std::fs::File;
use std::io::{BufWriter, Read, Write};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn header(dims: [usize; 3], width: u32, a: f32, b: f32) -> Vec<u8> {
    let mut h = b"VLB1".to_vec();
    for d in dims {
        h.extend((d as u32).to_le_bytes());
    }
    h.extend(width.to_le_bytes());
    h.extend(a.to_le_bytes());
    h.extend(b.to_le_bytes());
    h
}

/// An 8-bit `.vlb`: its dimensions, normalisation and voxels.
fn read8(path: &str) -> Res<([usize; 3], f32, f32, Vec<u8>)> {
    let mut bytes = Vec::new();
    File::open(path)?.read_to_end(&mut bytes)?;
    let u = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    let f = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    if &bytes[..4] != b"VLB1" || u(16) != 1 {
        return Err(format!("{path}: not an 8-bit .vlb").into());
    }
    let dims = [u(4), u(8), u(12)];
    let (a, b) = (f(20), f(24));
    Ok((dims, a, b, bytes.split_off(28)))
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| -> Res<&str> {
        args.get(i)
            .map(String::as_str)
            .ok_or_else(|| "missing argument (see the file's comment)".into())
    };
    match arg(0)? {
        "repeat" => {
            let (n, a, b, v) = read8(arg(1)?)?;
            let k: usize = arg(3)?.parse()?;
            let m = n.map(|d| d * k);
            let mut out = BufWriter::with_capacity(1 << 20, File::create(arg(2)?)?);
            out.write_all(&header(m, 1, a, b))?;
            let mut row = Vec::with_capacity(m[0]);
            for z in 0..m[2] {
                for y in 0..m[1] {
                    let at = n[0] * ((y % n[1]) + n[1] * (z % n[2]));
                    row.clear();
                    for _ in 0..k {
                        row.extend_from_slice(&v[at..at + n[0]]);
                    }
                    out.write_all(&row)?;
                }
            }
            out.flush()?;
        }
        "resample" => {
            let (n, a, b, v) = read8(arg(1)?)?;
            let k: usize = arg(3)?.parse()?;
            let wide = match arg(4)? {
                "8" => false,
                "16" => true,
                w => return Err(format!("width {w}: 8 or 16").into()),
            };
            let m = n.map(|d| k * (d - 1) + 1);
            let (a, b) = if wide { (0.0, 65535.0) } else { (a, b) };
            let mut out = BufWriter::with_capacity(1 << 20, File::create(arg(2)?)?);
            out.write_all(&header(m, if wide { 2 } else { 1 }, a, b))?;
            // Per axis, for each output node: the input cell and the weight of its far node.
            let axis = |d: usize, md: usize| -> Vec<(usize, f64)> {
                (0..md)
                    .map(|i| {
                        let (c, r) = (i / k, (i % k) as f64 / k as f64);
                        if c + 1 >= d {
                            (d.saturating_sub(2), if d > 1 { 1.0 } else { 0.0 })
                        } else {
                            (c, r)
                        }
                    })
                    .collect()
            };
            let (ax, ay, az) = (axis(n[0], m[0]), axis(n[1], m[1]), axis(n[2], m[2]));
            let at = |i: usize, j: usize, l: usize| v[i + n[0] * (j + n[1] * l)] as f64;
            let mut row = Vec::with_capacity(2 * m[0]);
            for &(cz, wz) in &az {
                for &(cy, wy) in &ay {
                    row.clear();
                    for &(cx, wx) in &ax {
                        let mut s = 0.0;
                        for (dz, fz) in [(0, 1.0 - wz), (1, wz)] {
                            for (dy, fy) in [(0, 1.0 - wy), (1, wy)] {
                                for (dx, fx) in [(0, 1.0 - wx), (1, wx)] {
                                    let f = fx * fy * fz;
                                    if f != 0.0 {
                                        s += f * at(cx + dx, cy + dy, cz + dz);
                                    }
                                }
                            }
                        }
                        if wide {
                            row.extend(((s * 257.0).round() as u16).to_le_bytes());
                        } else {
                            row.push(s.round() as u8);
                        }
                    }
                    out.write_all(&row)?;
                }
            }
            out.flush()?;
        }
        "ct" => {
            let n: usize = arg(2)?.parse()?;
            let mut out = BufWriter::with_capacity(1 << 20, File::create(arg(1)?)?);
            out.write_all(&header([n; 3], 2, 0.0, 4095.0))?;
            let c = (n as f64 - 1.0) / 2.0;
            let mut row = Vec::with_capacity(2 * n);
            for z in 0..n {
                for y in 0..n {
                    row.clear();
                    for x in 0..n {
                        let p = [x, y, z].map(|i| (i as f64 - c) / c);
                        let e = |r: [f64; 3], o: [f64; 3]| {
                            ((p[0] - o[0]) / r[0]).powi(2)
                                + ((p[1] - o[1]) / r[1]).powi(2)
                                + ((p[2] - o[2]) / r[2]).powi(2)
                        };
                        let body = e([0.85, 0.7, 0.9], [0.0; 3]);
                        let hu = if body > 1.0 {
                            -1000.0
                        } else if body > 0.92 {
                            1200.0
                        } else if e([0.25, 0.2, 0.3], [-0.3, 0.0, 0.1]) < 1.0 {
                            300.0
                        } else if e([0.15, 0.15, 0.15], [0.35, 0.1, -0.2]) < 1.0 {
                            700.0
                        } else {
                            40.0
                        };
                        // A hash of the position: deterministic noise of ±20.
                        let h = (x as u64)
                            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                            .wrapping_add((y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
                            .wrapping_add((z as u64).wrapping_mul(0x1656_67B1_9E37_79F9));
                        let noise = ((h >> 40) % 41) as f64 - 20.0;
                        let v = (hu + 1024.0 + noise).clamp(0.0, 4095.0) as u16;
                        row.extend(v.to_le_bytes());
                    }
                    out.write_all(&row)?;
                }
            }
            out.flush()?;
        }
        other => return Err(format!("unknown command {other} (repeat, resample or ct)").into()),
    }
    Ok(())
}
