//! The write side of the PE's row plan in Verilog
//! ([`super::pe_sample_rtl`]'s `plan` memory): the plan port that
//! receives the controller's runs and the comparators that turn each run
//! into the PE's own bits.
//!
//! Golden twin: [`crate::pe::Pe::plan_rows`] (the held columns inside a
//! row's runs), whose runs are `golden::skip::SampleMask::row_runs`'s
//! ([`crate::skip::plan_mask`]).
//!
//! The controller knows runs of ray indices, not which PE holds which
//! column, so it broadcasts every row's runs to every PE, one run a clock
//! (`pl_valid`), the slice's rows in order, `pl_first` on a row's first
//! run; a row no PE samples (no runs, or none over a held column: the
//! PEs' row reports) is not sent, as its word is never read. The runs are inside the slice's x range (the controller's
//! planner clips them to it), so a held column is planned when it is one
//! of the `map_n` held ones and inside the run: a comparator pair per
//! column map slot over `map_lo + i`. The row's word is the OR of its
//! runs' bits, gathered in `pl_acc` and written through on every run, so
//! the memory holds the whole word after the row's last run; the control
//! reads it from the next clock on (a run's beat is at least
//! [`crate::stages::sample::PLAN_TO_ISSUE`] clocks before its row's first
//! issue, which the model counts).

use std::fmt::Write as _;

use super::pe_sample_shape::PeSampleShape;

/// The plan port's declarations in the module's port list.
pub(super) fn ports(s: &PeSampleShape) -> String {
    format!(
        "  // The row plan's port: the controller's runs of ray indices (lo ..= hi), one
  // a clock, the slice's rows in order, pl_first on a row's first run.
  input wire pl_valid,
  input wire pl_first,
  input wire [{rb1}:0] pl_row,
  input wire signed [{ib1}:0] pl_lo,
  input wire signed [{ib1}:0] pl_hi,",
        rb1 = s.rays.row_bits() - 1,
        ib1 = s.index_bits - 1,
    )
}

/// The comparators and the plan memory's write, after the memory and the
/// held range (`map_lo`, `map_n`) are declared; returns the text and the
/// register bits it declares.
pub(super) fn write_side(s: &PeSampleShape) -> (String, u64) {
    let slots = s.slots();
    let mut t = String::new();
    let _ = writeln!(
        t,
        "  // The row plan's comparators: bit i is planned by a run when the column
  // map's entry i holds a column (i < map_n) whose ray lies in the run.
  wire [{s1}:0] pl_bits;
{compare}
  // The row's word so far, written through on every run.
  reg [{s1}:0] pl_acc;
  wire [{s1}:0] pl_word = (pl_first ? {{{slots}{{1'b0}}}} : pl_acc) | pl_bits;
  always @(posedge clk) begin
    if (rst) pl_acc <= 0;
    else if (pl_valid) pl_acc <= pl_word;
  end
  always @(posedge clk) if (pl_valid) plan[pl_row] <= pl_word;",
        s1 = slots - 1,
        compare = super::pe_columns_rtl::plan_compare(s),
    );
    (t, slots)
}
