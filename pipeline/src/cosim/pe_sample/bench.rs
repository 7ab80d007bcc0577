//! The sample stage's testbench (`ercube_pe_cosim`): P PEs
//! ([`crate::hw::pe_sample_rtl`]), each one's edge register wired to its
//! left neighbour's `edge_in`, driven by the replayed broadcast.
//!
//! It resets, writes the datapath's tables through the host port
//! (`tables.hex`, `+tables=N` rows) and the units' frame registers
//! through the register port (`frame.hex`, `+frames=N` rows), then runs clocks `0..=+cycles`. In
//! the middle of clock `c` it applies what the model did to each PE after
//! clock `c` outside the sample stage (`pe<K>.ev`: a slice's voxels into
//! the half of the slice buffer and the edge column its parity names, a
//! buffer word; written straight into the memories, as the model counts no
//! clock for them; kind 5, front to back with termination, a ray's
//! termination bit), drives the held range one clock ahead through the
//! `map` port (`pe<K>.map`), the controller's run of clock `c` on every
//! PE's plan port (`plan.txt`; none where the controller sends none) and
//! the broadcast of clock `c + 1` (`bus.txt`; nothing where the model did
//! not sample). At the end of each clock it
//! prints each PE's issue, taps and write-back (`rtl<K>.I`, `.T`, `.W`,
//! the model's text); in the middle of clock `+dump` (after that clock's
//! events) it writes each PE's buffer
//! (`buf<K>.hex`: both banks' word at each address, a line each).
//! Nothing in the text depends on the frame beyond the shape.

use std::fmt::Write as _;

use crate::hw::pe_sample_rtl::{PeSampleShape, MODULE};
use crate::hw::pe_units_rtl::UnitWiring;
use crate::hw::pipeline_rtl::PipelinedModule;

/// The testbench's module name.
pub const TOP: &str = "ercube_pe_cosim";

/// The testbench for `pes` PEs of `shape` around datapath `dp`, whose
/// tap stage is `tap_stage` clocks after issue; `nz` slices.
pub fn testbench(
    shape: &PeSampleShape,
    dp: &PipelinedModule,
    pes: usize,
    nz: u64,
    tap_stage: u64,
) -> String {
    let bits = |n: &str| {
        dp.ports
            .iter()
            .find(|p| p.name == n)
            .map_or(1, |p| p.word.bits)
    };
    let (sb, ab, db) = (bits("tbl_sel"), bits("tbl_addr"), bits("tbl_data"));
    // The ray index, as the PE's iss_m declares it.
    let mr = dp.ports.iter().find(|p| p.name == "slot_m").map_or_else(
        || "[0:0]".to_owned(),
        |p| crate::hw::pe_sample_rtl::range(p.word.bits, p.word.signed),
    );
    let units = UnitWiring::of(dp);
    // The units' ports of each PE: the broadcast's words, the frame port.
    let mut unit_conns = String::new();
    for n in units.row_names() {
        let src = if n == "voi_y" { "bc_vy" } else { "bc_vz" };
        let _ = write!(unit_conns, " .bc_{n}({src}),");
    }
    if !units.frame.is_empty() {
        unit_conns.push_str(" .frm_we(frm_we), .frm_sel(frm_sel), .frm_data(frm_data),");
    }
    let tw = 1 + sb + ab + db;
    let r = &shape.rays;
    let (cw, aw) = (r.color_bits, r.alpha_bits);
    let (ny, half, stored) = (shape.ny, shape.half_rows, shape.stored);
    let vol = nz * ny * stored;
    let bd = r.bank_depth;
    // A row's termination bits, front to back with termination.
    let s1 = shape.slots() - 1;
    let mut v = String::new();
    let w = &mut v;
    let _ = writeln!(
        w,
        "// {TOP}: the sample stage of {pes} PEs replayed from the model (pipeline::cosim::pe_sample).
`timescale 1ns/1ps
module {TOP};
  reg clk, rst;
  reg [63:0] cyc, cycles, dump_at;
  integer phase, ntables, i, got, fcfg, fdump, yy, ll, zz, zp;
  reg [{tw1}:0] tables [0:65535];
  reg tbl_we;
  reg [{sb1}:0] tbl_sel;
  reg [{ab1}:0] tbl_addr;
  reg [{db1}:0] tbl_data;
  // The files the clocked blocks read with $fscanf are public: Verilator
  // 5.006 takes $fscanf's descriptor for a variable it writes, so it
  // copies a descriptor set in the initial block into each always block
  // as a local left at 0, and every read there fails.
  // The broadcast (one clock ahead) and the next line of bus.txt.
  integer fbus /* verilator public_flat */;
  reg [63:0] b_0, b_1, b_2, b_3, b_4, b_5, b_6, b_7, b_8, b_9, b_10, b_11, b_12, b_13, b_14, b_15, b_16, b_17, b_18, b_19;
  reg b_ok;
  // The units' broadcast words (the row's y position, the slice) and the
  // host's frame register writes (frame.hex, +frames=N rows).
  reg [63:0] bc_vy, bc_vz;
  integer nframes;
  reg [{fw1}:0] frames [0:255];
  reg frm_we;
  reg [{fs1}:0] frm_sel;
  reg [{fd1}:0] frm_data;
  reg bc_go, bc_first, bc_z, bc_nv, bc_nz;
  reg [63:0] bc_row, bc_y0, bc_y1, bc_ny0, bc_ny1;
  reg [63:0] bc_w [0:6];
  reg [63:0] word;
  // The plan port (this clock's run) and the next line of plan.txt.
  integer fplan /* verilator public_flat */;
  reg [63:0] q_0, q_1, q_2, q_3, q_4;
  reg q_ok, pl_valid, pl_first;
  reg [63:0] pl_row, pl_lo, pl_hi;",
        tw1 = tw - 1,
        sb1 = sb - 1,
        ab1 = ab - 1,
        db1 = db - 1,
        fw1 = units.sel_bits() + units.data_bits() - 1,
        fs1 = units.sel_bits() - 1,
        fd1 = units.data_bits() - 1,
    );
    let e1 = 2 * shape.voxel_bits - 1;
    for k in 0..pes {
        let _ = writeln!(
            w,
            "  // PE {k}
  reg [{v1}:0] vol{k} [0:{volm}];
  reg [63:0] cw{k}, clo{k}, cend{k}, nxl{k};
  integer fev{k} /* verilator public_flat */, fmap{k} /* verilator public_flat */;
  integer fi{k}, ft{k}, fw{k};
  reg {mr} im{k};
  reg [63:0] ev{k}_0, ev{k}_1, ev{k}_2, ev{k}_3, ev{k}_4;
  reg ev_ok{k};
  reg [63:0] mp{k}_0, mp{k}_1, mp{k}_2, mp{k}_3;
  reg mp_ok{k}, map_we{k};
  reg [63:0] map_lo{k}, map_n{k}, map_sl{k};{tw}{rr}
  wire [{e1}:0] edge_out{k};",
            mr = mr,
            rr = if shape.round_robin {
                format!(
                    "\n  // The column map's entries (pe{k}.cm) and the column decoder (pe{k}.loc).
  integer fcm{k} /* verilator public_flat */;
  reg [63:0] cm{k}_0, cm{k}_1, cm{k}_2, cm{k}_3;
  reg cm_ok{k};
  reg [63:0] loc{k} [0:{nxm}];",
                    nxm = shape.nx - 1
                )
            } else {
                String::new()
            },
            tw = if shape.termination.is_some() {
                format!("\n  reg [{s1}:0] tw{k};")
            } else {
                String::new()
            },
            v1 = shape.voxel_bits - 1,
            volm = vol.max(1) - 1,
        );
    }
    for k in 0..pes {
        let right = if k + 1 < pes {
            format!("edge_out{}", k + 1)
        } else {
            format!("{}'d0", e1 + 1)
        };
        let _ = writeln!(
            w,
            "  {MODULE} pe{k} (.clk(clk), .rst(rst), .tbl_we(tbl_we), .tbl_sel(tbl_sel), .tbl_addr(tbl_addr), .tbl_data(tbl_data),
    .vld_we(1'b0), .vld_z(1'b0), .vld_bank(1'b0), .vld_row(0), .vld_col(0), .vld_data(0),
    .map_we(map_we{k}), .map_lo_in(map_lo{k}), .map_n_in(map_n{k}), .map_sl_in(map_sl{k}),
    .pl_valid(pl_valid), .pl_first(pl_first), .pl_lo(pl_lo), .pl_hi(pl_hi),
    .col_lo(clo{k}), .col_end(cend{k}), .nx_last(nxl{k}),
    .bc_go(bc_go), .bc_first(bc_first), .bc_row(bc_row), .bc_z(bc_z), .bc_y0(bc_y0), .bc_y1(bc_y1),
    .bc_nv(bc_nv), .bc_nz(bc_nz), .bc_ny0(bc_ny0), .bc_ny1(bc_ny1),
    .bc_a(bc_w[0]), .bc_t(bc_w[1]), .bc_b(bc_w[2]), .bc_k(bc_w[3]), .bc_row_wy(bc_w[4]), .bc_sy(bc_w[5]), .bc_sz(bc_w[6]),{unit_conns}
    .edge_in({right}), .edge_out(edge_out{k}),
    .iss_valid(), .iss_m(), .acc_valid(), .iss_acc_r(), .iss_acc_g(), .iss_acc_b(), .iss_acc_a(),
    .tap_valid(), .tap_v00(), .tap_v01(), .tap_v10(), .tap_v11(),
    .wb_valid(), .wb_addr(), .wb_data());"
        );
    }
    // Start: files, reset, tables.
    let _ = writeln!(
        w,
        "  always #5 clk = ~clk;
  initial begin
    clk = 0; rst = 1; cyc = 0; phase = 0;
    tbl_we = 0; tbl_sel = 0; tbl_addr = 0; tbl_data = 0;
    bc_go = 0; bc_first = 0; bc_z = 0; bc_nv = 0; bc_nz = 0;
    bc_row = 0; bc_y0 = 0; bc_y1 = 0; bc_ny0 = 0; bc_ny1 = 0;
    for (i = 0; i < 7; i = i + 1) bc_w[i] = 0;
    bc_vy = 0; bc_vz = 0;
    frm_we = 0; frm_sel = 0; frm_data = 0;
    if (!$value$plusargs(\"frames=%d\", nframes)) nframes = 0;
    if (nframes > 0) $readmemh(\"frame.hex\", frames, 0, nframes - 1);
    pl_valid = 0; pl_first = 0; pl_row = 0; pl_lo = 0; pl_hi = 0;
    if (!$value$plusargs(\"cycles=%d\", cycles)) cycles = 0;
    if (!$value$plusargs(\"dump=%d\", dump_at)) dump_at = 64'hffffffffffffffff;
    if (!$value$plusargs(\"tables=%d\", ntables)) ntables = 0;
    if (ntables > 0) $readmemh(\"tables.hex\", tables, 0, ntables - 1);
"
    );
    for k in 0..pes {
        let _ = writeln!(
            w,
            "    $readmemh(\"pe{k}.vol\", vol{k});
    fcfg = $fopen(\"pe{k}.cfg\", \"r\");
    got = $fscanf(fcfg, \"%h %h %h %h\\n\", cw{k}, clo{k}, cend{k}, nxl{k});
    $fclose(fcfg);
    fev{k} = $fopen(\"pe{k}.ev\", \"r\");
    got = $fscanf(fev{k}, \"%h %h %h %h %h\\n\", ev{k}_0, ev{k}_1, ev{k}_2, ev{k}_3, ev{k}_4);
    ev_ok{k} = (got == 5);
    fmap{k} = $fopen(\"pe{k}.map\", \"r\");{rr}
    got = $fscanf(fmap{k}, \"%h %h %h %h\\n\", mp{k}_0, mp{k}_1, mp{k}_2, mp{k}_3);
    mp_ok{k} = (got == 4);
    map_we{k} = 0; map_lo{k} = 0; map_n{k} = 0; map_sl{k} = 0;
    fi{k} = $fopen(\"rtl{k}.I\", \"w\");
    ft{k} = $fopen(\"rtl{k}.T\", \"w\");
    fw{k} = $fopen(\"rtl{k}.W\", \"w\");",
            rr = if shape.round_robin {
                format!(
                    "
    fcm{k} = $fopen(\"pe{k}.cm\", \"r\");
    got = $fscanf(fcm{k}, \"%h %h %h %h\\n\", cm{k}_0, cm{k}_1, cm{k}_2, cm{k}_3);
    cm_ok{k} = (got == 4);
    $readmemh(\"pe{k}.loc\", loc{k});
    for (i = 0; i < {nx}; i = i + 1) pe{k}.loc[i] = loc{k}[i];",
                    nx = shape.nx
                )
            } else {
                String::new()
            }
        );
    }
    let _ = writeln!(
        w,
        "    fbus = $fopen(\"bus.txt\", \"r\");
    got = $fscanf(fbus, \"%h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h\\n\",
        b_0, b_1, b_2, b_3, b_4, b_5, b_6, b_7, b_8, b_9, b_10, b_11, b_12, b_13, b_14, b_15, b_16, b_17, b_18, b_19);
    b_ok = (got == 20);
    fplan = $fopen(\"plan.txt\", \"r\");
    got = $fscanf(fplan, \"%h %h %h %h %h\\n\", q_0, q_1, q_2, q_3, q_4);
    q_ok = (got == 5);
`ifdef ERCUBE_VCD
    if ($test$plusargs(\"vcd\")) begin $dumpfile(\"rtl.vcd\"); $dumpvars(0, {TOP}); end
`endif
    repeat (4) @(posedge clk);
    @(negedge clk) rst = 0;
    for (i = 0; i < ntables; i = i + 1) begin
      @(negedge clk);
      {{tbl_we, tbl_sel, tbl_addr, tbl_data}} = tables[i];
    end
    @(negedge clk);
    tbl_we = 0;
    for (i = 0; i < nframes; i = i + 1) begin
      {{frm_sel, frm_data}} = frames[i];
      frm_we = 1;
      @(negedge clk);
    end
    frm_we = 0;
"
    );
    for k in 0..pes {
        let _ = writeln!(
            w,
            "    // The held range of clock 0, in place for its first clock.
    if (mp_ok{k} && mp{k}_0 == 0) begin
      map_we{k} = 1; map_lo{k} = mp{k}_1; map_n{k} = mp{k}_2; map_sl{k} = mp{k}_3;
      got = $fscanf(fmap{k}, \"%h %h %h %h\\n\", mp{k}_0, mp{k}_1, mp{k}_2, mp{k}_3);
      mp_ok{k} = (got == 4);
    end"
        );
    }
    let _ = writeln!(
        w,
        "    // Past the edge, so that no always block races the start.
    @(posedge clk);
    #1 phase = 2;
  end"
    );
    // The middle of each clock: events, the held range, the broadcast.
    let _ = writeln!(w, "  always @(negedge clk) if (phase == 2) begin");
    for k in 0..pes {
        // Kind 5, front to back with termination: a ray's termination bit.
        let kind5 = if shape.termination.is_some() {
            format!(
                "
      end else if (ev{k}_1 == 5) begin
        tw{k} = pe{k}.term[ev{k}_2];
        tw{k}[ev{k}_3] = ev{k}_4[0];
        pe{k}.term[ev{k}_2] = tw{k};"
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            w,
            "    while (ev_ok{k} && ev{k}_0 == cyc) begin
      if (ev{k}_1 == 1) begin
        zz = ev{k}_2; zp = ev{k}_3;
        for (yy = 0; yy < {ny}; yy = yy + 1)
          for (ll = 0; ll < cw{k}; ll = ll + 1) begin
            word = vol{k}[(zz * {ny} + yy) * cw{k} + ll];
            if (yy % 2 == 0) pe{k}.sb0[(zp * {half} + yy / 2) * {stored} + ll] = word;
            else pe{k}.sb1[(zp * {half} + yy / 2) * {stored} + ll] = word;
            if (ll == 0 && yy % 2 == 0) pe{k}.ec0[zp * {half} + yy / 2] = word;
            if (ll == 0 && yy % 2 == 1) pe{k}.ec1[zp * {half} + yy / 2] = word;
          end{kind5}
      end else begin
        if (ev{k}_2 % 2 == 0) pe{k}.bank0[ev{k}_2 / 2] = ev{k}_4;
        else pe{k}.bank1[ev{k}_2 / 2] = ev{k}_4;
      end
      got = $fscanf(fev{k}, \"%h %h %h %h %h\\n\", ev{k}_0, ev{k}_1, ev{k}_2, ev{k}_3, ev{k}_4);
      ev_ok{k} = (got == 5);
    end
    map_we{k} = 0;{rr}
    if (mp_ok{k} && mp{k}_0 == cyc + 1) begin
      map_we{k} = 1; map_lo{k} = mp{k}_1; map_n{k} = mp{k}_2; map_sl{k} = mp{k}_3;
      got = $fscanf(fmap{k}, \"%h %h %h %h\\n\", mp{k}_0, mp{k}_1, mp{k}_2, mp{k}_3);
      mp_ok{k} = (got == 4);
    end",
            rr = if shape.round_robin {
                format!(
                    "
    while (cm_ok{k} && cm{k}_0 == cyc) begin
      pe{k}.cm_mx[cm{k}_1] = cm{k}_2;
      pe{k}.cm_sl[cm{k}_1] = cm{k}_3;
      got = $fscanf(fcm{k}, \"%h %h %h %h\\n\", cm{k}_0, cm{k}_1, cm{k}_2, cm{k}_3);
      cm_ok{k} = (got == 4);
    end"
                )
            } else {
                String::new()
            }
        );
    }
    let _ = writeln!(
        w,
        "    if (q_ok && q_0 == cyc) begin
      pl_valid = 1; pl_first = q_1; pl_row = q_2; pl_lo = q_3; pl_hi = q_4;
      got = $fscanf(fplan, \"%h %h %h %h %h\\n\", q_0, q_1, q_2, q_3, q_4);
      q_ok = (got == 5);
    end else begin
      pl_valid = 0;
    end
    if (b_ok && b_0 == cyc + 1) begin
      bc_go = b_1; bc_first = b_2; bc_row = b_3; bc_z = b_4; bc_y0 = b_5; bc_y1 = b_6;
      bc_w[0] = b_7; bc_w[1] = b_8; bc_w[2] = b_9; bc_w[3] = b_10; bc_w[4] = b_11; bc_w[5] = b_12; bc_w[6] = b_13;
      bc_nv = b_14; bc_nz = b_15; bc_ny0 = b_16; bc_ny1 = b_17; bc_vy = b_18; bc_vz = b_19;
      got = $fscanf(fbus, \"%h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h %h\\n\",
        b_0, b_1, b_2, b_3, b_4, b_5, b_6, b_7, b_8, b_9, b_10, b_11, b_12, b_13, b_14, b_15, b_16, b_17, b_18, b_19);
      b_ok = (got == 20);
    end else begin
      bc_go = 0; bc_first = 0; bc_nv = 0;
    end"
    );
    for k in 0..pes {
        let _ = writeln!(
            w,
            "    if (cyc == dump_at) begin
      fdump = $fopen(\"buf{k}.hex\", \"w\");
      for (ll = 0; ll < {bd}; ll = ll + 1) $fwrite(fdump, \"%0h %0h\\n\", pe{k}.bank0[ll], pe{k}.bank1[ll]);
      $fclose(fdump);
    end"
        );
    }
    let _ = writeln!(w, "  end");
    // The end of each clock: what each PE did.
    let _ = writeln!(w, "  always @(posedge clk) if (phase == 2) begin");
    for k in 0..pes {
        let p = format!("pe{k}");
        let _ = writeln!(
            w,
            "    // An issue's accumulators reach the datapath a clock after it.
    if ({p}.acc_valid) $fwrite(fi{k}, \"I %0h %0h %0h %0h %0h %0h\\n\", cyc - 1, im{k}, {p}.iss_acc_r, {p}.iss_acc_g, {p}.iss_acc_b, {p}.iss_acc_a);
    if ({p}.iss_valid) im{k} = {p}.iss_m;
    if ({p}.tap_valid) $fwrite(ft{k}, \"T %0h %0h %0h %0h %0h\\n\", cyc - {tap_stage}, {p}.tap_v00, {p}.tap_v01, {p}.tap_v10, {p}.tap_v11);
    if ({p}.wb_valid) $fwrite(fw{k}, \"W %0h %0h %0h %0h %0h %0h\\n\", cyc, {p}.wb_addr, {p}.wb_data[{r1}:0], {p}.wb_data[{g1}:{cw}], {p}.wb_data[{b1}:{g2}], {p}.wb_data[{a1}:{b2}]);",
            r1 = cw - 1,
            g1 = 2 * cw - 1,
            g2 = 2 * cw,
            b1 = 3 * cw - 1,
            b2 = 3 * cw,
            a1 = 3 * cw + aw - 1,
        );
    }
    let _ = writeln!(w, "    if (cyc >= cycles) begin");
    for k in 0..pes {
        let _ = writeln!(w, "      $fclose(fi{k}); $fclose(ft{k}); $fclose(fw{k});");
    }
    let _ = writeln!(
        w,
        "      $display(\"pe-cosim done %0d\", cyc);\n      $finish;\n    end\n    cyc <= cyc + 1;\n  end\nendmodule"
    );
    v
}
