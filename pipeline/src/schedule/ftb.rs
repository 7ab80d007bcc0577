//! Front to back, the schedule of golden [`golden::methods::Method::ErFtb`]:
//! regions from the front; at each boundary the rays migrate to their
//! positions on the front region's rear plane, the datapath drains and the
//! split runs; every slice is migrated to and sampled (terminated rays
//! cost no cycle); after the last region the fold runs boundary by
//! boundary from the back, each after bringing the back rays to the PE
//! that kept their split parent's final state and draining; the rays go
//! back to their slice-0 owners and are read out.

use std::sync::Arc;

use super::btf::rays;
use super::Output;
use crate::array::{clamp, Array, RunError};
use crate::host::FramePlan;
use crate::stages::fold::FoldGrids;

/// Runs `plan` front to back on `a`.
pub(crate) fn front_to_back(a: &mut Array, plan: &FramePlan) -> Result<Output, RunError> {
    let k = a.regions_to_run(plan);
    a.distribute(&plan.regions[0]);
    let mut merges = 0;
    for i in 0..k {
        let region = &plan.regions[i];
        if i > 0 {
            // Parents split on the boundary plane, one voxel apart: every
            // PE in their span holds some, so each child's second parent is
            // held or one link away.
            let front = &plan.regions[i - 1];
            a.migrate_pass(&front.rear)?;
            a.drain()?;
            let start = a.clock.now();
            let (reads, writes) = a.split(&front.grid, &region.grid)?;
            // The parents' final states stay in the buffer for the fold.
            a.ray_buffer_pass(start, reads, writes)?;
            a.settle_links();
            merges += 1;
        }
        for slice in plan.region_passes(i, true) {
            let Some(slice) = a.visit(i, slice)? else {
                continue;
            };
            a.migrate(&slice)?;
            a.sample(region, &slice)?;
        }
    }
    let acc = [a.dp.cfg.accum_color, a.dp.cfg.accum_alpha];
    let merge = [a.dp.cfg.merge, a.dp.cfg.merge];
    let mut fmt = acc;
    for i in (1..k).rev() {
        let (back, front) = (&plan.regions[i], &plan.regions[i - 1]);
        // Each back ray goes to the PE that kept its split parent's final
        // state, where its difference joins the merge.
        let dp = Arc::clone(&a.dp);
        let owners = a.pass_owners(&dp, &front.rear);
        let (lo, hi) = (front.grid.lo[0], front.grid.hi[0]);
        a.migrate_home(front.rear.z, |n| owners.of(clamp(n.div_euclid(2), lo, hi)))?;
        a.drain()?;
        let start = a.clock.now();
        a.fold(FoldGrids {
            back: &back.grid,
            front: &front.grid,
            rf: fmt,
        })?;
        // The back rays and the kept final states in, the front rays out.
        let (nb, nf) = (rays(&back.grid), rays(&front.grid));
        a.ray_buffer_pass(start, nb + nf, nf)?;
        a.settle_links();
        fmt = merge;
    }
    // The fold leaves region 0's rays where their parents sat on the
    // region-1 boundary (the rays beyond the volume's sides piled into the
    // end PEs); bring them back to their slice-0 column-block owners so the readout
    // streams from every PE.
    if let Some(front) = plan.regions[0].slices.last() {
        a.migrate_pass(front)?;
    }
    a.drain()?;
    let raw = a.readout(&plan.regions[0].grid)?;
    Ok((raw, fmt, merges))
}
