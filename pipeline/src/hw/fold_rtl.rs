//! The PE's dense fold in Verilog (front to back): the differences, the
//! x and y tents of the Bartlett merge with the line buffer between them,
//! and the add of the kept final states, as one module
//! (`ercube_pe_fold`) driven by the controller's pass broadcast.
//!
//! Golden twin of the stage: [`crate::stages::fold`]'s `FoldGrids` (the
//! model this module is checked against, clock for clock, by
//! [`crate::cosim::fold`]), whose golden twin is the fold of
//! `golden::methods::render`, `result_(i-1) = final_(i-1) +
//! merge(result_i - inherited_i)`, with [`golden::merge::merge`]'s tent.
//!
//! What it holds: the pass's registers (the PE's child count and first
//! child, its held span, the back grid's first row and row count, the
//! front grid's first row, latched on `begin_fold`) and the line buffer
//! at its declared depth and width ([`crate::pe::Pe::declaration`]'s
//! `line_buffer`: 3 rows of the most children a PE computes, R, G, B, A
//! `merge` words). Each clock the x pass takes child `m = m0 + col`'s back
//! columns `2m - 1 ..= 2m + 1` of back row `x_row`: a held column's
//! difference `result - inherited` (its result word `h<k>_*`, a `merge`
//! word, less its inherited state `i<k>_*`, an accumulator word, assigned
//! into `merge`), the left neighbour's edge difference (`el_*`) for the
//! column just below the span, or zero; it writes their tent into the
//! line buffer at back row `x_row`'s slot (`x_row mod 3`). The y pass
//! reads back rows `2 my - 1 ..= 2 my + 1` of child row
//! `my = fg_lo + y_row` (a row outside the back grid reads zero), adds
//! their tent to the child's kept final state (`f_*`, an accumulator
//! word) into `merge` and drives it on the bank write port. The
//! arithmetic is [`folds`]' graph, emitted by
//! [`crate::hw::verilog::cut`].
//!
//! Not in the module: the compositing buffer's read of the held results
//! and inherited states (the deepest boundary's results are accumulator
//! words the read widens exactly into `merge`, whose fraction and integer
//! bits cover both accumulators'), the kept finals' read from the ray
//! buffer, the edge drive on the link, the children's bank itself, the
//! sparse fold's work lists (`pass_skip_empty`) and the bank swap of
//! `EndFold`.

use std::fmt::Write as _;

use super::merge_rtl::{x_taps, y_taps, y_words, MergeShape};
use super::pass_rtl::{self, PassHead, TENT_PASS_LATCHED};
use super::split_rtl::rng;
use super::tents::{tent, CHANNELS};
use super::Graph;
use crate::config::{Order, PipelineConfig};
use crate::cost::inventory::Geometry;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::rtl::RtlError;

/// The PE fold module's name.
pub const MODULE: &str = "ercube_pe_fold";

/// The formats, depths and counters of the fold: the merge's line buffer
/// and counters ([`MergeShape`]), front to back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FoldShape {
    /// The line buffer, formats and counters.
    pub pass: MergeShape,
}

impl FoldShape {
    /// The shape of `cfg`'s PE for the worst view of `geo`, from the PE's
    /// declaration; refused in one line where the module does not cover
    /// the configuration.
    pub fn new(cfg: &PipelineConfig, geo: &Geometry) -> Result<FoldShape, String> {
        if cfg.order != Order::FrontToBack {
            return Err("back to front has no fold (only front to back folds rays)".into());
        }
        Ok(FoldShape {
            pass: MergeShape::declared(cfg, geo, "fold")?,
        })
    }

    /// The shape for a frame of `view`.
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<FoldShape, String> {
        crate::host::plan(cfg, view).map_err(|e| e.to_string())?;
        let geo = Geometry::for_view(cfg, view).map_err(|e| e.to_string())?;
        FoldShape::new(cfg, &geo)
    }

    /// Register bits the module declares: the child count, five ray
    /// indices (the first child, the held span's ends, the grids' first
    /// rows), the back grid's row count, and the write ports' registers
    /// (each pass's valid bit and four `merge` words).
    pub fn register_bits(&self) -> u64 {
        let s = &self.pass;
        let ports = 2 * (1 + 4 * u32::from(s.merge.bits()));
        u64::from(s.col_bits() + 5 * RAY_INDEX_BITS + s.row_bits() + ports)
    }
}

/// The fold's arithmetic described once, per channel: the x pass's
/// differences `d_<ch>_<k>` of a result (`d.<ch>.<k>.r`, `merge`) less an
/// inherited state (`d.<ch>.<k>.i`, the accumulator), assigned into
/// `merge` as [`crate::datapath::Datapath::fold_diff`]; its tent of three
/// differences (`x.<ch>.<k>`) into `merge` (`x_<ch>`); the y pass's tent of
/// three line-buffer words (`y.<ch>.<k>`) into `merge` plus the kept final
/// state (`f.<ch>`, the accumulator), assigned into `merge` (`y_<ch>`) as
/// [`crate::datapath::Datapath::fold_add`].
pub fn folds(cfg: &PipelineConfig) -> Graph {
    let c = cfg;
    let mut g = Graph::new();
    let acc = |ch: usize| if ch < 3 { c.accum_color } else { c.accum_alpha };
    g.item("fold", "differences (R, G, B, A)", 0);
    for (ch, name) in CHANNELS.iter().enumerate() {
        for k in 0..3 {
            let r = g.input(&format!("d.{name}.{k}.r"), c.merge);
            let i = g.input(&format!("d.{name}.{k}.i"), acc(ch));
            let d = g.sum(&format!("d_{name}_{k}.s"), r, i, true);
            let q = g.quantize(&format!("d_{name}_{k}"), d, c.merge);
            g.output(&format!("d_{name}_{k}"), q);
        }
    }
    for pass in ["x", "y"] {
        g.item("fold", &format!("{pass} pass (R, G, B, A tents)"), 0);
        for (ch, name) in CHANNELS.iter().enumerate() {
            let p = [0, 1, 2].map(|k| g.input(&format!("{pass}.{name}.{k}"), c.merge));
            let t = tent(&mut g, &format!("{pass}_{name}.t"), p, c.merge);
            let out = if pass == "x" {
                t
            } else {
                let f = g.input(&format!("f.{name}"), acc(ch));
                let s = g.sum(&format!("y_{name}.s"), f, t, false);
                g.quantize(&format!("y_{name}"), s, c.merge)
            };
            g.output(&format!("{pass}_{name}"), out);
        }
    }
    g
}

/// The fold module of `shape` for `cfg` (whose formats `shape` holds).
pub fn emit(cfg: &PipelineConfig, shape: &FoldShape) -> Result<String, RtlError> {
    let s = &shape.pass;
    let g = folds(cfg);
    let mut ports: Vec<(String, String)> = Vec::new();
    let mut outs: Vec<(String, String)> = Vec::new();
    for ch in CHANNELS {
        for k in 0..3 {
            ports.push((format!("h{k}_{ch}"), format!("d.{ch}.{k}.r")));
            ports.push((format!("i{k}_{ch}"), format!("d.{ch}.{k}.i")));
            outs.push((format!("d{k}_{ch}"), format!("d_{ch}_{k}")));
        }
    }
    for pass in ["x", "y"] {
        for ch in CHANNELS {
            for k in 0..3 {
                ports.push((format!("{pass}{k}_{ch}"), format!("{pass}.{ch}.{k}")));
            }
            if pass == "y" {
                ports.push((format!("f_{ch}"), format!("f.{ch}")));
            }
            let n = if pass == "x" {
                format!("x_{ch}.t")
            } else {
                format!("y_{ch}")
            };
            outs.push((format!("t{pass}_{ch}"), n));
        }
    }
    let cut = pass_rtl::cut_named(&g, &ports, &outs, "fold's differences and tents")?;
    let mb = u32::from(s.merge.bits());
    let lw = 4 * mb;
    let (rb, ib) = (s.row_bits(), RAY_INDEX_BITS);
    // Ray index arithmetic: 2m + 1 of an index of ib bits, signed.
    let xw = ib + 3;
    let acc = pass_rtl::acc_bits(s.acc);
    let mw = [mb; 4];
    let mut v = String::new();
    let o = &mut v;
    pass_rtl::head(
        o,
        &PassHead {
            module: MODULE,
            what: "dense fold (the differences, the Bartlett merge's x and y
// tents with the line buffer between them, and the add of the kept finals)",
            source: "fold_rtl",
            notes:
                "//   begin_fold, begin_n, begin_m0, begin_lo, begin_hi, begin_bg_lo, begin_bg_rows,
//   begin_fg_lo            BeginFold: the children this PE computes (its kept finals)
//                          and the first, its held back columns' first and last index,
//                          the back grid's first row and rows, the front grid's first row
//   x_valid, x_row, y_valid, y_row, col
//                          the pass broadcast: the back row the x pass filters, the
//                          child row the y pass writes, the child column
//   h0_r..h2_a             child col's back columns 2m - 1, 2m, 2m + 1 in back row x_row:
//                          their results as the held columns give them (merge words)
//   i0_r..i2_a             and their inherited states (accumulator words)
//   el_r..el_a             the left neighbour's edge difference of row x_row (merge words)
//   f_r..f_a               the child's kept final state in child row y_row (accumulators)
//   lx_valid, lx_r..lx_a   the x pass's merge words written to the line buffer
//   w_valid, w_r..w_a      the y pass's child word (merge words) on the children's
//                          bank write port
// Lint: WIDTH is waived: counters and ray indices compare and add at their own
// widths (sign-extended where signed); UNUSEDSIGNAL is waived: a row's slot
// takes the low bits of its index.
",
            begin: "begin_fold",
            latched: TENT_PASS_LATCHED,
            parents: &[
                ("h0", mw),
                ("h1", mw),
                ("h2", mw),
                ("i0", acc),
                ("i1", acc),
                ("i2", acc),
                ("el", mw),
                ("f", acc),
            ],
            flags: &[],
            rows: s.rows,
            width: s.width,
            merge: s.merge,
            child: mw,
            col_bits: s.col_bits(),
            row_bits: rb,
        },
    );
    x_taps(o, xw, "back", "the left neighbour's last (lo - 1)", false);
    y_taps(o, s, xw, lw, "back");
    // The x tents' taps are the differences as the x pass picks them,
    // assigned after the logic that forms them; the y tents' the line
    // buffer's words.
    for (ch, n) in CHANNELS.iter().enumerate() {
        for k in 0..3 {
            let _ = writeln!(o, "  wire {} x{k}_{n};", rng(mb));
        }
        y_words(o, mb, ch);
    }
    pass_rtl::body(o, &cut);
    for n in CHANNELS {
        for k in 0..3 {
            let _ = writeln!(
                o,
                "  assign x{k}_{n} = held{k} ? d{k}_{n}_w : left{k} ? el_{n} : {mb}'d0;"
            );
        }
    }
    // The write ports' registers: the x pass's merge words as the line
    // buffer takes them, the y pass's child word as the bank takes it,
    // each on the outputs the clock after.
    let child = [0, 1, 2, 3].map(|ch| (mb, format!("ty_{}_w", CHANNELS[ch])));
    pass_rtl::write_ports(o, s.merge, "t", child, &[]);
    Ok(v)
}
