//! A DICOM file's structure checked before it is parsed: every element, item and fragment
//! of the file meta group and the data set must lie inside the file (or inside the item that
//! holds it), and sequences nest at most [`DEPTH`] deep. A parser allocates an element's
//! value by the length its header declares; a file of a few bytes that declares 4 GiB is
//! refused here, naming the element, before anything is allocated for it. After the data
//! set's pixel data (7FE0,0010), bytes that are no element in order are trailing data, where
//! the data set ends (pydicom reads such files too).
//!
//! The walk reads element headers only (tag, VR, length) in the data set's encoding:
//! explicit or implicit VR, little or big endian; a sequence of defined length in implicit
//! VR is known by the standard dictionary, as the parser knows it. A binary element's length
//! must be a whole number of its values (2 bytes for US, 4 for UL, …; in implicit VR, of the
//! dictionary's VR): the parser reads whole values and would read the next element's header
//! from the bytes left over. Deflated data sets are not walked: they are refused by their
//! transfer syntax before parsing.

use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry, VirtualVr};
use dicom_core::{Tag, VR};
use dicom_dictionary_std::StandardDataDictionary;

/// How deep sequences may nest.
pub const DEPTH: usize = 32;

/// The undefined length.
const UNDEFINED: u32 = 0xFFFF_FFFF;

/// Implicit VR Little Endian, Explicit VR Big Endian, Deflated Explicit VR Little Endian.
pub const IMPLICIT_LE: &str = "1.2.840.10008.1.2";
pub const EXPLICIT_BE: &str = "1.2.840.10008.1.2.2";
pub const DEFLATED: &str = "1.2.840.10008.1.2.1.99";

/// Whether `head` (a file's first bytes) is a DICOM file: `DICM` at byte 128.
pub fn is_dicom(head: &[u8]) -> bool {
    head.get(128..132) == Some(b"DICM")
}

/// Checks the structure of the DICOM file `bytes` (preamble included); returns its transfer
/// syntax UID and where its data set ends: the end of the file, or where trailing data after
/// its pixel data begins (zero padding, other bytes: see [`Walk::dataset`]).
pub fn check(bytes: &[u8]) -> Result<(String, usize), String> {
    if !is_dicom(bytes) {
        return Err("not a DICOM file (no DICM at byte 128)".into());
    }
    let mut w = Walk {
        b: bytes,
        pos: 132,
        explicit: true,
        big: false,
    };
    // The file meta group: explicit VR little endian, group 0002; where it starts with its
    // group length (0002,0000), up to where that says, as the parser reads it (whole elements
    // until that many bytes are read: the data set starts after them, whatever their group).
    let mut ts = None;
    let mut meta_end: Option<usize> = None;
    loop {
        let more = match meta_end {
            Some(end) => w.pos < end,
            None => w.pos + 4 <= bytes.len() && w.u16_at(w.pos) == 0x0002,
        };
        if !more {
            break;
        }
        let first = w.pos == 132;
        let (tag, vr, len, header) = w.header()?;
        let start = w.pos + header;
        if len == UNDEFINED || start + len as usize > bytes.len() {
            return Err(w.overrun(tag, len, bytes.len().saturating_sub(start)));
        }
        if first && tag == Tag(0x0002, 0x0000) && len == 4 {
            meta_end = Some((start + 4).saturating_add(w.u32_at(start) as usize));
        }
        if tag == Tag(0x0002, 0x0010) && vr == Some(VR::UI) {
            let uid = &bytes[start..start + len as usize];
            ts = Some(
                String::from_utf8_lossy(uid)
                    .trim_end_matches(['\0', ' '])
                    .to_string(),
            );
        }
        w.pos = start + len as usize;
    }
    let ts = ts.ok_or("no TransferSyntaxUID (0002,0010) in the file meta information")?;
    match ts.as_str() {
        DEFLATED => return Ok((ts, bytes.len())),
        IMPLICIT_LE => w.explicit = false,
        EXPLICIT_BE => w.big = true,
        _ => {}
    }
    w.dataset(Some(bytes.len()), 0)?;
    Ok((ts, w.pos))
}

/// The bytes of one value of `vr` (1 for text and bytes).
fn unit(vr: VR) -> u32 {
    use VR::*;
    match vr {
        US | SS | OW => 2,
        AT | FL | OF | SL | UL | OL => 4,
        FD | OD | SV | UV | OV => 8,
        _ => 1,
    }
}

struct Walk<'a> {
    b: &'a [u8],
    pos: usize,
    explicit: bool,
    big: bool,
}

impl Walk<'_> {
    fn u16_at(&self, at: usize) -> u16 {
        let v = [self.b[at], self.b[at + 1]];
        if self.big {
            u16::from_be_bytes(v)
        } else {
            u16::from_le_bytes(v)
        }
    }

    fn u32_at(&self, at: usize) -> u32 {
        let v = [self.b[at], self.b[at + 1], self.b[at + 2], self.b[at + 3]];
        if self.big {
            u32::from_be_bytes(v)
        } else {
            u32::from_le_bytes(v)
        }
    }

    fn overrun(&self, tag: Tag, len: u32, left: usize) -> String {
        format!(
            "element {tag} at byte {} declares {}, but {left} remain",
            self.pos,
            crate::counted(len, "byte")
        )
    }

    /// The element header at the current position: tag, VR (explicit VR only), value length
    /// and header size. Item tags (FFFE,xxxx) have no VR in either encoding.
    fn header(&self) -> Result<(Tag, Option<VR>, u32, usize), String> {
        let at = self.pos;
        let short = || format!("the file ends inside an element header at byte {at}");
        if at + 8 > self.b.len() {
            return Err(short());
        }
        let tag = Tag(self.u16_at(at), self.u16_at(at + 2));
        if !self.explicit || tag.group() == 0xFFFE {
            return Ok((tag, None, self.u32_at(at + 4), 8));
        }
        let code = [self.b[at + 4], self.b[at + 5]];
        let vr = VR::from_binary(code).ok_or_else(|| {
            format!(
                "element {tag} at byte {at}: {:?} is not a value representation",
                String::from_utf8_lossy(&code)
            )
        })?;
        use VR::*;
        if matches!(
            vr,
            OB | OD | OF | OL | OV | OW | SQ | SV | UC | UN | UR | UT | UV
        ) {
            if at + 12 > self.b.len() {
                return Err(short());
            }
            Ok((tag, Some(vr), self.u32_at(at + 8), 12))
        } else {
            Ok((tag, Some(vr), self.u16_at(at + 6) as u32, 8))
        }
    }

    /// Whether an element of defined length holds a sequence.
    fn is_sequence(&self, tag: Tag, vr: Option<VR>) -> bool {
        match vr {
            Some(vr) => vr == VR::SQ,
            None => StandardDataDictionary
                .by_tag(tag)
                .is_some_and(|e| matches!(e.vr(), VirtualVr::Exact(VR::SQ))),
        }
    }

    /// The elements of a data set up to byte `end` (`None`: up to its item delimiter). In the
    /// file's own data set (`depth` 0), an element after the pixel data (7FE0,0010) that is
    /// not one (no element header, a tag not above the one before, a length past the end)
    /// starts trailing data: the walk ends before it.
    fn dataset(&mut self, end: Option<usize>, depth: usize) -> Result<(), String> {
        if depth > DEPTH {
            return Err(format!(
                "sequences nested more than {DEPTH} deep at byte {}",
                self.pos
            ));
        }
        let mut pixels: Option<Tag> = None;
        loop {
            match end {
                Some(e) if self.pos == e => return Ok(()),
                None if self.pos >= self.b.len() => {
                    return Err("an item of undefined length has no end".into())
                }
                _ => {}
            }
            let at = self.pos;
            match (self.element(end, depth), pixels) {
                (Ok(None), _) => return Ok(()),
                (Ok(Some(tag)), Some(before)) if tag <= before => {
                    self.pos = at;
                    return Ok(());
                }
                (Ok(Some(tag)), _) => {
                    if depth == 0 && (pixels.is_some() || tag == Tag(0x7FE0, 0x0010)) {
                        pixels = Some(tag);
                    }
                }
                (Err(_), Some(_)) => {
                    self.pos = at;
                    return Ok(());
                }
                (Err(e), None) => return Err(e),
            }
        }
    }

    /// The element at the current position, in a data set up to byte `end` (`None`: up to
    /// its item delimiter, which ends it: `None`); its tag.
    fn element(&mut self, end: Option<usize>, depth: usize) -> Result<Option<Tag>, String> {
        let limit = end.unwrap_or(self.b.len());
        let (tag, vr, len, header) = self.header()?;
        if self.pos + header > limit {
            return Err(format!(
                "element {tag} at byte {} overruns its item",
                self.pos
            ));
        }
        if tag.group() == 0xFFFE {
            if tag == Tag(0xFFFE, 0xE00D) && end.is_none() {
                self.pos += 8;
                return Ok(None);
            }
            return Err(format!("item tag {tag} out of place at byte {}", self.pos));
        }
        let start = self.pos + header;
        if len == UNDEFINED {
            self.pos = start;
            if tag == Tag(0x7FE0, 0x0010) {
                self.fragments()?;
            } else if vr == Some(VR::UN) {
                // A sequence of unknown VR: implicit VR little endian inside.
                let saved = (self.explicit, self.big);
                (self.explicit, self.big) = (false, false);
                let walked = self.sequence(None, depth + 1);
                (self.explicit, self.big) = saved;
                walked?;
            } else {
                self.sequence(None, depth + 1)?;
            }
            return Ok(Some(tag));
        }
        if start + len as usize > limit {
            return Err(self.overrun(tag, len, limit - start));
        }
        // The parser reads whole values of the VR (the dictionary's, in implicit VR) and goes
        // on after them: bytes left over would have it read the next element from inside
        // this one.
        let read_as = vr.or_else(|| StandardDataDictionary.by_tag(tag).map(|e| e.vr().relaxed()));
        if let Some(vr) = read_as.filter(|&vr| len % unit(vr) != 0) {
            return Err(format!(
                "element {tag} at byte {}: {} of {vr:?}, not a whole number of its {}-byte \
                 values",
                self.pos,
                crate::counted(len, "byte"),
                unit(vr)
            ));
        }
        self.pos = start;
        if self.is_sequence(tag, vr) {
            self.sequence(Some(start + len as usize), depth + 1)?;
        } else {
            self.pos += len as usize;
        }
        Ok(Some(tag))
    }

    /// The items of a sequence up to byte `end` (`None`: up to its sequence delimiter).
    fn sequence(&mut self, end: Option<usize>, depth: usize) -> Result<(), String> {
        let limit = end.unwrap_or(self.b.len());
        loop {
            if end == Some(self.pos) {
                return Ok(());
            }
            if self.pos + 8 > limit {
                return Err(format!(
                    "a sequence ends inside an item at byte {}",
                    self.pos
                ));
            }
            let tag = Tag(self.u16_at(self.pos), self.u16_at(self.pos + 2));
            let len = self.u32_at(self.pos + 4);
            match (tag.element(), tag.group()) {
                (0xE0DD, 0xFFFE) if end.is_none() => {
                    self.pos += 8;
                    return Ok(());
                }
                (0xE000, 0xFFFE) => {
                    self.pos += 8;
                    if len == UNDEFINED {
                        self.dataset(None, depth)?;
                    } else if self.pos + len as usize > limit {
                        return Err(self.overrun(tag, len, limit - self.pos));
                    } else {
                        self.dataset(Some(self.pos + len as usize), depth)?;
                    }
                }
                _ => {
                    return Err(format!(
                        "{tag} at byte {} where a sequence item belongs",
                        self.pos
                    ))
                }
            }
        }
    }

    /// The fragments of encapsulated pixel data, up to their sequence delimiter.
    fn fragments(&mut self) -> Result<(), String> {
        loop {
            if self.pos + 8 > self.b.len() {
                return Err("encapsulated pixel data without its end".into());
            }
            let tag = Tag(self.u16_at(self.pos), self.u16_at(self.pos + 2));
            let len = self.u32_at(self.pos + 4);
            self.pos += 8;
            match (tag.group(), tag.element()) {
                (0xFFFE, 0xE0DD) => return Ok(()),
                (0xFFFE, 0xE000) if len != UNDEFINED => {
                    let left = self.b.len() - self.pos;
                    if len as usize > left {
                        self.pos -= 8;
                        return Err(self.overrun(tag, len, left));
                    }
                    self.pos += len as usize;
                }
                _ => {
                    return Err(format!(
                        "{tag} at byte {} where a pixel data fragment belongs",
                        self.pos - 8
                    ))
                }
            }
        }
    }
}
