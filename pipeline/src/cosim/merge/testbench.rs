//! The merge co-simulation's vector file and Verilog testbench around one
//! emitted `ercube_pe_merge` per PE.

use std::fmt::Write as _;
use std::path::Path;

use super::{MergeCapture, TOP};
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::merge_rtl::{MergeShape, MODULE};
use crate::hw::tents::CHANNELS;

/// The low `bits` of `v`, in hex.
fn hex(v: i64, bits: u32) -> String {
    let m = if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    format!("{:x}", (v as u64) & m)
}

/// The module's inputs driven from the vectors, with their widths.
fn inputs(s: &MergeShape) -> Vec<(String, u32)> {
    let (cb, rb) = (s.col_bits(), s.row_bits());
    let mut v: Vec<(String, u32)> = vec![
        ("x_valid".into(), 1),
        ("x_row".into(), rb),
        ("y_valid".into(), 1),
        ("y_row".into(), rb),
        ("col".into(), cb),
    ];
    for p in ["h0", "h1", "h2", "el", "er"] {
        for (ch, n) in CHANNELS.iter().enumerate() {
            v.push((format!("{p}_{n}"), u32::from(s.acc_of(ch).bits())));
        }
    }
    v
}

/// The module's outputs compared, with their widths.
fn outputs(s: &MergeShape) -> Vec<(String, u32)> {
    let mb = u32::from(s.merge.bits());
    let mut v: Vec<(String, u32)> = vec![("lx_valid".into(), 1)];
    v.extend(CHANNELS.iter().map(|n| (format!("lx_{n}"), mb)));
    v.push(("w_valid".into(), 1));
    v.extend(
        CHANNELS
            .iter()
            .enumerate()
            .map(|(ch, n)| (format!("w_{n}"), u32::from(s.acc_of(ch).bits()))),
    );
    v
}

/// Writes `merge.hex`: per pass a header (its first cycle, clocks, the
/// back grid's first row and rows, the front grid's first row), each PE's
/// child count, first child and held span, then each clock's line per PE
/// (inputs, then the model's outputs). Returns the clocks over every
/// pass.
pub fn write_files(s: &MergeShape, passes: &[MergeCapture], dir: &Path) -> Result<u64, String> {
    let mut t = String::new();
    let ib = RAY_INDEX_BITS;
    let mut ticks = 0u64;
    for p in passes {
        if p.children.len() != s.pes || p.ticks.iter().any(|t| t.len() != s.pes) {
            return Err(format!(
                "a merge pass captured for {} PEs",
                p.children.len()
            ));
        }
        if let Some(n) = p.children.iter().map(|c| c.0).find(|&n| n as u64 > s.width) {
            return Err(format!(
                "a PE computes {n} children; the line buffer holds {}",
                s.width
            ));
        }
        let (bg_lo, bg_rows, fg_lo) = p.grids;
        let _ = writeln!(
            t,
            "{:x} {:x} {} {:x} {}",
            p.first,
            p.ticks.len(),
            hex(bg_lo, ib),
            bg_rows,
            hex(fg_lo, ib)
        );
        for (n, m0, lo, hi) in &p.children {
            let _ = writeln!(
                t,
                "{n:x} {} {} {}",
                hex(*m0, ib),
                hex(*lo, ib),
                hex(*hi, ib)
            );
        }
        for tick in &p.ticks {
            for e in tick {
                let mut f: Vec<String> = vec![
                    hex(i64::from(e.x.is_some()), 1),
                    format!("{:x}", e.x.unwrap_or(0)),
                    hex(i64::from(e.y.is_some()), 1),
                    format!("{:x}", e.y.unwrap_or(0)),
                    format!("{:x}", e.col),
                ];
                for w in e.held.iter().chain(&e.edges) {
                    for (ch, v) in w.iter().enumerate() {
                        f.push(hex(*v, u32::from(s.acc_of(ch).bits())));
                    }
                }
                let line = e.line.unwrap_or_default();
                f.push(hex(i64::from(e.line.is_some()), 1));
                for w in line {
                    f.push(hex(w, u32::from(s.merge.bits())));
                }
                let child = e.child.unwrap_or_default();
                f.push(hex(i64::from(e.child.is_some()), 1));
                for (ch, w) in child.iter().enumerate() {
                    f.push(hex(*w, u32::from(s.acc_of(ch).bits())));
                }
                let _ = writeln!(t, "{}", f.join(" "));
            }
        }
        ticks += p.ticks.len() as u64;
    }
    let path = dir.join("merge.hex");
    std::fs::write(&path, t).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(ticks)
}

/// The testbench: one `ercube_pe_merge` per PE; per pass, `begin_merge`
/// for one clock (the broadcast), then each clock's inputs from
/// `merge.hex` and, after the clock edge, every output register of every
/// PE compared with what the model's PE wrote in that clock.
pub fn testbench(s: &MergeShape) -> String {
    let p = s.pes;
    let (cb, rb, ib) = (s.col_bits(), s.row_bits(), RAY_INDEX_BITS);
    let ins = inputs(s);
    let outs = outputs(s);
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
            "        if (e[k*{no} + {j}][{w1}:0] !== {n}[k*{w} +: {w}]) begin\n          if (mism[k] < 64'd4) $display(\"MMISMATCH %0d %0d {n} %h %h\", first + t, k, e[k*{no} + {j}][{w1}:0], {n}[k*{w} +: {w}]);\n          mism[k] = mism[k] + 64'd1;\n        end",
            no = outs.len(),
            w1 = w - 1
        );
    }
    format!(
        "// {TOP}: the merge's co-simulation testbench, generated by ercube
// (pipeline::cosim::merge).
`timescale 1ns/1ps
module {TOP};
  reg clk = 1'b0;
  always #5 clk = ~clk;
  reg rst = 1'b1;
  reg begin_merge = 1'b0;
  reg [{pcb1}:0] begin_n = 0;
  reg [{pib1}:0] begin_m0 = 0;
  reg [{pib1}:0] begin_lo = 0;
  reg [{pib1}:0] begin_hi = 0;
  reg [{ib1}:0] begin_bg_lo = 0;
  reg [{rb1}:0] begin_bg_rows = 0;
  reg [{ib1}:0] begin_fg_lo = 0;
{decl}  always @(negedge clk) begin
{copy}  end
  genvar gk;
  generate
    for (gk = 0; gk < {p}; gk = gk + 1) begin : pe
      {MODULE} dut (
        .clk(clk), .rst(rst), .begin_merge(begin_merge), .begin_n(begin_n[gk*{cb} +: {cb}]),
        .begin_m0(begin_m0[gk*{ib} +: {ib}]), .begin_lo(begin_lo[gk*{ib} +: {ib}]),
        .begin_hi(begin_hi[gk*{ib} +: {ib}]), .begin_bg_lo(begin_bg_lo),
        .begin_bg_rows(begin_bg_rows), .begin_fg_lo(begin_fg_lo){conn}
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
    fd = $fopen(\"merge.hex\", \"r\");
    if (fd == 0) $display(\"ERROR cannot open merge.hex\");
    for (q = 0; q < passes; q = q + 1) begin
      got = $fscanf(fd, \"%h %h %h %h %h\\n\", h[0], h[1], h[2], h[3], h[4]);
      if (got != 5) $display(\"ERROR merge.hex ends at pass %0d\", q);
      first = h[0];
      ticks = h[1];
      begin_bg_lo = h[2][{ib1}:0];
      begin_bg_rows = h[3][{rb1}:0];
      begin_fg_lo = h[4][{ib1}:0];
      for (k = 0; k < {p}; k = k + 1) begin
        got = $fscanf(fd, \"%h %h %h %h\\n\", h[0], h[1], h[2], h[3]);
        begin_n[k*{cb} +: {cb}] = h[0][{cb1}:0];
        begin_m0[k*{ib} +: {ib}] = h[1][{ib1}:0];
        begin_lo[k*{ib} +: {ib}] = h[2][{ib1}:0];
        begin_hi[k*{ib} +: {ib}] = h[3][{ib1}:0];
      end
      // The BeginMerge broadcast: one clock between the model's cycles.
      begin_merge = 1'b1;
      @(posedge clk); #1;
      begin_merge = 1'b0;
      for (t = 64'd0; t < ticks; t = t + 64'd1) begin
        for (k = 0; k < {p}; k = k + 1) begin
          got = $fscanf(fd, \"{fmt}\\n\", {vars});
          if (got != {nf} && !short) begin
            $display(\"ERROR merge.hex ends at clock %0d\", first + t);
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
    $display(\"MTICKS %0d\", all);
    for (k = 0; k < {p}; k = k + 1) $display(\"MPE %0d %0d %0d %0d\", k, lines[k], words[k], mism[k]);
    $finish;
  end
endmodule
",
        pcb1 = p as u32 * cb - 1,
        pib1 = p as u32 * ib - 1,
        ib1 = ib - 1,
        rb1 = rb - 1,
        cb1 = cb - 1,
        ne1 = p * outs.len() - 1,
        p1 = p - 1,
        vars = vars.join(", "),
    )
}
