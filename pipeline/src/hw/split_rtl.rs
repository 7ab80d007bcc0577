//! The PE's dense split in Verilog: the x and y filters of the bilinear
//! split and the line buffer between them, as one module
//! (`ercube_pe_split`) driven by the controller's pass broadcast.
//!
//! Golden twin of the stage: [`crate::stages::split::SplitPass`] (the
//! model this module is checked against, clock for clock, by
//! [`crate::cosim::split`]), whose golden twin is
//! [`golden::merge::split`].
//!
//! What it holds: the pass's registers (the PE's child count, the front
//! grid's first row and row count, the back grid's first row, latched on
//! `begin_split`) and the line buffer at its declared depth and width
//! ([`Pe::declaration`]'s `line_buffer`: 3 rows of the most children a
//! PE computes, R, G, B, A `merge` words). Each clock the y pass reads
//! child `col` of the one or two parent rows child row `y_row` takes
//! (`floor(my / 2)` and, when `my` is odd, the next; a row outside the
//! front grid reads zero) and drives the mean, with its termination flag,
//! on the bank write port; the x pass writes the mean of the two parents
//! on `a_*`, `b_*` into the line buffer at parent row `x_row`'s slot
//! (`x_row mod 3`). The y pass reads before the clock edge that writes
//! (the model's read-first buffer): the line buffer is a register file
//! read without a clock. The halving arithmetic is [`halves`]' graph,
//! emitted by [`crate::hw::verilog::cut`].
//!
//! Not in the module: the parents' fetch (the held columns' compositing
//! buffer and the right neighbour's edge ray, the `a_*`/`b_*` ports), the
//! edge drive, the children's bank itself, the sparse split's work lists
//! (`pass_skip_empty`) and the bank swap of `EndSplit`.

use std::fmt::Write as _;

use super::pass_rtl::{self, Latch, PassHead};
use super::{Graph, Word};
use crate::config::{Order, PipelineConfig};
use crate::cost::inventory::Geometry;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::fixed::Format;
use crate::pe::Pe;
use crate::rtl::RtlError;

/// The PE split module's name.
pub const MODULE: &str = "ercube_pe_split";

/// The channels, in accumulator order.
pub const CHANNELS: [&str; 4] = ["r", "g", "b", "a"];

/// Bits to hold `0 ..= n` (at least one).
pub(super) fn bits_for(n: u64) -> u32 {
    (64 - n.leading_zeros()).max(1)
}

/// The formats, depths and counters of the split for a configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SplitShape {
    /// PEs in the array.
    pub pes: usize,
    /// The colour and opacity accumulators' formats.
    pub acc: [Format; 2],
    /// The line buffer's word format (`merge`).
    pub merge: Format,
    /// Entries of a line buffer row (the most children a PE computes).
    pub width: u64,
    /// Rows of the line buffer.
    pub rows: u32,
    /// The most rows a ray grid has (`2 ny + 1`).
    pub max_rows: u64,
    /// The termination comparator's threshold on the opacity word (none
    /// when termination is off).
    pub threshold: Option<i64>,
}

impl SplitShape {
    /// The shape of `cfg`'s PE for the worst view of `geo`, from the PE's
    /// declaration; refused in one line where the module does not cover
    /// the configuration.
    pub fn new(cfg: &PipelineConfig, geo: &Geometry) -> Result<SplitShape, String> {
        if cfg.order != Order::FrontToBack {
            return Err("back to front has no split (only front to back splits rays)".into());
        }
        if cfg.pass_skip_empty {
            return Err(
                "the sparse split (pass_skip_empty: its work lists) is not emitted yet".into(),
            );
        }
        let decls = Pe::declaration(cfg, geo);
        let lb = decls
            .iter()
            .find(|d| d.name == "line_buffer")
            .ok_or("the PE declares no line_buffer")?;
        let mb = u32::from(cfg.merge.bits());
        if lb.width != 4 * mb {
            return Err(format!(
                "the line buffer's word is declared {} bits; the split writes 4 merge words of {mb}",
                lb.width
            ));
        }
        Ok(SplitShape {
            pes: usize::from(cfg.pes),
            acc: [cfg.accum_color, cfg.accum_alpha],
            merge: cfg.merge,
            width: lb.depth.max(1),
            rows: lb.copies,
            max_rows: crate::cost::arch::ray_rows(geo),
            threshold: cfg.termination_raw(),
        })
    }

    /// The shape for a frame of `view`.
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<SplitShape, String> {
        crate::host::plan(cfg, view).map_err(|e| e.to_string())?;
        let geo = Geometry::for_view(cfg, view).map_err(|e| e.to_string())?;
        SplitShape::new(cfg, &geo)
    }

    /// The accumulator format of channel `ch`.
    pub fn acc_of(&self, ch: usize) -> Format {
        self.acc[usize::from(ch == 3)]
    }
    /// Bits of a column (child) counter, `0 ..= width`.
    pub fn col_bits(&self) -> u32 {
        bits_for(self.width)
    }
    /// Bits of a row counter, `0 ..= max_rows`.
    pub fn row_bits(&self) -> u32 {
        bits_for(self.max_rows)
    }
    /// Bits of a line buffer address (`slot * width + col`).
    pub fn addr_bits(&self) -> u32 {
        bits_for(u64::from(self.rows) * self.width - 1)
    }
    /// Memory bits the module declares (the line buffer).
    pub fn memory_bits(&self) -> u64 {
        u64::from(self.rows) * self.width * 4 * u64::from(self.merge.bits())
    }
    /// Register bits the module declares: the child count, the front
    /// grid's first row and row count, the back grid's first row, and the
    /// write ports' registers (the x pass's valid bit and four `merge`
    /// words, the y pass's valid bit, four accumulator words and flag).
    pub fn register_bits(&self) -> u64 {
        let acc = 3 * u32::from(self.acc[0].bits()) + u32::from(self.acc[1].bits());
        let ports = 1 + 4 * u32::from(self.merge.bits()) + 1 + acc + 1;
        u64::from(self.col_bits() + 2 * RAY_INDEX_BITS + self.row_bits() + ports)
    }
}

/// The split's halving taps described once: the x pass's mean of two
/// parents' accumulator words into `merge`, and the y pass's of two
/// line-buffer `merge` words back into the accumulators, per channel
/// `(p0 + p1) / 2` assigned into the pass's format, as
/// [`crate::datapath::Datapath::halve`]. Ports `x.<ch>.<k>`,
/// `y.<ch>.<k>`; outputs `x_<ch>`, `y_<ch>`.
pub fn halves(cfg: &PipelineConfig) -> Graph {
    let mut g = Graph::new();
    let acc = |ch: usize| {
        if ch < 3 {
            cfg.accum_color
        } else {
            cfg.accum_alpha
        }
    };
    for (pass, y) in [("x", false), ("y", true)] {
        g.item("split", &format!("{pass} pass (R, G, B, A halves)"), 0);
        for (ch, name) in CHANNELS.iter().enumerate() {
            let (from, to) = if y {
                (cfg.merge, acc(ch))
            } else {
                (acc(ch), cfg.merge)
            };
            let p = [0, 1].map(|k| g.input(&format!("{pass}.{name}.{k}"), from));
            let n = format!("{pass}_{name}");
            let s = g.sum(&format!("{n}.s"), p[0], p[1], false);
            let ws = g.word(s);
            let half = g.field(
                &format!("{n}.h"),
                s,
                0,
                Word {
                    frac: ws.frac + 1,
                    ..ws
                },
            );
            let q = g.quantize(&n, half, to);
            g.output(&n, q);
        }
    }
    g
}

/// `[n-1:0]`.
pub(super) fn rng(bits: u32) -> String {
    format!("[{}:0]", bits - 1)
}

/// The split module of `shape` for `cfg` (whose formats `shape` holds).
pub fn emit(cfg: &PipelineConfig, s: &SplitShape) -> Result<String, RtlError> {
    let cut = pass_rtl::cut_passes(&halves(cfg), 2, "h", "split's halves")?;
    let mb = u32::from(s.merge.bits());
    let lw = 4 * mb;
    let (rb, ab, ib) = (s.row_bits(), s.addr_bits(), RAY_INDEX_BITS);
    let w = s.width;
    let acc = pass_rtl::acc_bits(s.acc);
    let mut v = String::new();
    let o = &mut v;
    pass_rtl::head(
        o,
        &PassHead {
            module: MODULE,
            what: "dense split (the bilinear split's x and y filters and
// the line buffer between them)",
            source: "split_rtl",
            notes: "//   begin_split, begin_n, begin_fg_lo, begin_fg_rows, begin_bg_lo
//                          BeginSplit: the children this PE computes (its report), the
//                          front grid's first row and rows, the back grid's first row
//   x_valid, x_row, y_valid, y_row, col
//                          the pass broadcast: the parent row the x pass filters, the
//                          child row the y pass writes, the child column
//   a_r..a_a, b_r..b_a     child col's two parents in parent row x_row (accumulator words)
//   lx_valid, lx_r..lx_a   the x pass's merge words written to the line buffer
//   w_valid, w_r..w_a, w_done
//                          the y pass's child word (accumulators) and termination flag
//                          on the children's bank write port
// Lint: WIDTH is waived: counters compare and add at their own widths;
// UNUSEDSIGNAL is waived: a row's slot takes the low bits of its index.
",
            begin: "begin_split",
            latched: &[
                ("n", Latch::Count),
                ("fg_lo", Latch::Index),
                ("fg_rows", Latch::Rows),
                ("bg_lo", Latch::Index),
            ],
            parents: &[("a", acc), ("b", acc)],
            flags: &["w_done"],
            rows: s.rows,
            width: w,
            merge: s.merge,
            child: acc,
            col_bits: s.col_bits(),
            row_bits: rb,
        },
    );
    let done = match s.threshold {
        Some(t) if t <= 0 => "1'b1".to_owned(),
        Some(t) => {
            let ab_ = u32::from(s.acc[1].bits());
            if t >= 1i64 << ab_.min(62) {
                "1'b0".to_owned()
            } else {
                format!("w_a >= {ab_}'d{t}")
            }
        }
        None => "1'b0".to_owned(),
    };
    let _ = writeln!(
        o,
        "  // The y pass: child row my = bg_lo + y_row reads parent rows floor(my / 2)
  // and, when my is odd, the next (relative to the front grid).
  wire signed [{ib}:0] my = bg_lo + $signed({{1'b0, y_row}});
  wire signed [{ib}:0] py = my >>> 1;
  wire signed [{ib1}:0] r0 = py - fg_lo;
  wire signed [{ib1}:0] r1 = r0 + $signed({{{ib1}'d0, my[0]}});
  wire in0 = !r0[{ib1}] && r0 < $signed({{1'b0, fg_rows}});
  wire in1 = !r1[{ib1}] && r1 < $signed({{1'b0, fg_rows}});
  wire {abr} t0_addr = (r0[{rb1}:0] % {rows}) * {w} + col;
  wire {abr} t1_addr = (r1[{rb1}:0] % {rows}) * {w} + col;
  wire {lwr} t0 = in0 ? line_buffer[t0_addr] : {lw}'d0;
  wire {lwr} t1 = in1 ? line_buffer[t1_addr] : {lw}'d0;
  wire {abr} x_addr = (x_row % {rows}) * {w} + col;",
        lwr = rng(lw),
        abr = rng(ab),
        ib1 = ib + 1,
        rb1 = rb - 1,
        rows = s.rows,
    );
    // The halves' ports: the parents and the line buffer's taps.
    for (ch, n) in CHANNELS.iter().enumerate() {
        let lo = ch as u32 * mb;
        let _ = writeln!(
            o,
            "  wire {r} x0_{n} = a_{n};\n  wire {r} x1_{n} = b_{n};\n  wire {m} y0_{n} = t0[{hi}:{lo}];\n  wire {m} y1_{n} = t1[{hi}:{lo}];",
            r = rng(u32::from(s.acc_of(ch).bits())),
            m = rng(mb),
            hi = lo + mb - 1,
        );
    }
    pass_rtl::body(o, &cut);
    // The write ports' registers: the x pass's merge words as the line
    // buffer takes them, the y pass's child word and flag as the bank
    // takes them, each on the outputs the clock after.
    let child = [0, 1, 2, 3].map(|ch| (acc[ch], format!("hy_{}_w", CHANNELS[ch])));
    let flag = done.replace("w_a", "hy_a_w");
    pass_rtl::write_ports(o, s.merge, "h", child, &[("w_done", flag)]);
    Ok(v)
}
