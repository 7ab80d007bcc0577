//! The sample datapath pipelined for a clock (`ercube cost
//! --target-mhz`): operators packed into stages while the delay model of
//! the parent module keeps each stage within the period.

use serde::Serialize;

use super::{model, node_path, Path};
use crate::config::PipelineConfig;
use crate::cost::Target;
use crate::hw::schedule::{registers_and_depth, Schedule};
use crate::hw::{Graph, Op};

/// The sample datapath pipelined for a clock: how many chains and
/// multipliers each stage holds, and what that costs in depth and
/// pipeline registers.
#[derive(Debug, Clone, Serialize)]
pub struct ClockSchedule {
    /// The family.
    pub target: Target,
    /// The clock asked for, MHz.
    pub target_mhz: f64,
    /// The predicted clock of the slowest stage, MHz (at least
    /// `target_mhz`).
    pub predicted_mhz: f64,
    /// Stages from the first to the outputs' register: the latency, clocks.
    pub depth: u32,
    /// Pipeline-register bits (delay lines included), as
    /// [`crate::hw::schedule::Schedule::register_bits`].
    pub register_bits: u64,
    /// The one-operator-per-stage schedule's depth, for comparison.
    pub one_op_depth: u32,
    /// Its register bits.
    pub one_op_register_bits: u64,
}

/// A graph's schedule for a clock, and the clock its slowest stage is
/// predicted to reach.
#[derive(Debug, Clone)]
pub struct Clocked {
    /// The stages, in the form `ercube rtl` emits and the model's latency
    /// reads ([`crate::cost::latency::sample_schedule`]).
    pub schedule: Schedule,
    /// The slowest stage's predicted clock, MHz (at least the target).
    pub predicted_mhz: f64,
}

/// Schedules `g` for `target_mhz` on `t`: as soon as possible, each
/// operator joining its operands' stage while the stage's predicted path
/// stays within the period, else starting the next stage (its operands
/// registered); a memory read or a declared register starts a stage, a
/// square root takes one stage per result bit. A one-line error when the
/// model has no figures for `t` or when one operator alone is slower than
/// the period.
pub fn clock_schedule(g: &Graph, t: Target, target_mhz: f64) -> Result<Clocked, String> {
    let model = model(t).ok_or_else(|| {
        format!(
            "target_mhz: no delay model for {} (no open timing flow to fit it to)",
            t.name()
        )
    })?;
    let budget = 1e3 / target_mhz;
    let consumers = g.consumers();
    let n = g.nodes.len();
    let mut stage = vec![0u32; n];
    let mut reads = vec![0u32; n];
    let mut arrive = vec![Path::default(); n];
    let mut worst = 0.0f64;
    for i in 0..n {
        let id = crate::hw::NodeId(i);
        let op = g.node(id).op;
        let own = node_path(t, g, id, &consumers);
        let ops = op.operands();
        let s = ops.iter().map(|o| stage[o.0]).max().unwrap_or(0);
        let (st, r, arr) = match op {
            Op::Input => (crate::hw::schedule::port_stage(g, i), 0, Path::default()),
            Op::Const(_) => (0, 0, Path::default()),
            Op::Reg(_) => (s + 1, s, Path::default()),
            Op::Read(..) => (
                s + 1,
                s,
                Path {
                    brams: 1.0,
                    ..Path::default()
                },
            ),
            Op::Isqrt(_) => {
                // One stage per result bit, each one chain.
                let k = g.node(id).word.bits.max(1);
                (s + k, s + 1, own)
            }
            _ => {
                let joined = ops
                    .iter()
                    .filter(|o| stage[o.0] == s)
                    .map(|o| arrive[o.0])
                    .fold(Path::default(), |a, b| {
                        if model.period_ns(&b) > model.period_ns(&a) {
                            b
                        } else {
                            a
                        }
                    })
                    .then(own);
                if model.period_ns(&joined) <= budget {
                    (s, s, joined)
                } else {
                    (s + 1, s + 1, own)
                }
            }
        };
        let ns = model.period_ns(&arr);
        if ns > budget {
            let what = if arr == Path::default() {
                "a register-to-register hop".to_owned()
            } else {
                g.node(id).name.clone()
            };
            return Err(format!(
                "target_mhz = {target_mhz}: no schedule reaches it on {}: {what} alone is predicted at {:.1} MHz",
                t.name(),
                1e3 / ns
            ));
        }
        worst = worst.max(ns);
        stage[i] = st;
        reads[i] = r;
        arrive[i] = arr;
    }
    let (register_bits, depth) = registers_and_depth(g, &stage, &reads);
    Ok(Clocked {
        schedule: Schedule {
            stage,
            reads,
            depth,
            register_bits,
        },
        predicted_mhz: 1e3 / worst.max(model.base_ns),
    })
}

/// Schedules [`crate::hw::sample::plain`] for `target_mhz` on `t`
/// ([`clock_schedule`]), against the one-operator-per-stage schedule.
pub fn schedule_for(
    cfg: &PipelineConfig,
    t: Target,
    target_mhz: f64,
) -> Result<ClockSchedule, String> {
    let g = crate::hw::sample::plain(cfg);
    let c = clock_schedule(&g, t, target_mhz)?;
    let one = crate::hw::schedule::schedule(&g);
    Ok(ClockSchedule {
        target: t,
        target_mhz,
        predicted_mhz: c.predicted_mhz,
        depth: c.schedule.depth,
        register_bits: c.schedule.register_bits,
        one_op_depth: one.depth,
        one_op_register_bits: one.register_bits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::fmax::stage_prediction as pe_prediction;

    /// A slower clock packs more operators a stage: fewer stages and
    /// register bits; a clock no single operator reaches is refused.
    #[test]
    fn slower_clocks_need_fewer_stages() {
        let cfg = PipelineConfig::default();
        let pe = pe_prediction(&cfg, Target::Ecp5).unwrap();
        let fast = schedule_for(&cfg, Target::Ecp5, pe.mhz * 0.99).unwrap();
        let slow = schedule_for(&cfg, Target::Ecp5, pe.mhz / 3.0).unwrap();
        assert!(fast.predicted_mhz >= pe.mhz * 0.99, "{fast:?}");
        assert!(slow.depth < fast.depth, "{slow:?} {fast:?}");
        assert!(slow.register_bits < fast.register_bits);
        let e = schedule_for(&cfg, Target::Ecp5, 2000.0).unwrap_err();
        assert!(
            e.contains("no schedule reaches") && !e.contains('\n'),
            "{e}"
        );
        assert!(schedule_for(&cfg, Target::Xc7, 100.0).is_err());
    }
}
