//! The facts about the data the bound needs ([`BoundInputs`]): the
//! voxels' largest neighbour differences, the table's largest steps and,
//! from ER's ray layout, the largest ray index, path length and merges;
//! and the slices each region samples ([`region_slices`]).

use glam::DVec3;
use golden::geometry::View;
use golden::methods::Method;
use golden::slices::SliceStack;
use golden::tf::Lut;
use golden::volume::Volume;

/// Facts about the data that the bound needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundInputs {
    /// Largest difference between voxels adjacent along view x, and along
    /// view y, in data units.
    pub gradient: [f64; 2],
    /// Largest step between adjacent classification entries: colour, opacity.
    pub table_step: [f64; 2],
    /// Largest ray index magnitude `|m|`.
    pub max_index: f64,
    /// Largest position magnitude in voxels.
    pub max_coord: f64,
    /// Largest path length per slice step (must be at least 1).
    pub ds_max: f64,
    /// Slices a ray can sample.
    pub slices: usize,
    /// Merges on a ray's way to the baseplane.
    pub merges: usize,
    /// Bits of the data (8 or 16).
    pub data_bits: u32,
}

impl BoundInputs {
    /// Measures the facts on a volume seen through `view` with table `lut`:
    /// the largest neighbour differences along view x and y, the largest
    /// table steps, and from ER's ray layout the largest ray index, the
    /// largest path length per slice step (spacing-scaled) and the merges.
    pub fn measure(volume: &Volume, lut: &Lut, view: &View) -> golden::Result<BoundInputs> {
        let at = |x: usize, y: usize, z: usize| {
            let i = view.axes.to_index(DVec3::new(x as f64, y as f64, z as f64));
            f64::from(volume.get(i.x as usize, i.y as usize, i.z as usize))
        };
        Self::from_gradient(
            neighbour_differences(view.dims, at),
            lut,
            view,
            volume.kind().bits(),
        )
    }

    /// [`BoundInputs::measure`] on the permuted stack a frame renders from
    /// (the volume is no longer at hand once a frame owns it): the same
    /// voxels, read in view space.
    pub fn measure_stack(
        stack: &SliceStack,
        lut: &Lut,
        view: &View,
        data_bits: u32,
    ) -> golden::Result<BoundInputs> {
        // Padded index of view (x, y) in a slice: one voxel of padding on
        // every side.
        let at = |x: usize, y: usize, z: usize| {
            f64::from(stack.slice(z).get((y + 1) * stack.row + x + 1))
        };
        Self::from_gradient(neighbour_differences(stack.dims, at), lut, view, data_bits)
    }

    /// The facts other than the voxels' neighbour differences.
    fn from_gradient(
        gradient: [f64; 2],
        lut: &Lut,
        view: &View,
        data_bits: u32,
    ) -> golden::Result<BoundInputs> {
        let [nx, ny, nz] = view.dims;
        let mut table_step = [0f64; 2];
        for w in lut.rgba.windows(2) {
            for (a, b) in w[0][..3].iter().zip(&w[1][..3]) {
                table_step[0] = table_step[0].max(f64::from((b - a).abs()));
            }
            table_step[1] = table_step[1].max(f64::from((w[1][3] - w[0][3]).abs()));
        }
        let layout = Method::Er.layout(view)?;
        let mut max_index = 0f64;
        let mut ds_max = 1f64;
        for g in layout.grids.iter().filter(|g| !g.is_empty()) {
            let inv = 1.0 / (g.z_ref + view.d);
            let mut slope = [0f64; 2];
            for (a, s) in slope.iter_mut().enumerate() {
                for m in [g.lo[a], g.hi[a]] {
                    max_index = max_index.max(m.unsigned_abs() as f64);
                    *s = s.max(((g.phi[a] + m as f64 - view.eye[a]) * inv).abs());
                }
            }
            ds_max = ds_max.max(view.world_length(slope[0], slope[1], 1.0));
        }
        Ok(BoundInputs {
            gradient,
            table_step,
            max_index,
            max_coord: nx.max(ny) as f64,
            ds_max,
            slices: nz,
            merges: layout.grids.len() - 1,
            data_bits,
        })
    }
}

/// Largest difference between voxels adjacent along view x, and along view
/// y, of a volume of view dimensions `dims` read through `at(x, y, z)`.
fn neighbour_differences(dims: [usize; 3], at: impl Fn(usize, usize, usize) -> f64) -> [f64; 2] {
    let [nx, ny, nz] = dims;
    let mut gradient = [0f64; 2];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let v = at(x, y, z);
                if x + 1 < nx {
                    gradient[0] = gradient[0].max((at(x + 1, y, z) - v).abs());
                }
                if y + 1 < ny {
                    gradient[1] = gradient[1].max((at(x, y + 1, z) - v).abs());
                }
            }
        }
    }
    gradient
}

/// Slices each region of `view` can sample, front (region 0) to back: the
/// `n_i` of [`ftb_error_bound`](super::ftb_error_bound).
pub fn region_slices(view: &View) -> golden::Result<Vec<usize>> {
    Ok(Method::ErFtb
        .layout(view)?
        .grids
        .iter()
        .map(|g| g.slices.len())
        .collect())
}
