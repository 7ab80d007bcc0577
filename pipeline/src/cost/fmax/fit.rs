//! The delay model's fit: a least-squares fit of the relative error of
//! the period over the measured units of one family, each unit priced by
//! its slowest path under the model being fitted (which path is slowest
//! depends on the coefficients, so the fit iterates until the choice
//! settles).

use super::{module_paths, DelayModel, Path, Role, MEASURED};
use crate::cost::Target;

/// The fit's features: a constant and the six counts of a [`Path`].
pub const FEATURES: usize = 7;

/// The slowest of `paths` under `model` (the empty path when none).
pub(super) fn slowest(model: &DelayModel, paths: &[Path]) -> Path {
    paths.iter().copied().fold(Path::default(), |a, b| {
        if model.period_ns(&b) > model.period_ns(&a) {
            b
        } else {
            a
        }
    })
}

/// Features the family's place and route does not time, held at 0: on
/// iCE40 the multiplier blocks (columns 4 and 5), which nextpnr-ice40 0.4
/// gives a nominal 0.10 ns clock-to-out and no arcs through (its reports'
/// paths show it); fitted freely they take a fraction of a nanosecond from
/// the slope square's fabric sums, which is the wrapper's hop's spread.
fn untimed(t: Target, feature: usize) -> bool {
    t == Target::Ice40 && (feature == 4 || feature == 5)
}

/// Solves the weighted least-squares problem `rows . x = y` (each row
/// weighted by `1 / y`, so the relative error is minimised) over the
/// columns in `keep` (the others 0), by the normal equations; a column
/// without data stays 0.
pub fn least_squares(
    rows: &[[f64; FEATURES]],
    y: &[f64],
    keep: &[bool; FEATURES],
) -> [f64; FEATURES] {
    let idx: Vec<usize> = (0..FEATURES).filter(|&i| keep[i]).collect();
    let n = idx.len();
    let mut a = vec![vec![0.0; n + 1]; n];
    for (r, &yv) in rows.iter().zip(y) {
        let w = 1.0 / (yv * yv);
        for (i, &ci) in idx.iter().enumerate() {
            for (j, &cj) in idx.iter().enumerate() {
                a[i][j] += w * r[ci] * r[cj];
            }
            a[i][n] += w * r[ci] * yv;
        }
    }
    // Gaussian elimination with partial pivoting.
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap_or(c);
        a.swap(c, p);
        if a[c][c].abs() < 1e-12 {
            continue;
        }
        let pivot = a[c].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != c {
                let f = row[c] / pivot[c];
                for (x, p) in row.iter_mut().zip(&pivot).skip(c) {
                    *x -= f * p;
                }
            }
        }
    }
    let mut x = [0.0; FEATURES];
    for (i, &ci) in idx.iter().enumerate() {
        if a[i][i].abs() >= 1e-12 {
            x[ci] = a[i][n] / a[i][i];
        }
    }
    x
}

/// Fits rows of candidate paths (each unit's [`module_paths`]) to periods
/// `y`, ns: from a start model, price each unit by its slowest path, fit
/// the coefficients to those paths (a coefficient fitting negative is
/// dropped and the rest refitted), and repeat until no unit's slowest path
/// changes (at most 50 rounds).
pub fn fit_rows(t: Target, candidates: &[Vec<Path>], y: &[f64]) -> Option<DelayModel> {
    if candidates.is_empty() {
        return None;
    }
    // A start of the right order everywhere: the fastest unit's period as
    // the base, a fraction of a nanosecond a carry bit, a few a LUT level
    // or a block.
    let floor = y.iter().copied().fold(f64::INFINITY, f64::min);
    let mut model = DelayModel::from_coefficients(t, [floor * 0.5, 0.1, 1.0, 1.0, 3.0, 1.0, 3.0]);
    let mut chosen: Vec<Path> = Vec::new();
    for _ in 0..50 {
        let now: Vec<Path> = candidates.iter().map(|c| slowest(&model, c)).collect();
        if now == chosen {
            break;
        }
        chosen = now;
        let rows: Vec<[f64; FEATURES]> = chosen.iter().map(Path::features).collect();
        let mut keep = [true; FEATURES];
        // A feature no unit's path has cannot be fitted.
        for (k, slot) in keep.iter_mut().enumerate() {
            *slot = rows.iter().any(|r| r[k] != 0.0) && !untimed(t, k);
        }
        let mut x = least_squares(&rows, y, &keep);
        while let Some(k) = (1..FEATURES).find(|&k| keep[k] && x[k] < 0.0) {
            keep[k] = false;
            x = least_squares(&rows, y, &keep);
        }
        model = DelayModel::from_coefficients(t, x);
    }
    Some(model)
}

/// The model of `t` fitted to the measurements of `role`'s settings.
pub(super) fn fit(t: Target, role: Role) -> Option<DelayModel> {
    let mut candidates = Vec::new();
    let mut y = Vec::new();
    for m in MEASURED
        .iter()
        .filter(|m| m.target == t && m.setting.role() == role)
    {
        candidates.push(module_paths(t, &m.units()?));
        y.push(1e3 / m.mhz);
    }
    fit_rows(t, &candidates, &y)
}
