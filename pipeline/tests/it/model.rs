//! Integration tests of the bit-accurate, cycle-level PE-array model
//! (`pipeline`): properties of the array as a whole that unit tests of one
//! PE or one datapath step cannot see.
//!
//! 1. The order in which PEs are stepped within a clock cannot change
//!    anything (the two-phase port discipline).
//! 2. Every PE only talks to its neighbours, and the array takes exactly
//!    golden `er`'s samples, for any P and any principal axis.
//! 3. The cycle counters add up.
//! 4. The baseplane's raw words do not depend on P.
//! 5. The VCD waveform shows exactly the model's compositing results,
//!    converts to FST with GTKWave's `vcd2fst`, and comes with a `.gtkw`
//!    naming only traced signals.
//! 6. Tracing does not perturb the model.
//! 7. Fixed-point ray positions rarely disagree with golden's float
//!    positions about whether a ray is inside a slice.
//! 8. Bad configurations are refused with one-line errors, by the library
//!    and by the `ercube` binary.
//! 9. `ercube render --method pipeline` writes what it promises, and its
//!    raw words are those of the in-process model.
//!
//! Volumes are 24^3 to 32^3 so the whole file runs in well under a minute
//! in release.

mod array;
mod edges;
mod refusals;
mod waveform;

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::array::{Array, Frame};
use pipeline::config::PipelineConfig;
use waves::Tracer;

use crate::chip::Subject;
use crate::scenes::up_for;

/// Where the eye sits: outside the face of index axis `axis` on the side
/// `positive`, `d` voxels from the nearest slice (so the view's `D` is `d`),
/// shifted by `off` along the other two axes (in increasing axis order)
/// from the volume's centre line.
#[derive(Debug, Clone, Copy)]
struct Eye {
    axis: usize,
    positive: bool,
    d: f64,
    off: [f64; 2],
}

impl Eye {
    fn position(&self, n: usize) -> DVec3 {
        let c = (n as f64 - 1.0) / 2.0;
        let mut p = [c; 3];
        let others: Vec<usize> = (0..3).filter(|&k| k != self.axis).collect();
        p[others[0]] += self.off[0];
        p[others[1]] += self.off[1];
        p[self.axis] = if self.positive {
            n as f64 - 1.0 + self.d
        } else {
            -self.d
        };
        DVec3::from_array(p)
    }
}

/// The eye `e` looking at the volume's centre with a 60 degree, 32x32
/// camera. (The image only matters to the warp, which the array never
/// sees.)
fn prepare(s: &Subject, e: Eye) -> Prepared {
    let eye = e.position(s.n);
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), 60.0, 32, 32).expect("camera");
    let prep = Prepared::new(&s.vol, &cam).expect("view");
    assert!(
        (prep.view.d - e.d).abs() < 1e-9,
        "{e:?}: the view's D is {}, not {}",
        prep.view.d,
        e.d
    );
    prep
}

/// Runs one frame, optionally with a PE step order (which also makes the
/// sampling stage step cycle by cycle, where the order could matter) and a
/// tracer.
fn run_with(
    cfg: &PipelineConfig,
    s: &Subject,
    prep: &Prepared,
    order: Option<Vec<usize>>,
    tracer: Tracer,
) -> Frame {
    let mut array = match Array::new(cfg, &s.vol, &s.lut, &prep.view, tracer) {
        Ok(a) => a,
        Err(e) => panic!("Array::new with {} PEs: {e}", cfg.pes),
    };
    if let Some(o) = order {
        array.set_step_order(o);
        array.set_clocked(true);
    }
    array
        .run(&prep.view)
        .unwrap_or_else(|e| panic!("run with {} PEs: {e}", cfg.pes))
}

/// Runs one untraced frame in the natural step order.
fn run(cfg: &PipelineConfig, s: &Subject, prep: &Prepared) -> Frame {
    run_with(cfg, s, prep, None, Tracer::disabled())
}
