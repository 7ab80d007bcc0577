//! Back to front, the schedule of golden [`golden::methods::Method::Er`]:
//! regions from the back; in each, every slice is migrated to and sampled;
//! at each region boundary the rays migrate to their positions on the
//! boundary plane, the datapath drains, and the Bartlett merge runs; the
//! datapath drains again before the readout.

use super::Output;
use crate::array::{Array, RunError};
use crate::host::FramePlan;
use golden::geometry::RayGrid;

/// The rays of grid `g`.
pub(crate) fn rays(g: &RayGrid) -> u64 {
    g.counts().iter().map(|&n| n as u64).product()
}

/// Runs `plan` back to front on `a`.
pub(crate) fn back_to_front(a: &mut Array, plan: &FramePlan) -> Result<Output, RunError> {
    let k = a.regions_to_run(plan);
    let mut merges = 0;
    for i in (0..k).rev() {
        let region = &plan.regions[i];
        if i == k - 1 {
            a.distribute(region);
        }
        for slice in plan.region_passes(i, false) {
            let Some(slice) = a.visit(i, slice)? else {
                continue;
            };
            a.migrate(&slice)?;
            a.sample(region, &slice)?;
        }
        if i > 0 {
            // Rays merge on the boundary plane: first bring each to the PE
            // of its position there, so that every PE holds rays and a
            // merge's neighbours are one link away even when regions
            // without slices follow one another (eyes closer than half a
            // voxel). The merge runs on column blocks in every mapping.
            a.migrate_pass(&region.front)?;
            a.drain()?;
            let start = a.clock.now();
            let (bg, fg) = (&region.grid, &plan.regions[i - 1].grid);
            let (reads, writes) = a.merge(bg, fg)?;
            a.ray_buffer_pass(start, reads, writes)?;
            a.settle_links();
            merges += 1;
        }
    }
    a.drain()?;
    let raw = a.readout(&plan.regions[0].grid)?;
    let fmt = [a.dp.cfg.accum_color, a.dp.cfg.accum_alpha];
    Ok((raw, fmt, merges))
}
