//! The PE's sample stage in Verilog: its voxel memory (the slice buffer
//! and the copy of its first column it drives to the left neighbour), its
//! compositing buffer, the column map's held range, and the control that
//! walks a row's rays one a clock into the pipelined datapath
//! ([`super::pipeline_rtl`]'s `ercube_sample`), reads each ray's
//! accumulators from the buffer as it issues and writes them back
//! when the datapath returns them, and serves the voxel taps, the column
//! right of the block from the right neighbour's edge register.
//!
//! Golden twin of the stage: [`crate::pe::Pe::sample_step`] (the model
//! this module is checked against, clock for clock, by
//! [`crate::cosim::pe_sample`]), whose golden twin is
//! `golden::sampling::sample_region`.
//!
//! The depths, widths and addresses are [`PeSampleShape`]'s (from the
//! PE's declaration).
//!
//! The controller's broadcast comes one clock ahead (`bc_*`): in the clock
//! before a sampling cycle the control picks the ray that issues in it
//! (the row's `c`-th planned column, `c` counting the row's sampling
//! cycles); in the clock it finds the ray's buffer word from the
//! registered pick and reads its accumulators, which the datapath takes a
//! clock later ([`super::schedule::RAY_STAGE`]), a write-back of the
//! issue's clock forwarded. Two clocks, so that neither holds both the
//! pick's carry chain and the buffer's address.
//!
//! Which columns a row samples is the PE's **row plan** (`plan`, one word
//! of `slots` bits a sampled ray row, bit `i` for held column `map_lo +
//! i`, a FIFO in the order the rows issue): what
//! [`crate::pe::Pe::plan_rows`] computes from the controller's `PlanRows`
//! broadcast at the slice's start, the held columns inside the slice's x
//! range and inside the row's runs. The runs are the controller's: its
//! occupancy memory and clip planes decide them
//! ([`crate::skip::plan_mask`], golden's planner), so empty-space skipping
//! and culling reach the PE as cleared bits, and the control issues a
//! row's set bits lowest first, one a clock (the lowest bit not yet
//! issued, one-hot from a carry chain, its index from an OR tree; the
//! slot `map_sl + idx` wrapped once, `map_sl` the held range's first slot,
//! which migration writes with the range). The plan is written through
//! its port (`pl_*`, `pe_plan_rtl`: the controller's runs, one a clock,
//! turned into the PE's bits by thermometer codes of the run's ends)
//! before the row's first issue.
//!
//! Front to back with early ray termination the PE also keeps a
//! **termination bit** a ray (`term`, a word of `slots` bits a ray row,
//! indexed by slot): each write-back writes its ray's bit from the
//! threshold comparator on the opacity it writes, and a row issues its
//! planned columns whose bit is clear, the row's word read in the clock
//! before its first issue (`pe_term_rtl`).

use std::fmt::Write as _;

pub use super::pe_sample_shape::PeSampleShape;
use super::pipeline_rtl::PipelinedModule;
use crate::cost::inventory::addr_bits;

/// The module's name.
pub const MODULE: &str = "ercube_pe_sample";

/// The emitted module and what it declares.
#[derive(Debug, Clone)]
pub struct PeSampleRtl {
    /// The Verilog text.
    pub verilog: String,
    /// Register bits the control declares (the datapath's are its own).
    pub register_bits: u64,
}

/// The datapath's accumulator ports, which the PE feeds from its buffer.
const ACCS: [&str; 4] = ["acc_r", "acc_g", "acc_b", "acc_a"];

/// A port's `[w-1:0]`, signed when `signed`.
pub(crate) fn range(bits: u32, signed: bool) -> String {
    format!("{}[{}:0]", if signed { "signed " } else { "" }, bits - 1)
}

/// The PE's sample stage around `dp` (the emitted `ercube_sample`).
pub fn emit(s: &PeSampleShape, dp: &PipelinedModule) -> Result<PeSampleRtl, String> {
    let port = |n: &str| {
        dp.ports
            .iter()
            .find(|p| p.name == n)
            .ok_or_else(|| format!("the datapath has no port {n}"))
    };
    let sx = port("x0")?.stage;
    let sv = port("v00")?.stage;
    if sv != sx + 1 {
        return Err(format!(
            "the datapath reads its taps {sv} clocks after issue and shows the tap column at {sx}: the voxel memory answers one clock after the column"
        ));
    }
    for n in ACCS {
        let st = port(n)?.stage;
        if st != super::schedule::RAY_STAGE {
            return Err(format!(
                "the datapath takes the ray's {n} {st} clocks after issue: the PE reads the buffer in the issue's clock and gives it {} clocks after",
                super::schedule::RAY_STAGE
            ));
        }
    }
    let depth = dp.depth;
    let v = s.voxel_bits;
    let r = &s.rays;
    let (cw, aw) = (r.color_bits, r.alpha_bits);
    let bw = r.buffer_width;
    let ab = r.ray_addr_bits();
    let rb = r.row_bits();
    let yb = s.row_bits();
    let cb = s.col_bits();
    let ib = s.index_bits;
    let half = s.half_rows;
    let (slots, off, stored) = (s.slots(), s.slot_offset(), s.stored);
    let bank_words = s.bank_words();
    let sbw = addr_bits(bank_words);
    let ebw = addr_bits(2 * half);
    let hb = addr_bits(half);
    let lb = addr_bits(stored);
    let units = super::pe_units_rtl::UnitWiring::of(dp);
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(
        w,
        "// {MODULE}: one PE's sample stage (pipeline::hw::pe_sample_rtl), emitted by ercube.
// Slice buffer: 2 row banks x 2 slices x {stored} columns x {half} rows of {v} bits;
// edge column: 2 row banks x 2 slices x {half} words; compositing buffer: 2 banks x
// {bd} words of {bw} bits, ray (slot, row) at row * {slots} + slot, slot = (mx + {off}) % {slots}
// (map_sl + idx, wrapped); row plan: a FIFO of {rows} words of {slots} bits in the order the rows
// issue, bit i set when held column map_lo + i samples in the row.
// The broadcast bc_* is the next clock's; the datapath ({dp_name}) is {depth} clocks deep,
// shows its tap column {sx} clocks after issue and reads the taps one clock later.
{units_header}// Lint waivers: WIDTH (some indices are computed in 32-bit integers and cut to
// their memories' address widths), UNUSEDSIGNAL (a word's upper bits past an
// address go nowhere).
/* verilator lint_off WIDTH */
/* verilator lint_off UNUSEDSIGNAL */
module {MODULE} (
  input wire clk,
  input wire rst,",
        bd = r.bank_depth,
        rows = r.max_rows,
        dp_name = dp.name,
        units_header = units.header(),
    );
    for n in ["tbl_we", "tbl_sel", "tbl_addr", "tbl_data"] {
        let p = port(n)?;
        let _ = writeln!(w, "  input wire {} {n},", range(p.word.bits, false));
    }
    w.push_str(&units.ports());
    let _ = writeln!(
        w,
        "  // The host's voxel load: slice parity, row bank, row / 2, local column.
  input wire vld_we,
  input wire vld_z,
  input wire vld_bank,
  input wire [{hb1}:0] vld_row,
  input wire [{lb1}:0] vld_col,
  input wire [{v1}:0] vld_data,
  // The held columns (the column map's range: first mx, count, the first's slot), written by migration.
  input wire map_we,
  input wire signed [{ib1}:0] map_lo_in,
  input wire [{sb1}:0] map_n_in,
  input wire [{tb1}:0] map_sl_in,
{plan_ports}
  // This PE's voxel columns: first, one past the last, the volume's last.
  input wire [{cb1}:0] col_lo,
  input wire [{cb1}:0] col_end,
  input wire [{cb1}:0] nx_last,
  // The controller's broadcast for the next clock.
  input wire bc_go,
  input wire bc_first,
  input wire [{rb1}:0] bc_row,
  input wire bc_z,
  input wire [{yb1}:0] bc_y0,
  input wire [{yb1}:0] bc_y1,
  input wire bc_nv,
  input wire bc_nz,
  input wire [{yb1}:0] bc_ny0,
  input wire [{yb1}:0] bc_ny1,",
        hb1 = hb - 1,
        lb1 = lb - 1,
        v1 = v - 1,
        ib1 = ib - 1,
        sb1 = r.slot_bits() - 1,
        tb1 = super::pe_columns_rtl::slot_bits(s) - 1,
        cb1 = cb - 1,
        rb1 = rb - 1,
        yb1 = yb - 1,
        plan_ports = super::pe_plan_rtl::ports(s),
    );
    // The row's words, then the units' (taken at issue like them).
    let row_words: Vec<&str> = ["a", "t", "b", "k", "row_wy", "sy", "sz"]
        .into_iter()
        .chain(units.row_names())
        .collect();
    for &n in &row_words {
        let p = port(n)?;
        let _ = writeln!(
            w,
            "  input wire {} bc_{n},",
            range(p.word.bits, p.word.signed)
        );
    }
    let accs = ACCS;
    let taps = ["v00", "v01", "v10", "v11"];
    let m = port("slot_m")?;
    let _ = writeln!(
        w,
        "  // The neighbours: the right one's first column at the row's two voxel rows, ours to the left.
  input wire [{e1}:0] edge_in,
  output wire [{e1}:0] edge_out,
  // What the control issues into the datapath, the taps it serves, the write-back.
  output reg iss_valid,
  output {mk} {mr} iss_m,",
        e1 = 2 * v - 1,
        mr = range(m.word.bits, m.word.signed),
        mk = if s.round_robin { "reg" } else { "wire" },
    );
    // The issuing ray's accumulators, a clock after its issue.
    let _ = writeln!(w, "  output wire acc_valid,");
    for n in accs {
        let p = port(n)?;
        let _ = writeln!(
            w,
            "  output wire {} iss_{n},",
            range(p.word.bits, p.word.signed)
        );
    }
    let _ = writeln!(w, "  output reg tap_valid,");
    for n in taps {
        let _ = writeln!(w, "  output wire [{}:0] tap_{n},", v - 1);
    }
    let _ = writeln!(
        w,
        "  output wire wb_valid,\n  output wire [{}:0] wb_addr,\n  output wire [{}:0] wb_data\n);",
        ab - 1,
        bw - 1
    );
    // Memories and the column map's range.
    let (plan_write, plan_regs) = super::pe_plan_rtl::write_side(s);
    let _ = writeln!(
        w,
        "  reg [{v1}:0] sb0 [0:{bwm}];
  reg [{v1}:0] sb1 [0:{bwm}];
  reg [{v1}:0] ec0 [0:{ewm}];
  reg [{v1}:0] ec1 [0:{ewm}];
  reg [{bw1}:0] bank0 [0:{bdm}];
  reg [{bw1}:0] bank1 [0:{bdm}];
  reg [{s1}:0] plan [0:{rm}];
  reg signed [{ib1}:0] map_lo;
  reg [{sb1}:0] map_n;
  reg [{tb1}:0] map_sl;
{rr_decls}{frame_regs}  always @(posedge clk) begin
    if (rst) begin
      map_lo <= 0;
      map_n <= 0;
      map_sl <= 0;
    end else if (map_we) begin
      map_lo <= map_lo_in;
      map_n <= map_n_in;
      map_sl <= map_sl_in;
    end
  end
{plan_write}  // The host's voxel load; column 0 also into the edge column.
  wire [{sbw1}:0] vld_rw = (vld_z ? {half} : 0) + vld_row;
  wire [{sbw1}:0] vld_word = {vld_base} + vld_col;
  wire [31:0] vld_edge = {{31'd0, vld_z}} * {half} + vld_row;
  always @(posedge clk) begin
    if (vld_we && !vld_bank) sb0[vld_word[{sbw1}:0]] <= vld_data;
    if (vld_we && vld_bank) sb1[vld_word[{sbw1}:0]] <= vld_data;
    if (vld_we && vld_col == 0 && !vld_bank) ec0[vld_edge[{ebw1}:0]] <= vld_data;
    if (vld_we && vld_col == 0 && vld_bank) ec1[vld_edge[{ebw1}:0]] <= vld_data;
  end",
        v1 = v - 1,
        bwm = bank_words - 1,
        ewm = 2 * half - 1,
        bw1 = bw - 1,
        bdm = r.bank_depth - 1,
        ib1 = ib - 1,
        sb1 = r.slot_bits() - 1,
        tb1 = super::pe_columns_rtl::slot_bits(s) - 1,
        sbw1 = sbw - 1,
        ebw1 = ebw - 1,
        vld_base = super::pe_columns_rtl::times(stored, "vld_rw"),
        s1 = slots - 1,
        rm = r.max_rows - 1,
        rr_decls = super::pe_columns_rtl::declarations(s),
        frame_regs = units.registers(),
    );
    if let Some(thr) = s.termination {
        super::pe_term_rtl::termination_bits(w, s, depth, thr);
    }
    let live = if s.termination.is_some() {
        " & ~dead"
    } else {
        ""
    };
    // The control: the pick one clock ahead of issue, the buffer's read in
    // the clock.
    let _ = writeln!(
        w,
        "  // The row's c-th planned column issues in the row's c-th cycle: the
  // lowest of the row's bits not issued yet (rem holds them after the first),
  // one-hot from a carry chain (bits & -bits), its index from an OR tree.
  reg [{s1}:0] rem;
  wire [{s1}:0] row_bits = bc_first ? hq{live} : rem;
  wire [{s1}:0] one = row_bits & (~row_bits + {slots}'d1);
  wire [{tb1}:0] idx;
{encoder}
{mx}
  wire go = bc_go && row_bits != 0;
  always @(posedge clk) begin
    if (rst) rem <= 0;
    else if (bc_go) rem <= row_bits & ~one;
  end
  // The pick, registered: the issuing ray's row and what finds its slot.
  reg [{rb1}:0] k_row;
  always @(posedge clk) begin
    if (rst) k_row <= 0;
    else k_row <= bc_row;
  end
{pick}
{slot}
  // The ray's buffer word, row * {slots} + slot, the product as the row's
  // shifted sums, read from both banks in the issue's clock: the datapath
  // takes the accumulators a clock after issue, a write-back of the issue's
  // clock forwarded (compared then, off the read's path).
  wire [{ab1}:0] row_w = k_row;
  wire [{ab1}:0] addr = {row_base} + slot;
  reg [{bw1}:0] rq0, rq1;
  reg [{ab1}:0] s_addr;
  always @(posedge clk) begin
    rq0 <= bank0[addr[{ab1}:1]];
    rq1 <= bank1[addr[{ab1}:1]];
    if (rst) s_addr <= 0;
    else s_addr <= addr[{ab1}:0];
  end
  reg a_valid;
  reg s_z;
  reg [{yb1}:0] s_y0, s_y1;
  reg fw_v;
  reg [{ab1}:0] fw_a;
  reg [{bw1}:0] fw_d;",
        s1 = slots - 1,
        tb1 = super::pe_columns_rtl::slot_bits(s) - 1,
        rb1 = rb - 1,
        bw1 = bw - 1,
        ab1 = ab - 1,
        yb1 = yb - 1,
        encoder = super::pe_columns_rtl::encoder(s),
        mx = super::pe_columns_rtl::mx(s),
        slot = super::pe_columns_rtl::slot(s),
        pick = super::pe_columns_rtl::pick_registers(s).0,
        row_base = super::pe_columns_rtl::times(slots, "row_w"),
    );
    for &n in &row_words {
        let p = port(n)?;
        let _ = writeln!(w, "  reg {} s_{n};", range(p.word.bits, p.word.signed));
    }
    let _ = writeln!(
        w,
        "  always @(posedge clk) begin
    if (rst) begin
      iss_valid <= 1'b0;{m0}
      a_valid <= 1'b0;
      s_z <= 1'b0;
      s_y0 <= 0;
      s_y1 <= 0;
      fw_v <= 1'b0;
      fw_a <= 0;
      fw_d <= 0;",
        m0 = if s.round_robin {
            "\n      iss_m <= 0;"
        } else {
            ""
        },
    );
    for &n in &row_words {
        let _ = writeln!(w, "      s_{n} <= 0;");
    }
    let _ = writeln!(
        w,
        "    end else begin
      iss_valid <= go;{m1}
      a_valid <= iss_valid;
      s_z <= bc_z;
      s_y0 <= bc_y0;
      s_y1 <= bc_y1;
      fw_v <= wb_valid;
      fw_a <= wb_addr;
      fw_d <= wb_data;",
        m1 = if s.round_robin {
            "\n      iss_m <= go ? mx : 0;"
        } else {
            ""
        },
    );
    for &n in &row_words {
        let _ = writeln!(w, "      s_{n} <= go ? bc_{n} : 0;");
    }
    let _ = writeln!(
        w,
        "    end
  end
  wire [{bw1}:0] acc_word = (fw_v && fw_a == s_addr) ? fw_d : (s_addr[0] ? rq1 : rq0);
  wire [{bw1}:0] acc_in = a_valid ? acc_word : {{{bw}{{1'b0}}}};
  assign acc_valid = a_valid;",
        bw1 = bw - 1,
    );
    let fields = [
        ("acc_r", 0, cw),
        ("acc_g", cw, cw),
        ("acc_b", 2 * cw, cw),
        ("acc_a", 3 * cw, aw),
    ];
    for (n, lo, bits) in fields {
        let _ = writeln!(w, "  assign iss_{n} = acc_in[{}:{lo}];", lo + bits - 1);
    }
    // Delay lines to the tap stage, and the taps.
    let x0r = range(port("x0")?.word.bits, true);
    let mut regs = super::pe_taps_rtl::tap_stage(w, s, &x0r, sx);
    regs += super::pe_columns_rtl::edge_register(w, s);
    regs += super::pe_carry_rtl::address_line(w, ab, depth);
    let out_fields: Vec<String> = ["acc_out_a", "acc_out_b", "acc_out_g", "acc_out_r"]
        .iter()
        .map(|n| format!("{n}_w"))
        .collect();
    for (n, bits) in [
        ("acc_out_r", cw),
        ("acc_out_g", cw),
        ("acc_out_b", cw),
        ("acc_out_a", aw),
    ] {
        let _ = writeln!(w, "  wire [{}:0] {n}_w;", bits - 1);
    }
    let _ = writeln!(
        w,
        "  wire dp_out_valid;
  assign wb_valid = dp_out_valid;
  assign wb_addr = wa_{depth};
  assign wb_data = {{{}}};
  always @(posedge clk) begin
    if (wb_valid && !wb_addr[0]) bank0[wb_addr[{ab1}:1]] <= wb_data;
    if (wb_valid && wb_addr[0]) bank1[wb_addr[{ab1}:1]] <= wb_data;
  end",
        out_fields.join(", "),
        ab1 = ab - 1
    );
    if s.termination.is_some() {
        regs += super::pe_carry_rtl::termination_line(w, s, depth);
    }
    // rem, the pick's, k_row, rq0/rq1, iss_valid, a_valid, s_addr, s_z,
    // s_y0/s_y1, fw_v/fw_a/fw_d, the held range (map_lo, map_n, map_sl),
    // and under a round-robin mapping iss_m (else a sum of the pick's).
    regs += slots
        + super::pe_columns_rtl::pick_registers(s).1
        + u64::from(rb)
        + 2 * u64::from(bw)
        + 2
        + if s.round_robin {
            u64::from(m.word.bits)
        } else {
            0
        }
        + u64::from(ab)
        + 1
        + 2 * u64::from(yb)
        + 1
        + u64::from(ab)
        + u64::from(bw)
        + u64::from(ib)
        + u64::from(r.slot_bits())
        + u64::from(super::pe_columns_rtl::slot_bits(s));
    for &n in &row_words {
        regs += u64::from(port(n)?.word.bits);
    }
    regs += units.register_bits();
    // The datapath.
    let mut conns = Vec::new();
    for p in &dp.ports {
        let n = p.name.as_str();
        let c = match n {
            "clk" | "rst" | "tbl_we" | "tbl_sel" | "tbl_addr" | "tbl_data" => n.to_owned(),
            "in_valid" => "iss_valid".to_owned(),
            "out_valid" => "dp_out_valid".to_owned(),
            "slot_m" => "iss_m".to_owned(),
            "x0" => "x0".to_owned(),
            _ if row_words.contains(&n) => format!("s_{n}"),
            _ if units.is_frame(n) => format!("frm_{n}"),
            _ if accs.contains(&n) => format!("iss_{n}"),
            _ if taps.contains(&n) => format!("tap_{n}"),
            _ if n.starts_with("acc_out_") => format!("{n}_w"),
            _ => return Err(format!("the datapath's port {n} has no place in the PE")),
        };
        conns.push(format!(".{n}({c})"));
    }
    let _ = writeln!(
        w,
        "  {} u_dp ({});\nendmodule\n/* verilator lint_on UNUSEDSIGNAL */\n/* verilator lint_on WIDTH */",
        dp.name,
        conns.join(", ")
    );
    Ok(PeSampleRtl {
        verilog: t,
        register_bits: regs + plan_regs,
    })
}
