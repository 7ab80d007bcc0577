//! The Bartlett merge's tents described once: the x pass's tent of three
//! parents' accumulator words into `merge`, and the y pass's of three
//! line-buffer `merge` words back into the accumulators, per channel
//! `(p[-1] + 2 p[0] + p[1]) / 4` assigned into the pass's format, as
//! [`crate::datapath::Datapath::tent`] (`hw::units_tests` checks it word
//! for word). Golden twin: `golden::merge::merge`'s tent.
//!
//! Ports: `x.<ch>.<k>` and `y.<ch>.<k>` (channel `r`, `g`, `b`, `a`,
//! tap `k` of 0, 1, 2). Tap 0 of the x pass is the previous child's
//! tap 2 (the parents overlap by one), held in a register the port
//! stands for: its bits are priced with the pass. Outputs: `x_<ch>` in
//! `merge`, `y_<ch>` in the channel's accumulator.

use super::{Graph, NodeId, Word};
use crate::config::PipelineConfig;
use crate::fixed::Format;

/// The channels, in accumulator order.
pub const CHANNELS: [&str; 4] = ["r", "g", "b", "a"];

/// One tent of taps `p` (in `from`) into `to`: `p0 + p2`, plus `2 p1`
/// (wires), read at two more fraction bits, assigned.
pub(super) fn tent(g: &mut Graph, name: &str, p: [NodeId; 3], to: Format) -> NodeId {
    let s02 = g.sum(&format!("{name}.s02"), p[0], p[2], false);
    let w1 = g.word(p[1]);
    let two = g.field(
        &format!("{name}.two"),
        p[1],
        -1,
        Word {
            bits: w1.bits + 1,
            ..w1
        },
    );
    let s = g.sum(&format!("{name}.s"), s02, two, false);
    let ws = g.word(s);
    let quarter = g.field(
        &format!("{name}.q"),
        s,
        0,
        Word {
            frac: ws.frac + 2,
            ..ws
        },
    );
    g.quantize(name, quarter, to)
}

/// The merge unit's description for `cfg`: both passes.
pub fn tents(cfg: &PipelineConfig) -> Graph {
    let c = cfg;
    let mut g = Graph::new();
    let acc = |ch: usize| if ch < 3 { c.accum_color } else { c.accum_alpha };
    for (pass, y) in [("x", false), ("y", true)] {
        g.item("merge", &format!("{pass} pass (R, G, B, A tents)"), 0);
        for (ch, name) in CHANNELS.iter().enumerate() {
            let (from, to) = if y {
                (c.merge, acc(ch))
            } else {
                (acc(ch), c.merge)
            };
            let p = [0, 1, 2].map(|k| g.input(&format!("{pass}.{name}.{k}"), from));
            if !y {
                // The previous child's right parent, held.
                g.step_out(p[0]);
            }
            let t = tent(&mut g, &format!("{pass}_{name}"), p, to);
            g.step_out(t);
            g.output(&format!("{pass}_{name}"), t);
        }
    }
    g
}
