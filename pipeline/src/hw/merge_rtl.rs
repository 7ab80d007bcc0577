//! The PE's dense merge in Verilog: the x and y tents of the Bartlett
//! merge and the line buffer between them, as one module
//! (`ercube_pe_merge`) driven by the controller's pass broadcast.
//!
//! Golden twin of the stage: [`crate::stages::merge::MergePass`] (the
//! model this module is checked against, clock for clock, by
//! [`crate::cosim::merge`]), whose golden twin is
//! [`golden::merge::merge`].
//!
//! What it holds: the pass's registers (the PE's child count and first
//! child, its held span, the back grid's first row and row count, the
//! front grid's first row, latched on `begin_merge`) and the line buffer
//! at its declared depth and width ([`Pe::declaration`]'s `line_buffer`:
//! 3 rows of the most children a PE computes, R, G, B, A `merge` words).
//! Each clock the x pass takes child `m = m0 + col`'s parents
//! `2m - 1 ..= 2m + 1` of parent row `x_row`, each a held column's word
//! (`h0_*` .. `h2_*`, the compositing buffer's read), the left
//! neighbour's edge ray (`el_*`) for the column just below the span, the
//! right neighbour's (`er_*`) for the one just above, or zero, and
//! writes their tent into the line buffer at parent row `x_row`'s slot
//! (`x_row mod 3`); the y pass reads parent rows `2 my - 1 ..= 2 my + 1`
//! of child row `my = fg_lo + y_row` (a row outside the back grid reads
//! zero) and drives their tent on the bank write port. The y pass reads
//! before the clock edge that writes (the model's read-first buffer): the
//! line buffer is a register file read without a clock. The tents'
//! arithmetic is [`tents`]' graph, emitted by [`crate::hw::verilog::cut`].
//!
//! Not in the module: the compositing buffer's read of the held parents
//! (with the register that keeps a child's right parent as the next
//! child's left, priced with the pass), the edge drive on the links, the
//! children's bank itself, the sparse merge's work lists
//! (`pass_skip_empty`) and the bank swap of `EndMerge`.

use std::fmt::Write as _;

use super::pass_rtl::{self, PassHead, TENT_PASS_LATCHED};
use super::split_rtl::{bits_for, rng};
use super::tents::{tents, CHANNELS};
use crate::config::{Order, PipelineConfig};
use crate::cost::inventory::Geometry;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::fixed::Format;
use crate::pe::Pe;
use crate::rtl::RtlError;

/// The PE merge module's name.
pub const MODULE: &str = "ercube_pe_merge";

/// The formats, depths and counters of the merge for a configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MergeShape {
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
}

impl MergeShape {
    /// The shape of `cfg`'s PE for the worst view of `geo`, from the PE's
    /// declaration; refused in one line where the module does not cover
    /// the configuration.
    pub fn new(cfg: &PipelineConfig, geo: &Geometry) -> Result<MergeShape, String> {
        if cfg.order != Order::BackToFront {
            return Err("front to back has no merge (only back to front merges rays)".into());
        }
        MergeShape::declared(cfg, geo, "merge")
    }

    /// The shape of a dense boundary pass `what` that writes the line
    /// buffer `cfg`'s PE declares for `geo` (the merge's, the fold's),
    /// refused in one line for the sparse pass or a line buffer of another
    /// word.
    pub(crate) fn declared(
        cfg: &PipelineConfig,
        geo: &Geometry,
        what: &str,
    ) -> Result<MergeShape, String> {
        if cfg.pass_skip_empty {
            return Err(format!(
                "the sparse {what} (pass_skip_empty: its work lists) is not emitted yet"
            ));
        }
        let decls = Pe::declaration(cfg, geo);
        let lb = decls
            .iter()
            .find(|d| d.name == "line_buffer")
            .ok_or("the PE declares no line_buffer")?;
        let mb = u32::from(cfg.merge.bits());
        if lb.width != 4 * mb {
            return Err(format!(
                "the line buffer's word is declared {} bits; the {what} writes 4 merge words of {mb}",
                lb.width
            ));
        }
        Ok(MergeShape {
            pes: usize::from(cfg.pes),
            acc: [cfg.accum_color, cfg.accum_alpha],
            merge: cfg.merge,
            width: lb.depth.max(1),
            rows: lb.copies,
            max_rows: crate::cost::arch::ray_rows(geo),
        })
    }

    /// The shape for a frame of `view`.
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<MergeShape, String> {
        crate::host::plan(cfg, view).map_err(|e| e.to_string())?;
        let geo = Geometry::for_view(cfg, view).map_err(|e| e.to_string())?;
        MergeShape::new(cfg, &geo)
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
    /// Register bits the module declares: the child count, five ray
    /// indices (the first child, the held span's ends, the grids' first
    /// rows), the back grid's row count, and the write ports' registers
    /// (the x pass's valid bit and four `merge` words, the y pass's valid
    /// bit and four accumulator words).
    pub fn register_bits(&self) -> u64 {
        let acc = 3 * u32::from(self.acc[0].bits()) + u32::from(self.acc[1].bits());
        let ports = 1 + 4 * u32::from(self.merge.bits()) + 1 + acc;
        u64::from(self.col_bits() + 5 * RAY_INDEX_BITS + self.row_bits() + ports)
    }
}

/// Ray index `{m}{k}`, tap `k`'s of `2 {m} - 1 ..= 2 {m} + 1`, as a
/// Verilog expression of `xw`-bit signed words.
fn tap(m: &str, k: usize, xw: u32) -> String {
    match k {
        0 => format!("{m} + {m} - {xw}'sd1"),
        1 => format!("{m} + {m}"),
        _ => format!("{m} + {m} + {xw}'sd1"),
    }
}

/// The merge module of `shape` for `cfg` (whose formats `shape` holds).
pub fn emit(cfg: &PipelineConfig, s: &MergeShape) -> Result<String, RtlError> {
    let cut = pass_rtl::cut_passes(&tents(cfg), 3, "t", "merge's tents")?;
    let mb = u32::from(s.merge.bits());
    let lw = 4 * mb;
    let (rb, ib) = (s.row_bits(), RAY_INDEX_BITS);
    // Ray index arithmetic: 2m + 1 of an index of ib bits, signed.
    let xw = ib + 3;
    let w = s.width;
    let acc = pass_rtl::acc_bits(s.acc);
    let mut v = String::new();
    let o = &mut v;
    pass_rtl::head(
        o,
        &PassHead {
            module: MODULE,
            what: "dense merge (the Bartlett merge's x and y tents and
// the line buffer between them)",
            source: "merge_rtl",
            notes: "//   begin_merge, begin_n, begin_m0, begin_lo, begin_hi, begin_bg_lo, begin_bg_rows,
//   begin_fg_lo            BeginMerge: the children this PE computes (its report) and
//                          the first, its held columns' first and last index, the back
//                          grid's first row and rows, the front grid's first row
//   x_valid, x_row, y_valid, y_row, col
//                          the pass broadcast: the parent row the x pass filters, the
//                          child row the y pass writes, the child column
//   h0_r..h2_a             child col's parents 2m - 1, 2m, 2m + 1 in parent row x_row
//                          as the held columns give them (accumulator words)
//   el_r..el_a, er_r..er_a the left and right neighbours' edge rays of row x_row
//   lx_valid, lx_r..lx_a   the x pass's merge words written to the line buffer
//   w_valid, w_r..w_a      the y pass's child word (accumulators) on the children's
//                          bank write port
// Lint: WIDTH is waived: counters and ray indices compare and add at their own
// widths (sign-extended where signed); UNUSEDSIGNAL is waived: a row's slot
// takes the low bits of its index.
",
            begin: "begin_merge",
            latched: TENT_PASS_LATCHED,
            parents: &[
                ("h0", acc),
                ("h1", acc),
                ("h2", acc),
                ("el", acc),
                ("er", acc),
            ],
            flags: &[],
            rows: s.rows,
            width: w,
            merge: s.merge,
            child: acc,
            col_bits: s.col_bits(),
            row_bits: rb,
        },
    );
    x_taps(
        o,
        xw,
        "parent",
        "the left edge ray (lo - 1), the right (hi + 1)",
        true,
    );
    y_taps(o, s, xw, lw, "parent");
    // The tents' ports: the parents as the x pass picks them and the line
    // buffer's taps.
    for (ch, n) in CHANNELS.iter().enumerate() {
        let b = u32::from(s.acc_of(ch).bits());
        for k in 0..3 {
            let _ = writeln!(
                o,
                "  wire {r} x{k}_{n} = held{k} ? h{k}_{n} : left{k} ? el_{n} : right{k} ? er_{n} : {b}'d0;",
                r = rng(b),
            );
        }
        y_words(o, mb, ch);
    }
    pass_rtl::body(o, &cut);
    // The write ports' registers: the x pass's merge words as the line
    // buffer takes them, the y pass's child word as the bank takes it,
    // each on the outputs the clock after.
    let child = [0, 1, 2, 3].map(|ch| (acc[ch], format!("ty_{}_w", CHANNELS[ch])));
    pass_rtl::write_ports(o, s.merge, "t", child, &[]);
    Ok(v)
}

/// The x pass's three taps of child `m = m0 + col`: ray indices
/// `mx<k>` of its `what` columns `2m - 1 ..= 2m + 1`, each `held<k>`
/// (`lo ..= hi`), `left<k>` (just below the span) and with `right`
/// `right<k>` (just above); `beyond` names the taps beyond the span.
pub(super) fn x_taps(o: &mut String, xw: u32, what: &str, beyond: &str, right: bool) {
    let _ = writeln!(
        o,
        "  // The x pass: child m = m0 + col takes {what} columns 2m - 1 + k, each
  // held (lo ..= hi), {beyond} or zero.
  wire signed {xwr} m = m0 + $signed({{1'b0, col}});
  wire signed {xwr} lo_x = lo;
  wire signed {xwr} hi_x = hi;",
        xwr = rng(xw),
    );
    for k in 0..3 {
        let _ = writeln!(
            o,
            "  wire signed {xwr} mx{k} = {t};
  wire held{k} = mx{k} >= lo_x && mx{k} <= hi_x;
  wire left{k} = mx{k} + {xw}'sd1 == lo_x;",
            xwr = rng(xw),
            t = tap("m", k, xw),
        );
        if right {
            let _ = writeln!(o, "  wire right{k} = mx{k} - {xw}'sd1 == hi_x;");
        }
    }
}

/// The y pass's three line-buffer taps `t0` .. `t2` of child row
/// `my = fg_lo + y_row` (its `what` rows `2 my - 1 ..= 2 my + 1` less
/// `bg_x`, zero outside the `bg_rows` rows), and the x pass's write
/// address.
pub(super) fn y_taps(o: &mut String, s: &MergeShape, xw: u32, lw: u32, what: &str) {
    let _ = writeln!(
        o,
        "  // The y pass: child row my = fg_lo + y_row reads {what} rows
  // 2 my - 1 + k (relative to the back grid), zero outside it.
  wire signed {xwr} my = fg_lo + $signed({{1'b0, y_row}});
  wire signed {xwr} bg_x = bg_lo;",
        xwr = rng(xw),
    );
    let (rb, ab, w) = (s.row_bits(), s.addr_bits(), s.width);
    for k in 0..3 {
        let _ = writeln!(
            o,
            "  wire signed {xwr} r{k} = {t} - bg_x;
  wire in{k} = !r{k}[{xw1}] && r{k} < $signed({{1'b0, bg_rows}});
  wire {abr} t{k}_addr = (r{k}[{rb1}:0] % {rows}) * {w} + col;
  wire {lwr} t{k} = in{k} ? line_buffer[t{k}_addr] : {lw}'d0;",
            xwr = rng(xw),
            t = tap("my", k, xw),
            xw1 = xw - 1,
            abr = rng(ab),
            rb1 = rb - 1,
            rows = s.rows,
            lwr = rng(lw),
        );
    }
    let _ = writeln!(
        o,
        "  wire {} x_addr = (x_row % {}) * {w} + col;",
        rng(ab),
        s.rows
    );
}

/// The y pass's tent ports of channel `ch`: its `merge` word of each
/// line-buffer tap.
pub(super) fn y_words(o: &mut String, mb: u32, ch: usize) {
    let n = CHANNELS[ch];
    let lo = ch as u32 * mb;
    for k in 0..3 {
        let _ = writeln!(
            o,
            "  wire {m} y{k}_{n} = t{k}[{hi}:{lo}];",
            m = rng(mb),
            hi = lo + mb - 1,
        );
    }
}
