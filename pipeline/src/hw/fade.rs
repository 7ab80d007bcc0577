//! A fade unit: the classified opacity scaled by one per-frame constant
//! `k` (the `alpha` format), described once and modelled beside its
//! description.
//!
//! Ports: the classified opacity `class.a` and the host's `k`. Output:
//! `alpha` (`alpha`).

use super::Graph;
use crate::config::PipelineConfig;
use crate::fixed::{Fx, QuantStats};

/// The frame's fade: the factor the opacities are scaled by, in `[0, 1)`.
#[derive(Debug, Clone, Copy)]
pub struct Fade(pub f64);

/// The unit's per-frame constant.
#[derive(Debug, Clone)]
pub struct FadeUnit {
    /// The factor, an `alpha` word.
    k: Fx,
}

impl FadeUnit {
    /// `a k` into `alpha` (exact product, then `alpha`'s rounding and
    /// saturation).
    pub fn scale(&self, cfg: &PipelineConfig, a: Fx, st: &mut QuantStats) -> Fx {
        crate::reg!(cfg, alpha).assign(a * self.k, st)
    }
}

/// The host quantises the factor into `alpha`.
impl crate::datapath::FrameUnit for Fade {
    fn load(
        &self,
        f: &crate::datapath::UnitFrame<'_>,
        units: &mut super::compose::FrameUnits,
        st: &mut QuantStats,
    ) -> Result<(), crate::RunError> {
        let reg = crate::reg!(f.dp.cfg, alpha);
        let q = reg.from_f64(self.0)?;
        st.record_as(reg.id, &q);
        units.fade = Some(FadeUnit { k: q.value });
        Ok(())
    }
}

/// The unit's description for `cfg`.
pub fn fade(cfg: &PipelineConfig) -> Graph {
    let mut g = Graph::new();
    g.no_item();
    let a = g.input("class.a", cfg.alpha);
    let k = g.input("k", cfg.alpha);
    g.item("fade", "opacity a k", 0);
    let ak = g.mul_exact("fade.ak", a, k);
    let alpha = g.quantize("alpha", ak, cfg.alpha);
    g.step_out(alpha);
    g.output("alpha", alpha);
    g
}
