//! The pre-integration unit described once: a step's table positions,
//! the table read, the bilinear interpolation of its four channels, `p =
//! tau len` into the opacity correction's `2^-p` stage
//! (`hw::sample::transmit`) and the colour dividers, as
//! [`crate::preint::PreintUnit::lookup`] and
//! [`crate::preint::PreintUnit::step`] (`hw::units_tests` checks it word
//! for word). Golden twins: `golden::preint::PreTable::lookup` and
//! `golden::preint::segment_opacity`.
//!
//! The table is read, not described: its words are whatever the host
//! loads. It is two banks per channel by the front bin's parity (even
//! rows `0, 2, ..`, odd rows `1, 3, ..`, each row `bins + 1` words), so
//! that a step's four words are two reads of each dual-read bank: the
//! even bank at row `ceil(i / 2)`, the odd at `floor(i / 2)`, columns `j`
//! and `j + 1`; a select by `i`'s parity puts the rows back in order.
//!
//! Ports: the step's front scalar `front` (the sample), the ray's
//! previous sample `prev`, the lead flag `lead` (slice 0's half step: its
//! back scalar is the front one, its path half the step's), the half-path
//! flag `half` (the last slice's step to the volume's face: its path half
//! the step's, its back scalar `prev`), the per-frame table scale `scale`
//! (`K`, in `step`) and the ray's path per slice step `len` (`path`): the
//! model's `lookup(front, lead ? front : prev)` and `step(.., half ||
//! lead)`.
//! Outputs: `visible` (the extinction is not zero), the colour `c_r`,
//! `c_g`, `c_b` (`color`) and the opacity `alpha` (`opacity_corr`).

use super::{Graph, MemId, NodeId, Word};
use crate::config::PipelineConfig;
use crate::cost::inventory::addr_bits;
use crate::fixed::Format;
use crate::preint::GUARD_BITS;

/// The channels: R, G, B (`preint_color`) and the extinction
/// (`preint_tau`).
pub const CHANNELS: [&str; 4] = ["r", "g", "b", "tau"];

/// Bins per table axis ([`crate::cost::preint::bins`]).
pub fn bins(cfg: &PipelineConfig) -> u64 {
    crate::cost::preint::bins(cfg)
}

/// The memory of channel `ch`'s even (`odd` false) or odd bank, by name.
pub fn bank_name(ch: usize, odd: bool) -> String {
    format!(
        "preint_{}_{}",
        CHANNELS[ch],
        if odd { "odd" } else { "even" }
    )
}

/// `x n` for the constant `n`: a shift-add, one adder per set bit past
/// the first.
fn times(g: &mut Graph, name: &str, x: NodeId, n: u64, bits: u32) -> NodeId {
    let w = Word::unsigned(bits, 0);
    let mut acc: Option<NodeId> = None;
    for b in (0..64i32).filter(|&b| n >> b & 1 == 1) {
        let t = g.field(&format!("{name}.t{b}"), x, -b, w);
        acc = Some(match acc {
            None => t,
            Some(a) => g.add(&format!("{name}.a{b}"), a, t, w),
        });
    }
    acc.expect("a positive constant")
}

/// A table position: `s K` exact, its integer part clamped at the last
/// bin (index and weight 0 there), the weight from its fraction.
fn position(g: &mut Graph, c: &PipelineConfig, name: &str, s: NodeId, k: NodeId) -> [NodeId; 2] {
    let f = g.mul_exact(&format!("{name}.f"), s, k);
    let wf = g.word(f);
    let frac = wf.frac.max(0);
    let last = bins(c) - 1;
    let int_bits = (wf.bits as i32 - frac).max(1) as u32;
    let int = g.field(&format!("{name}.int"), f, frac, Word::unsigned(int_bits, 0));
    let lastc = g.constant(
        &format!("{name}.last"),
        i128::from(last),
        Word::unsigned(addr_bits(last + 1), 0),
    );
    let clamp = g.ge(&format!("{name}.clamp"), int, lastc);
    let bb = addr_bits(bins(c));
    let idx = g.mux(
        &format!("{name}.index"),
        clamp,
        int,
        lastc,
        Word::unsigned(bb, 0),
    );
    let ww: Word = c.weight.into();
    let w = if frac > 0 {
        let rem = g.field(
            &format!("{name}.rem"),
            f,
            0,
            Word::unsigned(frac as u32, frac),
        );
        let wq = g.quantize(&format!("{name}.wq"), rem, c.weight);
        let zero = g.constant(&format!("{name}.zero"), 0, ww);
        g.mux(&format!("{name}.w"), clamp, wq, zero, ww)
    } else {
        g.constant(&format!("{name}.w"), 0, ww)
    };
    g.step_out(idx);
    g.step_out(w);
    [idx, w]
}

/// The unit's description for `cfg`.
pub fn preint(cfg: &PipelineConfig) -> Graph {
    let c = cfg;
    let mut g = Graph::new();
    let n = bins(c) + 1;
    let rows = [n.div_ceil(2), n / 2];
    let mut banks: Vec<[MemId; 2]> = Vec::new();
    for ch in 0..4 {
        let f = if ch < 3 { c.preint_color } else { c.preint_tau };
        banks.push([false, true].map(|odd| {
            let r = rows[usize::from(odd)];
            g.mem(&bank_name(ch, odd), r * n, f)
        }));
    }
    let exp = g.mem(
        super::sample::MEMORIES[5],
        (1 << c.exp_table_bits) + 1,
        c.opacity_corr,
    );
    g.no_item();
    let front = g.input("front", c.sample);
    let prev = g.input("prev", c.sample);
    let lead = g.input_word("lead", Word::unsigned(1, 0));
    let half_in = g.input_word("half", Word::unsigned(1, 0));
    let k = g.input("scale", c.step);
    // A lead step's path is halved too: a select, no carry chain.
    let one_bit = g.constant("pre.half_one", 1, Word::unsigned(1, 0));
    let half = g.mux(
        "pre.half_path",
        lead,
        half_in,
        one_bit,
        Word::unsigned(1, 0),
    );
    let len = g.input("len", c.path);

    // 1. Table positions: the front's bin i, the back's j (a lead step's
    // back scalar is its front one).
    g.item("preint", "table position f = s K (front, back)", 0);
    let [i, wi] = position(&mut g, c, "pre.front", front, k);
    g.item("preint", "table position f = s K (front, back)", 1);
    let back = g.mux("pre.back", lead, prev, front, c.sample.into());
    let [j, wj] = position(&mut g, c, "pre.back_pos", back, k);

    // 2. The bank addresses: row (bins + 1) + j and its j + 1.
    g.item("preint", "table address (2 banks x 2 ports)", 0);
    let ab = addr_bits(rows[0] * n);
    let one = g.constant("pre.one", 1, Word::unsigned(1, 0));
    let ib = g.word(i).bits;
    let i1 = g.add("pre.i1", i, one, Word::unsigned(ib + 1, 0));
    let even_row = g.field("pre.row_even", i1, 1, Word::unsigned(ib, 0));
    let odd_row = g.field("pre.row_odd", i, 1, Word::unsigned(ib.max(2) - 1, 0));
    let parity = g.field("pre.parity", i, 0, Word::unsigned(1, 0));
    let mut addr = Vec::new();
    for (r, row) in [("even", even_row), ("odd", odd_row)] {
        let base = times(&mut g, &format!("pre.{r}.base"), row, n, ab);
        let a0 = g.add(&format!("pre.{r}.a0"), base, j, Word::unsigned(ab, 0));
        let a1 = g.add(&format!("pre.{r}.a1"), a0, one, Word::unsigned(ab, 0));
        g.step_out(a0);
        g.step_out(a1);
        addr.push([a0, a1]);
    }
    g.step_out(parity);

    // 3. The reads, rows put back in order, and the lerps: along the back
    // scalar on both rows, then along the front.
    // The items in the inventory's order.
    for it in [
        "table rows i, i+1: swap by i's parity",
        "back lerp, colour (R, G, B; rows i, i+1)",
        "back lerp, extinction (rows i, i+1)",
        "front lerp, colour (R, G, B)",
        "front lerp, extinction",
    ] {
        g.item("preint", it, 0);
    }
    let mut out = Vec::new();
    for (ch, name) in CHANNELS.iter().enumerate() {
        let f: Format = if ch < 3 { c.preint_color } else { c.preint_tau };
        g.no_item();
        let read = |g: &mut Graph, odd: usize, col: usize| {
            let nm = format!("pre.{name}.{}{col}", ["e", "o"][odd]);
            g.read(&nm, banks[ch][odd], addr[odd][col])
        };
        let e = [read(&mut g, 0, 0), read(&mut g, 0, 1)];
        let o = [read(&mut g, 1, 0), read(&mut g, 1, 1)];
        let fw: Word = f.into();
        let mut rows_in_order = [[NodeId(0); 2]; 2];
        for (row, words) in rows_in_order.iter_mut().enumerate() {
            g.item(
                "preint",
                "table rows i, i+1: swap by i's parity",
                row as u32,
            );
            for (col, word) in words.iter_mut().enumerate() {
                // Row i is the even bank's when i is even.
                let (ev, od) = (e[col], o[col]);
                let (fv, tv) = if row == 0 { (ev, od) } else { (od, ev) };
                *word = g.mux(&format!("pre.{name}.row{row}{col}"), parity, fv, tv, fw);
            }
        }
        let (back_item, front_item, copies) = if ch < 3 {
            (
                "back lerp, colour (R, G, B; rows i, i+1)",
                "front lerp, colour (R, G, B)",
                ch as u32,
            )
        } else {
            (
                "back lerp, extinction (rows i, i+1)",
                "front lerp, extinction",
                0,
            )
        };
        g.item("preint", back_item, 2 * copies);
        let [a, b] = rows_in_order[0];
        let top = g.lerp(&format!("pre.{name}.top"), a, Some(b), wj, f);
        g.step_out(top);
        g.item("preint", back_item, 2 * copies + 1);
        let [cc, d] = rows_in_order[1];
        let bot = g.lerp(&format!("pre.{name}.bot"), cc, Some(d), wj, f);
        g.step_out(bot);
        g.item("preint", front_item, copies);
        let v = g.lerp(&format!("pre.{name}"), top, Some(bot), wi, f);
        g.step_out(v);
        out.push(v);
    }
    let tau = out[3];
    g.item("preint", "extinction != 0", 0);
    let visible = g.nonzero("visible", tau);
    g.step_out(visible);

    // 4. p = tau len (a half step's one bit lower), then the 2^-p stage.
    g.item("preint", "p = tau len", 0);
    let prod = g.mul_exact("pre.p.prod", tau, len);
    let pw = g.word(prod);
    let halved = g.field(
        "pre.p.half",
        prod,
        0,
        Word {
            frac: pw.frac + 1,
            ..pw
        },
    );
    let sel = g.mux(
        "pre.p.sel",
        half,
        prod,
        halved,
        Word {
            bits: pw.bits + 1,
            frac: pw.frac + 1,
            ..pw
        },
    );
    let p = g.quantize("p", sel, c.log_transmittance);
    let alpha = super::sample::transmit(&mut g, c, p, exp);

    // 5. The colour dividers min(wc / tau, 1) into `color`.
    let qf = i32::from(c.color.frac()) + GUARD_BITS;
    let qw = Word::unsigned((qf + 1).max(1) as u32, qf);
    let onec = g.constant("pre.one_q", 1, Word::unsigned(1, 0));
    let mut rgb = Vec::new();
    for (ch, name) in CHANNELS[..3].iter().enumerate() {
        let pc = c.preint_color.bits();
        let pt = c.preint_tau.bits();
        g.item(
            "preint",
            &format!("colour min(wc / tau, 1) ({pc}b / {pt}b)"),
            ch as u32,
        );
        let q = g.div(&format!("pre.{name}.q"), out[ch], tau, qw);
        let m = g.min(&format!("pre.{name}.min"), q, onec);
        let col = g.quantize(&format!("c_{name}"), m, c.color);
        g.step_out(col);
        rgb.push(col);
    }
    g.output("visible", visible);
    for (name, &x) in CHANNELS[..3].iter().zip(&rgb) {
        g.output(&format!("c_{name}"), x);
    }
    g.output("alpha", alpha);
    g
}
