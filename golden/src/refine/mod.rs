//! Adaptive and progressive refinement (Levoy, "Volume Rendering by
//! Adaptive Refinement", The Visual Computer 1990, cited by both seeds:
//! 001 ("Design for a Real-Time High-Quality Volume Rendering
//! Workstation") for its sparse grid of rays refined where the image is
//! complex, and 000 ("Gaze-Directed Volume Rendering", Levoy and
//! Whitaker) for combining image complexity with retinal acuity and for
//! progressive refinement while the viewer rests).
//!
//! **Rays.** Every ray is a full-resolution pixel ray: the one through the
//! centre of pixel `(i, j)`, as one ray per pixel casts it. A ray is cast
//! at most once; the cast values are kept per pixel with a flag (the
//! paper's boolean flag array).
//!
//! **Cells.** The image's pixel centres are covered by a quadtree of
//! cells whose corners are pixels. A level-`l` cell spans `2^l` pixels
//! on each side (less at the right and bottom edges, which are clamped to
//! the last pixel): corners `(x0, y0)` to `(x1, y1)`. The frame starts
//! with the level-`L` cells, one ray per `2^L x 2^L` pixels, and
//! subdivides a cell into its (up to) four children while
//!
//! - the **complexity** across its four corners, the largest range of
//!   any channel (premultiplied red, green, blue and opacity) over them,
//!   exceeds the threshold, and
//! - with a gaze profile ([`crate::gaze::Gaze`]), the profile allows a
//!   finer level there: the profile's level at the cell's point nearest
//!   the gaze point is below the cell's. This is seed 000's closing
//!   combination: the periphery stays coarse however complex, and near
//!   the gaze only complex cells are refined.
//!
//! A split casts only the rays at the children's corners not yet cast.
//!
//! **Pixels.** Each pixel belongs to one leaf (the half-open box
//! `[x0, x1) x [y0, y1)`, closed at the image's last column and row) and
//! takes the bilinear interpolation of that leaf's four corner rays; a
//! pixel whose own ray was cast takes it exactly. A leaf of level 0 has
//! every pixel's ray cast, so a frame refined to level 0 everywhere is
//! the one-ray-per-pixel frame bit for bit.
//!
//! The corner test misses detail that lies strictly inside a cell and
//! touches none of its corners (a thin feature between rays `2^L` pixels
//! apart): the threshold bounds the error only where the image varies
//! smoothly at the coarse grid's spacing.
//!
//! **Progressive refinement** ([`Refiner::step`]) keeps the leaves and the
//! cast rays between frames of a resting view: each step splits the leaves
//! of highest priority (their complexity, plus 1/256 so flat cells are
//! ordered too, times the profile's acuity `2^-level` with a gaze) until
//! the step's budget of new rays is reached, and the last step splits
//! every leaf down to level 0. With a gaze, cells near the gaze point go
//! first, so the sweet spot grows until it covers the image.
//! [`frame`] runs it for the reference and the mip-map caster.
//! docs/golden.md#adaptive-and-progressive-refinement.

pub mod frame;

use rayon::prelude::*;

use crate::error::{input, Result};
use crate::gaze::Gaze;
use crate::image::Image;

/// Coarsest level allowed (one ray per `2^6 x 2^6` pixels), the gaze
/// profile's.
pub const MAX_LEVEL: u32 = crate::gaze::MAX_LEVEL;

/// An adaptive refinement: the complexity threshold and the coarsest level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refine {
    /// A cell splits while a channel's range over its corners exceeds
    /// this (in `[0, 1]` units of premultiplied colour and opacity).
    pub threshold: f64,
    /// Coarsest level `L`: the first grid has one ray per `2^L x 2^L`
    /// pixels.
    pub levels: u32,
}

impl Refine {
    /// The threshold `complexity` alone means: on brainsmall 256x256 it
    /// keeps the RMSE against one ray per pixel below 0.005
    /// (docs/golden.md#adaptive-and-progressive-refinement).
    pub const DEFAULT_THRESHOLD: f64 = 0.02;
    /// The default coarsest level: one ray per 8 x 8 pixels.
    pub const DEFAULT_LEVELS: u32 = 3;

    /// Parses `complexity` or `complexity:THRESHOLD`, with `levels`.
    pub fn parse(spec: &str, levels: u32) -> Result<Refine> {
        let threshold = match spec.split_once(':') {
            None if spec == "complexity" => Refine::DEFAULT_THRESHOLD,
            Some(("complexity", t)) => t.trim().parse::<f64>().map_err(|_| {
                input(format!(
                    "refine threshold '{t}' is not a number (use complexity:0.02)"
                ))
            })?,
            _ => {
                return Err(input(format!(
                    "unknown refinement '{spec}': use complexity or complexity:THRESHOLD"
                )))
            }
        };
        let r = Refine { threshold, levels };
        r.validate()?;
        Ok(r)
    }

    /// Refuses a threshold outside `[0, 1]` (or not finite) and a level
    /// count outside `1..=MAX_LEVEL`.
    pub fn validate(&self) -> Result<()> {
        if !(self.threshold.is_finite() && (0.0..=1.0).contains(&self.threshold)) {
            return Err(input(format!(
                "refine threshold {} must be a number from 0 to 1",
                self.threshold
            )));
        }
        if !(1..=MAX_LEVEL).contains(&self.levels) {
            return Err(input(format!(
                "refine levels {} must be 1 to {MAX_LEVEL}",
                self.levels
            )));
        }
        Ok(())
    }
}

/// What a refined frame cast.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct RefineStats {
    /// Rays cast per level, finest first: the first grid's at `L`, a
    /// split of a level-`l` cell's at `l - 1`.
    pub rays_per_level: Vec<u64>,
    /// Leaves per level, finest first.
    pub leaves_per_level: Vec<u64>,
    /// Rays in all.
    pub rays: u64,
    /// Pixels (the rays of one ray per pixel).
    pub pixels: u64,
}

impl RefineStats {
    /// The same counts as a gaze-directed frame's (rays per level, rays,
    /// pixels), for [`crate::render::Frame`].
    pub fn as_gaze(&self) -> crate::gaze::GazeStats {
        crate::gaze::GazeStats {
            rays_per_level: self.rays_per_level.clone(),
            rays: self.rays,
            pixels: self.pixels,
        }
    }
}

/// One quadtree cell: corner pixels `(x0, y0)`, `(x1, y1)`, level `l`
/// (nominal side `2^l`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Cell {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    level: u32,
}

/// Cell starts along an axis of `n` pixels at spacing `s`, with their
/// ends (clamped to the last pixel).
fn spans(n: u32, s: u32) -> Vec<(u32, u32)> {
    if n == 1 {
        return vec![(0, 0)];
    }
    (0..n - 1)
        .step_by(s as usize)
        .map(|a| (a, (a + s).min(n - 1)))
        .collect()
}

/// The halves of `[a, b]` at nominal side `s` (`s >= 2`): one when the
/// midpoint is at or past `b`.
fn halves(a: u32, b: u32, s: u32) -> Vec<(u32, u32)> {
    let m = a + s / 2;
    if m >= b {
        vec![(a, b)]
    } else {
        vec![(a, m), (m, b)]
    }
}

impl Cell {
    fn children(&self) -> Vec<Cell> {
        let s = 1u32 << self.level;
        let mut out = Vec::with_capacity(4);
        for (y0, y1) in halves(self.y0, self.y1, s) {
            for (x0, x1) in halves(self.x0, self.x1, s) {
                out.push(Cell {
                    x0,
                    y0,
                    x1,
                    y1,
                    level: self.level - 1,
                });
            }
        }
        out
    }

    fn corners(&self, w: usize) -> [usize; 4] {
        let (x0, y0, x1, y1) = (
            self.x0 as usize,
            self.y0 as usize,
            self.x1 as usize,
            self.y1 as usize,
        );
        [y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1]
    }

    /// The point of the cell's pixel centres nearest `at`.
    fn nearest(&self, at: [f64; 2]) -> (f64, f64) {
        let c = |v: f64, a: u32, b: u32| v.clamp(f64::from(a) + 0.5, f64::from(b) + 0.5);
        (c(at[0], self.x0, self.x1), c(at[1], self.y0, self.y1))
    }
}

/// The frame's rays, cells and counts; [`Refiner::refine`] makes the
/// adaptive frame, [`Refiner::step`] refines it further.
pub struct Refiner {
    w: usize,
    h: usize,
    refine: Refine,
    gaze: Option<Gaze>,
    rays: Vec<[f64; 4]>,
    cast: Vec<bool>,
    leaves: Vec<Cell>,
    rays_per_level: Vec<u64>,
}

/// Rays cast per parallel task.
const CHUNK: usize = 256;

impl Refiner {
    /// An empty frame of `size` pixels; nothing is cast yet.
    pub fn new(size: [u32; 2], refine: Refine, gaze: Option<Gaze>) -> Result<Refiner> {
        refine.validate()?;
        if let Some(g) = &gaze {
            g.validate()?;
        }
        let (w, h) = (size[0] as usize, size[1] as usize);
        if w == 0 || h == 0 {
            return Err(input("a refined frame needs at least one pixel"));
        }
        Ok(Refiner {
            w,
            h,
            refine,
            gaze,
            rays: vec![[0.0; 4]; w * h],
            cast: vec![false; w * h],
            leaves: Vec::new(),
            rays_per_level: vec![0; refine.levels as usize + 1],
        })
    }

    /// Rays cast so far.
    pub fn rays(&self) -> u64 {
        self.rays_per_level.iter().sum()
    }

    /// Pixels of the frame.
    pub fn pixels(&self) -> u64 {
        (self.w * self.h) as u64
    }

    /// Whether every pixel's ray has been cast.
    pub fn complete(&self) -> bool {
        self.rays() == self.pixels()
    }

    /// The counts so far.
    pub fn stats(&self) -> RefineStats {
        let mut leaves = vec![0; self.rays_per_level.len()];
        for c in &self.leaves {
            leaves[c.level as usize] += 1;
        }
        RefineStats {
            rays_per_level: self.rays_per_level.clone(),
            leaves_per_level: leaves,
            rays: self.rays(),
            pixels: self.pixels(),
        }
    }

    /// Casts the rays of `cells`' corners not yet cast, counting them at
    /// `level`; `cast(x, y, counts)` casts the ray through pixel position
    /// `(x, y)`. Per-task counts start from `init()` and are added with
    /// `add` in task order, so they are the same for any thread count.
    fn cast_corners<S: Send>(
        &mut self,
        cells: &[Cell],
        level: u32,
        init: &(impl Fn() -> S + Sync),
        add: &impl Fn(&mut S, &S),
        counts: &mut S,
        cast: &(impl Fn(f64, f64, &mut S) -> [f64; 4] + Sync),
    ) {
        let mut todo: Vec<usize> = cells
            .iter()
            .flat_map(|c| c.corners(self.w))
            .filter(|&p| !self.cast[p])
            .collect();
        todo.sort_unstable();
        todo.dedup();
        let w = self.w;
        let done: Vec<(Vec<[f64; 4]>, S)> = todo
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut st = init();
                let v = chunk
                    .iter()
                    .map(|&p| cast((p % w) as f64 + 0.5, (p / w) as f64 + 0.5, &mut st))
                    .collect();
                (v, st)
            })
            .collect();
        for (chunk, (vals, st)) in todo.chunks(CHUNK).zip(&done) {
            for (&p, v) in chunk.iter().zip(vals) {
                self.rays[p] = *v;
                self.cast[p] = true;
            }
            add(counts, st);
        }
        self.rays_per_level[level as usize] += todo.len() as u64;
    }

    /// The largest range of any channel over the cell's corners.
    fn complexity(&self, c: &Cell) -> f64 {
        let k = c.corners(self.w).map(|p| self.rays[p]);
        (0..4)
            .map(|ch| {
                let (lo, hi) = k
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                        (lo.min(r[ch]), hi.max(r[ch]))
                    });
                hi - lo
            })
            .fold(0.0, f64::max)
    }

    /// The gaze profile's level at the cell's point nearest the gaze
    /// point (0 without a gaze).
    fn gaze_level(&self, c: &Cell) -> f64 {
        self.gaze.as_ref().map_or(0.0, |g| {
            let (x, y) = c.nearest(g.at);
            g.level(x, y)
        })
    }

    /// Whether the adaptive frame splits `c`.
    fn splits(&self, c: &Cell) -> bool {
        c.level > 0
            && self.complexity(c) > self.refine.threshold
            && self.gaze_level(c) < f64::from(c.level)
    }

    /// The adaptive frame: the level-`L` grid, then, level by level, the
    /// splits the complexity (and gaze) criterion asks for.
    /// `cast(x, y, counts)` casts the ray through pixel position `(x, y)`;
    /// per-task counts start from `init()` and are added to `counts` with
    /// `add` in task order, the same for any thread count.
    pub fn refine<S: Send>(
        &mut self,
        init: impl Fn() -> S + Sync,
        add: impl Fn(&mut S, &S),
        counts: &mut S,
        cast: impl Fn(f64, f64, &mut S) -> [f64; 4] + Sync,
    ) {
        let top = self.refine.levels;
        let s = 1u32 << top;
        let mut front: Vec<Cell> = Vec::new();
        for &(y0, y1) in &spans(self.h as u32, s) {
            for &(x0, x1) in &spans(self.w as u32, s) {
                front.push(Cell {
                    x0,
                    y0,
                    x1,
                    y1,
                    level: top,
                });
            }
        }
        self.leaves.clear();
        self.cast_corners(&front, top, &init, &add, counts, &cast);
        while !front.is_empty() {
            let (split, keep): (Vec<Cell>, Vec<Cell>) =
                front.into_iter().partition(|c| self.splits(c));
            self.leaves.extend(keep);
            front = split.iter().flat_map(Cell::children).collect();
            if let Some(c) = front.first() {
                let l = c.level;
                self.cast_corners(&front, l, &init, &add, counts, &cast);
            }
        }
        self.sort_leaves();
    }

    /// Leaves in raster order of their first corner (the order the image
    /// and the priorities visit them).
    fn sort_leaves(&mut self) {
        self.leaves.sort_unstable_by_key(|c| (c.y0, c.x0));
    }

    /// A leaf's priority for the next progressive split.
    fn priority(&self, c: &Cell) -> f64 {
        let acuity = (-self.gaze_level(c)).exp2();
        (self.complexity(c) + 1.0 / 256.0) * acuity
    }

    /// One progressive step: splits the leaves of highest priority (ties:
    /// coarser first, then raster order) until at least `budget` new rays
    /// are due, and casts them; a round splits each chosen leaf one level,
    /// and rounds repeat until the budget is met. With `budget` at or
    /// above the rays still uncast, splits every leaf down to level 0.
    /// Call after [`Refiner::refine`]. Returns the rays it cast.
    pub fn step<S: Send>(
        &mut self,
        budget: u64,
        init: impl Fn() -> S + Sync,
        add: impl Fn(&mut S, &S),
        counts: &mut S,
        cast: impl Fn(f64, f64, &mut S) -> [f64; 4] + Sync,
    ) -> u64 {
        let before = self.rays();
        let all = budget >= self.pixels() - before;
        while self.rays() - before < budget && self.leaves.iter().any(|c| c.level > 0) {
            let chosen = if all {
                self.leaves.iter().map(|c| c.level > 0).collect()
            } else {
                self.choose(budget - (self.rays() - before))
            };
            let mut next = Vec::with_capacity(self.leaves.len());
            let mut children = Vec::new();
            for (c, &ch) in self.leaves.iter().zip(&chosen) {
                if ch {
                    children.extend(c.children());
                } else {
                    next.push(*c);
                }
            }
            // Children of different levels: each counted at its own.
            let mut levels: Vec<u32> = children.iter().map(|c| c.level).collect();
            levels.sort_unstable();
            levels.dedup();
            for l in levels.into_iter().rev() {
                let at: Vec<Cell> = children.iter().filter(|c| c.level == l).copied().collect();
                self.cast_corners(&at, l, &init, &add, counts, &cast);
            }
            next.extend(children);
            self.leaves = next;
            self.sort_leaves();
        }
        self.rays() - before
    }

    /// The leaves one round splits: in priority order until at least
    /// `budget` new rays are due.
    fn choose(&self, budget: u64) -> Vec<bool> {
        let mut order: Vec<(f64, usize)> = self
            .leaves
            .iter()
            .enumerate()
            .filter(|(_, c)| c.level > 0)
            .map(|(i, c)| (self.priority(c), i))
            .collect();
        order.sort_by(|a, b| {
            let (ca, cb) = (&self.leaves[a.1], &self.leaves[b.1]);
            b.0.total_cmp(&a.0)
                .then(cb.level.cmp(&ca.level))
                .then(a.1.cmp(&b.1))
        });
        let mut pending = vec![false; self.w * self.h];
        let mut due = 0u64;
        let mut chosen = vec![false; self.leaves.len()];
        for &(_, i) in &order {
            if due >= budget {
                break;
            }
            chosen[i] = true;
            for ch in self.leaves[i].children() {
                for p in ch.corners(self.w) {
                    if !self.cast[p] && !pending[p] {
                        pending[p] = true;
                        due += 1;
                    }
                }
            }
        }
        chosen
    }

    /// The image: each pixel its leaf's bilinear interpolation, or its own
    /// ray where that was cast; and each pixel's leaf level.
    pub fn image(&self) -> (Image, Vec<u8>) {
        let (w, h) = (self.w, self.h);
        let mut img = Image::new(w, h);
        let mut level = vec![0u8; w * h];
        for c in &self.leaves {
            let k = c.corners(w).map(|p| self.rays[p]);
            let (x0, y0, x1, y1) = (c.x0 as usize, c.y0 as usize, c.x1 as usize, c.y1 as usize);
            let xe = if x1 == w - 1 { x1 + 1 } else { x1.max(x0 + 1) };
            let ye = if y1 == h - 1 { y1 + 1 } else { y1.max(y0 + 1) };
            let span = |a: usize, b: usize, v: usize| {
                if b > a {
                    (v - a) as f64 / (b - a) as f64
                } else {
                    0.0
                }
            };
            for y in y0..ye {
                let ty = span(y0, y1, y);
                for x in x0..xe {
                    let p = y * w + x;
                    level[p] = c.level as u8;
                    img.data[p] = if self.cast[p] {
                        self.rays[p].map(|v| v as f32)
                    } else {
                        let tx = span(x0, x1, x);
                        std::array::from_fn(|ch| {
                            let top = k[0][ch] + tx * (k[1][ch] - k[0][ch]);
                            let bot = k[2][ch] + tx * (k[3][ch] - k[2][ch]);
                            (top + ty * (bot - top)) as f32
                        })
                    };
                }
            }
        }
        (img, level)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(size: [u32; 2], r: Refine, f: impl Fn(f64, f64) -> [f64; 4] + Sync) -> Refiner {
        let mut rf = Refiner::new(size, r, None).unwrap();
        rf.refine(|| (), |_, _| {}, &mut (), |x, y, _| f(x, y));
        rf
    }

    /// Every pixel lies in exactly one leaf, and the leaves' corners were
    /// cast, for image sizes that are and are not multiples of `2^L`.
    #[test]
    fn leaves_tile_the_image() {
        for size in [[1, 1], [1, 7], [9, 1], [16, 16], [17, 30], [33, 8]] {
            let r = Refine {
                threshold: 0.0,
                levels: 3,
            };
            let rf = run(size, r, |x, _| [x.sin().abs(), 0.0, 0.0, 0.5]);
            let (w, h) = (size[0] as usize, size[1] as usize);
            let mut owner = vec![0u32; w * h];
            for c in &rf.leaves {
                let xe = if c.x1 as usize == w - 1 {
                    c.x1 + 1
                } else {
                    c.x1.max(c.x0 + 1)
                };
                let ye = if c.y1 as usize == h - 1 {
                    c.y1 + 1
                } else {
                    c.y1.max(c.y0 + 1)
                };
                for y in c.y0..ye {
                    for x in c.x0..xe {
                        owner[y as usize * w + x as usize] += 1;
                    }
                }
                for p in c.corners(w) {
                    assert!(rf.cast[p], "{size:?}: corner {p} of {c:?} not cast");
                }
            }
            assert!(owner.iter().all(|&n| n == 1), "{size:?}: {owner:?}");
        }
    }

    /// Bad thresholds and level counts are refused; the spellings parse.
    #[test]
    fn parse_and_validate() {
        assert_eq!(
            Refine::parse("complexity", 3).unwrap().threshold,
            Refine::DEFAULT_THRESHOLD
        );
        assert_eq!(Refine::parse("complexity:0.1", 2).unwrap().threshold, 0.1);
        for (spec, l) in [
            ("complexity:-0.1", 3),
            ("complexity:nan", 3),
            ("complexity:2", 3),
            ("complexity:x", 3),
            ("gaze", 3),
            ("complexity", 0),
            ("complexity", MAX_LEVEL + 1),
        ] {
            let e = Refine::parse(spec, l).unwrap_err().to_string();
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
