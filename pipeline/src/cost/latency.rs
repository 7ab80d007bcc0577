//! The sample datapath's latency in clocks, from a ray slot's read to its
//! accumulators' write-back: the depth of the schedule `ercube rtl` emits.
//!
//! The plain sample's depth is its description's ([`crate::hw::sample::plain`])
//! schedule: one multiplier or one carry chain a stage
//! ([`crate::hw::schedule::schedule`]) when `target_mhz` is 0, else the
//! stages the delay model of [`super::fmax`] packs for that clock on
//! `target_family` ([`super::fmax::clock_schedule`]). The emitted module is
//! built on the same schedule ([`sample_schedule`]), so its depth is the
//! model's latency.
//!
//! With the gradient and shading unit, the volume-of-interest stage or the
//! pre-integration unit the latency is the depth of the composed sample
//! ([`crate::hw::compose`]: shading and VOI spliced between the
//! classification and the opacity correction, pre-integration in the
//! classification's and the log table's place) on the same schedule
//! rules: the module the cost inventory prices, and that `ercube rtl` and
//! `ercube cosim` emit for a shaded or VOI frame.

use crate::config::PipelineConfig;
use crate::hw::compose::Units;
use crate::hw::schedule::Schedule;

use super::inventory;

/// The plain sample datapath's schedule for `cfg`: the one the model's
/// latency and `ercube rtl`'s module follow.
///
/// With `target_mhz` set, the clock's schedule on `target_family`;
/// [`PipelineConfig::validate`] refuses a clock no schedule reaches, and
/// an unvalidated configuration asking for one gets the one-operator
/// schedule.
pub fn sample_schedule(cfg: &PipelineConfig) -> Schedule {
    graph_schedule(cfg, &crate::hw::sample::plain(cfg))
}

/// The schedule of `g`, a sample's description for `cfg`: the clock's
/// when `target_mhz` is set and reachable, else one operator a stage.
pub fn graph_schedule(cfg: &PipelineConfig, g: &crate::hw::Graph) -> Schedule {
    if cfg.target_mhz > 0 {
        if let Ok(c) = super::fmax::clock_schedule(g, cfg.target_family, f64::from(cfg.target_mhz))
        {
            return c.schedule;
        }
    }
    crate::hw::schedule::schedule(g)
}

/// The depth of the sample's datapath with `units`
/// ([`crate::hw::compose::sample`] on [`graph_schedule`]); the plain
/// depth without units.
pub fn units_depth(cfg: &PipelineConfig, units: Units) -> u32 {
    if units.plain() {
        return plain_depth(cfg);
    }
    graph_schedule(cfg, &crate::hw::compose::sample(cfg, units))
        .depth
        .max(1)
}

/// The write-back latency of a sample's datapath with `units`: the
/// configured latency when set, else [`units_depth`].
pub fn sample_latency(cfg: &PipelineConfig, units: Units) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    units_depth(cfg, units)
}

/// The plain sample datapath's depth: [`sample_schedule`]'s.
pub fn plain_depth(cfg: &PipelineConfig) -> u32 {
    sample_schedule(cfg).depth.max(1)
}

/// The plain datapath's latency: [`PipelineConfig::datapath_latency`]
/// when set, else [`plain_depth`].
pub fn datapath_latency(cfg: &PipelineConfig) -> u32 {
    unit_latency(cfg, (false, false))
}

/// The latency of a datapath with the gradient and shading unit built
/// for one light (`shading`) and the volume-of-interest stage (`voi`):
/// [`sample_latency`].
pub fn unit_latency(cfg: &PipelineConfig, (shading, voi): (bool, bool)) -> u32 {
    sample_latency(
        cfg,
        Units {
            lights: shading.then_some(1),
            voi,
            ..Units::default()
        },
    )
}

/// The latency of a datapath with the gradient and shading unit (one
/// light).
pub fn shaded_latency(cfg: &PipelineConfig) -> u32 {
    unit_latency(cfg, (true, false))
}

/// The latency of a datapath with the pre-integration unit
/// ([`crate::preint`], priced in [`super::preint`]) in the
/// classification's and the log table's place: [`sample_latency`].
pub fn preint_latency(cfg: &PipelineConfig) -> u32 {
    sample_latency(
        cfg,
        Units {
            preint: true,
            ..Units::default()
        },
    )
}

/// The latency of a datapath with the units of `geo`.
pub fn geometry_latency(cfg: &PipelineConfig, geo: &inventory::Geometry) -> u32 {
    sample_latency(cfg, geo.units)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Order;
    use crate::cost::Target;

    /// The shading, VOI and pre-integration latencies are the composed
    /// sample's scheduled depths, in both orders; the units only deepen
    /// it; a stated latency is the whole datapath's.
    #[test]
    fn unit_latencies_are_the_composed_depths() {
        for order in [Order::BackToFront, Order::FrontToBack] {
            let cfg = PipelineConfig {
                order,
                ..PipelineConfig::default()
            };
            let plain = crate::hw::schedule::schedule(&crate::hw::sample::plain(&cfg)).depth;
            let composed = |lights: Option<usize>, voi: bool, preint: bool| {
                let units = match preint {
                    true => Units {
                        preint,
                        ..Units::default()
                    },
                    false => Units {
                        lights,
                        voi,
                        ..Units::default()
                    },
                };
                crate::hw::schedule::schedule(&crate::hw::compose::sample(&cfg, units)).depth
            };
            let row = [
                datapath_latency(&cfg),
                shaded_latency(&cfg),
                unit_latency(&cfg, (false, true)),
                unit_latency(&cfg, (true, true)),
                preint_latency(&cfg),
            ];
            eprintln!("{order:?}: plain {plain}; plain, shaded, voi, both, preint {row:?}");
            assert_eq!(row[0], plain);
            assert_eq!(row[1], composed(Some(1), false, false));
            assert_eq!(row[2], composed(None, true, false));
            assert_eq!(row[3], composed(Some(1), true, false));
            assert_eq!(row[4], composed(None, false, true));
            assert!(row[1..].iter().all(|&d| d > plain), "{row:?}");
            assert!(row[3] >= row[1].max(row[2]), "{row:?}");
            let stated = PipelineConfig {
                datapath_latency: 40,
                ..cfg
            };
            for units in [(false, false), (true, false), (false, true), (true, true)] {
                assert_eq!(unit_latency(&stated, units), 40);
            }
            assert_eq!(preint_latency(&stated), 40);
        }
    }

    /// A clock's schedule sets the plain depth, and a unit still deepens
    /// it.
    #[test]
    fn target_mhz_sets_the_plain_depth() {
        let d = PipelineConfig::default();
        let slow = PipelineConfig {
            target_mhz: 40,
            target_family: Target::Ecp5,
            ..d
        };
        slow.validate().unwrap();
        let c = crate::cost::fmax::schedule_for(&d, Target::Ecp5, 40.0).unwrap();
        assert_eq!(datapath_latency(&slow), c.depth);
        assert!(c.depth < datapath_latency(&d));
        assert!(shaded_latency(&slow) > datapath_latency(&slow));
    }
}
