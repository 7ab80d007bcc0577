//! The shading terms of the derived bound (step 3s, after classification):
//! how far the pipeline's shaded colour and gradient-modulated opacity of
//! one sample can be from golden's, given the classified differences
//! `dc`, `da` of step 3. Units as in the parent module; gradients in
//! golden's (scalar units per world unit), `u = 2 s_min 2^(v - b)` of
//! them per `gradient` code.
//!
//! 1. Gradient, per component: interpolation is `L`-Lipschitz along x and
//!    y (`L` the largest difference of adjacent voxels' gradient
//!    components, measured), so the position and weight errors add
//!    `2 L (ex + r(weight))`; in codes, three `gradient` assignments reach
//!    the result, the axis scale rounds when it is not 1
//!    (`2^(v + 1) r(grad_scale)`) and narrower voxel words round each tap
//!    (`2 r(voxel)`): `eg = 2 L (ex + rw) + (codes) / u + 8 e g_max`;
//!    the vector differs by at most `|dg| = sqrt 3 eg`.
//! 2. Normal: `|g / |g| - g' / |g'|| <= 2 |dg| / |g|`, and the fade weights
//!    it by `r = min(1, |g| / F)`, so `r |dn| <= 2 |dg| / F` whatever `|g|`
//!    (without a fade, `F = 0`, there is no finite bound: a tiny gradient's
//!    direction is arbitrary). Each cosine adds the light vector's rounding
//!    `sqrt 3 r(light)`, the divider's truncation `q(normal_dot)` and the
//!    norm's truncation `q(grad_norm) / F_c` (`F_c = F u`):
//!    `ecos = 2 |dg| / F + sqrt 3 r(light) + q(nd) + q(gn) / F_c`.
//! 3. Fade: `dr = |dg| / F + q(gn) / F_c + q(nd) + (F_c + q(gn)) r(grad_recip)`.
//! 4. Diffuse `D = r sum |n.L| + (1 - r) n_L`: `dD <= 2 n_L dr + n_L ecos`.
//!    Highlight `r sum |n.H|^p`: `x^p` is `p`-Lipschitz on `[0, 1]`; the
//!    table interpolates within `min(1, p (p - 1) h^2 / 8)` (`h` its step)
//!    and rounds twice: `dS <= n_L (dr + p ecos + min(1, p(p-1) h^2/8) + 2
//!    r(specular) + p h r(weight))`.
//! 5. Colour `c' = min(1, c (ka + kd D) + ks S)` (the clamp is
//!    1-Lipschitz, `c <= 1`): `dc' = (ka + kd n_L) dc + kd dD + ks dS +
//!    (2 + 2 n_L) r(material) + r(color) + 4 e`.
//! 6. Opacity with gradient opacity `G`: `a' = a min(1, |g| / G)`:
//!    `da' = da + |dg| / G + q(gn) / G_c + (G_c + q(gn)) r(grad_recip) +
//!    r(alpha)`.
//!
//! The colour terms count once per ray and the opacity terms once per
//! slice, as the unshaded `dc` and `da` do.

use golden::geometry::View;
use golden::gradients::Gradients;
use golden::shading::{Lighting, Shade};
use golden::slices::SliceStack;
use golden::volume::Volume;

use super::{r, BoundInputs};
use crate::config::PipelineConfig;

/// What the shading terms need: the shading and facts of the data's
/// gradients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadeInputs {
    /// The shading (material, fade, gradient opacity).
    pub shade: Shade,
    /// Lights, the headlight counting one.
    pub lights: usize,
    /// Largest difference of a gradient component between voxels adjacent
    /// along view x or y (golden's gradient units).
    pub lipschitz: f64,
    /// Largest gradient component magnitude.
    pub max: f64,
    /// The smallest voxel spacing.
    pub s_min: f64,
    /// Whether the spacing differs between axes.
    pub anisotropic: bool,
}

impl ShadeInputs {
    /// Measures golden's voxel gradients of `volume` seen through `view`.
    pub fn measure(volume: &Volume, view: &View, shade: &Shade) -> golden::Result<ShadeInputs> {
        let stack = SliceStack::new(volume, &view.axes)?;
        Ok(Self::measure_stack(&stack, view, shade))
    }

    /// [`ShadeInputs::measure`] on the permuted stack a frame renders from.
    pub fn measure_stack(stack: &SliceStack, view: &View, shade: &Shade) -> ShadeInputs {
        let g = Gradients::new(view, stack);
        let [nx, ny, nz] = view.dims;
        let (mut lip, mut max) = (0f64, 0f64);
        for comp in 0..3 {
            for z in 0..nz {
                let at = |x, y| f64::from(g.at(z, x, y)[comp]);
                // Padded positions: the padding is sampled too (a ray half
                // a voxel outside reads it).
                for y in 0..ny + 2 {
                    for x in 0..nx + 2 {
                        let v = at(x, y);
                        max = max.max(v.abs());
                        if x + 1 < nx + 2 {
                            lip = lip.max((at(x + 1, y) - v).abs());
                        }
                        if y + 1 < ny + 2 {
                            lip = lip.max((at(x, y + 1) - v).abs());
                        }
                    }
                }
            }
        }
        ShadeInputs {
            shade: *shade,
            lights: Lighting::new(view, shade).lights.len(),
            lipschitz: lip,
            max,
            s_min: view.spacing.iter().copied().fold(f64::INFINITY, f64::min),
            anisotropic: view.spacing.iter().any(|&s| s != view.spacing[0]),
        }
    }

    /// Steps 1 to 6: the shaded colour and opacity differences from the
    /// classified ones, at position error `ex`.
    pub(super) fn terms(
        &self,
        cfg: &PipelineConfig,
        d: &BoundInputs,
        ex: f64,
        (dc, da): (f64, f64),
    ) -> (f64, f64) {
        let e = 2f64.powi(-24);
        let vb = i32::from(cfg.voxel.bits());
        let u = 2.0 * self.s_min * 2f64.powi(vb - d.data_bits as i32);
        let rw = r(cfg.weight);
        let mut codes = 3.0 * r(cfg.gradient);
        if (vb as u32) < d.data_bits {
            codes += 2.0 * r(cfg.voxel);
        }
        if self.anisotropic {
            // An axis scale below 1 rounds; isotropic volumes scale by 1.
            codes += 2f64.powi(vb + 1) * r(cfg.grad_scale);
        }
        let eg = 2.0 * self.lipschitz * (ex + rw) + codes / u + 8.0 * e * self.max;
        let dg = 3f64.sqrt() * eg;
        let f = self.shade.normal_fade;
        if f <= 0.0 {
            return (f64::INFINITY, f64::INFINITY);
        }
        let (qn, qd) = (cfg.grad_norm.lsb(), cfg.normal_dot.lsb());
        let rr = r(cfg.grad_recip);
        let fc = f * u;
        let ecos = 2.0 * dg / f + 3f64.sqrt() * r(cfg.light) + qd + qn / fc;
        let dr = dg / f + qn / fc + qd + (fc + qn) * rr;
        let nl = self.lights as f64;
        let m = self.shade.material;
        let p = m.shininess;
        let h = 2f64.powi(-i32::from(cfg.shade_table_bits));
        let dd = 2.0 * nl * dr + nl * ecos;
        let table = (p * (p - 1.0).max(0.0) * h * h / 8.0).min(1.0);
        let ds = nl * (dr + p * ecos + table + 2.0 * r(cfg.specular) + p * h * rw);
        let dc2 = (m.ambient + m.diffuse * nl) * dc
            + m.diffuse * dd
            + m.specular * ds
            + (2.0 + 2.0 * nl) * r(cfg.material)
            + r(cfg.color)
            + 4.0 * e;
        let g = self.shade.gradient_opacity;
        let da2 = if g > 0.0 {
            let gc = g * u;
            da + dg / g + qn / gc + (gc + qn) * rr + r(cfg.alpha)
        } else {
            da
        };
        (dc2, da2)
    }
}
