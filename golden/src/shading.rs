//! Gradients and Blinn-Phong shading, the half of a Cube pipeline after
//! interpolation: a sample's colour is shaded before it is composited
//! (premultiplied compositing is unchanged).
//!
//! **Gradients on voxels, interpolated like the scalar** (VolumePro 1000's
//! choice): central differences `(f(i + 1) - f(i - 1)) / (2 s)` per axis at
//! every voxel, `s` the axis's spacing (anisotropic volumes scale the
//! gradient), stored in the scalar's padded layout ([`crate::gradients`]) and
//! interpolated with the scalar's own weights. In hardware this needs only
//! what a PE has: the `x +- 1` neighbour from the next PE, `y +- 1` from
//! line buffers, `z +- 1` from the slices before and after; and it is one
//! interpolation per channel at the sample, the same as the scalar's.
//! (Cube-4 takes differences of interpolated samples instead; both are
//! second-order accurate and agree to within the interpolation error.)
//!
//! **Shading** of colour `c` with unit normal `n = g / |g|` under
//! directional lights `L` with the viewer direction `V`:
//! `c' = min(1, c (ka + kd sum |n . L|) + ks sum |n . H|^p)`, `H` the
//! half vector of `L` and `V`. Lighting is two-sided (`|n . L|`): a
//! volume's gradient points towards denser material, and a surface is lit
//! from whichever side the light is on, as VTK's volume mapper does by
//! default. The default light is a **headlight**: a directional light
//! from the volume's centre towards the eye, which is also the viewer
//! direction (so `H = L`).
//!
//! **Normal fade.** A zero gradient (a homogeneous region) has no normal:
//! it is lit as if it faced the light, without a highlight. Below
//! [`Shade::normal_fade`] `= F` of gradient magnitude the normal fades in
//! linearly, `r = min(1, |g| / F)`:
//! `c' = min(1, c (ka + kd (r sum |n . L| + (1 - r) n_L)) + ks r sum |n . H|^p)`
//! (`n_L` the number of lights). The direction of a tiny gradient is
//! noise (a rounding, an interpolation weight, the golden model's `f32`
//! against the chip's fixed point can turn it anywhere), and without the
//! fade a shaded colour is not even continuous in the data at `g = 0`;
//! with it the shading is Lipschitz in `g` (constant about `3 (kd + ks)
//! n_L / F`), which is what lets the pipeline's derived error bound (`pipeline::bound`)
//! exist. `F = 0` restores the abrupt rule. The default, 1 scalar unit
//! per world unit, is far below any surface's gradient (an 8-bit head's
//! skin is tens of units per voxel).
//!
//! **Gradient opacity** (Levoy 1988): with `gradient_opacity = G > 0` a
//! sample's opacity is scaled by `min(1, |g| / G)` (`G` in scalar units per
//! world unit), so homogeneous regions go transparent and surfaces stay.
//!
//! The defaults are VTK's `vtkVolumeProperty` material (ambient 0.1,
//! diffuse 0.7, specular 0.2, power 10), so peer comparisons shade alike.

use std::sync::Arc;

use glam::DVec3;

use crate::error::{input, Result};
use crate::geometry::View;
use crate::gradients::Gradients;
use crate::slices::SliceStack;

/// Offset in voxels of the samples differenced in
/// [`GradientMode::Samples`].
pub const SAMPLE_OFFSET: f32 = 0.5;

/// Most directional lights a render takes.
pub const MAX_LIGHTS: usize = 4;

/// The material of the Blinn-Phong model.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Ambient coefficient `ka`.
    pub ambient: f64,
    /// Diffuse coefficient `kd`.
    pub diffuse: f64,
    /// Specular coefficient `ks`.
    pub specular: f64,
    /// Specular exponent `p`.
    pub shininess: f64,
}

impl Default for Material {
    fn default() -> Material {
        Material {
            ambient: 0.1,
            diffuse: 0.7,
            specular: 0.2,
            shininess: 10.0,
        }
    }
}

impl Material {
    /// Parses `ka,kd,ks,shininess`.
    pub fn parse(text: &str) -> Result<Material> {
        let v: Vec<f64> = text
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| input(format!("material {text:?}: expected ka,kd,ks,shininess")))?;
        let [ambient, diffuse, specular, shininess] = v[..] else {
            return Err(input(format!(
                "material {text:?}: expected four numbers ka,kd,ks,shininess"
            )));
        };
        let m = Material {
            ambient,
            diffuse,
            specular,
            shininess,
        };
        m.validate()?;
        Ok(m)
    }

    /// Refuses negative or non-finite coefficients and an exponent outside
    /// `[1, 1000]`.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("ambient", self.ambient),
            ("diffuse", self.diffuse),
            ("specular", self.specular),
        ] {
            if !(v.is_finite() && (0.0..=10.0).contains(&v)) {
                return Err(input(format!("material {name} {v} must lie in [0, 10]")));
            }
        }
        if !(self.shininess.is_finite() && (1.0..=1000.0).contains(&self.shininess)) {
            return Err(input(format!(
                "material shininess {} must lie in [1, 1000]",
                self.shininess
            )));
        }
        Ok(())
    }
}

/// Where the gradient is taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GradientMode {
    /// Central differences on voxels, interpolated like the scalar (the
    /// default, VolumePro 1000's).
    #[default]
    Voxels,
    /// Central differences of interpolated samples half a voxel either
    /// side of the sample, ER's densest ray spacing (Cube-4 differences its
    /// resampled grid's samples): six more interpolations per sample.
    /// (At one voxel either side the differences of trilinear samples equal
    /// the interpolated voxel differences exactly: an integer shift keeps
    /// the weights.)
    Samples,
}

impl std::str::FromStr for GradientMode {
    type Err = crate::error::Error;

    fn from_str(s: &str) -> Result<GradientMode> {
        match s {
            "voxels" => Ok(GradientMode::Voxels),
            "samples" => Ok(GradientMode::Samples),
            _ => Err(input(format!(
                "unknown gradient {s:?}: use voxels or samples"
            ))),
        }
    }
}

/// What to shade with: lights (world directions towards each light; none
/// is the headlight), the material, the gradient-opacity scale and where
/// gradients are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shade {
    lights: [[f64; 3]; MAX_LIGHTS],
    count: usize,
    /// The material.
    pub material: Material,
    /// `G` of the gradient-opacity modulation; 0 disables it.
    pub gradient_opacity: f64,
    /// Where gradients are taken.
    pub gradient: GradientMode,
    /// `F` of the normal fade (see the module's documentation), in scalar
    /// units per world unit; 0 disables it.
    pub normal_fade: f64,
}

/// The default [`Shade::normal_fade`].
pub const NORMAL_FADE: f64 = 1.0;

impl Default for Shade {
    fn default() -> Shade {
        Shade {
            lights: [[0.0; 3]; MAX_LIGHTS],
            count: 0,
            material: Material::default(),
            gradient_opacity: 0.0,
            gradient: GradientMode::Voxels,
            normal_fade: NORMAL_FADE,
        }
    }
}

impl Shade {
    /// Adds a directional light from world direction `dir` (towards the
    /// light; need not be unit length).
    pub fn add_light(&mut self, dir: DVec3) -> Result<()> {
        if self.count == MAX_LIGHTS {
            return Err(input(format!("at most {MAX_LIGHTS} lights")));
        }
        let len = dir.length();
        if !(len.is_finite() && len > 1e-9) {
            return Err(input(format!(
                "light direction {},{},{} must be finite and non-zero",
                dir.x, dir.y, dir.z
            )));
        }
        self.lights[self.count] = (dir / len).to_array();
        self.count += 1;
        Ok(())
    }

    /// The lights added (empty: the headlight).
    pub fn lights(&self) -> &[[f64; 3]] {
        &self.lights[..self.count]
    }

    /// Refuses a bad material or gradient scale.
    pub fn validate(&self) -> Result<()> {
        self.material.validate()?;
        if !(self.gradient_opacity.is_finite() && self.gradient_opacity >= 0.0) {
            return Err(input(format!(
                "gradient opacity {} must be a finite number >= 0",
                self.gradient_opacity
            )));
        }
        if !(self.normal_fade.is_finite() && self.normal_fade >= 0.0) {
            return Err(input(format!(
                "normal fade {} must be a finite number >= 0",
                self.normal_fade
            )));
        }
        Ok(())
    }
}

/// The lights of a view in view space (unit vectors towards each light)
/// and their half vectors with the viewer direction: what the golden
/// shader and the pipeline's host share, computed once in `f64`.
#[derive(Debug, Clone, PartialEq)]
pub struct Lighting {
    /// Directions towards the lights.
    pub lights: Vec<[f64; 3]>,
    /// Half vectors `normalize(L + V)`.
    pub halves: Vec<[f64; 3]>,
}

impl Lighting {
    /// `shade`'s lights (the headlight when none) in `view`'s space.
    pub fn new(view: &View, shade: &Shade) -> Lighting {
        // World lengths along the view axes: index units times spacing.
        let s = DVec3::from_array(view.spacing);
        let centre = DVec3::from_array(view.dims.map(|n| (n as f64 - 1.0) / 2.0));
        let to_eye = ((view.eye - centre) * s).normalize_or_zero();
        let lights: Vec<DVec3> = if shade.count == 0 {
            vec![to_eye]
        } else {
            shade
                .lights()
                .iter()
                .map(|&d| {
                    view.axes
                        .dir_to_view(DVec3::from_array(d))
                        .normalize_or_zero()
                })
                .collect()
        };
        let halves = lights
            .iter()
            .map(|&l| (l + to_eye).normalize_or_zero().to_array())
            .collect();
        Lighting {
            lights: lights.iter().map(|l| l.to_array()).collect(),
            halves,
        }
    }
}

/// A view's shader: the voxel gradients or the scale of
/// the sample differences, and the lights in view space.
pub struct Shader {
    grads: Option<Arc<Gradients>>,
    /// Samples mode: `1 / (2 h spacing)` per view axis, `h = 1/2`.
    inv2s: [f64; 3],
    lighting: Lighting,
    m: Material,
    /// The exponent as an integer when it is one (most materials): `powi`
    /// is a few multiplications where `powf` is a libm call, and agrees
    /// with it to an `f64` rounding or two, far below the `f32` samples.
    int_p: Option<i32>,
    g_ref: f64,
    fade: f64,
    /// The `f32` shader's constants ([`Shader::shade_f32`]).
    f: Shade32,
}

/// [`Shader::shade`]'s constants rounded to `f32` once, for
/// [`Shader::shade_f32`].
struct Shade32 {
    lights: [[f32; 3]; MAX_LIGHTS],
    halves: [[f32; 3]; MAX_LIGHTS],
    count: usize,
    material: [f32; 4],
    /// `1 / F` and `1 / G` (0 when disabled).
    inv_fade: f32,
    inv_g_ref: f32,
}

impl Shader {
    /// The gradients of `stack` (the view's permuted volume) and `shade`'s
    /// lights in `view`'s space.
    pub fn new(view: &View, stack: &SliceStack, shade: &Shade) -> Result<Shader> {
        shade.validate()?;
        let grads =
            (shade.gradient == GradientMode::Voxels).then(|| Arc::new(Gradients::new(view, stack)));
        Shader::with_gradients(view, grads, shade)
    }

    /// A shader over voxel gradients computed before (a prepared view
    /// caches them, see [`crate::render::Prepared::gradients`]); `None` in
    /// samples mode, which needs none.
    pub fn with_gradients(
        view: &View,
        grads: Option<Arc<Gradients>>,
        shade: &Shade,
    ) -> Result<Shader> {
        shade.validate()?;
        if (shade.gradient == GradientMode::Voxels) != grads.is_some() {
            return Err(input("voxel gradients are needed exactly in voxels mode"));
        }
        let lighting = Lighting::new(view, shade);
        let m = shade.material;
        let mut f = Shade32 {
            lights: [[0.0; 3]; MAX_LIGHTS],
            halves: [[0.0; 3]; MAX_LIGHTS],
            count: lighting.lights.len(),
            material: [m.ambient, m.diffuse, m.specular, m.shininess].map(|v| v as f32),
            inv_fade: recip_or_zero(shade.normal_fade),
            inv_g_ref: recip_or_zero(shade.gradient_opacity),
        };
        for (k, (l, h)) in lighting.lights.iter().zip(&lighting.halves).enumerate() {
            f.lights[k] = l.map(|v| v as f32);
            f.halves[k] = h.map(|v| v as f32);
        }
        Ok(Shader {
            grads,
            inv2s: view.spacing.map(|s| 1.0 / s),
            lighting,
            m: shade.material,
            int_p: (shade.material.shininess.fract() == 0.0 && shade.material.shininess <= 128.0)
                .then_some(shade.material.shininess as i32),
            g_ref: shade.gradient_opacity,
            fade: shade.normal_fade,
            f,
        })
    }

    /// The voxel gradients, in voxels mode (`None` in samples mode): for a
    /// renderer that resamples with its own filter (shear-warp's tent)
    /// and interpolates the gradient with the scalar's weights.
    pub fn voxel_gradients(&self) -> Option<&Gradients> {
        self.grads.as_deref()
    }

    /// The gradient at view `(x, y)` in slice `z` of `stack` (the
    /// scalar): voxel gradients bilinear like the scalar's sample there, or
    /// differences of samples.
    #[inline(always)]
    pub fn gradient_bilinear(&self, stack: &SliceStack, z: usize, x: f32, y: f32) -> [f32; 3] {
        match &self.grads {
            Some(g) => g.bilinear(z, x, y),
            None => self.sample_differences_f32(stack, x, y, z as f32),
        }
    }

    /// The gradient at view `(x, y, z)` in `f32`, trilinear like the
    /// slice-order methods' sub-slice samples.
    #[inline(always)]
    pub fn gradient_trilinear_f32(&self, stack: &SliceStack, x: f32, y: f32, z: f32) -> [f32; 3] {
        match &self.grads {
            Some(g) => g.trilinear_f32(x, y, z),
            None => self.sample_differences_f32(stack, x, y, z),
        }
    }

    /// The gradient at view `(x, y, z)` in `f64` (the reference's).
    #[inline]
    pub fn gradient_trilinear(&self, stack: &SliceStack, x: f64, y: f64, z: f64) -> [f64; 3] {
        match &self.grads {
            Some(g) => g.trilinear(x, y, z),
            None => {
                let (k, h) = (self.inv2s, SAMPLE_OFFSET as f64);
                [
                    (stack.trilinear(x + h, y, z) - stack.trilinear(x - h, y, z)) * k[0],
                    (stack.trilinear(x, y + h, z) - stack.trilinear(x, y - h, z)) * k[1],
                    (stack.trilinear(x, y, z + h) - stack.trilinear(x, y, z - h)) * k[2],
                ]
            }
        }
    }

    /// Central differences of trilinear samples [`SAMPLE_OFFSET`] either
    /// side.
    #[inline]
    fn sample_differences_f32(&self, stack: &SliceStack, x: f32, y: f32, z: f32) -> [f32; 3] {
        let (k, h) = (self.inv2s.map(|v| v as f32), SAMPLE_OFFSET);
        let t = |x, y, z| stack.trilinear_f32(x, y, z);
        [
            (t(x + h, y, z) - t(x - h, y, z)) * k[0],
            (t(x, y + h, z) - t(x, y - h, z)) * k[1],
            (t(x, y, z + h) - t(x, y, z - h)) * k[2],
        ]
    }

    /// Shades classified colour `c` (R, G, B not premultiplied, A) with
    /// gradient `g`, in `f64`.
    pub fn shade(&self, c: [f64; 4], g: [f64; 3]) -> [f64; 4] {
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        let m = &self.m;
        let lit = &self.lighting;
        let (mut diffuse, mut specular) = (0.0, 0.0);
        // The normal's weight: the fade, or all or nothing without one.
        let r = if self.fade > 0.0 {
            (len / self.fade).min(1.0)
        } else if len > 1e-12 {
            1.0
        } else {
            0.0
        };
        if r > 0.0 {
            let n = g.map(|v| v / len);
            let dot = |a: &[f64; 3]| (n[0] * a[0] + n[1] * a[1] + n[2] * a[2]).abs();
            for (l, h) in lit.lights.iter().zip(&lit.halves) {
                diffuse += dot(l);
                let x = dot(h);
                specular += match self.int_p {
                    Some(p) => x.powi(p),
                    None => x.powf(m.shininess),
                };
            }
        }
        let diffuse = r * diffuse + (1.0 - r) * lit.lights.len() as f64;
        let specular = r * specular;
        let k = m.ambient + m.diffuse * diffuse;
        let s = m.specular * specular;
        let a = if self.g_ref > 0.0 {
            c[3] * (len / self.g_ref).min(1.0)
        } else {
            c[3]
        };
        [
            (c[0] * k + s).min(1.0),
            (c[1] * k + s).min(1.0),
            (c[2] * k + s).min(1.0),
            a,
        ]
    }

    /// The largest difference between [`Shader::shade_f32`] and
    /// [`Shader::shade`] in any channel, for colours in `[0, 1]` and any
    /// gradient: the normal and its dot products carry a few `f32`
    /// roundings (relative `2^-24` each; 2e-7 covers the handful), which the
    /// highlight's power `p` multiplies by `p`; the sum is at most
    /// `ka + kd n_L + ks n_L`.
    pub fn f32_tolerance(&self) -> f64 {
        let m = &self.m;
        let n = self.lighting.lights.len() as f64;
        2e-7 * (1.0 + m.ambient + m.diffuse * n + m.specular * n * (1.0 + m.shininess))
    }

    /// [`Shader::shade`] for the slice-order methods' `f32` samples, in
    /// `f32`: one reciprocal of `|g|` instead of three divisions, the
    /// highlight's integer power by squaring, and the constants rounded
    /// once. It agrees with `shade` to [`Shader::f32_tolerance`] (tested),
    /// which at the default material is far below an 8-bit grey level.
    #[inline(always)]
    pub fn shade_f32(&self, c: [f32; 4], g: [f32; 3]) -> [f32; 4] {
        let f = &self.f;
        let [ka, kd, ks, p] = f.material;
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        let r = if f.inv_fade > 0.0 {
            (len * f.inv_fade).min(1.0)
        } else if len > 1e-12 {
            1.0
        } else {
            0.0
        };
        let (mut diffuse, mut specular) = (0.0f32, 0.0f32);
        if r > 0.0 {
            let inv = 1.0 / len;
            let n = g.map(|v| v * inv);
            let dot = |a: &[f32; 3]| (n[0] * a[0] + n[1] * a[1] + n[2] * a[2]).abs();
            for k in 0..f.count {
                diffuse += dot(&f.lights[k]);
                let x = dot(&f.halves[k]).min(1.0);
                specular += match self.int_p {
                    Some(e) => powi_f32(x, e as u32),
                    None => x.powf(p),
                };
            }
        }
        let diffuse = r * diffuse + (1.0 - r) * f.count as f32;
        let k = ka + kd * diffuse;
        let s = ks * (r * specular);
        let a = if f.inv_g_ref > 0.0 {
            c[3] * (len * f.inv_g_ref).min(1.0)
        } else {
            c[3]
        };
        [
            (c[0] * k + s).min(1.0),
            (c[1] * k + s).min(1.0),
            (c[2] * k + s).min(1.0),
            a,
        ]
    }
}

/// `1 / v`, or 0 for a disabled (zero) scale.
fn recip_or_zero(v: f64) -> f32 {
    if v > 0.0 {
        (1.0 / v) as f32
    } else {
        0.0
    }
}

/// `x^e` by squaring, `x` in `[0, 1]`: a handful of multiplications where
/// `powi` is a library call; its rounding grows like `log2(e)` roundings.
#[inline]
fn powi_f32(mut x: f32, mut e: u32) -> f32 {
    let mut acc = 1.0f32;
    while e > 0 {
        if e & 1 == 1 {
            acc *= x;
        }
        x *= x;
        e >>= 1;
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_parses_and_refuses() {
        let m = Material::parse("0.2, 0.6,0.3,16").unwrap();
        assert_eq!(
            (m.ambient, m.diffuse, m.specular, m.shininess),
            (0.2, 0.6, 0.3, 16.0)
        );
        for bad in [
            "1,2,3",
            "a,b,c,d",
            "0.1,0.7,0.2,0",
            "-1,0.7,0.2,10",
            "0.1,nan,0.2,10",
        ] {
            let e = Material::parse(bad).unwrap_err().to_string();
            assert!(e.contains("material"), "{bad}: {e}");
        }
        let mut s = Shade::default();
        assert!(s.add_light(DVec3::ZERO).is_err());
        for _ in 0..MAX_LIGHTS {
            s.add_light(DVec3::X).unwrap();
        }
        assert!(s.add_light(DVec3::X).is_err());
        assert_eq!(s.lights().len(), MAX_LIGHTS);
    }
}
