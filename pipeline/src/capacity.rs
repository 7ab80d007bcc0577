//! How much a PE's ray memories must hold for a frame: the most ray
//! columns (the column map's slots), rows per column, a pass's children
//! (the line buffer's row) and, front to back, kept final rays, derived
//! from the frame's ray grids and the ownership rule before it runs.
//!
//! **Why the frame, not only the volume.** A region's rays are the rays
//! that sample the volume somewhere in it (or carry state from the region
//! behind), half a voxel to a voxel apart; at any one plane a PE's own
//! columns hold at most `2 W + 1` of them, but the rays beyond the
//! volume's sides at that plane (not sampled there, owned by the PE of
//! their clamped base column) all sit in the end PEs, and how many there
//! are grows with the eye's offset from the volume: at brainsmall's
//! rear slices (16 PEs, eye (64, 64, -64)) about 51 columns in each end
//! PE. Spreading them over the PEs would break the ownership order the
//! line's migration and the passes' one-link neighbours rely on (columns
//! held in ascending ray index, owners growing with it), and not storing
//! them would lose state: front to back (and back to front from an eye
//! beside the volume) a ray beyond a side has already composited what it
//! met. So the chip's ray memories are sized for the views it is built
//! for: [`need`] gives a view's depths, the cost model charges them
//! ([`crate::cost::inventory::Geometry::for_view`]), and a frame whose
//! need passes a chip's declared depths is refused before it runs
//! ([`check`]).
//!
//! **How it is counted.** For every region, at every plane its rays are
//! owned on (each slice, both boundary planes, a pre-integrated pass's
//! end plane), each ray counts for the PEs owning its base column under
//! the sampling mapping and under column blocks, its position widened by
//! the fixed-point positions' error (so a ray on a column edge counts on
//! both sides); the most any PE gets, plus the columns a migration keeps
//! in flight ([`IN_FLIGHT`]), bounds its columns. A merge's (split's)
//! children are counted from the span of parents each PE holds on the
//! boundary plane, a fold's back rays from the PE holding their split
//! parent, and the kept finals are every split's parents, stacked.
//! `pipeline/tests/it/occupancy.rs` checks, on clocked frames over scenes,
//! eyes beside and outside the volume, wide views, 1 to 16 PEs, both
//! orders and the architectures, that no PE ever holds more.
//!
//! Golden has no twin: this is the ownership of
//! [`golden::sampling::slice_rays`]' rays, not what they compute.

use golden::geometry::{Layout, RayGrid, View};
use golden::methods::Method;

use crate::config::{Order, PipelineConfig};
use crate::mapping::ColumnMap;

/// Columns a migration may keep in a PE beyond those it owns on either
/// plane: a column passing through (its first row arrived, its last not
/// yet sent on) per link side and lane.
pub const IN_FLIGHT: u64 = 2;

/// What one PE's ray memories must hold for a frame (the most over its
/// PEs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct RayDepths {
    /// Ray columns at once: the column map's slots.
    pub columns: u64,
    /// Rows of a column (of the tallest region's grid).
    pub rows: u64,
    /// Children of one pass on one PE: the line buffer's row width.
    pub children: u64,
    /// Front to back: the final rays kept for the fold (0 back to front).
    pub kept: u64,
}

impl RayDepths {
    /// The larger of each field.
    pub fn max(self, o: RayDepths) -> RayDepths {
        RayDepths {
            columns: self.columns.max(o.columns),
            rows: self.rows.max(o.rows),
            children: self.children.max(o.children),
            kept: self.kept.max(o.kept),
        }
    }

    /// Whether every field is at or under `declared`'s.
    pub fn fits(&self, declared: &RayDepths) -> bool {
        self.columns <= declared.columns
            && self.rows <= declared.rows
            && self.children <= declared.children
            && self.kept <= declared.kept
    }
}

/// Why a frame cannot run on a chip of given depths.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the view needs {} ray columns of {} rows, {} children a pass and {} kept final rays a PE, past the declared {}, {}, {} and {}",
    need.columns, need.rows, need.children, need.kept,
    declared.columns, declared.rows, declared.children, declared.kept
)]
pub struct TooDeep {
    /// What the frame needs.
    pub need: RayDepths,
    /// What the chip declares.
    pub declared: RayDepths,
}

/// Refuses a frame whose `need` passes `declared` (one line naming both).
pub fn check(need: RayDepths, declared: RayDepths) -> Result<(), TooDeep> {
    if need.fits(&declared) {
        Ok(())
    } else {
        Err(TooDeep { need, declared })
    }
}

/// The ray depths a frame of `view` needs on `cfg`'s array.
pub fn need(cfg: &PipelineConfig, view: &View) -> Result<RayDepths, golden::Error> {
    let layout = Method::Er.layout(view)?;
    Ok(need_of(cfg, view, &layout))
}

/// [`need`] for a planned layout.
pub fn need_of(cfg: &PipelineConfig, view: &View, layout: &Layout) -> RayDepths {
    let nx = view.dims[0];
    let pes = usize::from(cfg.pes.max(1));
    let maps = [ColumnMap::of(cfg, nx), ColumnMap::blocks(pes, nx)];
    let plane = Plane {
        view,
        pes,
        slack: cfg.position.lsb() + cfg.step.lsb(),
    };
    let mut out = RayDepths::default();
    let mut kept = vec![0u64; pes];
    for (i, g) in layout.grids.iter().enumerate() {
        if g.is_empty() {
            continue;
        }
        out.rows = out.rows.max(g.counts()[1] as u64);
        let (b0, b1) = (layout.bounds[i], layout.bounds[i + 1]);
        let mut zs: Vec<f64> = g.slices.clone().map(|z| z as f64).collect();
        zs.extend([b0, b1, g.slices.end as f64, view.dims[2] as f64 - 0.5]);
        for &z in &zs {
            for map in &maps {
                let held = plane.owned(g, z, map);
                out.columns = out
                    .columns
                    .max(held.iter().map(|s| s.count).max().unwrap_or(0));
            }
        }
        // Back to front: this region's rays merge into the front
        // region's on plane b0; front to back: the front region's rays
        // split into this one's on the same plane, and this region's rays
        // fold into the front one's there.
        let Some(front) = i.checked_sub(1).map(|f| &layout.grids[f]) else {
            continue;
        };
        let blocks = &maps[1];
        if cfg.order == Order::BackToFront {
            let spans = plane.owned(g, b0, blocks);
            let kids = children(&spans, front, |m| (2 * m).clamp(g.lo[0], g.hi[0]));
            out.children = out.children.max(kids);
        } else {
            let parents = plane.owned(front, b0, blocks);
            let kids = children(&parents, g, |n| {
                n.div_euclid(2).clamp(front.lo[0], front.hi[0])
            });
            out.children = out.children.max(kids);
            let rows = front.counts()[1] as u64;
            for (k, s) in parents.iter().enumerate() {
                kept[k] += s.count * rows;
                // The fold computes one child per kept parent.
                out.children = out.children.max(s.count);
            }
            // The fold gathers each back ray at its split parent's PE.
            let mut back = vec![0u64; pes];
            for n in g.lo[0]..=g.hi[0] {
                let p = n.div_euclid(2).clamp(front.lo[0], front.hi[0]);
                for (k, s) in parents.iter().enumerate() {
                    if s.contains(p) {
                        back[k] += 1;
                    }
                }
            }
            out.columns = out.columns.max(back.into_iter().max().unwrap_or(0));
        }
    }
    out.columns += IN_FLIGHT * u64::from(cfg.link_lanes.max(1));
    out.kept = kept.into_iter().max().unwrap_or(0);
    out
}

/// The rays one PE owns on a plane: how many, and the span of their
/// indices.
#[derive(Debug, Clone, Copy)]
struct Span {
    count: u64,
    lo: i64,
    hi: i64,
}

impl Span {
    fn contains(&self, m: i64) -> bool {
        self.count > 0 && (self.lo..=self.hi).contains(&m)
    }
}

/// How many of `kids`' rays have their centre parent (`centre`) in a
/// PE's span, the most over the PEs.
fn children(spans: &[Span], kids: &RayGrid, centre: impl Fn(i64) -> i64) -> u64 {
    spans
        .iter()
        .map(|s| {
            (kids.lo[0]..=kids.hi[0])
                .filter(|&m| s.contains(centre(m)))
                .count() as u64
        })
        .max()
        .unwrap_or(0)
}

/// Ray positions on a plane of a view, with the slack of the fixed-point
/// positions.
struct Plane<'a> {
    view: &'a View,
    pes: usize,
    slack: f64,
}

impl Plane<'_> {
    /// Every PE's rays of grid `g` on plane `z` under `map`: each ray
    /// counts for the owners of the base columns its position reaches
    /// within the slack.
    fn owned(&self, g: &RayGrid, z: f64, map: &ColumnMap) -> Vec<Span> {
        let p = g.at(self.view.eye, self.view.d, z, 0);
        let last = self.view.dims[0] as i64 - 1;
        let mut spans = vec![
            Span {
                count: 0,
                lo: i64::MAX,
                hi: i64::MIN,
            };
            self.pes
        ];
        for m in g.lo[0]..=g.hi[0] {
            let x = p.a + m as f64 * p.t;
            // The slack grows with the index: the step's rounding adds up
            // along the row.
            let e = self.slack * (1.0 + (m as f64).abs());
            let c0 = ((x - e).floor() as i64).clamp(0, last) as usize;
            let c1 = ((x + e).floor() as i64).clamp(0, last) as usize;
            let (k0, k1) = (map.owner(c0), map.owner(c1));
            for k in [k0, k1] {
                let s = &mut spans[k];
                s.count += 1;
                s.lo = s.lo.min(m);
                s.hi = s.hi.max(m);
                if k0 == k1 {
                    break;
                }
            }
        }
        spans
    }
}
