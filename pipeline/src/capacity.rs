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
//! both sides), and under column blocks on every two neighbouring planes
//! a PE counts the rays it owns on either (a migration can land the next
//! plane's columns before the last plane's have left); the most any PE
//! gets, plus the columns a migration keeps
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

use crate::config::{Mapping, Migration, Order, PipelineConfig};
use crate::mapping::ColumnMap;

/// Columns a migration may keep in a PE beyond those it owns on either
/// plane: a column passing through (its first row arrived, its last not
/// yet sent on) per link side and lane.
pub const IN_FLIGHT: u64 = 2;

/// What one PE's ray memories must hold for a frame.
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

/// Every PE's ray depths, by PE index: what each PE's own ray memories
/// must hold (a need) or hold (a declaration).
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize)]
#[serde(transparent)]
pub struct PeDepths(pub Vec<RayDepths>);

impl PeDepths {
    /// `pes` PEs of the same depths.
    pub fn uniform(pes: usize, d: RayDepths) -> PeDepths {
        PeDepths(vec![d; pes])
    }

    /// PEs.
    pub fn pes(&self) -> usize {
        self.0.len()
    }

    /// PE `k`'s depths (none past the last PE).
    pub fn pe(&self, k: usize) -> RayDepths {
        self.0.get(k).copied().unwrap_or_default()
    }

    /// The deepest PE's, field by field: what a declaration as deep in
    /// every PE would hold.
    pub fn max(&self) -> RayDepths {
        self.0.iter().fold(RayDepths::default(), |a, d| a.max(*d))
    }

    /// Each PE's larger of `self`'s and `o`'s: a chip for the views of
    /// both (PE by PE; a PE only one of them has keeps its own).
    pub fn cover(&self, o: &PeDepths) -> PeDepths {
        let n = self.pes().max(o.pes());
        PeDepths((0..n).map(|k| self.pe(k).max(o.pe(k))).collect())
    }

    /// The distinct depths and the PEs declaring each, in order of their
    /// first PE.
    pub fn groups(&self) -> Vec<(RayDepths, Vec<usize>)> {
        let mut out: Vec<(RayDepths, Vec<usize>)> = Vec::new();
        for (k, d) in self.0.iter().enumerate() {
            match out.iter_mut().find(|(g, _)| g == d) {
                Some((_, pes)) => pes.push(k),
                None => out.push((*d, vec![k])),
            }
        }
        out
    }
}

/// Why a frame cannot run on a chip of given depths.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TooDeep {
    /// A PE needs more than it declares.
    #[error(
        "the view needs {} ray columns of {} rows, {} children a pass and {} kept final rays in PE {pe}, past its declared {}, {}, {} and {}",
        need.columns, need.rows, need.children, need.kept,
        declared.columns, declared.rows, declared.children, declared.kept
    )]
    Pe {
        /// The PE.
        pe: usize,
        /// What the frame needs there.
        need: RayDepths,
        /// What that PE declares.
        declared: RayDepths,
    },
    /// The declaration is for another PE count.
    #[error("the chip declares ray memories for {declared} PEs, the array has {pes}")]
    Pes {
        /// PEs declared.
        declared: usize,
        /// PEs of the array.
        pes: usize,
    },
}

/// Refuses a frame whose `need` passes `declared` in some PE (one line
/// naming the first such PE and both depths).
pub fn check(need: &PeDepths, declared: &PeDepths) -> Result<(), TooDeep> {
    if need.pes() != declared.pes() {
        return Err(TooDeep::Pes {
            declared: declared.pes(),
            pes: need.pes(),
        });
    }
    for (pe, (n, d)) in need.0.iter().zip(&declared.0).enumerate() {
        if !n.fits(d) {
            return Err(TooDeep::Pe {
                pe,
                need: *n,
                declared: *d,
            });
        }
    }
    Ok(())
}

/// Whether each PE's columns are its own (its rays on the planes they are
/// owned on, a pass's children, and those in flight) or the deepest PE's:
/// its own only under column blocks migrating between slices on dense
/// links, where every column moves whole along the line one ray a cycle
/// each way, so a PE's columns leave as fast as others arrive. An
/// overlapped migration holds a leaving row until its sample is written
/// back while rays arrive, sparse links send short columns past long
/// ones, and the round-robin mappings move columns both ways around the
/// ring between the sampling and the passes' owners: there a middle PE
/// was seen holding more than its own (`occupancy` proptest cases), so
/// every PE keeps the deepest PE's columns.
pub fn own_columns(cfg: &PipelineConfig) -> bool {
    cfg.mapping == Mapping::Blocks
        && cfg.migration == Migration::BetweenSlices
        && !cfg.link_skip_empty
}

/// The ray depths each PE of `cfg`'s array needs for a frame of `view`.
pub fn need(cfg: &PipelineConfig, view: &View) -> Result<PeDepths, golden::Error> {
    let layout = Method::Er.layout(view)?;
    Ok(need_of(cfg, view, &layout))
}

/// [`need`] for a planned layout.
///
/// A region without rays (`RayGrid::is_empty`) adds nothing: no columns,
/// no pass across its boundaries, no kept finals; a layout of none gives
/// rows, children and kept finals of 0 and only the columns in flight,
/// declarations the cost model and the emitted shapes take (a memory of
/// depth 0 is not charged; the shapes' depths are at least 1). Golden's
/// `er` layouts have none (every region with a slice has rays, and a
/// region without one is fed by the region behind it; a proptest in this
/// module's tests checks it over many views), but a layout built by hand
/// may.
pub fn need_of(cfg: &PipelineConfig, view: &View, layout: &Layout) -> PeDepths {
    let nx = view.dims[0];
    let pes = usize::from(cfg.pes.max(1));
    let maps = [ColumnMap::of(cfg, nx), ColumnMap::blocks(pes, nx)];
    let plane = Plane {
        view,
        pes,
        slack: cfg.position.lsb() + cfg.step.lsb(),
    };
    let mut out = vec![RayDepths::default(); pes];
    // Every PE's columns are as tall as the tallest region's: a column of
    // any region may pass through any PE on a migration.
    let rows = layout
        .grids
        .iter()
        .filter(|g| !g.is_empty())
        .map(|g| g.counts()[1] as u64)
        .max()
        .unwrap_or(0);
    let mut kept = vec![0u64; pes];
    for (i, g) in layout.grids.iter().enumerate() {
        if g.is_empty() {
            continue;
        }
        let (b0, b1) = (layout.bounds[i], layout.bounds[i + 1]);
        let mut zs: Vec<f64> = g.slices.clone().map(|z| z as f64).collect();
        zs.extend([b0, b1, g.slices.end as f64, view.dims[2] as f64 - 0.5]);
        zs.sort_by(f64::total_cmp);
        zs.dedup();
        for map in &maps {
            let owners: Vec<Vec<[usize; 2]>> =
                zs.iter().map(|&z| plane.owners(g, z, map)).collect();
            for o in &owners {
                raise(&mut out, &plane.counts(o, o), columns);
            }
            // Under column blocks a migration between two neighbouring
            // planes may hold every column of both at once: the columns
            // arriving from one side for the next plane can land before
            // those leaving on the other side have gone (that neighbour
            // still taking in its own), so a PE holds the rays it owns on
            // either plane. Under a round-robin mapping most rays change
            // owner from plane to plane and each PE sends and receives
            // about as many; there the deepest PE's columns plus those in
            // flight hold (the occupancy proptest's round-robin cases),
            // where the union would count most rays twice.
            if !map.round_robin() {
                for pair in owners.windows(2) {
                    raise(&mut out, &plane.counts(&pair[0], &pair[1]), columns);
                }
            }
        }
        // Back to front: this region's rays merge into the front
        // region's on plane b0; front to back: the front region's rays
        // split into this one's on the same plane, and this region's rays
        // fold into the front one's there.
        // A ray-less front region has no parents to split from or
        // children to merge into: no pass on this boundary (the clamps
        // below need a non-empty front).
        let Some(front) = i
            .checked_sub(1)
            .map(|f| &layout.grids[f])
            .filter(|f| !f.is_empty())
        else {
            continue;
        };
        let blocks = &maps[1];
        if cfg.order == Order::BackToFront {
            let spans = plane.owned(g, b0, blocks);
            let kids = children(&spans, front, |m| (2 * m).clamp(g.lo[0], g.hi[0]));
            raise(&mut out, &kids, children_of);
        } else {
            let parents = plane.owned(front, b0, blocks);
            let kids = children(&parents, g, |n| {
                n.div_euclid(2).clamp(front.lo[0], front.hi[0])
            });
            raise(&mut out, &kids, children_of);
            let front_rows = front.counts()[1] as u64;
            let held: Vec<u64> = parents.iter().map(|s| s.count).collect();
            for (k, n) in held.iter().enumerate() {
                kept[k] += n * front_rows;
            }
            // The fold computes one child per kept parent.
            raise(&mut out, &held, children_of);
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
            raise(&mut out, &back, columns);
        }
    }
    let in_flight = IN_FLIGHT * u64::from(cfg.link_lanes.max(1));
    // A PE's own columns bound what it holds only where [`own_columns`].
    let own = own_columns(cfg);
    // A pass's children take their centre parents' slots and stay there,
    // held columns, until the next migration.
    for d in out.iter_mut() {
        d.columns = d.columns.max(d.children);
    }
    let deepest = out.iter().map(|d| d.columns).max().unwrap_or(0);
    for (d, k) in out.iter_mut().zip(kept) {
        if !own {
            d.columns = deepest;
        }
        d.columns += in_flight;
        d.rows = rows;
        d.kept = k;
    }
    PeDepths(out)
}

/// Raises each PE's `field` to at least its entry of `each`.
fn raise(out: &mut [RayDepths], each: &[u64], field: fn(&mut RayDepths) -> &mut u64) {
    for (d, &n) in out.iter_mut().zip(each) {
        let v = field(d);
        *v = (*v).max(n);
    }
}

fn columns(d: &mut RayDepths) -> &mut u64 {
    &mut d.columns
}

fn children_of(d: &mut RayDepths) -> &mut u64 {
    &mut d.children
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

/// How many of `kids`' rays have their centre parent (`centre`) in each
/// PE's span.
fn children(spans: &[Span], kids: &RayGrid, centre: impl Fn(i64) -> i64) -> Vec<u64> {
    spans
        .iter()
        .map(|s| {
            (kids.lo[0]..=kids.hi[0])
                .filter(|&m| s.contains(centre(m)))
                .count() as u64
        })
        .collect()
}

/// Ray positions on a plane of a view, with the slack of the fixed-point
/// positions.
struct Plane<'a> {
    view: &'a View,
    pes: usize,
    slack: f64,
}

impl Plane<'_> {
    /// The owners of each of grid `g`'s rays on plane `z` under `map`
    /// (by ray, from `g.lo[0]`): the owners of the base columns its
    /// position reaches within the slack, twice the same PE for a ray
    /// clear of a column edge.
    fn owners(&self, g: &RayGrid, z: f64, map: &ColumnMap) -> Vec<[usize; 2]> {
        let p = g.at(self.view.eye, self.view.d, z, 0);
        let last = self.view.dims[0] as i64 - 1;
        (g.lo[0]..=g.hi[0])
            .map(|m| {
                let x = p.a + m as f64 * p.t;
                // The slack grows with the index: the step's rounding adds
                // up along the row.
                let e = self.slack * (1.0 + (m as f64).abs());
                let c0 = ((x - e).floor() as i64).clamp(0, last) as usize;
                let c1 = ((x + e).floor() as i64).clamp(0, last) as usize;
                [map.owner(c0), map.owner(c1)]
            })
            .collect()
    }

    /// Each PE's rays owned under `a` or `b` (owners of the same grid's
    /// rays on two planes, or one plane twice).
    fn counts(&self, a: &[[usize; 2]], b: &[[usize; 2]]) -> Vec<u64> {
        let mut n = vec![0u64; self.pes];
        let mut seen: Vec<usize> = Vec::with_capacity(4);
        for (x, y) in a.iter().zip(b) {
            seen.clear();
            for &k in x.iter().chain(y) {
                if !seen.contains(&k) {
                    seen.push(k);
                    n[k] += 1;
                }
            }
        }
        n
    }

    /// Every PE's rays of grid `g` on plane `z` under `map`: how many and
    /// the span of their indices.
    fn owned(&self, g: &RayGrid, z: f64, map: &ColumnMap) -> Vec<Span> {
        let mut spans = vec![
            Span {
                count: 0,
                lo: i64::MAX,
                hi: i64::MIN,
            };
            self.pes
        ];
        for (m, ks) in (g.lo[0]..).zip(self.owners(g, z, map)) {
            for (i, &k) in ks.iter().enumerate() {
                if i == 1 && k == ks[0] {
                    break;
                }
                let s = &mut spans[k];
                s.count += 1;
                s.lo = s.lo.min(m);
                s.hi = s.hi.max(m);
            }
        }
        spans
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::inventory::{pe_inventory, Geometry};
    use crate::cost::target::Target;
    use crate::hw::readout_rtl::{self, ReadoutShape};
    use crate::pe::Pe;
    use glam::DVec3;
    use golden::camera::Camera;
    use proptest::prelude::*;

    fn view(dims: [usize; 3], eye: DVec3, fov: f64) -> Option<View> {
        let c = DVec3::from_array(dims.map(|n| (n as f64 - 1.0) / 2.0));
        let cam = Camera::new(eye, c, DVec3::Y, fov, 4, 4).ok()?;
        View::new(dims, [1.0; 3], &cam, 1.0).ok()
    }

    fn cfg(pes: u16, order: Order) -> PipelineConfig {
        PipelineConfig {
            pes,
            order,
            ..PipelineConfig::default()
        }
    }

    /// Depths of a ray-less layout, declared: the PE's declaration, its
    /// cost (no memory of depth 0 charged) and the readout's emitted
    /// shape accept them.
    fn accepted(cfg: &PipelineConfig, dims: [usize; 3], need: &PeDepths) {
        let mut geo = Geometry::new(dims, cfg.pes);
        geo.pe_rays = need.clone();
        geo.rays = need.max();
        for k in 0..need.pes() {
            let g = geo.pe(k);
            for d in Pe::declaration(cfg, &g) {
                assert!(d.copies > 0, "{}", d.name);
            }
            let inv = pe_inventory(cfg, &g);
            for i in &inv.items {
                for u in &i.units {
                    assert!(
                        !matches!(u, crate::cost::units::Unit::Mem { depth: 0, .. }),
                        "{} charged at depth 0",
                        i.name
                    );
                }
            }
            assert!(inv.cost(Target::Xc7).lut > 0);
        }
        let shape = ReadoutShape::new(cfg, &geo).expect("readout shape");
        assert!(shape.bank_depth >= 1 && shape.map_depth >= 1 && shape.max_rows >= 1);
        let rtl = readout_rtl::emit(&shape);
        assert!(rtl.pe.contains("module") && rtl.array.contains("module"));
    }

    /// A region without rays, built by emptying a real layout's regions:
    /// the front one (front to back there is then no split or fold to
    /// count on its boundary, where the clamps to the front's rays would
    /// panic), a middle one, and every one (rows, children and kept
    /// finals 0, only the columns in flight). Each gives depths at most
    /// the full layout's, and the declarations, the cost and the readout's
    /// Verilog shape accept them.
    #[test]
    fn ray_less_regions_give_depths_the_cost_and_the_shapes_accept() {
        let dims = [24, 20, 40];
        let v = view(dims, DVec3::new(11.5, 9.5, -6.0), 90.0).expect("view");
        let layout = Method::Er.layout(&v).expect("layout");
        assert!(layout.grids.len() >= 3, "{} regions", layout.grids.len());
        let empty = |g: &mut golden::geometry::RayGrid| {
            g.lo = [0; 2];
            g.hi = [-1; 2];
        };
        for order in [Order::BackToFront, Order::FrontToBack] {
            let c = cfg(4, order);
            let full = need_of(&c, &v, &layout);
            for emptied in [vec![0], vec![1], (0..layout.grids.len()).collect()] {
                let mut l = layout.clone();
                for &i in &emptied {
                    empty(&mut l.grids[i]);
                }
                let need = need_of(&c, &v, &l);
                assert_eq!(need.pes(), 4);
                for k in 0..4 {
                    assert!(need.pe(k).fits(&full.pe(k)), "{order:?} {emptied:?} PE {k}");
                }
                if emptied.len() == layout.grids.len() {
                    let in_flight = RayDepths {
                        columns: IN_FLIGHT,
                        ..RayDepths::default()
                    };
                    assert_eq!(need, PeDepths::uniform(4, in_flight), "{order:?}");
                }
                if order == Order::FrontToBack && emptied == [0] {
                    // Region 0 keeps no finals: its boundary has no split.
                    assert!(need.max().kept < full.max().kept);
                }
                accepted(&c, dims, &need);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        /// Golden's `er` layouts have a ray in every region, over volume
        /// sizes, eyes near and far, in front, beside and outside the
        /// volume's sides, and fields of view up to 170 degrees: a
        /// ray-less region comes only from a layout built by hand.
        #[test]
        fn no_view_has_a_ray_less_region(
            dims in prop::array::uniform3(1usize..80),
            eye in (-2.0..3.0f64, -2.0..3.0f64, 0.001..4.0f64),
            fov in 5.0..170.0f64,
        ) {
            let d = dims.map(|n| n as f64);
            let e = DVec3::new(eye.0 * d[0], eye.1 * d[1], -eye.2 * d[2]);
            let Some(v) = view(dims, e, fov) else { return Ok(()) };
            let Ok(layout) = Method::Er.layout(&v) else { return Ok(()) };
            for (i, g) in layout.grids.iter().enumerate() {
                prop_assert!(!g.is_empty(), "region {i} of {} has no rays: {:?}", layout.grids.len(), v.dims);
            }
        }
    }
}
