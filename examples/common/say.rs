//! Standard output for the examples, as `vlconvert` writes it.

/// Writes `line` and a newline to standard output. Unlike `println!`, which panics (exit
/// status 101) when the write fails, a reader that has gone (`… --example mni | head -0`) is
/// not an error: the line is dropped and the example goes on. Any other failure (a full disk
/// behind a redirection, say) is returned, so `main` ends with it and exit status 1.
pub fn say(line: std::fmt::Arguments) -> Result<(), Box<dyn std::error::Error>> {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{line}") {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(format!("writing to standard output: {e}").into())
        }
        _ => Ok(()),
    }
}
