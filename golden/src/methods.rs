//! The slice-order methods: ER-Perspective back-to-front (`er`) and
//! front-to-back (`er-ftb`), the box-merge variant (`box`), and the
//! under- and oversampling baselines. All walk the slices along the
//! principal axis and produce a [`Baseplane`], which [`crate::warp`] turns
//! into the final image.

use std::str::FromStr;

use crate::error::{input, Result};
use crate::geometry::{Layout, Merge, View};
use crate::merge::{merge, split, Rgba};
use crate::sampling::{sample_slice, Order, MAX_SUBSTEPS};
use crate::slices::SliceStack;
use crate::tf::Lut;
use crate::warp::Baseplane;

/// A slice-order rendering method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// ER-Perspective back-to-front with the Bartlett merge.
    Er,
    /// ER-Perspective front-to-back with the bilinear split.
    ErFtb,
    /// One ray per voxel at the front, diverging behind.
    Under,
    /// One ray per voxel at the rear, converging in front.
    Over,
    /// ER with a 2x2 box merge instead of Bartlett (Novins-style).
    Box,
}

impl Method {
    /// Every slice-order method, in the order tables list them.
    pub const ALL: [Method; 5] = [
        Method::Er,
        Method::ErFtb,
        Method::Under,
        Method::Over,
        Method::Box,
    ];

    /// The method's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Er => "er",
            Method::ErFtb => "er-ftb",
            Method::Under => "under",
            Method::Over => "over",
            Method::Box => "box",
        }
    }

    /// The rays this method casts for `view`.
    pub fn layout(self, view: &View) -> Result<Layout> {
        match self {
            Method::Er | Method::ErFtb => Layout::exponential(view, Merge::Bartlett),
            Method::Box => Layout::exponential(view, Merge::Box),
            Method::Under => Layout::single(view, 0.0),
            Method::Over => Layout::single(view, (view.dims[2] as f64 - 1.0).max(0.0)),
        }
    }
}

impl FromStr for Method {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Method> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                input(format!(
                    "unknown method '{s}': use er, er-ftb, under, over or box"
                ))
            })
    }
}

/// Options of the slice-order methods.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Early ray termination threshold for `er-ftb` (1.0 disables it).
    pub terminate: f32,
    /// Samples per slice crossing (see [`crate::sampling`]); 1 is the
    /// paper's scheme.
    pub substeps: u32,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            terminate: 0.99,
            substeps: DEFAULT_SUBSTEPS,
        }
    }
}

/// Default samples per slice crossing: one, the paper's scheme and the
/// chip's. Two substeps trade twice the samples for much less error on
/// hard-edged data (see [`crate::sampling`] and the README).
pub const DEFAULT_SUBSTEPS: u32 = 1;

impl Options {
    /// Refuses options no method can run with.
    pub fn validate(&self) -> Result<()> {
        if !(self.terminate.is_finite() && self.terminate > 0.0 && self.terminate <= 1.0) {
            return Err(input(format!(
                "termination threshold {} must lie in (0, 1]",
                self.terminate
            )));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(input(format!(
                "substeps {} must be 1 to {MAX_SUBSTEPS}",
                self.substeps
            )));
        }
        Ok(())
    }
}

/// What a slice-order render counted.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct Stats {
    /// Region boundaries `b_0..b_K` in slices.
    pub regions: Vec<f64>,
    /// Samples taken in all.
    pub samples_total: u64,
    /// Samples per slice along the principal axis, front (slice 0) to back.
    pub samples_per_slice: Vec<u64>,
    /// Rays per region, front (region 0) to back.
    pub rays_per_region: Vec<u64>,
    /// Region boundaries at which rays were merged (or split).
    pub merges: u64,
    /// Samples per slice crossing.
    pub substeps: u32,
}

/// A slice-order render before the warp.
#[derive(Debug, Clone)]
pub struct Output {
    /// Region 0's rays at slice 0.
    pub baseplane: Baseplane,
    /// Counts.
    pub stats: Stats,
}

/// Renders `view` of `stack` with `method`.
pub fn render(
    method: Method,
    view: &View,
    stack: &SliceStack,
    lut: &Lut,
    opts: &Options,
) -> Result<Output> {
    opts.validate()?;
    let layout = method.layout(view)?;
    let mut stats = Stats {
        substeps: opts.substeps,
        regions: layout.bounds.clone(),
        samples_per_slice: vec![0; view.dims[2]],
        rays_per_region: layout.grids.iter().map(|g| g.len() as u64).collect(),
        ..Stats::default()
    };
    let base = match method {
        Method::ErFtb => front_to_back(&layout, view, stack, lut, opts, &mut stats),
        _ => back_to_front(&layout, view, stack, lut, opts.substeps, &mut stats),
    };
    stats.samples_total = stats.samples_per_slice.iter().sum();
    Ok(Output {
        baseplane: Baseplane {
            grid: layout.baseplane(),
            data: base,
        },
        stats,
    })
}

/// Back-to-front: each region's rays composite its slices from the rear,
/// then merge into the next region's rays.
fn back_to_front(
    layout: &Layout,
    view: &View,
    stack: &SliceStack,
    lut: &Lut,
    substeps: u32,
    stats: &mut Stats,
) -> Vec<Rgba> {
    let k = layout.grids.len();
    let mut buf = vec![[0f32; 4]; layout.grids[k - 1].len()];
    for i in (0..k).rev() {
        let grid = &layout.grids[i];
        for z in grid.slices.clone().rev() {
            stats.samples_per_slice[z] += sample_slice(
                view,
                stack,
                lut,
                grid,
                &mut buf,
                z,
                Order::BackToFront,
                substeps,
            );
        }
        if i > 0 {
            let kind = layout.merge.expect("multi-region layouts merge");
            buf = merge(kind, &buf, grid, &layout.grids[i - 1]);
            stats.merges += 1;
        }
    }
    buf
}

/// Front-to-back: each region's rays composite its slices from the front,
/// then split into the next region's rays. Folding back into one image:
/// every ray's result is its own final state plus the Bartlett merge of
/// what its children added behind it (child result minus what the child
/// inherited at the split). A ray whose children sample nothing keeps its
/// state exactly, and with zero opacity in front the fold is the
/// back-to-front merge cascade.
fn front_to_back(
    layout: &Layout,
    view: &View,
    stack: &SliceStack,
    lut: &Lut,
    opts: &Options,
    stats: &mut Stats,
) -> Vec<Rgba> {
    let order = Order::FrontToBack {
        terminate: opts.terminate,
    };
    let k = layout.grids.len();
    let mut finals: Vec<Vec<Rgba>> = Vec::with_capacity(k);
    let mut inherited: Vec<Vec<Rgba>> = Vec::with_capacity(k);
    let mut buf = vec![[0f32; 4]; layout.grids[0].len()];
    for i in 0..k {
        let grid = &layout.grids[i];
        if i > 0 {
            buf = split(&buf, &layout.grids[i - 1], grid);
            stats.merges += 1;
            inherited.push(buf.clone());
        } else {
            inherited.push(vec![[0f32; 4]; grid.len()]);
        }
        for z in grid.slices.clone() {
            stats.samples_per_slice[z] +=
                sample_slice(view, stack, lut, grid, &mut buf, z, order, opts.substeps);
        }
        finals.push(buf.clone());
    }
    let kind = layout.merge.expect("ER layouts merge");
    let mut result = finals.pop().expect("at least one region");
    for i in (1..k).rev() {
        let added: Vec<Rgba> = result
            .iter()
            .zip(&inherited[i])
            .map(|(r, h)| std::array::from_fn(|c| r[c] - h[c]))
            .collect();
        let folded = merge(kind, &added, &layout.grids[i], &layout.grids[i - 1]);
        result = finals.pop().expect("one final state per region");
        for (r, f) in result.iter_mut().zip(folded) {
            for c in 0..4 {
                r[c] += f[c];
            }
        }
    }
    result
}
