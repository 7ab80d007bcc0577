//! The sample stage's taps ([`super::pe_sample_rtl`]): the row, the slice
//! and the right neighbour's edge words carried from issue to the
//! datapath's tap column, the four slice-buffer reads there, and each
//! tap's word (its row bank's, or the edge register's for the column
//! right of the block).
//!
//! The tap column `x0` is the datapath's (the position's integer part, in
//! the clock it shows it); everything else the read addresses need is
//! known a clock earlier. So under column blocks the row's base in each
//! bank less the PE's first column (`col_lo`, which holds over the frame)
//! is registered in the clock before the tap column, with its `+ 1` and
//! `+ nx_last` forms, and in the tap column's clock each address is one
//! adder from `x0` beside the clamp's compares, which then select the
//! sum or a clamped column's registered form: the address of column
//! `clamp(x0)` in `rb + clamp(x0) - col_lo`, modulo the address width,
//! without the clamp's select, the local column's subtractor and the row
//! base in series with the datapath's adder. Under a round-robin mapping
//! the local column is the column decoder's read at the clamped column,
//! so the clamp stays in series.
//!
//! Golden twin: `golden::sampling::sample_region` (the taps each ray
//! reads), through [`crate::pe::Pe::sample_step`].

use std::fmt::Write as _;

use super::pe_sample_shape::PeSampleShape;
use crate::cost::inventory::addr_bits;

/// Writes the delay lines to the tap column (stage `sx` after issue) and
/// the tap stage, for a tap column `x0` of `x0_range` (its Verilog
/// range); returns the register bits declared.
pub(super) fn tap_stage(w: &mut String, s: &PeSampleShape, x0_range: &str, sx: u32) -> u64 {
    let (v, yb) = (s.voxel_bits, s.row_bits());
    let (half, stored) = (s.half_rows, s.stored);
    let sbw = addr_bits(s.bank_words());
    let e1 = 2 * v - 1;
    let lines: [(&str, String, &str); 5] = [
        ("y0", format!("[{}:0]", yb - 1), "s_y0"),
        ("y1", format!("[{}:0]", yb - 1), "s_y1"),
        ("z", String::new(), "s_z"),
        ("edge", format!("[{e1}:0]"), "edge_in"),
        ("tv", String::new(), "iss_valid"),
    ];
    let _ = writeln!(
        w,
        "  // The row, the slice and the right neighbour's edge words at issue, carried to the tap stage."
    );
    let mut regs: u64 = 0;
    for (n, rng, src) in &lines {
        let width = if rng.is_empty() {
            1
        } else if *n == "edge" {
            u64::from(2 * v)
        } else {
            u64::from(yb)
        };
        for i in 1..=sx {
            let _ = writeln!(w, "  reg {rng} d_{n}_{i};");
            regs += width;
        }
        let _ = writeln!(w, "  always @(posedge clk) begin");
        let _ = writeln!(w, "    if (rst) begin");
        for i in 1..=sx {
            let _ = writeln!(w, "      d_{n}_{i} <= 0;");
        }
        let _ = writeln!(w, "    end else begin");
        for i in 1..=sx {
            let prev = if i == 1 {
                (*src).to_owned()
            } else {
                format!("d_{n}_{}", i - 1)
            };
            let _ = writeln!(w, "      d_{n}_{i} <= {prev};");
        }
        let _ = writeln!(w, "    end\n  end");
    }
    // A carried word `k` clocks after issue (k = sx: at the tap column);
    // the registers (`s_*`) at 0 and, a clock before them, the
    // broadcast (`bc_*`, which they take every clock out of reset).
    let at = |n: &str, k: i64| match (n, k) {
        ("edge", 0) => "edge_in".to_owned(),
        ("tv", 0) => "iss_valid".to_owned(),
        (_, -1) => format!("bc_{n}"),
        (_, 0) => format!("s_{n}"),
        _ => format!("d_{n}_{k}"),
    };
    let sx_i = i64::from(sx);
    let rows = |y0: &str, y1: &str, z: &str, p: &str| {
        format!(
            "  wire [{yb1}:0] {p}r0 = {y0}[0] ? {y1} : {y0};
  wire [{yb1}:0] {p}r1 = {y0}[0] ? {y0} : {y1};
  // Each bank's slice row (row * {stored} as shifted sums).
  wire [{sbw1}:0] {p}rw0 = ({z} ? {half} : 0) + ({p}r0 >> 1), {p}rw1 = ({z} ? {half} : 0) + ({p}r1 >> 1);
  wire [{sbw1}:0] {p}rb0 = {rb0}, {p}rb1 = {rb1};",
            yb1 = yb - 1,
            sbw1 = sbw - 1,
            rb0 = super::pe_columns_rtl::times(stored, &format!("{p}rw0")),
            rb1 = super::pe_columns_rtl::times(stored, &format!("{p}rw1")),
        )
    };
    let _ = writeln!(
        w,
        "  // The tap stage: each row bank's row, both columns read.
  wire {x0_range} x0;
  wire signed [31:0] x0_i = x0;
  wire signed [31:0] last_i = $signed({{1'b0, nx_last}});
  wire [{yb1}:0] ty0 = {y0}, ty1 = {y1};",
        yb1 = yb - 1,
        y0 = at("y0", sx_i),
        y1 = at("y1", sx_i),
    );
    if s.round_robin {
        let _ = writeln!(
            w,
            "  // The clamped columns, their local columns through the column decoder.
  wire signed [31:0] c0 = x0_i < 0 ? 0 : (x0_i > last_i ? last_i : x0_i);
  wire signed [31:0] c1 = x0_i + 1 < 0 ? 0 : (x0_i + 1 > last_i ? last_i : x0_i + 1);
  wire [31:0] l0 = {{1'b0, loc[c0]}};
  wire [31:0] l1 = {{1'b0, loc[c1]}};
  wire held1 = 1'b1;
{rows}
  wire [{sbw1}:0] a00 = rb0 + l0, a01 = rb0 + l1;
  wire [{sbw1}:0] a10 = rb1 + l0, a11 = rb1 + l1;",
            sbw1 = sbw - 1,
            rows = rows("ty0", "ty1", &at("z", sx_i), ""),
        );
    } else {
        let _ = writeln!(
            w,
            "  // A clock ahead: each bank's row base less col_lo (held over the frame), and
  // its forms at column 1 and at the volume's last column.
{rows}
  wire [{sbw1}:0] p_l0 = p_rb0 - col_lo, p_l1 = p_rb1 - col_lo;
  reg [{sbw1}:0] rl0, rl1, rp0, rp1, rh0, rh1;
  always @(posedge clk) begin
    if (rst) begin
      rl0 <= 0 - col_lo;
      rl1 <= 0 - col_lo;
      rp0 <= 1 - col_lo;
      rp1 <= 1 - col_lo;
      rh0 <= nx_last - col_lo;
      rh1 <= nx_last - col_lo;
    end else begin
      rl0 <= p_l0;
      rl1 <= p_l1;
      rp0 <= p_l0 + 1;
      rp1 <= p_l1 + 1;
      rh0 <= p_l0 + nx_last;
      rh1 <= p_l1 + nx_last;
    end
  end
  // Columns x0 and x0 + 1 clamped into the volume: each address the sum with x0,
  // or a clamped column's registered form; the right tap held when x0 + 1 is in the block.
  wire lo0 = x0_i < 0, hi0 = x0_i > last_i;
  wire lo1 = x0_i < -1, hi1 = x0_i >= last_i;
  wire [{sbw1}:0] x0_a = x0_i[{sbw1}:0];
  wire [{sbw1}:0] a00 = lo0 ? rl0 : hi0 ? rh0 : rl0 + x0_a;
  wire [{sbw1}:0] a01 = lo1 ? rl0 : hi1 ? rh0 : rp0 + x0_a;
  wire [{sbw1}:0] a10 = lo0 ? rl1 : hi0 ? rh1 : rl1 + x0_a;
  wire [{sbw1}:0] a11 = lo1 ? rl1 : hi1 ? rh1 : rp1 + x0_a;
  // (c1 < col_end for c1 the clamped x0 + 1: x0 against col_end - 1, a frame constant.)
  wire signed [31:0] end_i = $signed({{1'b0, col_end}});
  wire held1 = lo1 ? end_i > 0 : hi1 ? last_i < end_i : x0_i < end_i - 1;",
            sbw1 = sbw - 1,
            rows = rows(
                &at("y0", sx_i - 1),
                &at("y1", sx_i - 1),
                &at("z", sx_i - 1),
                "p_"
            ),
        );
        regs += 6 * u64::from(sbw);
    }
    let _ = writeln!(
        w,
        "  reg [{v1}:0] q00, q01, q10, q11;
  always @(posedge clk) begin
    q00 <= sb0[a00[{sbw1}:0]];
    q01 <= sb0[a01[{sbw1}:0]];
    q10 <= sb1[a10[{sbw1}:0]];
    q11 <= sb1[a11[{sbw1}:0]];
  end
  reg p0, p1, h1;
  reg [{e1}:0] te;
  always @(posedge clk) begin
    if (rst) begin
      p0 <= 1'b0;
      p1 <= 1'b0;
      h1 <= 1'b0;
      te <= 0;
      tap_valid <= 1'b0;
    end else begin
      p0 <= ty0[0];
      p1 <= ty1[0];
      h1 <= held1;
      te <= {edge};
      tap_valid <= {tv};
    end
  end
  assign tap_v00 = p0 ? q10 : q00;
  assign tap_v10 = p1 ? q10 : q00;
  assign tap_v01 = h1 ? (p0 ? q11 : q01) : te[{v1}:0];
  assign tap_v11 = h1 ? (p1 ? q11 : q01) : te[{e1}:{v}];",
        v1 = v - 1,
        sbw1 = sbw - 1,
        edge = at("edge", sx_i),
        tv = at("tv", sx_i),
    );
    regs + 3 + u64::from(2 * v) + 1 + 4 * u64::from(v)
}
