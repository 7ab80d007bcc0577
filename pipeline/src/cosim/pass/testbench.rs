//! A boundary pass's vector file and the Verilog testbench around one
//! emitted pass module per PE, the pass's own ports and broadcast supplied
//! by its [`PassKind`].

use std::fmt::Write as _;
use std::path::Path;

use super::{PassDims, PassKind};
use crate::cost::shapes::RAY_INDEX_BITS;

/// The channels, in accumulator order.
const CHANNELS: [&str; 4] = ["r", "g", "b", "a"];

/// The low `bits` of `v`, in hex.
pub fn hex(v: i64, bits: u32) -> String {
    let m = if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    format!("{:x}", (v as u64) & m)
}

/// The vector fields of a clock's broadcast: the x pass's parent row, the
/// y pass's child row (each a valid bit and the row), the child column.
pub fn broadcast(x: Option<usize>, y: Option<usize>, col: usize) -> Vec<String> {
    vec![
        hex(i64::from(x.is_some()), 1),
        format!("{:x}", x.unwrap_or(0)),
        hex(i64::from(y.is_some()), 1),
        format!("{:x}", y.unwrap_or(0)),
        format!("{col:x}"),
    ]
}

/// Pushes onto `f` the four accumulator words `w`.
pub fn acc_words(f: &mut Vec<String>, d: &PassDims, w: &[i64; 4]) {
    for (ch, v) in w.iter().enumerate() {
        f.push(hex(*v, u32::from(d.acc_of(ch).bits())));
    }
}

/// Pushes onto `f` the four `merge` words `w`.
pub fn merge_words(f: &mut Vec<String>, d: &PassDims, w: &[i64; 4]) {
    for v in w {
        f.push(hex(*v, u32::from(d.merge.bits())));
    }
}

/// Pushes onto `f` the line-buffer write: its valid bit and merge words.
pub fn line_words(f: &mut Vec<String>, d: &PassDims, line: Option<[i64; 4]>) {
    f.push(hex(i64::from(line.is_some()), 1));
    for w in line.unwrap_or_default() {
        f.push(hex(w, u32::from(d.merge.bits())));
    }
}

/// The testbench's parts a pass supplies.
#[derive(Debug, Clone, Default)]
pub struct Bench {
    /// The parents' port prefixes (`a`, `b` or `h0` .. `er`), four
    /// accumulator words each unless named in `merge_parents`.
    pub parents: &'static [&'static str],
    /// The parents whose four words are `merge` words.
    pub merge_parents: &'static [&'static str],
    /// Whether the child word is four `merge` words (else accumulators).
    pub merge_child: bool,
    /// Whether the module drives a termination flag (`w_done`).
    pub done: bool,
    /// The begin strobe's port (`begin_split`).
    pub begin: &'static str,
    /// The broadcast's name in the comment (`BeginSplit`).
    pub broadcast: &'static str,
    /// The ray indices each PE latches besides its child count (`m0`,
    /// `lo`, `hi`), in the order of its line after the count.
    pub per_pe: &'static [&'static str],
    /// The grids' registers every PE latches, in the pass header's order:
    /// a grid's first row, its rows, the other grid's first row.
    pub grids: [&'static str; 3],
    /// The latched registers' port connections a line of the instance.
    pub ports_a_line: usize,
}

/// The latched registers' declarations, port connections, and the
/// statements taking the pass header's grids and PE `k`'s line.
fn begin_parts(d: &PassDims, b: &Bench) -> [String; 4] {
    let (p, cb, rb, ib) = (d.pes as u32, d.col_bits, d.row_bits, RAY_INDEX_BITS);
    let widths = [ib, rb, ib];
    let (mut regs, mut header) = (String::new(), String::new());
    for n in b.per_pe {
        let _ = writeln!(regs, "  reg [{}:0] begin_{n} = 0;", p * ib - 1);
    }
    for (i, (n, w)) in b.grids.iter().zip(widths).enumerate() {
        let _ = writeln!(regs, "  reg [{}:0] begin_{n} = 0;", w - 1);
        let _ = writeln!(header, "      begin_{n} = h[{}][{}:0];", i + 2, w - 1);
    }
    let mut ports: Vec<String> = b
        .per_pe
        .iter()
        .map(|n| format!(".begin_{n}(begin_{n}[gk*{ib} +: {ib}])"))
        .collect();
    ports.extend(b.grids.iter().map(|n| format!(".begin_{n}(begin_{n})")));
    let ports: Vec<String> = ports.chunks(b.ports_a_line).map(|c| c.join(", ")).collect();
    let fields = 1 + b.per_pe.len();
    let mut read = format!(
        "        got = $fscanf(fd, \"{}\\n\", {});\n        begin_n[k*{cb} +: {cb}] = h[0][{}:0];\n",
        vec!["%h"; fields].join(" "),
        (0..fields).map(|i| format!("h[{i}]")).collect::<Vec<_>>().join(", "),
        cb - 1
    );
    for (i, n) in b.per_pe.iter().enumerate() {
        let _ = writeln!(
            read,
            "        begin_{n}[k*{ib} +: {ib}] = h[{}][{}:0];",
            i + 1,
            ib - 1
        );
    }
    [regs, ports.join(",\n        "), header, read]
}

/// The module's inputs driven from the vectors, with their widths.
fn inputs(d: &PassDims, b: &Bench) -> Vec<(String, u32)> {
    let (cb, rb) = (d.col_bits, d.row_bits);
    let mut v: Vec<(String, u32)> = vec![
        ("x_valid".into(), 1),
        ("x_row".into(), rb),
        ("y_valid".into(), 1),
        ("y_row".into(), rb),
        ("col".into(), cb),
    ];
    for p in b.parents {
        let merge = b.merge_parents.contains(p);
        for (ch, n) in CHANNELS.iter().enumerate() {
            v.push((format!("{p}_{n}"), word_bits(d, ch, merge)));
        }
    }
    v
}

/// Bits of channel `ch`'s word: a `merge` word, or the accumulator's.
pub fn word_bits(d: &PassDims, ch: usize, merge: bool) -> u32 {
    u32::from(if merge { d.merge } else { d.acc_of(ch) }.bits())
}

/// The module's outputs compared, with their widths.
fn outputs(d: &PassDims, b: &Bench) -> Vec<(String, u32)> {
    let mb = u32::from(d.merge.bits());
    let mut v: Vec<(String, u32)> = vec![("lx_valid".into(), 1)];
    v.extend(CHANNELS.iter().map(|n| (format!("lx_{n}"), mb)));
    v.push(("w_valid".into(), 1));
    v.extend(
        CHANNELS
            .iter()
            .enumerate()
            .map(|(ch, n)| (format!("w_{n}"), word_bits(d, ch, b.merge_child))),
    );
    if b.done {
        v.push(("w_done".into(), 1));
    }
    v
}

/// Writes `<stage>.hex`: per pass a header (its first cycle, clocks, the
/// grids' first row and rows, the other grid's first row), each PE's line
/// ([`PassKind::child_line`]), then each clock's line per PE (inputs, then
/// the model's outputs). Returns the clocks over every pass.
pub fn write_files<K: PassKind>(
    d: &PassDims,
    passes: &[K::Capture],
    dir: &Path,
) -> Result<u64, String> {
    let mut t = String::new();
    let ib = RAY_INDEX_BITS;
    let mut ticks = 0u64;
    for p in passes {
        let (first, (g_lo, g_rows, o_lo), children) = K::header(p);
        let clocks = K::ticks(p);
        if children.len() != d.pes || clocks.iter().any(|t| t.len() != d.pes) {
            return Err(format!(
                "a {} pass captured for {} PEs",
                K::STAGE,
                children.len()
            ));
        }
        if let Some(n) = children.iter().find(|&&n| n as u64 > d.width) {
            return Err(format!(
                "a PE computes {n} children; the line buffer holds {}",
                d.width
            ));
        }
        let _ = writeln!(
            t,
            "{first:x} {:x} {} {g_rows:x} {}",
            clocks.len(),
            hex(g_lo, ib),
            hex(o_lo, ib)
        );
        for k in 0..children.len() {
            let _ = writeln!(t, "{}", K::child_line(p, k));
        }
        for tick in clocks {
            for e in tick {
                let _ = writeln!(t, "{}", K::tick_fields(d, e).join(" "));
            }
        }
        ticks += clocks.len() as u64;
    }
    let path = dir.join(format!("{}.hex", K::STAGE));
    std::fs::write(&path, t).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(ticks)
}

/// The testbench: one `K::MODULE` per PE; per pass, the begin strobe for
/// one clock (the broadcast), then each clock's inputs from
/// `<stage>.hex` and, after the clock edge, every output register of
/// every PE compared with what the model's PE wrote in that clock.
pub fn testbench<K: PassKind>(d: &PassDims) -> String {
    let b = K::bench();
    let (top, module, stage, pre, begin) = (K::TOP, K::MODULE, K::STAGE, K::PREFIX, b.begin);
    let p = d.pes;
    let cb = d.col_bits;
    let [begin_regs, begin_ports, header, child_read] = begin_parts(d, &b);
    let ins = inputs(d, &b);
    let outs = outputs(d, &b);
    let mut decl = String::new();
    let mut conn = String::new();
    // The inputs the loop sets are copied onto the ports at the falling
    // edge, from an always block: Verilator 5.006 does not settle the
    // logic on a port a timed initial block writes before the next edge.
    let mut copy = String::new();
    for (n, w) in &ins {
        let _ = writeln!(decl, "  reg [{}:0] {n} = 0;", p as u32 * w - 1);
        let _ = writeln!(decl, "  reg [{}:0] nx_{n} = 0;", p as u32 * w - 1);
        let _ = writeln!(copy, "    {n} <= nx_{n};");
        let _ = write!(conn, ", .{n}({n}[gk*{w} +: {w}])");
    }
    for (n, w) in &outs {
        let _ = writeln!(decl, "  wire [{}:0] {n};", p as u32 * w - 1);
        let _ = write!(conn, ", .{n}({n}[gk*{w} +: {w}])");
    }
    let nf = ins.len() + outs.len();
    let fmt = vec!["%h"; nf].join(" ");
    let vars: Vec<String> = (0..nf).map(|i| format!("v{i}")).collect();
    let mut set = String::new();
    for (i, (n, w)) in ins.iter().enumerate() {
        let _ = writeln!(set, "        nx_{n}[k*{w} +: {w}] = v{i}[{}:0];", w - 1);
    }
    let mut keep = String::new();
    let mut cmp = String::new();
    for (j, (n, w)) in outs.iter().enumerate() {
        let i = ins.len() + j;
        let _ = writeln!(keep, "        e[k*{no} + {j}] = v{i};", no = outs.len());
        let _ = writeln!(
            cmp,
            "        if (e[k*{no} + {j}][{w1}:0] !== {n}[k*{w} +: {w}]) begin\n          if (mism[k] < 64'd4) $display(\"{pre}MISMATCH %0d %0d {n} %h %h\", first + t, k, e[k*{no} + {j}][{w1}:0], {n}[k*{w} +: {w}]);\n          mism[k] = mism[k] + 64'd1;\n        end",
            no = outs.len(),
            w1 = w - 1
        );
    }
    format!(
        "// {top}: the {stage}'s co-simulation testbench, generated by ercube
// (pipeline::cosim::{stage}).
`timescale 1ns/1ps
module {top};
  reg clk = 1'b0;
  always #5 clk = ~clk;
  reg rst = 1'b1;
  reg {begin} = 1'b0;
  reg [{pcb1}:0] begin_n = 0;
{begin_regs}{decl}  always @(negedge clk) begin
{copy}  end
  genvar gk;
  generate
    for (gk = 0; gk < {p}; gk = gk + 1) begin : pe
      {module} dut (
        .clk(clk), .rst(rst), .{begin}({begin}), .begin_n(begin_n[gk*{cb} +: {cb}]),
        {begin_ports}{conn}
      );
    end
  endgenerate
  integer fd;
  integer got;
  integer k;
  integer q;
  reg [63:0] passes;
  reg short = 1'b0;
  reg [63:0] t;
  reg [63:0] ticks;
  reg [63:0] all;
  reg [63:0] first;
  reg [63:0] h [0:4];
  reg [63:0] {vars};
  reg [63:0] e [0:{ne1}];
  reg [63:0] mism [0:{p1}];
  reg [63:0] lines [0:{p1}];
  reg [63:0] words [0:{p1}];
  initial begin
    if (!$value$plusargs(\"passes=%d\", passes)) passes = 64'd0;
    all = 64'd0;
    for (k = 0; k < {p}; k = k + 1) begin
      mism[k] = 64'd0;
      lines[k] = 64'd0;
      words[k] = 64'd0;
    end
    @(posedge clk); @(posedge clk); #1 rst = 1'b0;
    fd = $fopen(\"{stage}.hex\", \"r\");
    if (fd == 0) $display(\"ERROR cannot open {stage}.hex\");
    for (q = 0; q < passes; q = q + 1) begin
      got = $fscanf(fd, \"%h %h %h %h %h\\n\", h[0], h[1], h[2], h[3], h[4]);
      if (got != 5) $display(\"ERROR {stage}.hex ends at pass %0d\", q);
      first = h[0];
      ticks = h[1];
{header}      for (k = 0; k < {p}; k = k + 1) begin
{child_read}      end
      // The {broadcast} broadcast: one clock between the model's cycles.
      {begin} = 1'b1;
      @(posedge clk); #1;
      {begin} = 1'b0;
      for (t = 64'd0; t < ticks; t = t + 64'd1) begin
        for (k = 0; k < {p}; k = k + 1) begin
          got = $fscanf(fd, \"{fmt}\\n\", {vars});
          if (got != {nf} && !short) begin
            $display(\"ERROR {stage}.hex ends at clock %0d\", first + t);
            short = 1'b1;
          end
{set}{keep}        end
        @(posedge clk); #1;
        for (k = 0; k < {p}; k = k + 1) begin
{cmp}          if (lx_valid[k]) lines[k] = lines[k] + 64'd1;
          if (w_valid[k]) words[k] = words[k] + 64'd1;
        end
        all = all + 64'd1;
      end
    end
    $display(\"{pre}TICKS %0d\", all);
    for (k = 0; k < {p}; k = k + 1) $display(\"{pre}PE %0d %0d %0d %0d\", k, lines[k], words[k], mism[k]);
    $finish;
  end
endmodule
",
        pcb1 = p as u32 * cb - 1,
        ne1 = p * outs.len() - 1,
        p1 = p - 1,
        vars = vars.join(", "),
        broadcast = b.broadcast,
    )
}
