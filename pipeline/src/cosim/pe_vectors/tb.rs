//! The plain Verilog-2005 testbench (`ercube_pe_vectors_tb`) that replays
//! one PE's vector files against `ercube_pe_sample`: it resets, writes the
//! tables through the host port (`tables.hex`), then for each clock
//! applies the memory writes of the clock before (`pe<K>_writes.hex`,
//! straight into the module's memories, as the model counts no clock for
//! them; under a round-robin mapping the column map and decoder among
//! them), drives every input's row, and after the rising edge compares
//! every output's row; it prints the first mismatch (clock, signal,
//! expected, got) and the count.

use std::fmt::Write as _;

use super::{Check, PeStream, MEMORIES};
use crate::cost::inventory::addr_bits;
use crate::hw::pe_sample_rtl::MODULE;

/// The testbench's top module.
pub const TOP: &str = "ercube_pe_vectors_tb";

/// Bits of a write's clock and address fields in `pe<K>_writes.hex`.
pub const WRITE_CYCLE_BITS: u32 = 32;
/// Bits of a write's memory code.
pub const WRITE_MEM_BITS: u32 = 4;
/// Bits of a write's address.
pub const WRITE_ADDR_BITS: u32 = 32;

/// The testbench of `s`'s files.
pub fn testbench(s: &PeStream) -> String {
    let k = s.pe;
    let rows = s.rows;
    let table_bits = super::ports(&s.verilog)
        .iter()
        .filter(|d| d.name.starts_with("tbl_"))
        .map(|d| (d.name.clone(), d.bits))
        .collect::<Vec<_>>();
    let tbits = |n: &str| table_bits.iter().find(|t| t.0 == n).map_or(1, |t| t.1);
    let tw = tbits("tbl_we") + tbits("tbl_sel") + tbits("tbl_addr") + tbits("tbl_data");
    let db = s.write_data_bits;
    let ew = WRITE_CYCLE_BITS + WRITE_MEM_BITS + WRITE_ADDR_BITS + db;
    let nw = s.writes.len().max(1);
    let nt = s.table_rows.1.max(1);
    let mut v = String::new();
    let w = &mut v;
    let _ = writeln!(
        w,
        "// {TOP}: replays ercube's vector files of PE {k}'s sample stage (manifest.json)
// against {MODULE} and counts mismatches. Run beside the files:
//   iverilog -g2005 -o tb {dp}.v {MODULE}.v pe_vectors_tb.v && vvp -n tb
`timescale 1ns/1ps
module {TOP};
  reg clk = 1'b0;
  always #5 clk = ~clk;
  reg rst = 1'b1;
  reg tbl_we = 1'b0;
  reg [{s1}:0] tbl_sel = 0;
  reg [{a1}:0] tbl_addr = 0;
  reg [{d1}:0] tbl_data = 0;
  reg [{tw1}:0] tables [0:{nt1}];
  reg [{ew1}:0] writes [0:{nw1}];
  reg [{ew1}:0] wr;
  integer row, i, wi, mismatches, checks;",
        dp = s.datapath.0,
        s1 = tbits("tbl_sel") - 1,
        a1 = tbits("tbl_addr") - 1,
        d1 = tbits("tbl_data") - 1,
        tw1 = tw - 1,
        nt1 = nt - 1,
        ew1 = ew - 1,
        nw1 = nw - 1,
    );
    if s.shape.termination.is_some() {
        let _ = writeln!(w, "  reg [{}:0] tw;", s.shape.slots() - 1);
    }
    for c in &s.columns {
        let p = &c.port;
        let sg = if p.signed { "signed " } else { "" };
        let kind = if p.input { "reg" } else { "wire" };
        let _ = writeln!(w, "  {kind} {sg}[{}:0] p_{};", p.bits - 1, p.name);
        let _ = writeln!(w, "  reg [{}:0] f_{} [0:{}];", p.bits - 1, p.name, rows - 1);
    }
    let conns: Vec<String> = super::ports(&s.verilog)
        .iter()
        .map(|d| {
            let n = &d.name;
            if let Some((_, c)) = s.constants.iter().find(|c| &c.0.name == n) {
                format!(".{n}({}'h{c:x})", d.bits)
            } else if s.columns.iter().any(|c| &c.port.name == n) {
                format!(".{n}(p_{n})")
            } else if n.starts_with("vld_") {
                format!(".{n}({}'d0)", d.bits)
            } else if n == "edge_out" {
                format!(".{n}()")
            } else {
                format!(".{n}({n})")
            }
        })
        .collect();
    let _ = writeln!(w, "  {MODULE} dut (\n    {});", conns.join(",\n    "));
    let _ = writeln!(
        w,
        "  initial begin
    mismatches = 0; checks = 0; wi = 0;"
    );
    if s.table_rows.1 > 0 {
        let _ = writeln!(w, "    $readmemh(\"tables.hex\", tables);");
    }
    if !s.writes.is_empty() {
        let _ = writeln!(w, "    $readmemh(\"pe{k}_writes.hex\", writes);");
    }
    for c in &s.columns {
        let _ = writeln!(w, "    $readmemh(\"pe{k}_{0}.hex\", f_{0});", c.port.name);
        if c.port.input {
            let _ = writeln!(w, "    p_{} = 0;", c.port.name);
        }
    }
    let _ = writeln!(
        w,
        "    repeat (4) @(posedge clk);
    @(negedge clk) rst = 1'b0;
    for (i = 0; i < {nt}; i = i + 1) begin
      @(negedge clk);
      {{tbl_we, tbl_sel, tbl_addr, tbl_data}} = tables[i];
    end
    @(negedge clk);
    tbl_we = 1'b0;
    for (row = 0; row < {rows}; row = row + 1) begin
      // The memory writes of the clock before.
      while (wi < {nws} && writes[wi][{ew1}:{cyc_lo}] + 1 <= row) begin
        wr = writes[wi];
        case (wr[{mem_hi}:{mem_lo}])",
        nt = s.table_rows.1,
        nws = s.writes.len(),
        ew1 = ew - 1,
        cyc_lo = ew - WRITE_CYCLE_BITS,
        mem_hi = ew - WRITE_CYCLE_BITS - 1,
        mem_lo = ew - WRITE_CYCLE_BITS - WRITE_MEM_BITS,
    );
    let (a_hi, a_lo) = (db + WRITE_ADDR_BITS - 1, db);
    let vb = s.shape.voxel_bits;
    let bw = s.shape.rays.buffer_width;
    let sh = &s.shape;
    for (code, mem) in MEMORIES.iter().enumerate() {
        let data_bits = match code {
            0..=3 => vb,
            4 | 5 => bw,
            // The column map and decoder: a round-robin mapping's only.
            7 if sh.round_robin => sh.index_bits,
            8 if sh.round_robin => addr_bits(sh.slots()),
            9 if sh.round_robin => addr_bits(sh.stored),
            _ => 0,
        };
        if code == 6 {
            if s.shape.termination.is_some() {
                let _ = writeln!(
                    w,
                    "          {code}: begin tw = dut.term[wr[{a_hi}:{a_lo}]]; tw[wr[{d1}:1]] = wr[0]; dut.term[wr[{a_hi}:{a_lo}]] = tw; end",
                    d1 = db - 1
                );
            }
            continue;
        }
        if data_bits == 0 {
            continue;
        }
        let _ = writeln!(
            w,
            "          {code}: dut.{mem}[wr[{a_hi}:{a_lo}]] = wr[{}:0];",
            data_bits - 1
        );
    }
    let _ = writeln!(
        w,
        "          default: ;
        endcase
        wi = wi + 1;
      end"
    );
    for c in s.columns.iter().filter(|c| c.port.input) {
        let _ = writeln!(w, "      p_{0} = f_{0}[row];", c.port.name);
    }
    let _ = writeln!(w, "      @(posedge clk); #1;");
    for c in s.columns.iter().filter(|c| !c.port.input) {
        let n = &c.port.name;
        let when = match c.check {
            Check::When(valid) => format!("f_{valid}[row]"),
            _ => "1'b1".to_owned(),
        };
        let _ = writeln!(
            w,
            "      if ({when}) begin
        checks = checks + 1;
        if (p_{n} !== f_{n}[row]) begin
          if (mismatches == 0) $display(\"MISMATCH cycle %0d pe {k} {n} expected %h got %h\", row, f_{n}[row], p_{n});
          mismatches = mismatches + 1;
        end
      end"
        );
    }
    let _ = writeln!(
        w,
        "    end
    $display(\"vectors: %0d mismatches in %0d checks over {rows} cycles of PE {k}\", mismatches, checks);
    $finish;
  end
endmodule"
    );
    v
}
