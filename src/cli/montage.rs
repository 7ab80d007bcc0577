//! A labelled side-by-side montage of images, with text from the `font8x8`
//! bitmap font so no font file is needed at run time.

use std::path::Path;

use anyhow::Result;
use font8x8::{UnicodeFonts, BASIC_FONTS};

use golden::image::Image;

const GAP: usize = 4;
const LABEL: usize = 12;

/// Writes `images` side by side, each under its label, scaled up by an
/// integer factor when small, as an RGB PNG.
pub fn write_montage(path: &Path, images: &[(String, &Image)]) -> Result<()> {
    let h = images.iter().map(|(_, i)| i.height).max().unwrap_or(1);
    let scale = (192 / h.max(1)).clamp(1, 4);
    let width: usize = images
        .iter()
        .map(|(_, i)| i.width * scale + GAP)
        .sum::<usize>()
        + GAP;
    let height = h * scale + LABEL + 2 * GAP;
    let mut rgb = vec![24u8; width * height * 3];
    let mut x0 = GAP;
    for (label, img) in images {
        text(&mut rgb, width, x0, GAP / 2, label);
        let px = img.to_rgb8();
        for j in 0..img.height * scale {
            for i in 0..img.width * scale {
                let s = ((j / scale) * img.width + i / scale) * 3;
                let d = ((LABEL + GAP + j) * width + x0 + i) * 3;
                rgb[d..d + 3].copy_from_slice(&px[s..s + 3]);
            }
        }
        x0 += img.width * scale + GAP;
    }
    golden::image::write_rgb_png(path, width, height, &rgb)?;
    Ok(())
}

fn text(rgb: &mut [u8], width: usize, x: usize, y: usize, s: &str) {
    let height = rgb.len() / 3 / width;
    for (n, ch) in s.chars().enumerate() {
        let Some(glyph) = BASIC_FONTS.get(ch) else {
            continue;
        };
        for (r, bits) in glyph.iter().enumerate() {
            for c in 0..8 {
                let (px, py) = (x + n * 8 + c, y + r);
                if bits >> c & 1 == 1 && px < width && py < height {
                    let d = (py * width + px) * 3;
                    rgb[d..d + 3].copy_from_slice(&[235, 235, 235]);
                }
            }
        }
    }
}
