//! What the boundary passes' modules (the split, [`super::split_rtl`];
//! the merge, [`super::merge_rtl`]) share: the header comment and port list, the registers `begin_*` latches,
//! the cut of the pass's arithmetic from its graph, and the write ports'
//! registers with the line buffer's write. Each module adds its own
//! taps, parents and notes.

use std::fmt::Write as _;

use super::split_rtl::rng;
use super::tents::CHANNELS;
use super::verilog::Cut;
use super::{Graph, NodeId};
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::fixed::Format;
use crate::rtl::RtlError;

/// The width of a register `begin_*` latches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Latch {
    /// A child count (column counter bits, unsigned).
    Count,
    /// A ray index (signed).
    Index,
    /// A row count (row counter bits, unsigned).
    Rows,
}

/// The registers a tent pass over the held columns (the merge, the fold)
/// latches from its `begin_*`, in port order: the PE's child count, its
/// first child, its held span, the back grid's first row and rows, the
/// front grid's first row.
pub(super) const TENT_PASS_LATCHED: &[(&str, Latch)] = &[
    ("n", Latch::Count),
    ("m0", Latch::Index),
    ("lo", Latch::Index),
    ("hi", Latch::Index),
    ("bg_lo", Latch::Index),
    ("bg_rows", Latch::Rows),
    ("fg_lo", Latch::Index),
];

/// A boundary pass module's shared parts.
pub(super) struct PassHead<'a> {
    /// The module's name.
    pub module: &'a str,
    /// What it is, after "one PE's ": the header comment's first lines.
    pub what: &'a str,
    /// The emitting module under `pipeline::hw`.
    pub source: &'a str,
    /// The comment lines after `clk, rst`'s: the pass's ports and lint
    /// waivers, each line starting `//`.
    pub notes: &'a str,
    /// The broadcast's latch strobe (`begin_split`).
    pub begin: &'a str,
    /// The registers it latches from `begin_<name>`, in port order.
    pub latched: &'a [(&'a str, Latch)],
    /// The x pass's parent inputs: a name and each channel's bits.
    pub parents: &'a [(&'a str, [u32; 4])],
    /// One-bit outputs after the child word (`w_done`).
    pub flags: &'a [&'a str],
    /// Rows of the line buffer.
    pub rows: u32,
    /// Entries of a line buffer row.
    pub width: u64,
    /// The line buffer's word format (`merge`).
    pub merge: Format,
    /// The child word's channels' bits (the accumulators').
    pub child: [u32; 4],
    /// Bits of a column counter.
    pub col_bits: u32,
    /// Bits of a row counter.
    pub row_bits: u32,
}

/// Each channel's accumulator bits of `acc` (colour, opacity).
pub(super) fn acc_bits(acc: [Format; 2]) -> [u32; 4] {
    [0, 1, 2, 3].map(|ch| u32::from(acc[usize::from(ch == 3)].bits()))
}

/// Writes the header comment, the port list, the line buffer's and the
/// latched registers' declarations with their reset and latch, and
/// `here` (the column is one of this PE's children).
pub(super) fn head(o: &mut String, h: &PassHead) {
    let mb = u32::from(h.merge.bits());
    let lw = 4 * mb;
    let (cb, rb, ib) = (h.col_bits, h.row_bits, RAY_INDEX_BITS);
    let w = h.width;
    let width = |l: Latch| match l {
        Latch::Count => format!("{} ", rng(cb)),
        Latch::Index => format!("signed {} ", rng(ib)),
        Latch::Rows => format!("{} ", rng(rb)),
    };
    let zero = |l: Latch| match l {
        Latch::Count => format!("{cb}'d0"),
        Latch::Index => format!("{ib}'sd0"),
        Latch::Rows => format!("{rb}'d0"),
    };
    let _ = write!(
        o,
        "// {m}: one PE's {what}, emitted by ercube (pipeline::hw::{src}).
//
// line_buffer: {rows} rows x {w} children x {lw} bits ({{a, b, g, r}} merge words of
//   {mb} bits, r at bit 0), child c of parent row q at (q mod {rows}) * {w} + c; a
//   register file read without a clock (the y pass reads before the x pass
//   writes at the clock edge).
// Ports:
//   clk, rst               synchronous reset of every register
{notes}/* verilator lint_off WIDTH */
/* verilator lint_off UNUSEDSIGNAL */
module {m} (
  input  wire clk,
  input  wire rst,
  input  wire {begin},
",
        m = h.module,
        what = h.what,
        src = h.source,
        rows = h.rows,
        notes = h.notes,
        begin = h.begin,
    );
    for (n, l) in h.latched {
        let _ = writeln!(o, "  input  wire {}begin_{n},", width(*l));
    }
    let _ = writeln!(
        o,
        "  input  wire x_valid,
  input  wire {rbr} x_row,
  input  wire y_valid,
  input  wire {rbr} y_row,
  input  wire {cbr} col,",
        rbr = rng(rb),
        cbr = rng(cb),
    );
    for (p, bits) in h.parents {
        for (n, b) in CHANNELS.iter().zip(bits) {
            let _ = writeln!(o, "  input  wire {} {p}_{n},", rng(*b));
        }
    }
    let _ = writeln!(o, "  output wire lx_valid,");
    for n in CHANNELS {
        let _ = writeln!(o, "  output wire {} lx_{n},", rng(mb));
    }
    let _ = writeln!(o, "  output wire w_valid,");
    for (ch, n) in CHANNELS.iter().enumerate() {
        let last = ch == 3 && h.flags.is_empty();
        let sep = if last { "" } else { "," };
        let _ = writeln!(o, "  output wire {} w_{n}{sep}", rng(h.child[ch]));
    }
    for (i, f) in h.flags.iter().enumerate() {
        let sep = if i + 1 == h.flags.len() { "" } else { "," };
        let _ = writeln!(o, "  output wire {f}{sep}");
    }
    let _ = writeln!(
        o,
        ");
  (* no_rw_check *) reg {} line_buffer [0:{}];",
        rng(lw),
        u64::from(h.rows) * w - 1
    );
    for (n, l) in h.latched {
        let _ = writeln!(o, "  reg {}{n};", width(*l));
    }
    let _ = writeln!(o, "  always @(posedge clk) begin\n    if (rst) begin");
    for (n, l) in h.latched {
        let _ = writeln!(o, "      {n} <= {};", zero(*l));
    }
    let _ = writeln!(o, "    end else if ({}) begin", h.begin);
    for (n, _) in h.latched {
        let _ = writeln!(o, "      {n} <= begin_{n};");
    }
    let _ = writeln!(o, "    end\n  end\n  wire here = col < n;");
}

/// The cut of `g`'s two passes: ports `<pass><k>_<ch>` for taps
/// `0..taps` (nodes `<pass>.<ch>.<k>`), outputs `<out><pass>_<ch>`
/// (nodes `<pass>_<ch>`); refused when the cut needs a register.
pub(super) fn cut_passes(g: &Graph, taps: usize, out: &str, what: &str) -> Result<Cut, RtlError> {
    let mut ports: Vec<(String, String)> = Vec::new();
    let mut outs: Vec<(String, String)> = Vec::new();
    for pass in ["x", "y"] {
        for ch in CHANNELS {
            for k in 0..taps {
                ports.push((format!("{pass}{k}_{ch}"), format!("{pass}.{ch}.{k}")));
            }
            outs.push((format!("{out}{pass}_{ch}"), format!("{pass}_{ch}")));
        }
    }
    cut_named(g, &ports, &outs, what)
}

/// The cut of `g` from `ports` to `outs` (each a Verilog name and the
/// graph node's); refused when the cut needs a register.
pub(super) fn cut_named(
    g: &Graph,
    ports: &[(String, String)],
    outs: &[(String, String)],
    what: &str,
) -> Result<Cut, RtlError> {
    let find = |n: &str| -> NodeId {
        g.nodes
            .iter()
            .position(|x| x.name == n)
            .map(NodeId)
            .unwrap_or_else(|| panic!("a node {n} of {what}"))
    };
    let pr: Vec<(&str, NodeId)> = ports.iter().map(|(v, n)| (v.as_str(), find(n))).collect();
    let or: Vec<(&str, NodeId)> = outs.iter().map(|(v, n)| (v.as_str(), find(n))).collect();
    let cut = super::verilog::cut(g, &pr, &or)?;
    if !cut.regs.is_empty() {
        return Err(RtlError::Unsupported(format!(
            "a register inside the {what}"
        )));
    }
    Ok(cut)
}

/// Writes the cut's logic and its outputs as `<name>_w` wires.
pub(super) fn body(o: &mut String, cut: &Cut) {
    o.push_str(cut.body.text());
    for (name, bits, src) in &cut.outputs {
        let _ = writeln!(o, "  wire {} {name}_w = {src};", rng(*bits));
    }
}

/// The write ports' registers: the x pass's `merge` words (`<out>x_<ch>_w`)
/// as the line buffer takes them, the y pass's child word as `child`
/// gives each channel (bits, source) and `flags` (name, source), each on
/// the outputs the clock after; the line buffer's write at `x_addr`; the
/// module's end.
pub(super) fn write_ports(
    o: &mut String,
    merge: Format,
    out: &str,
    child: [(u32, String); 4],
    flags: &[(&str, String)],
) {
    let mb = u32::from(merge.bits());
    let mut regs: Vec<(String, u32, String)> =
        vec![("lx_valid".into(), 1, "x_valid && here".into())];
    regs.extend(CHANNELS.iter().map(|n| {
        (
            format!("lx_{n}"),
            mb,
            format!("x_valid && here ? {out}x_{n}_w : {mb}'d0"),
        )
    }));
    regs.push(("w_valid".into(), 1, "y_valid && here".into()));
    for (n, (b, src)) in CHANNELS.iter().zip(child) {
        regs.push((
            format!("w_{n}"),
            b,
            format!("y_valid && here ? {src} : {b}'d0"),
        ));
    }
    for (n, d) in flags {
        regs.push(((*n).into(), 1, format!("y_valid && here && ({d})")));
    }
    for (n, b, _) in &regs {
        let _ = writeln!(o, "  reg {} q_{n};\n  assign {n} = q_{n};", rng(*b));
    }
    let _ = writeln!(
        o,
        "  always @(posedge clk) begin
    if (x_valid && here) line_buffer[x_addr] <= {{{out}x_a_w, {out}x_b_w, {out}x_g_w, {out}x_r_w}};
  end
  always @(posedge clk) begin
    if (rst) begin"
    );
    for (n, b, _) in &regs {
        let _ = writeln!(o, "      q_{n} <= {b}'d0;");
    }
    let _ = writeln!(o, "    end else begin");
    for (n, _, d) in &regs {
        let _ = writeln!(o, "      q_{n} <= {d};");
    }
    let _ = writeln!(
        o,
        "    end
  end
endmodule
/* verilator lint_on UNUSEDSIGNAL */
/* verilator lint_on WIDTH */"
    );
}
