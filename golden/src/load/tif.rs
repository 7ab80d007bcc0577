//! TIFF stacks: one multi-page TIFF, or a folder of single-page TIFFs, each
//! page one z slice (decoded with the `tiff` crate).

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;
use tiff::{ColorType, TiffError};

use super::{data_err, format_err, from_file, open};
use crate::error::{Error, Result};
use crate::volume::{check_dims, Volume, VoxelType, MAX_EDGE};

/// What a page is, checked before anything is decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Page {
    width: u32,
    height: u32,
    bits: u8,
}

impl Page {
    fn describe(self) -> String {
        format!("{}x{} {}-bit", self.width, self.height, self.bits)
    }
}

/// Loads a multi-page TIFF as a volume: page `k` is slice `z = k`, its
/// rows `y` and columns `x`.
///
/// Pages must be 8- or 16-bit unsigned greyscale (`BlackIsZero`, or
/// `WhiteIsZero`, which the decoder inverts), uncompressed, LZW, deflate
/// or PackBits, all of the same size and depth. Every page's size is read
/// and checked against the memory limit before any is decoded. TIFF holds
/// no voxel depth, so the spacing is 1 (rescale with `--spacing`).
pub fn load_tiff(path: &Path, limit: u64) -> Result<Volume> {
    let mut dec = decoder(path)?;
    let mut pages = Vec::new();
    loop {
        pages.push(page(path, &mut dec, pages.len() + 1)?);
        if pages.len() > MAX_EDGE {
            break; // check_dims names the absurd depth
        }
        if !dec.more_images() {
            break;
        }
        dec.next_image().map_err(|e| tiff_err(path, e))?;
    }
    let (page1, count) = check_stack(path, &pages, |k| format!("page {}", k + 1), limit)?;
    let mut dec = decoder(path)?;
    let mut data = Vec::with_capacity(count);
    for k in 0..pages.len() {
        if k > 0 {
            dec.next_image().map_err(|e| tiff_err(path, e))?;
        }
        decode_page(path, &mut dec, page1, &mut data)?;
    }
    finish(pages.len(), page1, data)
}

/// Loads a folder of single-page TIFFs (`.tif`/`.tiff`, any case; names
/// starting with `.` are skipped) as a volume, slice `z = k` being the
/// `k`-th file in byte order of the names (so number them with leading
/// zeros). Pages as for [`load_tiff`]; a multi-page file is refused, and
/// so is a folder with no TIFF in it.
pub fn load_tiff_dir(dir: &Path, limit: u64) -> Result<Volume> {
    let files = tiff_files(dir)?;
    if files.is_empty() {
        return Err(format_err(
            dir,
            "the folder holds no .tif or .tiff files: a folder must be a TIFF stack",
        ));
    }
    check_dims([1, 1, files.len()], 2, u64::MAX).map_err(|e| from_file(dir, e))?;
    let mut pages = Vec::with_capacity(files.len());
    for f in &files {
        let mut dec = decoder(f)?;
        pages.push(page(f, &mut dec, 1)?);
        if dec.more_images() {
            return Err(format_err(
                f,
                "has more than one page: a folder stack takes single-page TIFFs",
            ));
        }
    }
    let name = |k: usize| {
        let n = files[k].file_name().unwrap_or_default();
        n.to_string_lossy().into_owned()
    };
    let (page1, count) = check_stack(dir, &pages, name, limit)?;
    let mut data = Vec::with_capacity(count);
    for f in &files {
        decode_page(f, &mut decoder(f)?, page1, &mut data)?;
    }
    finish(files.len(), page1, data)
}

/// The TIFF files of `dir`, sorted by name.
fn tiff_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |e| super::io_err(dir, e);
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let p = entry.map_err(io)?.path();
        let name = p
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .to_ascii_lowercase();
        if !name.starts_with('.') && (name.ends_with(".tif") || name.ends_with(".tiff")) {
            // A member that is no readable file is refused, not skipped: a
            // skipped slice would silently shorten the stack.
            super::check_member(&p)?;
            files.push(p);
        }
    }
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    Ok(files)
}

/// All pages like the first, and the stack within the limit: the first
/// page and the voxel count. `label(k)` names page `k` for messages.
fn check_stack(
    path: &Path,
    pages: &[Page],
    label: impl Fn(usize) -> String,
    limit: u64,
) -> Result<(Page, usize)> {
    let first = pages[0];
    if let Some(k) = pages.iter().position(|&p| p != first) {
        return Err(format_err(
            path,
            format!(
                "{} is {}, {} is {}: all pages must have the same size and depth",
                label(k),
                pages[k].describe(),
                label(0),
                first.describe()
            ),
        ));
    }
    let dims = [first.width as usize, first.height as usize, pages.len()];
    let count = check_dims(dims, 2, limit).map_err(|e| from_file(path, e))?;
    Ok((first, count))
}

fn finish(depth: usize, page: Page, data: Vec<u16>) -> Result<Volume> {
    let kind = if page.bits == 8 {
        VoxelType::U8
    } else {
        VoxelType::U16
    };
    Volume::new(
        [page.width as usize, page.height as usize, depth],
        kind,
        data,
    )
}

fn decoder(path: &Path) -> Result<Decoder<BufReader<File>>> {
    check_ifds(path)?;
    Decoder::new(BufReader::new(open(path)?)).map_err(|e| tiff_err(path, e))
}

/// Walks the chain of image file directories before the decoder does:
/// every entry's values (count times the type's size) must fit in the
/// file, and the chain must not loop. The decoder sizes its tables by
/// those counts, so a forged count of millions would cost that much memory
/// before any check of ours ran.
fn check_ifds(path: &Path) -> Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = BufReader::new(open(path)?);
    let len = super::file_len(f.get_ref(), path)?;
    let bad = |msg: String| format_err(path, msg);
    let mut head = [0u8; 16];
    let n = f.read(&mut head).map_err(|e| super::io_err(path, e))?;
    let big_endian = match &head[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return Ok(()), // not a TIFF: the decoder says so
    };
    let u16_of = |b: &[u8]| {
        let b = [b[0], b[1]];
        if big_endian {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        }
    };
    let u32_of = |b: &[u8]| {
        let b = [b[0], b[1], b[2], b[3]];
        if big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    };
    let u64_of = |b: &[u8]| {
        let b: [u8; 8] = b[..8].try_into().expect("8 bytes");
        if big_endian {
            u64::from_be_bytes(b)
        } else {
            u64::from_le_bytes(b)
        }
    };
    if n < 8 {
        return Ok(());
    }
    let bigtiff = u16_of(&head[2..4]) == 43;
    if bigtiff && n < 16 {
        return Ok(());
    }
    let (mut at, count_bytes, entry_bytes) = if bigtiff {
        (u64_of(&head[8..16]), 8u64, 20u64)
    } else {
        (u64::from(u32_of(&head[4..8])), 2, 12)
    };
    let mut seen = std::collections::HashSet::new();
    let mut page = 0usize;
    while at != 0 {
        page += 1;
        if page > MAX_EDGE + 1 {
            break; // the loader names the absurd depth
        }
        if !seen.insert(at) {
            return Err(bad(format!("page {page}: the chain of pages loops")));
        }
        let mut buf = vec![0u8; count_bytes as usize];
        f.seek(SeekFrom::Start(at))
            .map_err(|e| super::io_err(path, e))?;
        if f.read_exact(&mut buf).is_err() {
            return Ok(()); // a cut file: the decoder says where
        }
        let entries = if bigtiff {
            u64_of(&buf)
        } else {
            u64::from(u16_of(&buf))
        };
        if entries.saturating_mul(entry_bytes) > len {
            return Err(bad(format!(
                "page {page}: {entries} directory entries, more than the file's {len} bytes hold"
            )));
        }
        let mut dir = Vec::new();
        (&mut f)
            .take(entries * entry_bytes + 8)
            .read_to_end(&mut dir)
            .map_err(|e| super::io_err(path, e))?;
        let got = dir.len();
        if (got as u64) < entries * entry_bytes {
            return Ok(());
        }
        for e in dir[..(entries * entry_bytes) as usize].chunks_exact(entry_bytes as usize) {
            let (tag, ty) = (u16_of(&e[0..2]), u16_of(&e[2..4]));
            let count = if bigtiff {
                u64_of(&e[4..12])
            } else {
                u64::from(u32_of(&e[4..8]))
            };
            let size: u64 = match ty {
                1 | 2 | 6 | 7 => 1,
                3 | 8 => 2,
                4 | 9 | 11 | 13 => 4,
                _ => 8,
            };
            if count.saturating_mul(size) > len {
                return Err(bad(format!(
                    "page {page}: tag {tag} claims {count} values, more than the file's {len} bytes hold"
                )));
            }
        }
        let next = &dir[(entries * entry_bytes) as usize..];
        let next_len = if bigtiff { 8 } else { 4 };
        if got < (entries * entry_bytes) as usize + next_len {
            return Ok(());
        }
        at = if bigtiff {
            u64_of(next)
        } else {
            u64::from(u32_of(next))
        };
    }
    Ok(())
}

/// The current page's size and depth; refuses anything but unsigned 8- or
/// 16-bit greyscale. `n` numbers the page for messages.
fn page(path: &Path, dec: &mut Decoder<BufReader<File>>, n: usize) -> Result<Page> {
    let (width, height) = dec.dimensions().map_err(|e| tiff_err(path, e))?;
    let color = dec.colortype().map_err(|e| tiff_err(path, e))?;
    let bits = match color {
        ColorType::Gray(b @ (8 | 16)) => b,
        other => {
            return Err(format_err(
                path,
                format!("page {n} is {other:?}: only 8- and 16-bit greyscale TIFF is supported"),
            ))
        }
    };
    let formats: Option<Vec<u16>> = dec
        .find_tag_unsigned_vec(Tag::SampleFormat)
        .map_err(|e| tiff_err(path, e))?;
    if formats.is_some_and(|f| f.iter().any(|&s| s != 1)) {
        return Err(format_err(
            path,
            format!(
                "page {n} holds signed or float samples: only unsigned greyscale TIFF is supported"
            ),
        ));
    }
    let page = Page {
        width,
        height,
        bits,
    };
    check_strips(path, dec, n, page)?;
    Ok(page)
}

/// Largest expansion each compression can give (decoded bytes per stored
/// byte): none 1, PackBits 64 (2 bytes for a run of 128), deflate 1032
/// (rounded up), LZW 4096 (also used for any other code, which the decoder
/// refuses anyway).
fn max_ratio(compression: u16) -> u64 {
    match compression {
        1 => 1,
        32773 => 64,
        8 | 32946 => 1100,
        _ => 4096,
    }
}

/// The page's strips (or tiles) lie inside the file, and their stored
/// bytes can hold the page at the compression's largest ratio: a header
/// promising an 8192x8192 page in a few bytes is refused before the page's
/// buffer is allocated.
fn check_strips(path: &Path, dec: &mut Decoder<BufReader<File>>, n: usize, p: Page) -> Result<()> {
    let tiff = |e| tiff_err(path, e);
    let (offsets, counts) = match dec
        .find_tag_unsigned_vec::<u64>(Tag::StripOffsets)
        .map_err(tiff)?
    {
        Some(o) => (
            o,
            dec.find_tag_unsigned_vec::<u64>(Tag::StripByteCounts)
                .map_err(tiff)?,
        ),
        None => (
            dec.find_tag_unsigned_vec::<u64>(Tag::TileOffsets)
                .map_err(tiff)?
                .unwrap_or_default(),
            dec.find_tag_unsigned_vec::<u64>(Tag::TileByteCounts)
                .map_err(tiff)?,
        ),
    };
    let bad = |msg: String| format_err(path, format!("page {n}: {msg}"));
    let counts = counts.ok_or_else(|| bad("no StripByteCounts (or TileByteCounts)".into()))?;
    if offsets.is_empty() || offsets.len() != counts.len() {
        return Err(bad(format!(
            "{} strip offsets but {} byte counts",
            offsets.len(),
            counts.len()
        )));
    }
    let len = std::fs::metadata(path)
        .map_err(|e| super::io_err(path, e))?
        .len();
    for (k, (&at, &c)) in offsets.iter().zip(&counts).enumerate() {
        if at < 8 || c == 0 || at.saturating_add(c) > len {
            return Err(bad(format!(
                "strip {} at byte {at} of {c} bytes does not lie in the file's {len} bytes",
                k + 1
            )));
        }
    }
    let compression = dec
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(tiff)?
        .unwrap_or(1);
    let stored: u64 = counts.iter().sum();
    let need = p.width as u64 * p.height as u64 * (p.bits as u64 / 8);
    if stored.saturating_mul(max_ratio(compression)) < need {
        return Err(bad(format!(
            "its strips hold {stored} bytes, too few for a {} page ({need} bytes) \
             under compression {compression}",
            p.describe()
        )));
    }
    Ok(())
}

/// Decodes the current page onto the end of `data`.
fn decode_page(
    path: &Path,
    dec: &mut Decoder<BufReader<File>>,
    want: Page,
    data: &mut Vec<u16>,
) -> Result<()> {
    let n = want.width as usize * want.height as usize;
    let before = data.len();
    match dec.read_image().map_err(|e| tiff_err(path, e))? {
        DecodingResult::U8(v) if want.bits == 8 => data.extend(v.iter().map(|&b| b as u16)),
        DecodingResult::U16(v) if want.bits == 16 => data.extend_from_slice(&v),
        _ => {
            return Err(format_err(
                path,
                "a page decoded to another sample type than its header states",
            ))
        }
    }
    if data.len() - before != n {
        return Err(format_err(
            path,
            format!(
                "a page decoded to {} samples, {n} expected for {}",
                data.len() - before,
                want.describe()
            ),
        ));
    }
    Ok(())
}

/// The decoder's errors as one line naming the file.
fn tiff_err(path: &Path, e: TiffError) -> Error {
    match e {
        TiffError::IoError(io) => data_err(path, io),
        other => {
            let msg = other.to_string().replace('\n', " ");
            format_err(path, format!("unreadable TIFF: {msg}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::load_auto;
    use crate::load::tests::{assert_err, pattern};
    use crate::volume::DEFAULT_MEMORY_LIMIT;
    use proptest::prelude::*;
    use std::io::Cursor;
    use tiff::encoder::{colortype, TiffEncoder};

    const LIM: u64 = DEFAULT_MEMORY_LIMIT;

    /// Pages of one type, in one TIFF.
    enum Pages<'a> {
        U8(&'a [&'a [u8]]),
        U16(&'a [&'a [u16]]),
    }

    fn tiff_bytes(w: u32, h: u32, pages: Pages) -> Vec<u8> {
        let mut out = Cursor::new(Vec::new());
        let mut enc = TiffEncoder::new(&mut out).unwrap();
        match pages {
            Pages::U8(ps) => ps
                .iter()
                .for_each(|p| enc.write_image::<colortype::Gray8>(w, h, p).unwrap()),
            Pages::U16(ps) => ps
                .iter()
                .for_each(|p| enc.write_image::<colortype::Gray16>(w, h, p).unwrap()),
        }
        out.into_inner()
    }

    fn u8_pages(w: usize, h: usize, d: usize) -> Vec<Vec<u8>> {
        let all: Vec<u8> = pattern(w * h * d, 256).iter().map(|&v| v as u8).collect();
        all.chunks(w * h).map(<[u8]>::to_vec).collect()
    }

    #[test]
    fn multi_page_tiff_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let pages = u8_pages(5, 4, 3);
        let refs: Vec<&[u8]> = pages.iter().map(Vec::as_slice).collect();
        let path = dir.path().join("s.TIF");
        std::fs::write(&path, tiff_bytes(5, 4, Pages::U8(&refs))).unwrap();
        let v = load_auto(&path, None, LIM).unwrap();
        assert_eq!(
            (v.dims(), v.kind(), v.spacing()),
            ([5, 4, 3], VoxelType::U8, [1.0; 3])
        );
        assert!(v
            .data()
            .iter()
            .zip(pages.concat())
            .all(|(&a, b)| a == b as u16));
        assert_eq!(v.get(4, 3, 2) as u8, pages[2][19]);

        let vals = pattern(6 * 2 * 2, 65536);
        let path = dir.path().join("w.tiff");
        let p16: Vec<&[u16]> = vals.chunks(12).collect();
        std::fs::write(&path, tiff_bytes(6, 2, Pages::U16(&p16))).unwrap();
        let v = load_tiff(&path, LIM).unwrap();
        assert_eq!(
            (v.dims(), v.kind(), &*v.data()),
            ([6, 2, 2], VoxelType::U16, &vals[..])
        );
        assert_err(load_tiff(&path, 40), "over the memory limit");
    }

    #[test]
    fn tiff_folder_is_sorted_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let pages = u8_pages(3, 2, 3);
        // Written out of order; a hidden file and a non-TIFF are ignored.
        for k in [2, 0, 1] {
            let name = dir.path().join(format!("z{k:02}.tif"));
            std::fs::write(name, tiff_bytes(3, 2, Pages::U8(&[&pages[k]]))).unwrap();
        }
        std::fs::write(dir.path().join("._z00.tif"), b"junk").unwrap();
        std::fs::write(dir.path().join("notes.txt"), b"junk").unwrap();
        let v = load_auto(dir.path(), None, LIM).unwrap();
        assert_eq!(v.dims(), [3, 2, 3]);
        assert!(v
            .data()
            .iter()
            .zip(pages.concat())
            .all(|(&a, b)| a == b as u16));
    }

    #[test]
    fn mixed_or_unsupported_tiffs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, bytes: Vec<u8>| {
            let p = dir.path().join(name);
            std::fs::write(&p, bytes).unwrap();
            p
        };
        // Pages of different sizes, in one file and in a folder.
        let mut out = Cursor::new(Vec::new());
        let mut enc = TiffEncoder::new(&mut out).unwrap();
        enc.write_image::<colortype::Gray8>(4, 4, &[0; 16]).unwrap();
        enc.write_image::<colortype::Gray8>(4, 3, &[0; 12]).unwrap();
        let p = write("mixed.tif", out.into_inner());
        assert_err(
            load_tiff(&p, LIM),
            "page 2 is 4x3 8-bit, page 1 is 4x4 8-bit",
        );
        let sub = dir.path().join("stack");
        std::fs::create_dir(&sub).unwrap();
        std::fs::write(sub.join("a.tif"), tiff_bytes(2, 2, Pages::U8(&[&[1; 4]]))).unwrap();
        std::fs::write(sub.join("b.tif"), tiff_bytes(2, 2, Pages::U16(&[&[1; 4]]))).unwrap();
        assert_err(
            load_tiff_dir(&sub, LIM),
            "b.tif is 2x2 16-bit, a.tif is 2x2 8-bit",
        );
        std::fs::write(
            sub.join("b.tif"),
            tiff_bytes(2, 2, Pages::U8(&[&[1; 4], &[2; 4]])),
        )
        .unwrap();
        assert_err(load_tiff_dir(&sub, LIM), "more than one page");
        let empty = dir.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        assert_err(load_auto(&empty, None, LIM), "holds no .tif or .tiff files");
        // Colour and float pages.
        let mut out = Cursor::new(Vec::new());
        TiffEncoder::new(&mut out)
            .unwrap()
            .write_image::<colortype::RGB8>(2, 1, &[1, 2, 3, 4, 5, 6])
            .unwrap();
        let p = write("rgb.tif", out.into_inner());
        assert_err(
            load_tiff(&p, LIM),
            "page 1 is RGB(8): only 8- and 16-bit greyscale",
        );
        let mut out = Cursor::new(Vec::new());
        TiffEncoder::new(&mut out)
            .unwrap()
            .write_image::<colortype::GrayI16>(2, 1, &[-1, 5])
            .unwrap();
        let p = write("signed.tif", out.into_inner());
        assert_err(load_tiff(&p, LIM), "signed or float samples");
        // Not a TIFF, and a cut one.
        assert_err(
            load_tiff(&write("x.tif", b"P5 junk".to_vec()), LIM),
            "unreadable TIFF",
        );
        let good = tiff_bytes(4, 4, Pages::U8(&[&[3; 16]]));
        let cut = write("cut.tif", good[..good.len() / 2].to_vec());
        assert!(load_tiff(&cut, LIM).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// Mutated TIFFs load or fail, never panic or allocate past the limit.
        #[test]
        fn mutated_tiffs_never_panic(
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
            cut in any::<prop::sample::Index>(),
            do_cut in any::<bool>(),
        ) {
            let dir = tempfile::tempdir().unwrap();
            let mut bytes = tiff_bytes(4, 3, Pages::U16(&[&[7; 12], &[9; 12]]));
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            if do_cut {
                bytes.truncate(cut.index(bytes.len() + 1));
            }
            let p = dir.path().join("m.tif");
            std::fs::write(&p, bytes).unwrap();
            let _ = load_tiff(&p, 1 << 16);
        }
    }
}
