//! Transfer functions: piecewise-linear RGBA over the scalar range,
//! tabulated to a lookup table for classification.
//!
//! Opacity is per unit of world length: a control point's `a` is the opacity
//! of a segment one world unit long (one voxel at unit spacing). Renderers
//! correct it for their step length `ds` as `1 - (1 - a)^ds`.

use std::path::Path;

use crate::error::{input, Error, Result};
use crate::volume::{Volume, VoxelType};

/// One control point: a scalar value and the colour and opacity there.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlPoint {
    /// Scalar value (voxel units, e.g. 0..=255 for u8 volumes).
    pub value: f64,
    /// Red, green, blue (not premultiplied) and opacity per unit length, each in [0, 1].
    #[serde(deserialize_with = "four_values")]
    pub rgba: [f64; 4],
}

/// Exactly four numbers (a fixed-size array alone would take the first
/// four of a longer list).
fn four_values<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<[f64; 4], D::Error> {
    use serde::de::Error as _;
    let v = <Vec<f64> as serde::Deserialize>::deserialize(d)?;
    let n = v.len();
    v.try_into()
        .map_err(|_| D::Error::invalid_length(n, &"four values r, g, b, a"))
}

/// A piecewise-linear transfer function; constant beyond its end points.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferFunction {
    /// Control points in non-decreasing order of `value`.
    #[serde(rename = "point")]
    pub points: Vec<ControlPoint>,
    /// The shading material this table is meant for (`[material]` with
    /// `ambient`, `diffuse`, `specular`, `shininess`): a table that has one
    /// is rendered shaded unless the user says `--no-shade`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<crate::shading::Material>,
    /// `fit = [lo, hi]`: the points' values are written against the scalar
    /// range `lo..=hi`, which is stretched onto the data's own range
    /// ([`data_range`], [`TransferFunction::fitted`]); the presets say
    /// `[0, 255]`. Without it the values are raw voxel units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<[f64; 2]>,
}

impl TransferFunction {
    /// Builds a transfer function, checking that the points are finite,
    /// ordered and in range.
    pub fn new(points: Vec<ControlPoint>) -> Result<TransferFunction> {
        let tf = TransferFunction {
            points,
            material: None,
            fit: None,
        };
        tf.validate()?;
        Ok(tf)
    }

    fn validate(&self) -> Result<()> {
        if let Some(m) = &self.material {
            m.validate()?;
        }
        if self.points.is_empty() {
            return Err(input("transfer function has no control points"));
        }
        if let Some([lo, hi]) = self.fit {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(input(format!(
                    "transfer function fit = [{lo}, {hi}] needs finite lo < hi"
                )));
            }
        }
        for (i, p) in self.points.iter().enumerate() {
            if !p.value.is_finite() {
                return Err(input(format!(
                    "transfer function point {i}: value is not finite"
                )));
            }
            if p.rgba.iter().any(|c| !(0.0..=1.0).contains(c)) {
                return Err(input(format!(
                    "transfer function point {i}: rgba {:?} must lie in [0, 1]",
                    p.rgba
                )));
            }
            if i > 0 && p.value < self.points[i - 1].value {
                return Err(input(format!(
                    "transfer function point {i}: value {} is below the previous {}",
                    p.value,
                    self.points[i - 1].value
                )));
            }
        }
        Ok(())
    }

    /// Parses the TOML form: `[[point]] value = 30  rgba = [1, 1, 1, 0]`, ...
    pub fn from_toml_str(text: &str) -> Result<TransferFunction> {
        let tf: TransferFunction = toml::from_str(text).map_err(|e| {
            // The library's own text draws the line under a caret over
            // several lines: give its message and the line number instead.
            // The table the error is in, when it is not the top level:
            // serde's message names the field but not its table.
            let at = e
                .span()
                .map(|s| {
                    let start = s.start.min(text.len());
                    let before = &text[..start];
                    // Up to the end of the error's own line, which may be
                    // the table's header.
                    let end = text[start..].find('\n').map_or(text.len(), |n| start + n);
                    let table = text[..end]
                        .lines()
                        .map(str::trim)
                        .rev()
                        .find(|l| l.starts_with('['))
                        .map_or_else(String::new, |t| format!(" in {t}"));
                    format!("line {}{table}: ", before.lines().count().max(1))
                })
                .unwrap_or_default();
            input(format!("transfer function: {at}{}", one_line(e.message())))
        })?;
        tf.validate()?;
        Ok(tf)
    }

    /// Reads a TOML transfer function file.
    pub fn from_file(path: &Path) -> Result<TransferFunction> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_owned(),
            err: source,
        })?;
        Self::from_toml_str(&text).map_err(|e| Error::Format {
            path: path.to_owned(),
            msg: e.to_string(),
        })
    }

    /// The TOML text of this transfer function (what `from_toml_str` reads).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("a validated transfer function serialises")
    }

    /// Evaluates the function at scalar `s` (piecewise linear, clamped).
    pub fn eval(&self, s: f64) -> [f64; 4] {
        let pts = &self.points;
        let first = pts[0];
        if s <= first.value {
            return first.rgba;
        }
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            if s <= b.value {
                if b.value == a.value {
                    return b.rgba;
                }
                let t = (s - a.value) / (b.value - a.value);
                return std::array::from_fn(|k| a.rgba[k] + t * (b.rgba[k] - a.rgba[k]));
            }
        }
        pts[pts.len() - 1].rgba
    }

    /// The table in raw voxel units for data whose values span `range`
    /// (see [`data_range`]): a `fit = [lo, hi]` table has each point's
    /// value moved linearly from `lo..=hi` onto `range`; a table without
    /// `fit`, or whose `fit` already is `range`, is returned unchanged
    /// (bit for bit, so 8-bit data renders as before).
    pub fn fitted(&self, range: [f64; 2]) -> TransferFunction {
        let mut tf = self.clone();
        let Some(from) = tf.fit.take() else {
            return tf;
        };
        if from == range {
            return tf;
        }
        let scale = (range[1] - range[0]) / (from[1] - from[0]);
        for p in &mut tf.points {
            p.value = range[0] + (p.value - from[0]) * scale;
        }
        tf
    }

    /// Whether this table shows none, some or all of `vol`: the opacity
    /// of each voxel value present ([`Volume::values`], kept with the
    /// volume), evaluated on the function itself, lowest value first,
    /// stopping at the first pair of a visible and a clear value.
    pub fn coverage(&self, vol: &Volume) -> Coverage {
        let (mut seen, mut clear) = (false, false);
        for v in vol.values().iter() {
            if self.eval(f64::from(v))[3] > 0.0 {
                seen = true;
            } else {
                clear = true;
            }
            if seen && clear {
                return Coverage::Some;
            }
        }
        match (seen, clear) {
            (false, _) => Coverage::None,
            (true, true) => Coverage::Some,
            (true, false) => Coverage::All,
        }
    }

    /// Tabulates the function into `entries` entries spanning scalars
    /// `0..=max_value`, the form both the golden model and the chip use.
    pub fn table(&self, entries: usize, max_value: f64) -> Lut {
        assert!(entries >= 2, "a lookup table needs at least two entries");
        // `Lut::lookup` indexes in 32 bits; positions finer than 2^-24 of
        // the range are not representable in `f32` anyway.
        assert!(
            entries <= 1 << 24,
            "a lookup table holds at most 2^24 entries"
        );
        let step = max_value / (entries - 1) as f64;
        let rgba = (0..entries)
            .map(|i| {
                let c = self.eval(i as f64 * step);
                [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32]
            })
            .collect();
        Lut {
            rgba,
            per_scalar: ((entries - 1) as f64 / max_value) as f32,
        }
    }
}

/// How much of a volume a transfer function shows
/// ([`TransferFunction::coverage`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coverage {
    /// Every voxel has opacity 0: the image is empty.
    None,
    /// Some voxels are visible and some are clear.
    Some,
    /// No voxel is clear: the image shows the volume's bounding box.
    All,
}

/// The scalar range a `fit` table ([`TransferFunction::fitted`]) is
/// stretched onto for `vol`: 8-bit data's whole range `0..=255` (so a
/// table written for 8-bit data keeps its meaning there); wider data's
/// smallest..largest voxel value, as ParaView and 3D Slicer fit a table
/// to the data; with a `--window` (`windowed`), the window, which the
/// volume holds as `0..=65535`. A constant volume gets a range one unit
/// wide above its value.
pub fn data_range(vol: &Volume, windowed: bool) -> [f64; 2] {
    match (vol.kind(), windowed) {
        (VoxelType::U8, false) => [0.0, 255.0],
        (VoxelType::U16, true) | (VoxelType::U8, true) => [0.0, 65535.0],
        (VoxelType::U16, false) => {
            let (lo, hi) = vol.value_range();
            let (lo, hi) = (f64::from(lo), f64::from(hi));
            [lo, if hi > lo { hi } else { lo + 1.0 }]
        }
    }
}

/// Keeps the first line of a parser message, for one-line errors.
fn one_line(msg: &str) -> String {
    msg.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

/// A tabulated transfer function: RGBA entries evenly spaced over the scalar
/// range. Lookups of a non-integer position interpolate linearly between
/// neighbouring entries (post-classification of an interpolated scalar).
#[derive(Debug, Clone)]
pub struct Lut {
    /// Colour (not premultiplied) and opacity per unit length, per entry.
    pub rgba: Vec<[f32; 4]>,
    /// Table entries per scalar unit.
    pub per_scalar: f32,
}

impl Lut {
    /// A table of `entries` (a power of two) over `data_bits`-bit scalars,
    /// with entries `2^(data_bits) / entries` scalar units apart, so that a
    /// scalar's table position is a power-of-two scaling, as in hardware
    /// (the last entry sits one spacing below `2^data_bits`; scalars above
    /// it clamp to it).
    pub fn for_bits(tf: &TransferFunction, entries: usize, data_bits: u32) -> Lut {
        assert!(
            entries.is_power_of_two() && entries >= 2,
            "table entries must be a power of two"
        );
        let spacing = (1u64 << data_bits) as f64 / entries as f64;
        tf.table(entries, (entries - 1) as f64 * spacing)
    }

    /// The classified colour and opacity of scalar `s`.
    #[inline]
    pub fn lookup(&self, s: f32) -> [f32; 4] {
        let last = self.rgba.len() - 1;
        let f = (s * self.per_scalar).clamp(0.0, last as f32);
        // `f` lies in `0..=last` (at most 2^24 entries, see `table`), so
        // truncating through `u32` is truncating through `usize`, with
        // one-instruction conversions (`usize` to `f32` is several).
        let i = (f as u32).min(last as u32 - 1);
        let t = f - i as f32;
        let (a, b) = (self.rgba[i as usize], self.rgba[i as usize + 1]);
        [
            a[0] + t * (b[0] - a[0]),
            a[1] + t * (b[1] - a[1]),
            a[2] + t * (b[2] - a[2]),
            a[3] + t * (b[3] - a[3]),
        ]
    }

    /// [`Lut::lookup`] for eight scalars: the table positions, indices
    /// and weights in `f32x8` vectors, each lane's two entries read and
    /// blended as one `f32x4` (the same operations, so the same bits).
    #[inline(always)]
    pub(crate) fn lookup_x8(&self, s: &[f32; 8]) -> [[f32; 4]; 8] {
        use wide::{f32x4, f32x8, i32x8};
        let last = self.rgba.len() - 1;
        // Within `0..=last` (at most 2^24) a compare-and-select clamp is
        // `f32::clamp`, and truncation through `i32` is through `u32`.
        let f = (f32x8::from(*s) * f32x8::splat(self.per_scalar))
            .max(f32x8::splat(0.0))
            .min(f32x8::splat(last as f32));
        let i = f.fast_trunc_int().min(i32x8::splat(last as i32 - 1));
        let t = (f - f32x8::from_i32x8(i)).to_array();
        let i = i.to_array();
        let mut out = [[0f32; 4]; 8];
        for l in 0..8 {
            let k = i[l] as usize;
            let (a, b) = (f32x4::from(self.rgba[k]), f32x4::from(self.rgba[k + 1]));
            out[l] = (a + f32x4::splat(t[l]) * (b - a)).to_array();
        }
        out
    }

    /// [`Lut::lookup`] in `f64`, for the reference renderer.
    #[inline]
    pub fn lookup_f64(&self, s: f64) -> [f64; 4] {
        let last = self.rgba.len() - 1;
        let f = (s * self.per_scalar as f64).clamp(0.0, last as f64);
        // Through `u32`, as `lookup`.
        let i = (f as u32).min(last as u32 - 1);
        let t = f - f64::from(i);
        let i = i as usize;
        let (a, b) = (self.rgba[i], self.rgba[i + 1]);
        std::array::from_fn(|k| a[k] as f64 + t * (b[k] as f64 - a[k] as f64))
    }

    /// The entries with non-zero opacity, for range queries of the
    /// empty-space map ([`crate::occupancy`]).
    pub fn visible_ranges(&self) -> crate::occupancy::VisibleEntries {
        crate::occupancy::VisibleEntries::new(self.rgba.iter().map(|e| e[3]), self.per_scalar)
    }

    /// A table position below which every lookup has zero opacity: with
    /// entries `0..k` transparent, a position under `k - 1` interpolates
    /// between two of them (`0 + t (0 - 0) = 0` exactly). Infinity when
    /// every entry is transparent; minus infinity when entry 0 or 1 is
    /// visible (a position under 0 clamps to entry 0 and reads entry 1).
    pub fn clear_below(&self) -> f32 {
        let k = self.rgba.iter().take_while(|e| e[3] == 0.0).count();
        clear_bound(k, self.rgba.len())
    }

    /// True when every entry has zero opacity (nothing can be seen).
    pub fn is_transparent(&self) -> bool {
        self.rgba.iter().all(|e| e[3] == 0.0)
    }
}

pub use crate::opacity::correct_opacity;

/// The position bound of a table of `n` entries (or bins) whose first `k`
/// are transparent: positions under `k - 1` read only those. Infinity when
/// all are; minus infinity when fewer than two are, since a position under
/// 0 clamps to entry 0 and interpolates towards entry 1.
pub(crate) fn clear_bound(k: usize, n: usize) -> f32 {
    match k {
        _ if k == n => f32::INFINITY,
        0 | 1 => f32::NEG_INFINITY,
        _ => (k - 1) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> TransferFunction {
        TransferFunction::new(vec![
            ControlPoint {
                value: 30.0,
                rgba: [0.0, 0.0, 0.0, 0.0],
            },
            ControlPoint {
                value: 150.0,
                rgba: [1.0, 1.0, 1.0, 1.0],
            },
        ])
        .unwrap()
    }

    #[test]
    fn evaluates_piecewise_linear_and_clamps() {
        let tf = ramp();
        assert_eq!(tf.eval(0.0)[3], 0.0);
        assert!((tf.eval(90.0)[3] - 0.5).abs() < 1e-12);
        assert_eq!(tf.eval(1000.0)[3], 1.0);
        let lut = tf.table(256, 255.0);
        assert!((lut.lookup(90.0)[3] - 0.5).abs() < 1e-6);
        assert!((lut.lookup(90.5)[3] - 60.5 / 120.0).abs() < 1e-6);
    }

    #[test]
    fn below_clear_below_every_lookup_is_transparent() {
        let lut = ramp().table(256, 255.0);
        let k = lut.rgba.iter().position(|e| e[3] != 0.0).unwrap();
        let clear = lut.clear_below();
        assert_eq!(clear, k as f32 - 1.0);
        // Every position up to the bound, in steps finer than an entry.
        let mut pos = 0.0f32;
        while pos < clear {
            assert_eq!(lut.lookup(pos / lut.per_scalar)[3], 0.0, "at {pos}");
            pos += 1.0 / 64.0;
        }
        // Just past entry `k - 1` the opacity rises from entry `k`'s.
        assert!(lut.lookup((clear + 0.5) / lut.per_scalar)[3] > 0.0);
        let clear_table = TransferFunction::new(vec![ControlPoint {
            value: 0.0,
            rgba: [1.0, 1.0, 1.0, 0.0],
        }])
        .unwrap()
        .table(16, 15.0);
        assert_eq!(clear_table.clear_below(), f32::INFINITY);
        // A table visible from entry 1 has no safe position.
        let mut early = lut.clone();
        early.rgba[1][3] = 0.25;
        assert_eq!(early.clear_below(), f32::NEG_INFINITY);
    }

    #[test]
    fn toml_round_trip_and_errors() {
        let tf = ramp();
        let back = TransferFunction::from_toml_str(&tf.to_toml_string()).unwrap();
        assert_eq!(tf, back);
        let bad = "[[point]]\nvalue = 3\nrgba = [0, 0, 2, 0]\n";
        let e = TransferFunction::from_toml_str(bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains("[0, 1]"), "{e}");
        let order =
            "[[point]]\nvalue = 3\nrgba = [0,0,0,0]\n[[point]]\nvalue = 1\nrgba = [0,0,0,0]\n";
        assert!(TransferFunction::from_toml_str(order).is_err());
        assert!(TransferFunction::from_toml_str("[[point]]\nvalu = 3\n").is_err());
        assert!(TransferFunction::from_toml_str("").is_err());
    }

    #[test]
    fn toml_errors_are_one_plain_line_and_rgba_takes_exactly_four() {
        let five = "[[point]]\nvalue = 3\nrgba = [0, 0, 0, 0, 1]\n";
        let e = TransferFunction::from_toml_str(five)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("invalid length 5") && e.contains("four values"),
            "{e}"
        );
        assert!(
            e.starts_with("transfer function: line 3 in [[point]]: "),
            "{e}"
        );
        let three = "[[point]]\nvalue = 3\nrgba = [0, 0, 0]\n";
        assert!(TransferFunction::from_toml_str(three).is_err());
        // An empty file: the message, not the library's caret drawing.
        let e = TransferFunction::from_toml_str("").unwrap_err().to_string();
        assert!(
            e.ends_with("missing field `point`") && !e.contains('\n'),
            "{e}"
        );
        let e = TransferFunction::from_toml_str("[[point]]\nvalue = 3\n").unwrap_err();
        let e = e.to_string();
        assert!(!e.contains('|') && !e.contains('^'), "{e}");
    }

    #[test]
    fn a_fit_table_keeps_8_bit_data_and_spans_wider_data() {
        let preset = crate::scenes::tf_preset("grey-ramp").unwrap();
        assert_eq!(preset.fit, Some([0.0, 255.0]));
        let u8_vol = Volume::new([2, 1, 1], VoxelType::U8, vec![3, 200]).unwrap();
        let same = preset.fitted(data_range(&u8_vol, false));
        assert_eq!(same.points, preset.points, "8-bit data keeps the table");
        assert_eq!(same.fit, None);
        // brainsmall's values times 200 plus 1000: 0..=255 onto 1000..=52000.
        let wide = Volume::new([2, 1, 1], VoxelType::U16, vec![1000, 52000]).unwrap();
        assert_eq!(data_range(&wide, false), [1000.0, 52000.0]);
        let t = preset.fitted(data_range(&wide, false));
        let values: Vec<f64> = t.points.iter().map(|p| p.value).collect();
        assert_eq!(values, [1000.0, 7000.0, 31000.0, 52000.0]);
        assert_eq!(t.points[2].rgba, preset.points[2].rgba);
        // A window is held as 0..=65535, so the table spans that.
        assert_eq!(data_range(&wide, true), [0.0, 65535.0]);
        // A raw table (no fit) is never moved.
        assert_eq!(ramp().fitted([1000.0, 52000.0]), ramp());
        // A file may declare its own scale.
        let unit = "fit = [0, 1]\n[[point]]\nvalue = 0.5\nrgba = [1, 1, 1, 1]\n";
        let f = TransferFunction::from_toml_str(unit).unwrap();
        assert_eq!(f.fitted([0.0, 255.0]).points[0].value, 127.5);
        for bad in ["fit = [1, 1]", "fit = [2, 1]", "fit = [0, nan]"] {
            let text = format!("{bad}\n[[point]]\nvalue = 0\nrgba = [0, 0, 0, 0]\n");
            let e = TransferFunction::from_toml_str(&text)
                .unwrap_err()
                .to_string();
            assert!(e.contains("lo < hi"), "{bad}: {e}");
        }
    }

    #[test]
    fn coverage_tells_none_some_and_all() {
        let vol = Volume::new([3, 1, 1], VoxelType::U16, vec![10, 100, 200]).unwrap();
        assert_eq!(ramp().coverage(&vol), Coverage::Some);
        let high = Volume::new([2, 1, 1], VoxelType::U16, vec![160, 5000]).unwrap();
        assert_eq!(ramp().coverage(&high), Coverage::All);
        let low = Volume::new([2, 1, 1], VoxelType::U8, vec![0, 30]).unwrap();
        assert_eq!(ramp().coverage(&low), Coverage::None);
    }

    proptest::proptest! {
        /// The walk over the values present, stopping early, tells what
        /// reading every voxel tells.
        #[test]
        fn coverage_is_the_whole_volumes(values in proptest::collection::vec(0u16..=300, 1..64)) {
            let tf = ramp();
            let vol = Volume::new([values.len(), 1, 1], VoxelType::U16, values.clone()).unwrap();
            let visible: Vec<bool> = values.iter().map(|&v| tf.eval(f64::from(v))[3] > 0.0).collect();
            let want = match (visible.iter().any(|&s| s), visible.iter().all(|&s| s)) {
                (false, _) => Coverage::None,
                (true, false) => Coverage::Some,
                (true, true) => Coverage::All,
            };
            proptest::prop_assert_eq!(tf.coverage(&vol), want);
        }
    }

    #[test]
    fn opacity_correction_matches_the_closed_form() {
        for &(a, ds) in &[(0.5f32, 1.0f32), (0.5, 2.0), (1e-4, 0.25), (0.99, 1.7)] {
            let want = 1.0 - (1.0 - a as f64).powf(ds as f64);
            assert!((correct_opacity(a, ds) as f64 - want).abs() < 1e-6 * want.max(1e-3));
        }
        assert_eq!(correct_opacity(0.0, 3.0), 0.0);
        assert_eq!(correct_opacity(1.0, 0.1), 1.0);
    }
}
