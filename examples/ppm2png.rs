//! Converts a binary PPM (P6, maxval 255) to PNG; the gallery uses it to show the PPM that the
//! paper's Figure 2 writes.
//!
//! ```text
//! cargo run --release --example ppm2png -- stone.ppm stone.png
//! ```

use std::process::ExitCode;

/// Parses a P6 file: magic, width, height, maxval 255 (with `#` comments), then the pixels.
fn parse_ppm(bytes: &[u8]) -> Result<(u32, u32, &[u8]), String> {
    let mut pos = 0;
    let mut fields = Vec::new();
    while fields.len() < 4 {
        while pos < bytes.len() && (bytes[pos].is_ascii_whitespace() || bytes[pos] == b'#') {
            if bytes[pos] == b'#' {
                while pos < bytes.len() && bytes[pos] != b'\n' {
                    pos += 1;
                }
            } else {
                pos += 1;
            }
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err("truncated header".into());
        }
        fields.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1; // the single whitespace byte before the pixels
    let num = |s: &str| s.parse::<u32>().map_err(|_| format!("bad number {s:?}"));
    if fields[0] != "P6" || num(&fields[3])? != 255 {
        return Err("only binary PPM (P6) with maxval 255 is supported".into());
    }
    let (w, h) = (num(&fields[1])?, num(&fields[2])?);
    let need = w as usize * h as usize * 3;
    let pixels = bytes.get(pos..pos + need).ok_or("truncated pixel data")?;
    Ok((w, h, pixels))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 {
        eprintln!("usage: ppm2png INPUT.ppm OUTPUT.png");
        return ExitCode::from(2);
    }
    let result = std::fs::read(&args[0])
        .map_err(|e| format!("{}: {e}", args[0]))
        .and_then(|bytes| {
            let (w, h, px) = parse_ppm(&bytes).map_err(|e| format!("{}: {e}", args[0]))?;
            vlib::write_image(std::path::Path::new(&args[1]), w, h, px).map_err(|e| e.to_string())
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ppm2png: {e}");
            ExitCode::FAILURE
        }
    }
}
