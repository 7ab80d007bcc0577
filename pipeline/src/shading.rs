//! The PE's gradient and shading units, bit for bit: central differences
//! of voxel words, interpolated like the scalar, then Blinn-Phong with a
//! divider and a specular power table: the fixed-point twin of
//! [`golden::shading::Shader::shade`] on [`golden::shading`]'s voxel
//! gradients (the default [`golden::shading::GradientMode::Voxels`]; the
//! samples mode is not built).
//!
//! **Where the voxels come from.** A sample between columns `c0 = x0` and
//! `c1 = x0 + 1` (clamped) and rows `y0`, `y0 + 1` of slice `z` needs,
//! for the x differences, columns `x0 - 1` and `x0 + 2` on both rows; for
//! the y differences, rows `y0 - 1` and `y0 + 2` of columns `c0`, `c1`;
//! for the z differences, slices `z - 1` and `z + 1` at the four corners
//! ([`Taps`]). All are the PE's own memory except at a block's edges:
//! the right neighbour drives its first column's eight words and its
//! second column's two ([`Halo`], beside the scalar's edge voxels) and the
//! left neighbour its last column's two (on its right port's edge), one
//! cycle ahead like the scalar's edge. So a PE reads three slices of its
//! block (a streaming chip's slice buffer holds `z - 1`, `z`, `z + 1`) and
//! four rows (two line buffers more than the scalar's), and every block
//! needs at least two columns.
//!
//! **Arithmetic** (every assignment names its format in
//! [`PipelineConfig`]):
//! 1. `d = (f(i + 1) - f(i - 1)) k_axis` per axis and corner, `k_axis =
//!    s_min / s_axis` ([`PipelineConfig::grad_scale`]), into
//!    [`PipelineConfig::gradient`] (golden: `(f(i+1) - f(i-1)) / (2 s)`,
//!    the same direction, a known scale);
//! 2. each component bilinear with the scalar's weights, three `lerp`s
//!    into `gradient`;
//! 3. `|g|`: exact sum of squares, integer square root truncated into
//!    [`PipelineConfig::grad_norm`];
//! 4. the fade `r = min(1, |g| / F)` as `|g| (1/F)` into
//!    [`PipelineConfig::normal_dot`] (`1/F` broadcast in
//!    [`PipelineConfig::grad_recip`]); `|n . L| = |g . L| / |g|` by a
//!    divider (exact quotient truncated, capped at 1) into `normal_dot`;
//! 5. `|n . H|^p` from a power table ([`PipelineConfig::specular`],
//!    `2^shade_table_bits + 1` entries) interpolated with the remaining
//!    bits (weight in [`PipelineConfig::weight`]);
//! 6. `c' = min(1, c (ka + kd (r sum |n.L| + (1 - r) n_L)) + ks r sum
//!    |n.H|^p)` exact, capped at 1 (a comparator), into
//!    [`PipelineConfig::color`]; with gradient opacity
//!    `a' = a min(1, |g| (1/G))` into [`PipelineConfig::alpha`].

use golden::geometry::View;
use golden::shading::{GradientMode, Lighting, Shade};

use crate::config::PipelineConfig;
use crate::datapath::{isqrt_into, lerp, FrameUnit, Loaded, UnitFrame};
use crate::fixed::{Fx, FxError, QuantStats, Wide};
use crate::hw::compose::FrameUnits;

/// Words the right neighbour drives beside its edge voxels while the
/// array shades, for the row announced next: its first column at rows
/// `y0 - 1`, `y0 + 2` of slice `z`, at rows `y0`, `y0 + 1` of slices
/// `z - 1` and `z + 1`, and its second column at rows `y0`, `y0 + 1` of
/// slice `z` (all clamped to the volume).
pub type Halo = [u16; 8];

/// The voxel words around one sample: `x[row][col]` rows `y0`, `y0 + 1`
/// of columns `x0 - 1, x0, x0 + 1, x0 + 2`; `y[col][k]` columns `x0`,
/// `x0 + 1` at rows `y0 - 1` (`k = 0`) and `y0 + 2` (`k = 1`);
/// `z[k][row][col]` slices `z - 1`, `z + 1` at the four corners.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Taps {
    /// Rows `y0`, `y0 + 1`, columns `x0 - 1 ..= x0 + 2`.
    pub x: [[u16; 4]; 2],
    /// Columns `x0`, `x0 + 1`, rows `y0 - 1`, `y0 + 2`.
    pub y: [[u16; 2]; 2],
    /// Slices `z - 1`, `z + 1`, rows `y0`, `y0 + 1`, columns `x0`, `x0 + 1`.
    pub z: [[[u16; 2]; 2]; 2],
}

/// What the shading unit did for one sample, for waveforms and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShadeTrace {
    /// Interpolated gradient, raw `gradient` words.
    pub grad: [i64; 3],
    /// `|g|`, raw `grad_norm`.
    pub norm: i64,
    /// Diffuse `|n . L|` of the first light, raw `normal_dot`.
    pub diffuse: i64,
    /// Shaded R, G, B, raw `color`.
    pub rgb: [i64; 3],
}

/// The rows `y0 - 1` and `y0 + 2` (clamped) of a sample whose clamped rows
/// are `(y0c, y1c)` in a volume `ny` rows high. The clamped pair tells
/// `y0` apart: `(0, 0)` with `ny > 1` is `y0 = -1` (the first half row),
/// anything else has `y0 = y0c`.
#[inline]
pub fn outer_rows(y0c: usize, y1c: usize, ny: usize) -> (usize, usize) {
    let last = ny as i64 - 1;
    let y0 = if y0c == 0 && y1c == 0 && ny > 1 {
        -1
    } else {
        y0c as i64
    };
    (
        (y0 - 1).clamp(0, last) as usize,
        (y0 + 2).clamp(0, last) as usize,
    )
}

/// The per-frame constants of the shading unit, loaded by the host: the
/// lights and half vectors in `light`, the material in `material`, the
/// axis scales, the fade's and gradient opacity's reciprocals and the
/// specular power table.
#[derive(Debug, Clone)]
pub struct ShadeUnit {
    /// Directions towards the lights.
    lights: Vec<[Fx; 3]>,
    /// Half vectors.
    halves: Vec<[Fx; 3]>,
    /// `ka`, `kd`, `ks`.
    k: [Fx; 3],
    /// `s_min / s_axis` per view axis.
    pub scale: [Fx; 3],
    /// `1 / F` per `gradient` code, `None` without a fade.
    inv_fade: Option<Fx>,
    /// `1 / G` per `gradient` code, `None` without gradient opacity.
    inv_g: Option<Fx>,
    /// `x^p` at `x = j / 2^shade_table_bits`.
    power: Vec<Fx>,
}

/// Why a frame cannot be shaded by the pipeline.
#[derive(Debug, thiserror::Error)]
pub enum ShadeError {
    /// An option the shading unit does not build.
    #[error("{0}")]
    Unsupported(String),
    /// A constant that does not fit its format.
    #[error("{0}")]
    Fixed(#[from] FxError),
}

/// The frame's shading ([`crate::datapath::FrameUnit`]): the unit's
/// constants for the frame's view and data width (the gradient's code
/// scale). Under column blocks every PE's block must hold at least two
/// columns (the gradient's right taps reach the neighbour's second);
/// round-robin PEs read their aprons.
impl FrameUnit for Shade {
    fn load(&self, f: &UnitFrame, units: &mut FrameUnits, st: &mut QuantStats) -> Loaded {
        let m = &f.map;
        if m.pes > 1 && !m.round_robin() && m.width < 2 {
            return Err(crate::RunError::Shade(ShadeError::Unsupported(format!(
                "shading needs at least 2 voxel columns per PE, but {} columns over {} PEs give {}",
                m.nx, m.pes, m.width
            ))));
        }
        f.dp.cfg.check_shading()?;
        let unit = ShadeUnit::new(&f.dp.cfg, self, f.view, f.data_bits, st)
            .map_err(crate::RunError::Shade)?;
        units.shade = Some(unit);
        Ok(())
    }
}

impl ShadeUnit {
    /// The unit's constants for `shade` in `view`, for voxel words of
    /// `data_bits`-bit data (the gradient's code scale).
    pub fn new(
        cfg: &PipelineConfig,
        shade: &Shade,
        view: &View,
        data_bits: u32,
        st: &mut QuantStats,
    ) -> Result<ShadeUnit, ShadeError> {
        shade
            .validate()
            .map_err(|e| ShadeError::Unsupported(e.to_string()))?;
        if shade.gradient != GradientMode::Voxels {
            return Err(ShadeError::Unsupported(
                "the pipeline's gradient unit takes differences on voxels; --gradient samples is golden only".into(),
            ));
        }
        let mut q = |f: crate::config::Reg, v: f64| -> Result<Fx, FxError> {
            let r = f.from_f64(v)?;
            st.record_as(f.id, &r);
            Ok(r.value)
        };
        let lit = Lighting::new(view, shade);
        let vec = |q: &mut dyn FnMut(crate::config::Reg, f64) -> Result<Fx, FxError>,
                   v: &[f64; 3]|
         -> Result<[Fx; 3], FxError> {
            Ok([
                q(crate::reg!(cfg, light), v[0])?,
                q(crate::reg!(cfg, light), v[1])?,
                q(crate::reg!(cfg, light), v[2])?,
            ])
        };
        let lights = lit
            .lights
            .iter()
            .map(|v| vec(&mut q, v))
            .collect::<Result<Vec<_>, _>>()?;
        let halves = lit
            .halves
            .iter()
            .map(|v| vec(&mut q, v))
            .collect::<Result<Vec<_>, _>>()?;
        let m = shade.material;
        let k = [
            q(crate::reg!(cfg, material), m.ambient)?,
            q(crate::reg!(cfg, material), m.diffuse)?,
            q(crate::reg!(cfg, material), m.specular)?,
        ];
        let s_min = view.spacing.iter().copied().fold(f64::INFINITY, f64::min);
        let scale = [
            q(crate::reg!(cfg, grad_scale), s_min / view.spacing[0])?,
            q(crate::reg!(cfg, grad_scale), s_min / view.spacing[1])?,
            q(crate::reg!(cfg, grad_scale), s_min / view.spacing[2])?,
        ];
        // One golden gradient unit (scalar units per world unit) in
        // `gradient` codes: the voxel word's scale times `2 s_min`.
        let unit = 2.0 * s_min * f64::powi(2.0, i32::from(cfg.voxel.bits()) - data_bits as i32);
        let recip = |q: &mut dyn FnMut(crate::config::Reg, f64) -> Result<Fx, FxError>,
                     g: f64|
         -> Result<Option<Fx>, FxError> {
            if g > 0.0 {
                q(crate::reg!(cfg, grad_recip), 1.0 / (g * unit)).map(Some)
            } else {
                Ok(None)
            }
        };
        let inv_fade = recip(&mut q, shade.normal_fade)?;
        let inv_g = recip(&mut q, shade.gradient_opacity)?;
        let n = 1usize << cfg.shade_table_bits;
        let power = (0..=n)
            .map(|j| {
                q(
                    crate::reg!(cfg, specular),
                    (j as f64 / n as f64).powf(m.shininess),
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(ShadeUnit {
            lights,
            halves,
            k,
            scale,
            inv_fade,
            inv_g,
            power,
        })
    }

    /// The unit from its words, for the description's checks
    /// (`crate::hw::units_tests`).
    #[cfg(test)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_words(
        lights: Vec<[Fx; 3]>,
        halves: Vec<[Fx; 3]>,
        k: [Fx; 3],
        scale: [Fx; 3],
        inv_fade: Option<Fx>,
        inv_g: Option<Fx>,
        power: Vec<Fx>,
    ) -> ShadeUnit {
        ShadeUnit {
            lights,
            halves,
            k,
            scale,
            inv_fade,
            inv_g,
            power,
        }
    }

    /// The unit's per-frame ports as its description names them
    /// ([`crate::hw::shading::shading`]: `scale.*`, `light<i>.*`,
    /// `halfv<i>.*`, `ka`, `kd`, `ks`, `inv_fade`, `inv_g`, `fade`,
    /// `gopac`), raw words; a reciprocal left out is a zero word with its
    /// flag low.
    pub fn port_words(&self) -> Vec<(String, i64)> {
        let mut v = Vec::new();
        for (k, a) in ["x", "y", "z"].iter().enumerate() {
            v.push((format!("scale.{a}"), self.scale[k].raw()));
            for (i, (l, h)) in self.lights.iter().zip(&self.halves).enumerate() {
                v.push((format!("light{i}.{a}"), l[k].raw()));
                v.push((format!("halfv{i}.{a}"), h[k].raw()));
            }
        }
        for (n, x) in ["ka", "kd", "ks"].iter().zip(self.k) {
            v.push(((*n).to_owned(), x.raw()));
        }
        for (n, flag, x) in [
            ("inv_fade", "fade", self.inv_fade),
            ("inv_g", "gopac", self.inv_g),
        ] {
            v.push((n.to_owned(), x.map_or(0, |x| x.raw())));
            v.push((flag.to_owned(), i64::from(x.is_some())));
        }
        v
    }

    /// The specular power table's raw words, entry by entry (the
    /// description's `power_table`).
    pub fn power_words(&self) -> Vec<i64> {
        self.power.iter().map(|x| x.raw()).collect()
    }

    /// Lights in the frame (the headlight counts one).
    pub fn light_count(&self) -> usize {
        self.lights.len()
    }

    /// Step 1: the central difference `(hi - lo) k` into `gradient`.
    #[inline]
    fn difference(
        &self,
        cfg: &PipelineConfig,
        hi: u16,
        lo: u16,
        axis: usize,
        st: &mut QuantStats,
    ) -> Fx {
        let d = Wide::new(i128::from(hi) - i128::from(lo), 0);
        // A 17-bit difference times a format word: far inside i128.
        let v = Wide::new(
            d.raw * i128::from(self.scale[axis].raw()),
            i32::from(cfg.grad_scale.frac()),
        );
        crate::reg!(cfg, gradient).assign(v, st)
    }

    /// Steps 1 and 2: the gradient at the sample, each component's four
    /// corner differences interpolated with the scalar's weights (along x on
    /// both rows, then along y).
    pub fn gradient(
        &self,
        cfg: &PipelineConfig,
        t: &Taps,
        (wx, wy): (Fx, Fx),
        st: &mut QuantStats,
    ) -> Result<[Fx; 3], FxError> {
        let g = crate::reg!(cfg, gradient);
        let mut out = [g.zero(); 3];
        for (axis, o) in out.iter_mut().enumerate() {
            // corner[row][col], col 0 = x0, 1 = x0 + 1.
            let mut corner = [[g.zero(); 2]; 2];
            for (j, row) in corner.iter_mut().enumerate() {
                for (i, c) in row.iter_mut().enumerate() {
                    let (hi, lo) = match axis {
                        0 => (t.x[j][i + 2], t.x[j][i]),
                        1 if j == 0 => (t.x[1][i + 1], t.y[i][0]),
                        1 => (t.y[i][1], t.x[0][i + 1]),
                        _ => (t.z[1][j][i], t.z[0][j][i]),
                    };
                    *c = self.difference(cfg, hi, lo, axis, st);
                }
            }
            let top = lerp(corner[0][0], corner[0][1], wx, g, st)?;
            let bot = lerp(corner[1][0], corner[1][1], wx, g, st)?;
            *o = lerp(top, bot, wy, g, st)?;
        }
        Ok(out)
    }

    /// `|g . v| / |g|`: the divider ([`divide`]) of the dot product's
    /// magnitude by the norm.
    #[inline]
    fn cosine(cfg: &PipelineConfig, g: &[Fx; 3], v: &[Fx; 3], norm: Fx) -> Result<Wide, FxError> {
        let dot = (g[0] * v[0])
            .checked_add(g[1] * v[1])?
            .checked_add(g[2] * v[2])?;
        divide(cfg, dot.raw.unsigned_abs() as i128, dot.frac, norm)
    }

    /// `x^p` for `x` in `[0, 1]` on the `normal_dot` grid: the power table
    /// indexed by the top `shade_table_bits` fraction bits, interpolated
    /// with the rest, into `specular`.
    #[inline]
    fn power(&self, cfg: &PipelineConfig, x: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
        let fo = u32::from(cfg.normal_dot.frac());
        let b = u32::from(cfg.shade_table_bits);
        let raw = x.raw().max(0);
        let idx = (raw >> (fo - b)) as usize;
        let last = self.power.len() - 1;
        if idx >= last {
            return Ok(self.power[last]);
        }
        let rem = raw & ((1i64 << (fo - b)) - 1);
        let w = crate::reg!(cfg, weight).assign(Wide::new(i128::from(rem), (fo - b) as i32), st);
        lerp(
            self.power[idx],
            self.power[idx + 1],
            w,
            crate::reg!(cfg, specular),
            st,
        )
    }

    /// Steps 3 to 6: shades classified colour `rgb` and opacity `a` with
    /// gradient `g`.
    pub fn shade(
        &self,
        cfg: &PipelineConfig,
        rgb: [Fx; 3],
        a: Fx,
        g: &[Fx; 3],
        st: &mut QuantStats,
    ) -> Result<([Fx; 3], Fx, ShadeTrace), FxError> {
        let nd = crate::reg!(cfg, normal_dot);
        let sum = (g[0] * g[0])
            .checked_add(g[1] * g[1])?
            .checked_add(g[2] * g[2])?;
        let norm = isqrt_into(sum, crate::reg!(cfg, grad_norm), "gradient norm", st)?;
        let one = Wide::new(1, 0);
        let r = match self.inv_fade {
            Some(inv) if norm.raw() > 0 => nd.assign(min(norm * inv, one), st),
            Some(_) => nd.zero(),
            None if norm.raw() > 0 => nd.assign(one, st),
            None => nd.zero(),
        };
        let (mut diffuse, mut spec) = (Wide::new(0, 0), Wide::new(0, 0));
        let mut first = 0;
        if norm.raw() > 0 {
            for (i, (l, h)) in self.lights.iter().zip(&self.halves).enumerate() {
                let dl = nd.assign(Self::cosine(cfg, g, l, norm)?, st);
                let dh = nd.assign(Self::cosine(cfg, g, h, norm)?, st);
                if i == 0 {
                    first = dl.raw();
                }
                diffuse = diffuse.checked_add(dl)?;
                spec = spec.checked_add(self.power(cfg, dh, st)?)?;
            }
        }
        let n_l = Wide::new(self.lights.len() as i128, 0);
        // r D + (1 - r) n_L, r S: exact.
        let diffuse = Wide::from(r)
            .checked_mul(diffuse)?
            .checked_add(one.checked_sub(r)?.checked_mul(n_l)?)?;
        let spec = Wide::from(r).checked_mul(spec)?;
        let [ka, kd, ks] = self.k;
        let gain = Wide::from(ka).checked_add(Wide::from(kd).checked_mul(diffuse)?)?;
        let high = Wide::from(ks).checked_mul(spec)?;
        let mut out = [cfg.color.zero(); 3];
        for (o, &c) in out.iter_mut().zip(&rgb) {
            let v = Wide::from(c).checked_mul(gain)?.checked_add(high)?;
            *o = crate::reg!(cfg, color).assign(min(v, one), st);
        }
        let alpha = match self.inv_g {
            Some(inv) => {
                let f = min(norm * inv, one);
                crate::reg!(cfg, alpha).assign(Wide::from(a).checked_mul(f)?, st)
            }
            None => a,
        };
        let trace = ShadeTrace {
            grad: g.map(Fx::raw),
            norm: norm.raw(),
            diffuse: first,
            rgb: out.map(Fx::raw),
        };
        Ok((out, alpha, trace))
    }
}

/// The shading divider: `num 2^-num_frac / norm` (`num >= 0`, `norm > 0`),
/// the exact quotient truncated onto the `normal_dot` grid and capped at 1
/// (quantised unit vectors can put a dot product a hair above it). Public
/// so that the calibration Verilog ([`crate::rtl`]) can be checked
/// against it.
#[inline]
pub fn divide(cfg: &PipelineConfig, num: i128, num_frac: i32, norm: Fx) -> Result<Wide, FxError> {
    let nd = cfg.normal_dot;
    // value = (num 2^-fd) / (n 2^-fn); on the grid 2^-fo: floor(num
    // 2^(fo + fn - fd) / n). Nested floors of positive integers are the
    // floor of the whole, so a right shift first is exact too.
    let s = i32::from(nd.frac()) + i32::from(norm.format().frac()) - num_frac;
    let scaled = if s >= 0 {
        num.checked_shl(s as u32)
            .filter(|v| v >> s as u32 == num)
            .ok_or(FxError::WideOverflow {
                op: "shading divide",
            })?
    } else {
        num >> (-s) as u32
    };
    let q = scaled / i128::from(norm.raw());
    Ok(Wide::new(q.min(1i128 << nd.frac()), i32::from(nd.frac())))
}

/// The smaller of two exact values (a comparator and a multiplexer).
#[inline]
fn min(a: Wide, b: Wide) -> Wide {
    if a.cmp_value(b).is_gt() {
        b
    } else {
        a
    }
}
