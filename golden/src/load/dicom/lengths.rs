//! A walk over a DICOM file's element headers, before `dicom-rs` parses
//! it: every defined length must fit in the bytes left in the file. The
//! parser reserves an element's declared length before reading it, so a
//! forged length (a 1 KB slice whose PixelData claims 4 GB) would cost that
//! much memory; here it costs a one-line error.

/// The tag of encapsulated pixel data, whose items are raw fragments.
const PIXEL_DATA: (u16, u16) = (0x7FE0, 0x0010);

/// Undefined length: a sequence, an item or encapsulated pixel data that
/// ends with a delimiter.
const UNDEFINED: u32 = 0xFFFF_FFFF;

/// Explicit VRs whose length is 2 bytes; every other (the long ones, and
/// any unknown VR, which the parser reads as UN) has 2 reserved bytes and a
/// 4-byte length.
const SHORT_VRS: [&[u8; 2]; 21] = [
    b"AE", b"AS", b"AT", b"CS", b"DA", b"DS", b"DT", b"FL", b"FD", b"IS", b"LO", b"LT", b"PN",
    b"SH", b"SL", b"SS", b"ST", b"TM", b"UI", b"UL", b"US",
];

/// Checks the element lengths of a Part 10 file's bytes (preamble, `DICM`,
/// the file meta group, the data set). Files without the magic are left to
/// the parser. A deflated data set is inflated first, its size checked
/// against `limit` before any byte of it is held ([`inflate`]); its lengths
/// are then checked against the inflated bytes. The error names the element
/// and its length.
pub(super) fn check_lengths(bytes: &[u8], limit: u64) -> Result<(), String> {
    if bytes.len() < 132 || &bytes[128..132] != b"DICM" {
        return Ok(());
    }
    let mut w = Walk {
        bytes,
        pos: 132,
        explicit: true,
        big: false,
    };
    // The file meta group is explicit VR little endian; it names the
    // transfer syntax of the rest. The parser reads it element by element
    // until the bytes its group length (0002,0000) declares are consumed,
    // so the walk does the same: where that length disagrees with the
    // elements (a forged count, a value one element too long), the data
    // set starts where the parser will start it, not at the first element
    // of another group. Without a group length the parser refuses the file
    // (nothing is allocated), and the walk checks what follows group 2.
    let mut ts = String::new();
    let group_length = w.group_length();
    let mut read = 0u64;
    // Fewer than 8 bytes cannot hold a header: the parser fails there.
    while w.left() >= 8
        && match group_length {
            Some(n) => read < n,
            None => w.peek_group() == Some(0x0002),
        }
    {
        let at = w.pos;
        let (tag, len, _) = w.header()?;
        if len == UNDEFINED {
            // The parser refuses an undefined length in the meta group.
            return Ok(());
        }
        let len = w.fit(tag, len)?;
        if tag == (0x0002, 0x0010) {
            let v = &bytes[w.pos..w.pos + len];
            // Trimmed as the parser trims it (any whitespace and NULs).
            ts = String::from_utf8_lossy(v)
                .trim_end_matches(|c: char| c.is_whitespace() || c == '\0')
                .to_owned();
        }
        w.pos += len;
        read += (w.pos - at) as u64;
    }
    match ts.as_str() {
        "1.2.840.10008.1.2.1.99" => {
            // Deflated explicit VR little endian: the data set after the
            // meta group is one raw deflate stream (RFC 1951).
            let inflated = inflate(&bytes[w.pos..], limit)?;
            return Walk {
                bytes: &inflated,
                pos: 0,
                explicit: true,
                big: false,
            }
            .data_set();
        }
        "1.2.840.10008.1.2" => w.explicit = false,
        "1.2.840.10008.1.2.2" => w.big = true,
        _ => {}
    }
    w.data_set()
}

/// The bytes of the raw deflate stream `data`, refused in one line when
/// they would be more than `limit` (a deflate bomb: 1 KB of input may
/// inflate to 1 MB), when the stream is cut off before its end, or when it
/// is corrupt. The stream is inflated twice: once counting its bytes
/// (nothing held), then into a buffer of exactly that size.
pub(super) fn inflate(data: &[u8], limit: u64) -> Result<Vec<u8>, String> {
    let size = inflate_into(data, |_, total| {
        if total > limit {
            return Err(format!(
                "the deflated data set inflates to more than the memory limit of {}",
                crate::error::human_bytes(limit as u128)
            ));
        }
        Ok(())
    })?;
    let mut out = Vec::new();
    out.try_reserve_exact(size as usize)
        .map_err(|_| format!("cannot hold the {size}-byte inflated data set"))?;
    inflate_into(data, |chunk, _| {
        out.extend_from_slice(chunk);
        Ok(())
    })?;
    Ok(out)
}

/// Runs the raw deflate stream `data` to its end, handing each inflated
/// chunk to `take` with the bytes inflated so far; returns their count.
fn inflate_into(
    data: &[u8],
    mut take: impl FnMut(&[u8], u64) -> Result<(), String>,
) -> Result<u64, String> {
    use flate2::{Decompress, FlushDecompress, Status};
    let mut z = Decompress::new(false);
    let mut buf = vec![0u8; 64 << 10];
    loop {
        let (was_in, was_out) = (z.total_in(), z.total_out());
        let status = z
            .decompress(&data[was_in as usize..], &mut buf, FlushDecompress::None)
            .map_err(|e| format!("the deflated data set is corrupt: {e}"))?;
        let n = (z.total_out() - was_out) as usize;
        take(&buf[..n], z.total_out())?;
        match status {
            Status::StreamEnd => return Ok(z.total_out()),
            // No progress: the input ended before the stream did.
            _ if n == 0 && z.total_in() == was_in => {
                return Err(format!(
                "the deflated data set is cut off after {} of its bytes (the stream does not end)",
                z.total_out()
            ))
            }
            _ => {}
        }
    }
}

/// A cursor over the bytes.
struct Walk<'a> {
    bytes: &'a [u8],
    pos: usize,
    explicit: bool,
    big: bool,
}

impl Walk<'_> {
    fn u16_at(&self, at: usize) -> u16 {
        let b = [self.bytes[at], self.bytes[at + 1]];
        if self.big {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        }
    }

    fn u32_at(&self, at: usize) -> u32 {
        let b = [
            self.bytes[at],
            self.bytes[at + 1],
            self.bytes[at + 2],
            self.bytes[at + 3],
        ];
        if self.big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    }

    fn left(&self) -> usize {
        self.bytes.len() - self.pos
    }

    /// The value of the group length element (0002,0000) at the cursor,
    /// stepping over it, if the file meta group starts with one (explicit
    /// VR `UL`, length 4), as the parser requires.
    fn group_length(&mut self) -> Option<u64> {
        let b = self.bytes.get(self.pos..self.pos + 12)?;
        if b[..4] != [2, 0, 0, 0] || &b[4..6] != b"UL" || b[6..8] != [4, 0] {
            return None;
        }
        self.pos += 12;
        Some(u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as u64)
    }

    fn peek_group(&self) -> Option<u16> {
        (self.left() >= 8)
            .then(|| u16::from_le_bytes([self.bytes[self.pos], self.bytes[self.pos + 1]]))
    }

    /// Reads an element (or item) header: its tag and declared length.
    /// Item and delimiter tags have no VR in either encoding.
    fn header(&mut self) -> Result<((u16, u16), u32, bool), String> {
        let tag = (self.u16_at(self.pos), self.u16_at(self.pos + 2));
        let item = tag.0 == 0xFFFE;
        if item || !self.explicit {
            self.need(8, tag)?;
            let len = self.u32_at(self.pos + 4);
            self.pos += 8;
            return Ok((tag, len, false));
        }
        let vr = [self.bytes[self.pos + 4], self.bytes[self.pos + 5]];
        if !SHORT_VRS.contains(&&vr) {
            self.need(12, tag)?;
            let len = self.u32_at(self.pos + 8);
            self.pos += 12;
            Ok((tag, len, &vr == b"SQ"))
        } else {
            let len = self.u16_at(self.pos + 6) as u32;
            self.pos += 8;
            Ok((tag, len, false))
        }
    }

    fn need(&self, n: usize, tag: (u16, u16)) -> Result<(), String> {
        if self.left() < n {
            return Err(format!(
                "element ({:04X},{:04X}) is cut off by the end of the file",
                tag.0, tag.1
            ));
        }
        Ok(())
    }

    /// A defined length that fits in the rest of the file.
    fn fit(&self, tag: (u16, u16), len: u32) -> Result<usize, String> {
        if len as u64 > self.left() as u64 {
            return Err(format!(
                "element ({:04X},{:04X}) claims {len} bytes, but only {} remain in the file",
                tag.0,
                tag.1,
                self.left()
            ));
        }
        Ok(len as usize)
    }

    /// Walks the data set to its end. Sequences and items are entered (their
    /// elements are walked in line); encapsulated pixel data's fragments
    /// are skipped; any other value is skipped by its length.
    fn data_set(&mut self) -> Result<(), String> {
        let mut fragments = false;
        while self.left() >= 8 {
            let (tag, len, sq) = self.header()?;
            if tag.0 == 0xFFFE {
                match tag.1 {
                    0xE000 if len != UNDEFINED => {
                        let n = self.fit(tag, len)?;
                        if fragments {
                            self.pos += n;
                        }
                    }
                    0xE0DD => fragments = false,
                    _ => {}
                }
                continue;
            }
            if len == UNDEFINED {
                fragments = tag == PIXEL_DATA;
                continue;
            }
            let n = self.fit(tag, len)?;
            let sequence = if self.explicit {
                sq
            } else {
                // Implicit VR: a value that starts with an item tag is a
                // sequence (no other value begins with FFFE,E000).
                n >= 8 && self.u16_at(self.pos) == 0xFFFE && self.u16_at(self.pos + 2) == 0xE000
            };
            if !sequence {
                self.pos += n;
            }
        }
        Ok(())
    }
}
