//! The 2D projective warp of the intermediate image to the final image.
//!
//! Each final pixel centre maps through the inverse warp
//! ([`super::factor::Factor::pixel_to_intermediate`]) to a point of the
//! intermediate image, read with a separable tent of half-width
//! `max(1, f)` intermediate pixels, `f` the square root of the map's
//! Jacobian determinant there (how many intermediate pixels one final
//! pixel covers): bilinear where the final image magnifies, a footprint
//! average where it minifies, so a coarse final image does not alias a
//! fine intermediate one. Beyond the intermediate image everything is
//! transparent (it covers the projection of every slice).

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::View;
use crate::image::Image;

/// The warp filter's half-width (intermediate pixels) at homogeneous
/// point `q = m (p_x, p_y, 1)` with `q.z > 0`.
#[inline]
pub fn half_width(m: &DMat3, q: DVec3) -> f64 {
    let (u, v) = (q.x / q.z, q.y / q.z);
    let (cx, cy) = (m.x_axis, m.y_axis);
    let du_dx = (cx.x - u * cx.z) / q.z;
    let dv_dx = (cx.y - v * cx.z) / q.z;
    let du_dy = (cy.x - u * cy.z) / q.z;
    let dv_dy = (cy.y - v * cy.z) / q.z;
    (du_dx * dv_dy - du_dy * dv_dx).abs().sqrt().max(1.0)
}

/// Normalised tent weights of half-width `h` around `u` over the integers
/// `k` with `|u - k| < h`; returns the first `k`.
#[inline]
fn tent(u: f64, h: f64, w: &mut Vec<f32>) -> i64 {
    w.clear();
    let k0 = (u - h).floor() as i64 + 1;
    let k1 = (u + h).ceil() as i64 - 1;
    let inv_h = 1.0 / h;
    let mut sum = 0.0;
    for k in k0..=k1 {
        let x = (1.0 - (u - k as f64).abs() * inv_h).max(0.0);
        sum += x;
        w.push(x as f32);
    }
    if sum > 0.0 {
        let inv = (1.0 / sum) as f32;
        w.iter_mut().for_each(|x| *x *= inv);
    }
    k0
}

/// Warps intermediate image `inter` (`counts[1]` rows of `counts[0]`
/// premultiplied RGBA pixels) through `m` (final pixel to intermediate,
/// homogeneous) into `view`'s final image, parallel over rows.
pub fn warp(view: &View, m: &DMat3, counts: [usize; 2], inter: &[[f32; 4]]) -> Image {
    let (w, h) = (view.size[0] as usize, view.size[1] as usize);
    let [nx, ny] = counts;
    let mut img = Image::new(w, h);
    if nx == 0 || ny == 0 {
        return img;
    }
    img.data.par_chunks_mut(w).enumerate().for_each_init(
        || (Vec::new(), Vec::new()),
        |(wx, wy), (j, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                let q = *m * DVec3::new(i as f64 + 0.5, j as f64 + 0.5, 1.0);
                if q.z <= 0.0 {
                    continue;
                }
                let (u, v) = (q.x / q.z, q.y / q.z);
                let hw = half_width(m, q);
                if !(u > -hw && u < nx as f64 - 1.0 + hw && v > -hw && v < ny as f64 - 1.0 + hw) {
                    continue;
                }
                let x0 = tent(u, hw, wx);
                let y0 = tent(v, hw, wy);
                // Taps beyond the intermediate image read nothing: clip
                // the tap ranges once.
                let xs = (-x0).max(0) as usize..((nx as i64 - x0).max(0) as usize).min(wx.len());
                let ys = (-y0).max(0) as usize..((ny as i64 - y0).max(0) as usize).min(wy.len());
                let mut acc = [0f32; 4];
                for ty in ys {
                    let line = &inter[(y0 + ty as i64) as usize * nx..];
                    let wyv = wy[ty];
                    for tx in xs.clone() {
                        let p = line[(x0 + tx as i64) as usize];
                        let k = wyv * wx[tx];
                        for c in 0..4 {
                            acc[c] += k * p[c];
                        }
                    }
                }
                *out = acc;
            }
        },
    );
    img
}
