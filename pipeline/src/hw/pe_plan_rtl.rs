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
//! PEs' row reports) is not sent, as its word is never read. The runs are
//! inside the slice's x range (the controller's planner clips them to
//! it), so a held column is planned when it is one of the `map_n` held
//! ones and inside the run. The row's word is the OR of its runs' bits,
//! gathered in `pl_acc` and written through on every run.
//!
//! The rows are sent in the order the controller samples them, and every
//! row sent is sampled, so the plan memory is a FIFO of words: `pl_first`
//! opens the entry after the tail, and the head entry is the row that
//! issues next. The head's word is a register (`p_h`), so that the
//! issue's pick starts at a flip-flop rather than at the block RAM's
//! clock-to-out (the pick's carry chain over the slots is the stage's
//! longest path): the memory (a synchronous read, so a block RAM) reads
//! the entry after the head a clock ahead, which a row's first clock
//! moves into the register. Each word is its entry as of two clocks
//! back; a run written to it in the last clock bypasses it (`p_bw`, a
//! flag a word). The control sees the word a run writes from the next
//! clock on, as with the memory read in the pick's clock, so the register
//! costs no clock of the issue: a run's beat is at least
//! [`crate::stages::sample::PLAN_TO_ISSUE`] clocks before its row's first
//! issue (which the model counts).

use std::fmt::Write as _;

use super::pe_sample_shape::PeSampleShape;
use crate::cost::inventory::addr_bits;

/// The plan port's declarations in the module's port list.
pub(super) fn ports(s: &PeSampleShape) -> String {
    format!(
        "  // The row plan's port: the controller's runs of ray indices (lo ..= hi), one
  // a clock, the slice's rows in order, pl_first on a row's first run.
  input wire pl_valid,
  input wire pl_first,
  input wire signed [{ib1}:0] pl_lo,
  input wire signed [{ib1}:0] pl_hi,",
        ib1 = s.index_bits - 1,
    )
}

/// The comparators, the plan FIFO's write and its head's read, after the
/// memory (`plan`) and the held range (`map_lo`, `map_n`) are declared:
/// the head row's word is `hq`. Returns the text and the register bits
/// it declares.
pub(super) fn write_side(s: &PeSampleShape) -> (String, u64) {
    let slots = s.slots();
    let rows = s.rays.max_rows;
    let pb = addr_bits(rows);
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
  // The rows' words in the order they are sent, the order they issue:
  // pl_first opens the entry after the tail, the row's other runs rewrite it.
  reg [{pb1}:0] p_tail, p_head;
  wire [{pb1}:0] p_open = p_tail == {last} ? {pb}'d0 : p_tail + {pb}'d1;
  wire [{pb1}:0] p_widx = pl_first ? p_open : p_tail;
  always @(posedge clk) begin
    if (rst) p_tail <= {pb}'d{last};
    else if (pl_valid) p_tail <= p_widx;
  end
  always @(posedge clk) if (pl_valid) plan[p_widx] <= pl_word;
  // The head entry (the row that issues next) held in a register, so that the
  // pick starts at a flip-flop, not at the memory's clock-to-out: the memory
  // reads the entry after it a clock ahead, for the row's first clock that
  // moves the head up. Each word is its entry as of two clocks back, a run
  // written to it in the last clock bypassing it.
  wire [{pb1}:0] p_next = p_head == {last} ? {pb}'d0 : p_head + {pb}'d1;
  wire [{pb1}:0] p_ra = bc_first ? p_next : p_head;
  wire [{pb1}:0] p_ra1 = p_ra == {last} ? {pb}'d0 : p_ra + {pb}'d1;
  reg [{s1}:0] p_q;
  always @(posedge clk) p_q <= plan[p_ra1];
  reg p_byp, p_byp1;
  reg [{s1}:0] p_bw, p_h;
  wire [{s1}:0] hq = p_byp ? p_bw : p_h;
  wire [{s1}:0] p_nq = p_byp1 ? p_bw : p_q;
  always @(posedge clk) begin
    if (rst) begin
      p_head <= 0;
      p_byp <= 1'b0;
      p_byp1 <= 1'b0;
      p_bw <= 0;
      p_h <= 0;
    end else begin
      if (bc_first) p_head <= p_next;
      p_byp <= pl_valid && p_widx == p_ra;
      p_byp1 <= pl_valid && p_widx == p_ra1;
      p_bw <= pl_word;
      p_h <= bc_first ? p_nq : hq;
    end
  end",
        s1 = slots - 1,
        pb1 = pb - 1,
        last = rows - 1,
        compare = super::pe_columns_rtl::plan_compare(s),
    );
    // pl_acc, the FIFO's pointers, the bypassed word and its two flags,
    // the head's word (the read register is the memory's).
    (t, 3 * slots + 2 * u64::from(pb) + 2)
}
