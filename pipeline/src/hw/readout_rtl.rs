//! The PE's readout stage in Verilog: its compositing buffer and column
//! map as inferable RAMs at their declared depths and widths
//! ([`Pe::declaration`]), the readout's cursor as a state machine, and an
//! array top of P such PEs with their host ports.
//!
//! Golden twin of the stage: [`Pe::readout_step`] (the model this module
//! is checked against, clock for clock, by [`crate::cosim::readout`]),
//! whose golden twin is the baseplane [`golden::warp::Baseplane`] the host
//! assembles.
//!
//! The buffer holds region 0's rays row by row at a stride of the column
//! map's slots (ray `(c, r)` at `r * slots + c`), its two banks
//! interleaved by the address's low bit; the column map's slot `c` holds
//! `{valid, mx}` of the `c`-th held column; with `pass_skip_empty` the
//! valid bits (the cost model's `ray valid bits`, a row to a word) say
//! which rays are not all zero. On `begin_readout` the machine reads row
//! 0's valid word (all held columns without `pass_skip_empty`); then each
//! clock it reads the lowest column still to read in the row in hand
//! (buffer and map, one clock of read latency), and the clock that leaves
//! a row reads the next row's word. The read register drives the host
//! port the clock after; `done` rises once the last row is left and the
//! read register is empty. A row costs as many clocks as it has rays to
//! stream, at least one, and the readout two more: what the model counts
//! ([`crate::stages::readout::ReadoutFsm`]).

use std::fmt::Write as _;

use crate::config::{PipelineConfig, RayBuffer};
use crate::cost::inventory::Geometry;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::state::StateDecl;
use crate::pe::Pe;

/// The PE readout module's name.
pub const PE_MODULE: &str = "ercube_pe_readout";
/// The array top's name.
pub const ARRAY_MODULE: &str = "ercube_readout_array";

/// `ld_sel` of the compositing buffer's words.
pub const SEL_BUFFER: u32 = 0;
/// `ld_sel` of the column map's words.
pub const SEL_MAP: u32 = 1;
/// `ld_sel` of the counts register `{ncols, rows}`.
pub const SEL_COUNTS: u32 = 2;
/// `ld_sel` of a row's valid word (with `pass_skip_empty`).
pub const SEL_VALID: u32 = 3;

/// Bits to hold `0 ..= n` (at least one).
fn bits_for(n: u64) -> u32 {
    (64 - n.leading_zeros()).max(1)
}

/// Bits to address `n` words (at least one).
fn addr_bits(n: u64) -> u32 {
    bits_for(n.saturating_sub(1))
}

/// The widths of the readout's words and counters for a configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ReadoutShape {
    /// PEs in the array.
    pub pes: usize,
    /// Bits of a colour accumulator (`accum_color`).
    pub color_bits: u32,
    /// Whether the colour accumulators are signed.
    pub color_signed: bool,
    /// Bits of the opacity accumulator (`accum_alpha`).
    pub alpha_bits: u32,
    /// Whether the opacity accumulator is signed.
    pub alpha_signed: bool,
    /// Words per bank of the compositing buffer (two banks).
    pub bank_depth: u64,
    /// Bits of a compositing buffer word as declared.
    pub buffer_width: u32,
    /// Slots of the column map.
    pub map_depth: u64,
    /// Bits of a column map word as declared.
    pub map_width: u32,
    /// The most rows a held column has (`2 ny + 1`).
    pub max_rows: u64,
    /// Whether zero rays are left off the host stream (`pass_skip_empty`).
    pub sparse: bool,
}

impl ReadoutShape {
    /// The shape of `cfg`'s PE for the worst view of `geo`, from the PE's
    /// declaration; refused in one line where the readout module does not
    /// cover the configuration yet.
    pub fn new(cfg: &PipelineConfig, geo: &Geometry) -> Result<ReadoutShape, String> {
        if cfg.ray_buffer == RayBuffer::External {
            return Err(
                "the readout from an external ray buffer is not emitted yet (only the on-chip compositing buffer's)"
                    .into(),
            );
        }
        if geo.units.preint {
            return Err("the readout of pre-integrated rays (their previous sample beside the accumulators) is not emitted yet".into());
        }
        let decls = Pe::declaration(cfg, geo);
        let find = |n: &str| -> Result<&StateDecl, String> {
            decls
                .iter()
                .find(|d| d.name == n)
                .ok_or_else(|| format!("the PE declares no {n}"))
        };
        let buf = find("compositing_buffer")?;
        let map = find("column_map")?;
        let color_bits = u32::from(cfg.accum_color.bits());
        let alpha_bits = u32::from(cfg.accum_alpha.bits());
        if buf.copies != 2 || buf.width != 3 * color_bits + alpha_bits {
            return Err(format!(
                "the compositing buffer is declared as {} banks of {} bits; the readout module reads 2 banks of the accumulators' {} bits",
                buf.copies,
                buf.width,
                3 * color_bits + alpha_bits
            ));
        }
        if map.width != RAY_INDEX_BITS + 1 {
            return Err(format!("the column map's word is {} bits", map.width));
        }
        Ok(ReadoutShape {
            pes: usize::from(cfg.pes),
            color_bits,
            color_signed: cfg.accum_color.is_signed(),
            alpha_bits,
            alpha_signed: cfg.accum_alpha.is_signed(),
            bank_depth: buf.depth.max(1),
            buffer_width: buf.width,
            map_depth: map.depth.max(1),
            map_width: map.width,
            max_rows: crate::cost::arch::ray_rows(geo),
            sparse: cfg.pass_skip_empty,
        })
    }

    /// The shape for a frame of `view` (its dimensions and regions).
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<ReadoutShape, String> {
        crate::host::plan(cfg, view).map_err(|e| e.to_string())?;
        let geo = Geometry::for_view(cfg, view).map_err(|e| e.to_string())?;
        ReadoutShape::new(cfg, &geo)
    }

    /// Bits of a bank address.
    pub fn bank_bits(&self) -> u32 {
        addr_bits(self.bank_depth)
    }
    /// Bits of a linear ray address (bank bit included).
    pub fn ray_addr_bits(&self) -> u32 {
        self.bank_bits() + 1
    }
    /// Bits of a slot counter (`0 ..= map_depth`).
    pub fn slot_bits(&self) -> u32 {
        bits_for(self.map_depth)
    }
    /// Bits of a row counter (`0 ..= max_rows`).
    pub fn row_bits(&self) -> u32 {
        bits_for(self.max_rows)
    }
    /// Bits of a column map address.
    pub fn map_bits(&self) -> u32 {
        addr_bits(self.map_depth)
    }
    /// Bits of a valid word's address (a row).
    pub fn valid_bits(&self) -> u32 {
        addr_bits(self.max_rows)
    }
    /// Bits of `ld_addr`.
    pub fn ld_addr_bits(&self) -> u32 {
        self.ray_addr_bits()
            .max(self.map_bits())
            .max(self.valid_bits())
    }
    /// Bits of `ld_data`.
    pub fn ld_data_bits(&self) -> u32 {
        self.buffer_width
            .max(self.map_width)
            .max(self.slot_bits() + self.row_bits())
            .max(self.map_depth as u32)
    }
    /// Bits of `ld_pe` in the array.
    pub fn pe_bits(&self) -> u32 {
        addr_bits(self.pes as u64)
    }
    /// Memory bits one PE's readout module declares (both banks, the
    /// column map and, with `pass_skip_empty`, the valid words).
    pub fn memory_bits(&self) -> u64 {
        let valid = if self.sparse {
            self.max_rows * self.map_depth
        } else {
            0
        };
        2 * self.bank_depth * u64::from(self.buffer_width)
            + self.map_depth * u64::from(self.map_width)
            + valid
    }
    /// Register bits one PE's readout module declares: the counts; the
    /// valid word's read register and its row; the row in hand and its
    /// bits; the buffer's and the map's read registers with their row and
    /// bank.
    pub fn register_bits(&self) -> u64 {
        let (s, r, n) = (
            u64::from(self.slot_bits()),
            u64::from(self.row_bits()),
            self.map_depth,
        );
        (s + r)
            + (1 + r + n)
            + (1 + r + n)
            + (1 + 1 + r + 2 * u64::from(self.buffer_width) + u64::from(self.map_width))
    }
}

/// The emitted readout: the PE module and the array top.
#[derive(Debug, Clone)]
pub struct ReadoutRtl {
    /// The shape it was emitted for.
    pub shape: ReadoutShape,
    /// `ercube_pe_readout`'s text.
    pub pe: String,
    /// `ercube_readout_array`'s text.
    pub array: String,
}

/// The readout stage of `shape`: the PE module and the array top.
pub fn emit(shape: &ReadoutShape) -> ReadoutRtl {
    ReadoutRtl {
        shape: *shape,
        pe: pe_module(shape),
        array: array_module(shape),
    }
}

fn pe_module(s: &ReadoutShape) -> String {
    let (cw, aw, w) = (s.color_bits, s.alpha_bits, s.buffer_width);
    let (lab, sb, rb, mb, vb) = (
        s.ray_addr_bits(),
        s.slot_bits(),
        s.row_bits(),
        s.map_bits(),
        s.valid_bits(),
    );
    let (la, ld) = (s.ld_addr_bits(), s.ld_data_bits());
    let ib = RAY_INDEX_BITS;
    let mw = s.map_width;
    let (d, m, rm) = (s.bank_depth, s.map_depth, s.max_rows);
    let n = m;
    let (valid_decl, valid_port, valid_doc) = if s.sparse {
        (
            format!(
                "  (* no_rw_check *) reg [{n1}:0] ray_valid [0:{rm1}];\n",
                n1 = n - 1,
                rm1 = rm - 1
            ),
            format!(
                "    if (ld_we && ld_sel == 2'd{SEL_VALID}) ray_valid[ld_addr[{vb1}:0]] <= ld_data[{n1}:0];\n    if (rst) vq <= {n}'d0;\n    else if (issue_v) vq <= ray_valid[v_addr[{vb1}:0]];\n",
                vb1 = vb - 1,
                n1 = n - 1
            ),
            format!(
                "//   ray_valid: {rm} words x {n} bits, row r's word holding bit c set when ray\n//     (c, r) is not all zero (pass_skip_empty: the readout streams those only).\n"
            ),
        )
    } else {
        (
            String::new(),
            format!(
                "    if (rst) vq <= {n}'d0;\n    else if (issue_v) vq <= ~({n}'d0 - {n}'d1 << ncols);\n"
            ),
            String::new(),
        )
    };
    let mut v = String::new();
    let o = &mut v;
    let _ = writeln!(
        o,
        "// {PE_MODULE}: one PE's readout stage, emitted by ercube (pipeline::hw::readout_rtl).
//
// Memories as declared by Pe::declaration (and, for the valid bits, the
// cost model's ray valid bits), each a synchronous-read RAM with one write
// port (the host load) and one read port (the readout), declared no_rw_check:
// the host loads them before begin_readout, never while the readout reads,
// so a read and a write of one address in one clock need no defined result
// (yosys then builds no bypass registers around the blocks):
//   compositing_buffer: 2 banks x {d} words x {w} bits ({{a, b, g, r}}: r at bit 0,
//     {cw}-bit colour words, a {aw}-bit opacity word), ray (slot c, row r) at the
//     linear address r * {m} + c, bank = its low bit;
//   column_map: {m} words x {mw} bits ({{valid, mx}}, mx a {ib}-bit two's complement index);
{valid_doc}// The readout runs row by row: begin_readout reads row 0's valid word; then
// each clock reads the lowest column still to read in the row in hand, and
// the clock that leaves a row (its last ray read, or none) reads the next
// row's valid word. The buffer's read register drives the host port.
// Ports:
//   clk, rst               synchronous reset of every register
//   ld_we, ld_sel, ld_addr, ld_data  host load: ld_sel {SEL_BUFFER} buffer word at the linear
//                          address, {SEL_MAP} column map slot, {SEL_COUNTS} {{ncols, rows}} ({sb} + {rb} bits){}
//   begin_readout          the controller's BeginReadout broadcast
//   host_valid, host_mx, host_row, host_r, host_g, host_b, host_a
//                          the ray read the clock before (all zero when not valid)
//   done                   every ray read and driven (the readout_done report line)
// Lint: WIDTH is waived: counters compare and add at their own widths and
// Verilog's rules extend the shorter operand with zeros; UNUSEDSIGNAL is
// waived: ld_data and ld_addr are as wide as the widest target and each
// target takes its low bits.
/* verilator lint_off WIDTH */
/* verilator lint_off UNUSEDSIGNAL */
module {PE_MODULE} (
  input  wire clk,
  input  wire rst,
  input  wire ld_we,
  input  wire [1:0] ld_sel,
  input  wire [{la1}:0] ld_addr,
  input  wire [{ld1}:0] ld_data,
  input  wire begin_readout,
  output wire host_valid,
  output wire [{ib1}:0] host_mx,
  output wire [{rb1}:0] host_row,
  output wire [{cw1}:0] host_r,
  output wire [{cw1}:0] host_g,
  output wire [{cw1}:0] host_b,
  output wire [{aw1}:0] host_a,
  output wire done
);
  (* no_rw_check *) reg [{w1}:0] bank0 [0:{d1}];
  (* no_rw_check *) reg [{w1}:0] bank1 [0:{d1}];
  (* no_rw_check *) reg [{mw1}:0] column_map [0:{m1}];
{valid_decl}  reg [{sb1}:0] ncols;
  reg [{rb1}:0] rows;
  reg vv;
  reg [{rb1}:0] vq_row;
  reg [{n1}:0] vq;
  reg have_cur;
  reg [{rb1}:0] cur_row;
  reg [{n1}:0] cur_bits;
  reg rv;
  reg rbank;
  reg [{rb1}:0] r_row;
  reg [{w1}:0] q0;
  reg [{w1}:0] q1;
  reg [{mw1}:0] mq;
  // The lowest set bit of a row's word still to read.
  function [{mb1}:0] lowest;
    input [{n1}:0] b;
    integer i;
    begin
      lowest = {mb}'d0;
      for (i = {n1}; i >= 0; i = i - 1)
        if (b[i]) lowest = i;
    end
  endfunction
  // The row in hand: the one being worked, or the one whose valid word
  // arrives this clock.
  wire active = have_cur || vv;
  wire [{n1}:0] bits = have_cur ? cur_bits : (vv ? vq : {n}'d0);
  wire [{rb1}:0] row_now = have_cur ? cur_row : vq_row;
  wire [{n1}:0] rest = bits & (bits - {n}'d1);
  wire pick = active && bits != {n}'d0;
  wire row_end = active && rest == {n}'d0;
  wire [{rb1}:0] next_row = row_now + {rb}'d1;
  wire issue_v = begin_readout ? (ncols != {sb}'d0 && rows != {rb}'d0) : (row_end && next_row != rows);
  wire [{rb1}:0] v_addr = begin_readout ? {rb}'d0 : next_row;
  wire [{mb1}:0] col = lowest(bits);
  wire [{lab1}:0] addr = row_now * {lab}'d{m} + col;
  wire ld_buf = ld_we && ld_sel == 2'd{SEL_BUFFER};
  always @(posedge clk) begin
    if (ld_buf && !ld_addr[0]) bank0[ld_addr[{lab1}:1]] <= ld_data[{w1}:0];
    if (rst) q0 <= {w}'d0;
    else if (pick) q0 <= bank0[addr[{lab1}:1]];
  end
  always @(posedge clk) begin
    if (ld_buf && ld_addr[0]) bank1[ld_addr[{lab1}:1]] <= ld_data[{w1}:0];
    if (rst) q1 <= {w}'d0;
    else if (pick) q1 <= bank1[addr[{lab1}:1]];
  end
  always @(posedge clk) begin
    if (ld_we && ld_sel == 2'd{SEL_MAP}) column_map[ld_addr[{mb1}:0]] <= ld_data[{mw1}:0];
    if (rst) mq <= {mw}'d0;
    else if (pick) mq <= column_map[col];
  end
  always @(posedge clk) begin
{valid_port}  end
  always @(posedge clk) begin
    if (rst) begin
      ncols <= {sb}'d0;
      rows <= {rb}'d0;
    end else if (ld_we && ld_sel == 2'd{SEL_COUNTS}) begin
      ncols <= ld_data[{srb1}:{rb}];
      rows <= ld_data[{rb1}:0];
    end
  end
  always @(posedge clk) begin
    if (rst) begin
      vv <= 1'b0;
      vq_row <= {rb}'d0;
      have_cur <= 1'b0;
      cur_row <= {rb}'d0;
      cur_bits <= {n}'d0;
      rv <= 1'b0;
      rbank <= 1'b0;
      r_row <= {rb}'d0;
    end else begin
      vv <= issue_v;
      if (issue_v) vq_row <= v_addr;
      have_cur <= active && !row_end;
      if (active) begin
        cur_bits <= rest;
        cur_row <= row_now;
      end
      rv <= pick;
      if (pick) begin
        r_row <= row_now;
        rbank <= addr[0];
      end
    end
  end
  // The read register drives the host port.
  wire [{w1}:0] word = rbank ? q1 : q0;
  assign host_valid = rv && mq[{ib}];
  assign host_mx = host_valid ? mq[{ib1}:0] : {ib}'d0;
  assign host_row = host_valid ? r_row : {rb}'d0;
  assign host_r = host_valid ? word[{cw1}:0] : {cw}'d0;
  assign host_g = host_valid ? word[{cw2}:{cw}] : {cw}'d0;
  assign host_b = host_valid ? word[{cw3}:{cw2p}] : {cw}'d0;
  assign host_a = host_valid ? word[{w1}:{cw3p}] : {aw}'d0;
  assign done = !vv && !have_cur && !rv;
endmodule
/* verilator lint_on UNUSEDSIGNAL */
/* verilator lint_on WIDTH */",
        if s.sparse {
            format!(", {SEL_VALID} ray_valid row word")
        } else {
            String::new()
        },
        la1 = la - 1,
        ld1 = ld - 1,
        ib1 = ib - 1,
        rb1 = rb - 1,
        cw1 = cw - 1,
        aw1 = aw - 1,
        w1 = w - 1,
        d1 = d - 1,
        mw1 = mw - 1,
        m1 = m - 1,
        n1 = n - 1,
        sb1 = sb - 1,
        lab1 = lab - 1,
        mb1 = mb - 1,
        srb1 = sb + rb - 1,
        cw2 = 2 * cw - 1,
        cw3 = 3 * cw - 1,
        cw2p = 2 * cw,
        cw3p = 3 * cw,
    );
    v
}

fn array_module(s: &ReadoutShape) -> String {
    let p = s.pes;
    let (cw, aw, rb, ib) = (s.color_bits, s.alpha_bits, s.row_bits(), RAY_INDEX_BITS);
    let (la, ld, pb) = (s.ld_addr_bits(), s.ld_data_bits(), s.pe_bits());
    let mut v = String::new();
    let o = &mut v;
    let _ = writeln!(
        o,
        "// {ARRAY_MODULE}: {p} PEs' readout stages and their host ports, emitted by ercube
// (pipeline::hw::readout_rtl).
//
// Ports:
//   clk, rst               synchronous reset of every register
//   ld_we, ld_pe, ld_sel, ld_addr, ld_data  host load into PE ld_pe ({PE_MODULE}'s load port)
//   begin_readout          the controller's BeginReadout, broadcast to every PE
//   host_valid[k], host_mx[k*{ib} +: {ib}], host_row[k*{rb} +: {rb}],
//   host_r/g/b[k*{cw} +: {cw}], host_a[k*{aw} +: {aw}]   PE k's host port
//   done[k]                PE k's readout_done report line; all_done their AND
module {ARRAY_MODULE} (
  input  wire clk,
  input  wire rst,
  input  wire ld_we,
  input  wire [{pb1}:0] ld_pe,
  input  wire [1:0] ld_sel,
  input  wire [{la1}:0] ld_addr,
  input  wire [{ld1}:0] ld_data,
  input  wire begin_readout,
  output wire [{p1}:0] host_valid,
  output wire [{pib1}:0] host_mx,
  output wire [{prb1}:0] host_row,
  output wire [{pcw1}:0] host_r,
  output wire [{pcw1}:0] host_g,
  output wire [{pcw1}:0] host_b,
  output wire [{paw1}:0] host_a,
  output wire [{p1}:0] done,
  output wire all_done
);
  assign all_done = &done;",
        pb1 = pb - 1,
        la1 = la - 1,
        ld1 = ld - 1,
        p1 = p - 1,
        pib1 = p as u32 * ib - 1,
        prb1 = p as u32 * rb - 1,
        pcw1 = p as u32 * cw - 1,
        paw1 = p as u32 * aw - 1,
    );
    for k in 0..p as u32 {
        let _ = writeln!(
            o,
            "  {PE_MODULE} pe{k} (
    .clk(clk), .rst(rst),
    .ld_we(ld_we && ld_pe == {pb}'d{k}), .ld_sel(ld_sel), .ld_addr(ld_addr), .ld_data(ld_data),
    .begin_readout(begin_readout),
    .host_valid(host_valid[{k}]),
    .host_mx(host_mx[{m1}:{m0}]),
    .host_row(host_row[{r1}:{r0}]),
    .host_r(host_r[{c1}:{c0}]),
    .host_g(host_g[{c1}:{c0}]),
    .host_b(host_b[{c1}:{c0}]),
    .host_a(host_a[{a1}:{a0}]),
    .done(done[{k}])
  );",
            m0 = k * ib,
            m1 = k * ib + ib - 1,
            r0 = k * rb,
            r1 = k * rb + rb - 1,
            c0 = k * cw,
            c1 = k * cw + cw - 1,
            a0 = k * aw,
            a1 = k * aw + aw - 1,
        );
    }
    let _ = writeln!(o, "endmodule");
    v
}
