//! The PE's termination bits in Verilog, front to back with early ray
//! termination (`super::pe_sample_rtl`'s `term` memory): written at each
//! write-back, read in the clock before a row's first issue.
//!
//! Golden twin: the early ray termination of golden's front-to-back
//! compositing, as [`crate::datapath::Datapath::terminated`] decides it.

use super::pe_sample_shape::PeSampleShape;
use crate::cost::inventory::addr_bits;
use std::fmt::Write as _;

/// Front to back with early ray termination, the termination bits
/// (`term`, one word of `slots` bits a ray row, bit `i` for the ray in
/// slot `i`): each write-back writes its ray's bit, set when the opacity
/// it writes reaches the threshold `thr` (the comparator the model's
/// [`crate::datapath::Datapath::terminated`] is; it also sets the bit of
/// every ray the split writes, outside this stage). In the clock before a
/// row's first issue the control reads the row's word (`dead`, a
/// write-back of that clock forwarded) and issues only the planned columns
/// whose bit is clear. A write-back landing later cannot reach that read:
/// the model's row plan holds such a row back until its terminated rays'
/// last write-backs have landed ([`crate::pe::Pe::plan_rows`]).
/// Declares the ray's row and slot carried to its write-back
/// ([`super::pe_carry_rtl::termination_line`] clocks them).
pub(super) fn termination_bits(w: &mut String, s: &PeSampleShape, depth: u32, thr: i64) {
    let r = &s.rays;
    let (cw, aw) = (r.color_bits, r.alpha_bits);
    let s1 = s.slots() - 1;
    let rb1 = r.row_bits() - 1;
    let tb1 = addr_bits(s.slots()) - 1;
    let alpha = format!("wb_data[{}:{}]", 3 * cw + aw - 1, 3 * cw);
    let max = if r.alpha_signed {
        (1i128 << (aw - 1)) - 1
    } else {
        (1i128 << aw) - 1
    };
    let reach = if i128::from(thr) > max {
        "1'b0".to_owned()
    } else if r.alpha_signed {
        format!("$signed({alpha}) >= $signed({aw}'d{thr})")
    } else {
        format!("{alpha} >= {aw}'d{thr}")
    };
    let _ = writeln!(
        w,
        "  // Front to back: the termination bits, a word of {slots} bits a ray row, bit i for
  // slot i; a write-back writes its ray's bit (its opacity at least {thr}).
  reg [{s1}:0] term [0:{rm}];",
        slots = s.slots(),
        rm = r.max_rows - 1,
    );
    for i in 1..=depth {
        let _ = writeln!(w, "  reg [{rb1}:0] tr_{i};\n  reg [{tb1}:0] ts_{i};");
    }
    let _ = writeln!(
        w,
        "  wire wb_done = {reach};
  always @(posedge clk) if (wb_valid) term[tr_{depth}][ts_{depth}] <= wb_done;
  // The row's bits as the control reads them, a write-back of this clock
  // forwarded, turned from slots to the plan's held columns.
  wire [{s1}:0] dead_s = term[bc_row]
      | ((wb_valid && wb_done && tr_{depth} == bc_row) ? ({n}'d1 << ts_{depth}) : {n}'d0);
{dead}",
        n = s.slots(),
        dead = super::pe_columns_rtl::dead_by_plan(s),
    );
}
