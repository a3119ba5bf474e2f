//! gzip data read member by member, as zlib's gzread and `gzip -d` read it: this module owns
//! where a gzip stream ends. Each member is decompressed with its CRC-32 and length checked
//! (one that does not match, or a member cut short, is an error). After a member, the end of
//! the input ends the stream; `1f 8b` starts another member (files joined with `cat`, BGZF);
//! anything else (zero padding, a newline, other bytes) is trailing data, counted and not
//! decompressed, for the reader to say in a note ([`Gunzip::trailing`]).

use flate2::bufread::GzDecoder;
use std::io::{self, BufRead, Read};

/// A reader of `R`'s bytes with room to look two bytes ahead (a member's magic) without
/// consuming them, even where they straddle two reads of `R`.
struct Ahead<R> {
    inner: R,
    buf: Box<[u8]>,
    pos: usize,
    end: usize,
}

impl<R: Read> Ahead<R> {
    fn new(inner: R) -> Ahead<R> {
        Ahead {
            inner,
            buf: vec![0; 64 * 1024].into_boxed_slice(),
            pos: 0,
            end: 0,
        }
    }

    /// Up to the next two bytes, not consumed (fewer only at the end of the input).
    fn peek2(&mut self) -> io::Result<&[u8]> {
        if self.end - self.pos < 2 {
            self.buf.copy_within(self.pos..self.end, 0);
            self.end -= self.pos;
            self.pos = 0;
            while self.end < 2 {
                match self.inner.read(&mut self.buf[self.end..]) {
                    Ok(0) => break,
                    Ok(n) => self.end += n,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(e),
                }
            }
        }
        Ok(&self.buf[self.pos..self.end.min(self.pos + 2)])
    }
}

impl<R: Read> Read for Ahead<R> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        let n = {
            let have = self.fill_buf()?;
            let n = have.len().min(out.len());
            out[..n].copy_from_slice(&have[..n]);
            n
        };
        self.consume(n);
        Ok(n)
    }
}

impl<R: Read> BufRead for Ahead<R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        if self.pos == self.end {
            self.end = self.inner.read(&mut self.buf)?;
            self.pos = 0;
        }
        Ok(&self.buf[self.pos..self.end])
    }

    fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.end);
    }
}

/// Where the reading is: inside a member, between members, or past the stream's end.
enum State<R> {
    Member(GzDecoder<Ahead<R>>),
    Between(Ahead<R>),
    Done,
}

/// The decompressed bytes of the gzip data `R` (which starts with a member), member by member.
pub struct Gunzip<R> {
    state: State<R>,
    trailing: u64,
}

impl<R: Read> Gunzip<R> {
    pub fn new(inner: R) -> Gunzip<R> {
        Gunzip {
            state: State::Member(GzDecoder::new(Ahead::new(inner))),
            trailing: 0,
        }
    }

    /// Bytes after the last member that start no other, once the stream has been read to its
    /// end (0 before).
    pub fn trailing(&self) -> u64 {
        self.trailing
    }
}

impl<R: Read> Read for Gunzip<R> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        loop {
            match &mut self.state {
                State::Member(d) => {
                    let n = d.read(out)?;
                    if n > 0 || out.is_empty() {
                        return Ok(n);
                    }
                    // The member ended, its checksum and length checked.
                    let State::Member(d) = std::mem::replace(&mut self.state, State::Done) else {
                        unreachable!("inside a member")
                    };
                    self.state = State::Between(d.into_inner());
                }
                State::Between(a) => match a.peek2()? {
                    [] => self.state = State::Done,
                    [0x1f, 0x8b] => {
                        let State::Between(a) = std::mem::replace(&mut self.state, State::Done)
                        else {
                            unreachable!("between members")
                        };
                        self.state = State::Member(GzDecoder::new(a));
                    }
                    _ => {
                        self.trailing = io::copy(a, &mut io::sink())?;
                        self.state = State::Done;
                    }
                },
                State::Done => return Ok(0),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Gunzip;
    use std::io::{Read, Write};

    fn member(bytes: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    /// A reader handing out one byte a read, so that a member's magic straddles two reads.
    struct Bytewise<'a>(&'a [u8]);

    impl Read for Bytewise<'_> {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            let n = self.0.len().min(out.len()).min(1);
            out[..n].copy_from_slice(&self.0[..n]);
            self.0 = &self.0[n..];
            Ok(n)
        }
    }

    #[test]
    fn members_are_joined_and_trailing_bytes_counted_whatever_the_reads() {
        let two = [member(b"abc"), member(b"defg")].concat();
        for (tail, trailing) in [
            (&b""[..], 0),
            (&[0u8; 7][..], 7),
            (&b"\n"[..], 1),
            (b"\x1f", 1),
        ] {
            let data = [&two[..], tail].concat();
            for bytewise in [false, true] {
                let mut g = if bytewise {
                    Gunzip::new(Box::new(Bytewise(&data)) as Box<dyn Read>)
                } else {
                    Gunzip::new(Box::new(&data[..]) as Box<dyn Read>)
                };
                let mut out = Vec::new();
                g.read_to_end(&mut out).unwrap();
                assert_eq!(out, b"abcdefg", "{tail:?}");
                assert_eq!(g.trailing(), trailing, "{tail:?}");
            }
        }
    }
}
