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
//! The shading unit, the volume-of-interest stage and the pre-integration
//! unit are not described as graphs yet: each adds the extra depth the cost
//! inventory's step schedule derives for it ([`shading_extra_depth`],
//! [`voi_extra_depth`], [`preint_extra_depth`]), the difference between
//! that schedule with and without the unit. When a unit's graph exists,
//! its function returns the graph's scheduled depth over the plain one.

use crate::config::PipelineConfig;
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
    let g = crate::hw::sample::plain(cfg);
    if cfg.target_mhz > 0 {
        if let Ok(c) = super::fmax::clock_schedule(&g, cfg.target_family, f64::from(cfg.target_mhz))
        {
            return c.schedule;
        }
    }
    crate::hw::schedule::schedule(&g)
}

/// The plain sample datapath's depth: [`sample_schedule`]'s.
pub fn plain_depth(cfg: &PipelineConfig) -> u32 {
    sample_schedule(cfg).depth.max(1)
}

/// The inventory schedule's depth with `units` (shading, VOI) over its
/// plain one.
fn inventory_extra(cfg: &PipelineConfig, units: (bool, bool)) -> u32 {
    inventory::unit_schedule_depth(cfg, units).saturating_sub(inventory::schedule_depth(cfg))
}

/// The clocks the gradient and shading unit adds to the plain datapath:
/// the cost inventory's step schedule's (its gradient, normalisation and
/// shading steps between the classification and the opacity correction).
pub fn shading_extra_depth(cfg: &PipelineConfig) -> u32 {
    inventory_extra(cfg, (true, false))
}

/// The clocks the volume-of-interest stage adds to the plain datapath:
/// the cost inventory's step schedule's (the distance's square root, then
/// the weight and the opacity's scale before the opacity correction).
pub fn voi_extra_depth(cfg: &PipelineConfig) -> u32 {
    inventory_extra(cfg, (false, true))
}

/// The clocks the pre-integration unit adds to the plain datapath: the
/// cost inventory's step schedule's (its colour dividers beside the exp
/// stage).
pub fn preint_extra_depth(cfg: &PipelineConfig) -> u32 {
    inventory::preint_schedule_depth(cfg).saturating_sub(inventory::schedule_depth(cfg))
}

/// The clocks shading and the VOI add together: each unit's extra, or
/// the inventory's joint figure when both are on (the VOI's scale then
/// feeds the shading's gradient opacity, one path in series).
fn units_extra_depth(cfg: &PipelineConfig, (shading, voi): (bool, bool)) -> u32 {
    match (shading, voi) {
        (false, false) => 0,
        (true, false) => shading_extra_depth(cfg),
        (false, true) => voi_extra_depth(cfg),
        (true, true) => inventory_extra(cfg, (true, true)),
    }
}

/// The plain datapath's latency: [`PipelineConfig::datapath_latency`]
/// when set, else [`plain_depth`].
pub fn datapath_latency(cfg: &PipelineConfig) -> u32 {
    unit_latency(cfg, (false, false))
}

/// The latency of a datapath with the gradient and shading unit
/// (`shading`) and the volume-of-interest stage (`voi`): the configured
/// latency (the whole datapath's), or [`plain_depth`] plus the units'
/// extra depth.
pub fn unit_latency(cfg: &PipelineConfig, units: (bool, bool)) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    plain_depth(cfg) + units_extra_depth(cfg, units)
}

/// The latency of a datapath with the gradient and shading unit.
pub fn shaded_latency(cfg: &PipelineConfig) -> u32 {
    unit_latency(cfg, (true, false))
}

/// The latency of a datapath with the pre-integration unit
/// ([`crate::preint`], priced in [`super::preint`]) in the
/// classification's and the log table's place: the configured latency,
/// or [`plain_depth`] plus [`preint_extra_depth`].
pub fn preint_latency(cfg: &PipelineConfig) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    plain_depth(cfg) + preint_extra_depth(cfg)
}

/// The latency of a datapath with the units of `geo`.
pub fn geometry_latency(cfg: &PipelineConfig, geo: &inventory::Geometry) -> u32 {
    if geo.preint {
        preint_latency(cfg)
    } else {
        unit_latency(cfg, (geo.shading, geo.voi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Order;
    use crate::cost::Target;

    /// Each unit's latency is the plain schedule's depth plus the extra
    /// its inventory steps add, in both orders; the units only deepen it;
    /// a stated latency is the whole datapath's.
    #[test]
    fn unit_latencies_add_the_inventory_extra_to_the_plain_depth() {
        for order in [Order::BackToFront, Order::FrontToBack] {
            let cfg = PipelineConfig {
                order,
                ..PipelineConfig::default()
            };
            let plain = crate::hw::schedule::schedule(&crate::hw::sample::plain(&cfg)).depth;
            let inv = inventory::schedule_depth(&cfg);
            let row = [
                datapath_latency(&cfg),
                shaded_latency(&cfg),
                unit_latency(&cfg, (false, true)),
                unit_latency(&cfg, (true, true)),
                preint_latency(&cfg),
            ];
            eprintln!("{order:?}: plain {plain} (inventory {inv}); plain, shaded, voi, both, preint {row:?}");
            assert_eq!(row[0], plain);
            assert_eq!(row[1] - plain, inventory::shaded_schedule_depth(&cfg) - inv);
            assert_eq!(
                row[2] - plain,
                inventory::unit_schedule_depth(&cfg, (false, true)) - inv
            );
            assert_eq!(
                row[3] - plain,
                inventory::unit_schedule_depth(&cfg, (true, true)) - inv
            );
            assert_eq!(row[4] - plain, inventory::preint_schedule_depth(&cfg) - inv);
            assert!(row[1..].iter().all(|&d| d > plain), "{row:?}");
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

    /// A clock's schedule sets the plain depth, and a unit still adds its
    /// extra on top.
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
        assert_eq!(
            shaded_latency(&slow) - datapath_latency(&slow),
            shaded_latency(&d) - datapath_latency(&d)
        );
    }
}
