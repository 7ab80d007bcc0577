//! Decoding a DICOM file's pixel data (all its frames at once), with the
//! decoder's panics on corrupt data turned into one-line errors.

use std::path::Path;

use dicom_dictionary_std::tags;
use dicom_object::DefaultDicomObject;
use dicom_pixeldata::{ConvertOptions, ModalityLutOption, PixelDecoder};

use super::{open_dicom, Slice};
use crate::error::Result;
use crate::load::format_err;

/// Decodes the file `path` once and appends the stored values of its
/// frames `order` (each slice's frame, in that order), rescaled.
pub(super) fn read_pixels(path: &Path, order: &[&Slice], out: &mut Vec<f64>) -> Result<()> {
    let s = order[0];
    let obj = open_dicom(path, false)?;
    let frame_bytes = s.rows * s.cols * usize::from(s.bits / 8);
    let ts = obj.meta().transfer_syntax().trim_end_matches('\0').trim();
    if ts == RLE_LOSSLESS {
        check_rle(&obj, s).map_err(|e| format_err(path, format!("undecodable pixel data: {e}")))?;
    }
    // dicom-rs 0.10's RLE decoder indexes past a cut segment: a panic in
    // the decoder is the file's fault, reported like its errors.
    let decoded = quiet_unwind(|| -> std::result::Result<Vec<Vec<f64>>, String> {
        let px = obj.decode_pixel_data().map_err(|e| e.to_string())?;
        if (px.rows() as usize, px.columns() as usize) != (s.rows, s.cols) {
            return Err("the pixel data disagrees with Rows and Columns".into());
        }
        // Native pixel data may carry one byte of padding to an even length.
        let (have, need) = (px.data().len(), frame_bytes * s.frames);
        // A single frame's extra bytes were always ignored; a multi-frame
        // object's would mean a wrong NumberOfFrames.
        if have < need || (s.frames > 1 && have > need + (need % 2)) {
            return Err(if s.frames > 1 {
                format!(
                    "the pixel data holds {have} bytes, but NumberOfFrames {} of {}x{} {}-bit frames need {need}",
                    s.frames, s.cols, s.rows, s.bits
                )
            } else {
                format!("truncated: {have} bytes of pixel data, {need} expected")
            });
        }
        // Stored values only: the slope and intercept are applied here,
        // the same way for every transfer syntax.
        let opts = ConvertOptions::new().with_modality_lut(ModalityLutOption::None);
        order
            .iter()
            .map(|f| {
                px.to_vec_frame_with_options(f.frame as u32, &opts)
                    .map_err(|e| e.to_string())
            })
            .collect()
    });
    let frames = match decoded {
        Some(Ok(v)) => v,
        Some(Err(e)) => return Err(dicom_err(path, "undecodable pixel data", &e)),
        None => {
            return Err(format_err(
                path,
                "undecodable pixel data: the decoder failed on corrupt or cut data",
            ))
        }
    };
    for (vals, f) in frames.iter().zip(order) {
        if vals.len() != s.rows * s.cols {
            return Err(format_err(
                path,
                format!(
                    "truncated: {} pixels decoded, {}x{} expected",
                    vals.len(),
                    s.cols,
                    s.rows
                ),
            ));
        }
        out.extend(vals.iter().map(|&v| v * f.slope + f.intercept));
    }
    Ok(())
}

/// The RLE lossless transfer syntax.
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// Checks RLE pixel data before it is decoded: one fragment per frame,
/// each with a header naming one segment per byte of a sample (1 or 2)
/// at increasing offsets inside the fragment, each segment decoding to at
/// least a frame's pixels and not much more (counted without decoding).
/// The decoder trusts the segment count and the fragment count, so a
/// forged header would make it allocate by them.
fn check_rle(obj: &DefaultDicomObject, s: &Slice) -> std::result::Result<(), String> {
    let Some(e) = obj.element_opt(tags::PIXEL_DATA).ok().flatten() else {
        return Err("no PixelData".into());
    };
    let frags = e
        .value()
        .fragments()
        .ok_or("RLE pixel data is not encapsulated")?;
    if frags.len() != s.frames {
        return Err(format!(
            "{} RLE fragments for {} frames (one per frame expected)",
            frags.len(),
            s.frames
        ));
    }
    let segments = u32::from(s.bits / 8);
    let pixels = (s.rows * s.cols) as u64;
    for (k, f) in frags.iter().enumerate() {
        let at = |m: String| format!("RLE fragment {}: {m}", k + 1);
        if f.len() < 64 {
            return Err(at(format!(
                "{} bytes, shorter than its 64-byte header",
                f.len()
            )));
        }
        let word =
            |i: usize| u32::from_le_bytes([f[4 * i], f[4 * i + 1], f[4 * i + 2], f[4 * i + 3]]);
        if word(0) != segments {
            return Err(at(format!(
                "{} segments, {segments} expected for {}-bit greyscale",
                word(0),
                s.bits
            )));
        }
        let mut ends: Vec<u64> = (1..=segments as usize).map(|i| word(i) as u64).collect();
        ends.push(f.len() as u64);
        for i in 0..segments as usize {
            let (a, b) = (ends[i], ends[i + 1]);
            if a < 64 || b <= a {
                return Err(at(format!(
                    "segment {} offsets {a}..{b} are not in order",
                    i + 1
                )));
            }
            let n = packbits_len(&f[a as usize..b as usize]);
            if n < pixels || n > 2 * pixels + 256 {
                return Err(at(format!(
                    "segment {} decodes to {n} bytes, {pixels} expected",
                    i + 1
                )));
            }
        }
    }
    Ok(())
}

/// The bytes a PackBits segment decodes to, counted without decoding.
fn packbits_len(seg: &[u8]) -> u64 {
    let (mut i, mut n) = (0usize, 0u64);
    while i < seg.len() {
        let h = seg[i] as i8;
        i += 1;
        match h {
            0..=127 => {
                n += h as u64 + 1;
                i += h as usize + 1;
            }
            -127..=-1 => {
                n += (1 - h as i64) as u64;
                i += 1;
            }
            -128 => {}
        }
    }
    n
}

thread_local! {
    /// Set while [`quiet_unwind`] runs a decoder on this thread.
    static QUIET: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f`, turning a panic into `None` without the panic message on
/// stderr (for this thread only; other threads' panics print as before).
pub(super) fn quiet_unwind<T>(f: impl FnOnce() -> T) -> Option<T> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(|q| q.get()) {
                previous(info);
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).ok();
    QUIET.with(|q| q.set(false));
    out
}

/// A `dicom-rs` error as one line.
pub(super) fn dicom_err(path: &Path, what: &str, e: &dyn std::fmt::Display) -> crate::error::Error {
    let msg = e.to_string();
    let line = msg.split_whitespace().collect::<Vec<_>>().join(" ");
    format_err(path, format!("{what}: {line}"))
}
