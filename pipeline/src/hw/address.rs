//! The PE's address and schedule step around the sample datapath
//! ([`super::sample`]), described for the cost inventory: the row
//! schedule's run compare (is the held ray's index inside the broadcast
//! run), the clamp of the column the taps are read at (`x0`, the sample's
//! output) into the volume, the right tap one column on, the local column
//! in the PE's block and whether it is the neighbour's edge column; with
//! the pre-integration unit, the tests of the ray against the pass's
//! three rectangles ([`crate::host::PreStep`]). Golden twin: the clamps
//! of `golden::slices::bilinear`'s tap addresses.
//!
//! Ports: `x0` (the column, the position's integer bits), `last` (the
//! volume's last column), `base` (the block's first column), `width`
//! (its last local column), `last_col` (the volume's last column in the
//! block, a per-frame constant), `m` (the ray index), `run.lo`, `run.hi`
//! (the broadcast run), and with pre-integration the rectangles'
//! bounds `rect<r>.<bound>`.

use super::{Graph, Op, Word};
use crate::config::PipelineConfig;
use crate::cost::shapes::RAY_INDEX_BITS;

/// The rectangles a pre-integrated pass broadcasts: the rays that
/// composite a step, keep their sample, take slice 0's half step.
const RECTS: [&str; 3] = ["comp", "keep", "lead"];

/// The step's description for `cfg`, a PE whose block has `col_bits`
/// bits of local column, with the pre-integration unit's pass tests when
/// `preint`.
pub fn address(cfg: &PipelineConfig, col_bits: u32, preint: bool) -> Graph {
    let mut g = Graph::new();
    let idx = Word::signed(RAY_INDEX_BITS, 0);
    let int_bits = u32::from(cfg.position.bits() - cfg.position.frac()).max(1);
    let int = Word::signed(int_bits, 0);
    let col = Word::unsigned(col_bits, 0);
    let bit = Word::unsigned(1, 0);
    let m = g.input_word("m", idx);

    g.item("address", "schedule: ray index in run", 0);
    let lo = g.input_word("run.lo", idx);
    let hi = g.input_word("run.hi", idx);
    g.ge("run.from", m, lo);
    g.ge("run.to", hi, m);

    g.item(
        "address",
        "address: clamp, right tap, local column, edge",
        0,
    );
    let x0 = g.input_word("x0", int);
    let last = g.input_word("last", int);
    let base = g.input_word("base", int);
    let width = g.input_word("width", col);
    let last_col = g.input_word("last_col", col);
    let zero = g.constant("addr.zero", 0, bit);
    let one = g.constant("addr.one", 1, bit);
    let past = g.ge("addr.past", x0, last);
    let below = g.ge("addr.below", zero, x0);
    let local = g.sub("addr.local", x0, base, Word::signed(col_bits + 1, 0));
    let local = g.field("addr.col", local, 0, col);
    let right = g.add("addr.right", local, one, Word::unsigned(col_bits + 1, 0));
    let right = g.field("addr.right_col", right, 0, col);
    for (n, tap) in [("c0", local), ("c1", right)] {
        let kept = g.mux(&format!("addr.{n}.hi"), past, tap, last_col, col);
        let c = g.mux(&format!("addr.{n}"), below, kept, zero, col);
        g.step_out(c);
    }
    let edge = g.push("addr.edge", Op::Eq(local, width), bit, None);
    g.step_out(edge);

    if preint {
        // Per rectangle, two compares per axis (the ray index and the
        // row), ANDed by selects.
        let row = g.input_word("row", idx);
        for (r, name) in RECTS.iter().enumerate() {
            g.item(
                "address",
                "pre-integrated pass rays: comp, keep, lead",
                r as u32,
            );
            let mut inside = None;
            for (axis, v) in [("x", m), ("y", row)] {
                let from = g.input_word(&format!("{name}.{axis}0"), idx);
                let to = g.input_word(&format!("{name}.{axis}1"), idx);
                for (k, (a, b)) in [(v, from), (to, v)].into_iter().enumerate() {
                    let c = g.ge(&format!("{name}.{axis}.{k}"), a, b);
                    inside = Some(match inside {
                        None => c,
                        Some(p) => g.mux(&format!("{name}.{axis}.and{k}"), p, zero, c, bit),
                    });
                }
            }
            let flag = inside.expect("four compares");
            g.step_out(flag);
            g.output(name, flag);
        }
    }
    g.no_item();
    g
}
