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
//! The buffer holds region 0's rays column after column (ray `(slot, row)`
//! at `slot * rows + row`), its two banks interleaved by the address's low
//! bit; the column map's slot `s` holds `{valid, mx}` of the `s`-th held
//! column. On `begin_readout` the cursor starts at `(0, 0)`; each clock it
//! reads one ray (buffer and map, one clock of read latency) and moves to
//! the next row or the next column's first; the read register drives the
//! host port the clock after, an all-zero word left off when the
//! configuration skips empty rays (`pass_skip_empty`). `done` rises once
//! the cursor has passed the last ray and the read register is empty.

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
        if geo.preint {
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
            max_rows: 2 * geo.dims[1] as u64 + 1,
            sparse: cfg.pass_skip_empty,
        })
    }

    /// The shape for a frame of `view` (its dimensions and regions).
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<ReadoutShape, String> {
        let plan = crate::host::plan(cfg, view).map_err(|e| e.to_string())?;
        let geo = Geometry {
            dims: view.dims,
            pes: cfg.pes,
            regions: plan.regions.len() as u32,
            shading: false,
            voi: false,
            preint: false,
        };
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
    /// Bits of `ld_addr`.
    pub fn ld_addr_bits(&self) -> u32 {
        self.ray_addr_bits().max(self.map_bits())
    }
    /// Bits of `ld_data`.
    pub fn ld_data_bits(&self) -> u32 {
        self.buffer_width
            .max(self.map_width)
            .max(self.slot_bits() + self.row_bits())
    }
    /// Bits of `ld_pe` in the array.
    pub fn pe_bits(&self) -> u32 {
        addr_bits(self.pes as u64)
    }
    /// Memory bits one PE's readout module declares (both banks and the
    /// column map).
    pub fn memory_bits(&self) -> u64 {
        2 * self.bank_depth * u64::from(self.buffer_width)
            + self.map_depth * u64::from(self.map_width)
    }
    /// Register bits one PE's readout module declares.
    pub fn register_bits(&self) -> u64 {
        let (s, r, a) = (
            u64::from(self.slot_bits()),
            u64::from(self.row_bits()),
            u64::from(self.ray_addr_bits()),
        );
        // ncols, rows; busy, slot, row, ra; rv, rbank, r_row; q0, q1, mq.
        s + r
            + 1
            + s
            + r
            + a
            + 1
            + 1
            + r
            + 2 * u64::from(self.buffer_width)
            + u64::from(self.map_width)
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
    let (lab, sb, rb, mb) = (s.ray_addr_bits(), s.slot_bits(), s.row_bits(), s.map_bits());
    let (la, ld) = (s.ld_addr_bits(), s.ld_data_bits());
    let ib = RAY_INDEX_BITS;
    let mw = s.map_width;
    let (d, m) = (s.bank_depth, s.map_depth);
    let nonzero = if s.sparse { "|word" } else { "1'b1" };
    let mut v = String::new();
    let o = &mut v;
    let _ = writeln!(
        o,
        "// {PE_MODULE}: one PE's readout stage, emitted by ercube (pipeline::hw::readout_rtl).
//
// Memories as declared by Pe::declaration, each a synchronous-read RAM
// (one write port, the host load; one read port, the cursor):
//   compositing_buffer: 2 banks x {d} words x {w} bits ({{a, b, g, r}}: r at bit 0,
//     {cw}-bit colour words, a {aw}-bit opacity word), ray (slot, row) at the
//     linear address slot * rows + row, bank = its low bit;
//   column_map: {m} words x {mw} bits ({{valid, mx}}, mx a {ib}-bit two's complement index).
// Ports:
//   clk, rst               synchronous reset of every register
//   ld_we, ld_sel, ld_addr, ld_data  host load: ld_sel {SEL_BUFFER} buffer word at the linear
//                          address, {SEL_MAP} column map slot, {SEL_COUNTS} {{ncols, rows}} ({sb} + {rb} bits)
//   begin_readout          the controller's BeginReadout broadcast; the clock it is
//                          high reads ray (0, 0)
//   host_valid, host_mx, host_row, host_r, host_g, host_b, host_a
//                          the ray read the clock before (all zero when not valid{});
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
  reg [{w1}:0] bank0 [0:{d1}];
  reg [{w1}:0] bank1 [0:{d1}];
  reg [{mw1}:0] column_map [0:{m1}];
  reg [{sb1}:0] ncols;
  reg [{rb1}:0] rows;
  reg busy;
  reg [{sb1}:0] slot;
  reg [{rb1}:0] row;
  reg [{lab1}:0] ra;
  reg rv;
  reg rbank;
  reg [{rb1}:0] r_row;
  reg [{w1}:0] q0;
  reg [{w1}:0] q1;
  reg [{mw1}:0] mq;
  // The cursor this clock: (0, 0) on begin_readout, else the registers.
  wire go = begin_readout ? (ncols != {sb}'d0 && rows != {rb}'d0) : busy;
  wire [{sb1}:0] c_slot = begin_readout ? {sb}'d0 : slot;
  wire [{rb1}:0] c_row = begin_readout ? {rb}'d0 : row;
  wire [{lab1}:0] c_a = begin_readout ? {lab}'d0 : ra;
  wire [{rb1}:0] n_row = c_row + {rb}'d1;
  wire [{sb1}:0] n_slot = c_slot + {sb}'d1;
  wire last_row = (n_row == rows);
  wire ld_buf = ld_we && ld_sel == 2'd{SEL_BUFFER};
  always @(posedge clk) begin
    if (ld_buf && !ld_addr[0]) bank0[ld_addr[{lab1}:1]] <= ld_data[{w1}:0];
    if (rst) q0 <= {w}'d0;
    else if (go) q0 <= bank0[c_a[{lab1}:1]];
  end
  always @(posedge clk) begin
    if (ld_buf && ld_addr[0]) bank1[ld_addr[{lab1}:1]] <= ld_data[{w1}:0];
    if (rst) q1 <= {w}'d0;
    else if (go) q1 <= bank1[c_a[{lab1}:1]];
  end
  always @(posedge clk) begin
    if (ld_we && ld_sel == 2'd{SEL_MAP}) column_map[ld_addr[{mb1}:0]] <= ld_data[{mw1}:0];
    if (rst) mq <= {mw}'d0;
    else if (go) mq <= column_map[c_slot[{mb1}:0]];
  end
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
      busy <= 1'b0;
      slot <= {sb}'d0;
      row <= {rb}'d0;
      ra <= {lab}'d0;
      rv <= 1'b0;
      rbank <= 1'b0;
      r_row <= {rb}'d0;
    end else begin
      rv <= go;
      if (go) begin
        r_row <= c_row;
        rbank <= c_a[0];
        ra <= c_a + {lab}'d1;
        if (last_row) begin
          row <= {rb}'d0;
          slot <= n_slot;
          busy <= (n_slot != ncols);
        end else begin
          row <= n_row;
          slot <= c_slot;
          busy <= 1'b1;
        end
      end
    end
  end
  // The read register drives the host port.
  wire [{w1}:0] word = rbank ? q1 : q0;
  wire live = rv && mq[{ib}];
  assign host_valid = live && {nonzero};
  assign host_mx = host_valid ? mq[{ib1}:0] : {ib}'d0;
  assign host_row = host_valid ? r_row : {rb}'d0;
  assign host_r = host_valid ? word[{cw1}:0] : {cw}'d0;
  assign host_g = host_valid ? word[{cw2}:{cw}] : {cw}'d0;
  assign host_b = host_valid ? word[{cw3}:{cw2p}] : {cw}'d0;
  assign host_a = host_valid ? word[{w1}:{cw3p}] : {aw}'d0;
  assign done = !busy && !rv;
endmodule
/* verilator lint_on UNUSEDSIGNAL */
/* verilator lint_on WIDTH */",
        if s.sparse {
            "; an all-zero ray is not valid"
        } else {
            ""
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
