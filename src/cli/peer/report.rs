//! What the peer's script reports: its JSON line and its `.npy` image.

use anyhow::{bail, Context, Result};
use serde::Deserialize;

use golden::image::Image;

/// What the peer's script prints on stdout (one JSON object).
#[derive(Debug, Clone, Deserialize)]
pub struct PeerReport {
    /// Median seconds per frame on the peer's own timer (VTK: the mapper's
    /// `GetTimeToDraw`, ray casting without the window's blit).
    pub time_s: f64,
    /// Every timed frame, on that timer.
    #[serde(default)]
    pub times_s: Vec<f64>,
    /// Which timer `time_s` is.
    #[serde(default)]
    pub timer: String,
    /// Median wall-clock seconds around a whole `Render()` (with the blit),
    /// when the script reports it.
    #[serde(default)]
    pub wall_time_s: Option<f64>,
    /// Every timed frame's wall clock.
    #[serde(default)]
    pub wall_times_s: Vec<f64>,
    /// The peer's version.
    #[serde(default)]
    pub vtk_version: String,
    /// The render window class that worked (EGL, OSMesa, X).
    #[serde(default)]
    pub backend: String,
    /// The mapper.
    #[serde(default)]
    pub mapper: String,
    /// Threads it used.
    #[serde(default)]
    pub threads: usize,
}

/// Reads the last line of the script's stdout that is a JSON object.
pub fn parse_peer_report(stdout: &str) -> Result<PeerReport> {
    let line = stdout
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('{'))
        .context("the peer printed no JSON report")?;
    let r: PeerReport =
        serde_json::from_str(line).context("the peer's JSON report is malformed")?;
    if !(r.time_s.is_finite() && r.time_s >= 0.0) {
        bail!("the peer's time_s {} is not a time", r.time_s);
    }
    if let Some(w) = r.wall_time_s {
        if !(w.is_finite() && w >= 0.0) {
            bail!("the peer's wall_time_s {w} is not a time");
        }
    }
    Ok(r)
}

/// Reads a float32 `H x W x 4` `.npy` (as `ercube render --npy` and the
/// peer write it) into an image.
pub fn read_npy_image(bytes: &[u8]) -> Result<Image> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        bail!("not a .npy file");
    }
    let (hlen, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => bail!(".npy version {v} is not supported"),
    };
    let header = bytes
        .get(start..start + hlen)
        .and_then(|h| std::str::from_utf8(h).ok())
        .context(".npy header is truncated")?;
    let field = |key: &str| -> Option<&str> {
        let i = header.find(&format!("'{key}'"))? + key.len() + 2;
        Some(header[i..].trim_start().strip_prefix(':')?.trim_start())
    };
    let descr = field("descr").context(".npy header has no descr")?;
    if !descr.starts_with("'<f4'") {
        bail!(
            ".npy holds {} values, float32 ('<f4') expected",
            descr.split(',').next().unwrap_or(descr)
        );
    }
    if !field("fortran_order").is_some_and(|f| f.starts_with("False")) {
        bail!(".npy is in Fortran order; C order expected");
    }
    let shape = field("shape").context(".npy header has no shape")?;
    let inner = shape
        .strip_prefix('(')
        .and_then(|s| s.split_once(')'))
        .map(|(s, _)| s)
        .context(".npy shape is malformed")?;
    let dims: Vec<usize> = inner
        .split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|t| t.parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .context(".npy shape is malformed")?;
    let [h, w, 4] = dims[..] else {
        bail!(".npy shape {dims:?} is not H x W x 4");
    };
    let data = &bytes[start + hlen..];
    if data.len() != h * w * 16 {
        bail!(
            ".npy has {} data bytes, {} expected for {h}x{w}x4",
            data.len(),
            h * w * 16
        );
    }
    let px = data
        .chunks_exact(16)
        .map(|c| {
            std::array::from_fn(|k| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap()))
        })
        .collect();
    Ok(Image {
        width: w,
        height: h,
        data: px,
    })
}
