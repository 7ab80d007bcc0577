//! The emitted module's text: its header, ports, registers, tables and
//! the clocked block that loads the stage registers, from what
//! [`super::emit_scheduled`] built (the stages' combinational bodies, the
//! registers, the outputs and the table reads).

use std::fmt::Write as _;

use super::{addr_bits, verilog_name, PipelinedModule, Reg};
use crate::hw::{Graph, Word};
use crate::rtl::{range, Body, RtlError};

/// `signed [n-1:0]` or `[n-1:0]`.
pub(super) fn decl(w: Word) -> String {
    format!("{}{}", if w.signed { "signed " } else { "" }, range(w.bits))
}

/// The module's text.
pub(super) fn text(
    g: &Graph,
    m: &PipelinedModule,
    b: &Body,
    regs: &[Reg],
    outs: &[(String, Word, String)],
    mem_reads: &[Vec<(String, String)>],
    (sel_bits, ta, td): (u32, u32, u32),
) -> Result<String, RtlError> {
    let mut v = String::new();
    let w = &mut v;
    // The header names the blocks the description holds (the plain
    // sample's, or with the units composed into it), in inventory order.
    let mut blocks: Vec<&str> = Vec::new();
    for it in &g.items {
        if !blocks.contains(&it.group) {
            blocks.push(it.group);
        }
    }
    let _ = writeln!(
        w,
        "// {}: a datapath pipelined from its description, {} clocks from issue to the outputs.",
        m.name, m.depth
    );
    let _ = writeln!(w, "// Blocks: {}.", blocks.join(", "));
    let _ = writeln!(w, "// Emitted by ercube (pipeline::hw::pipeline_rtl) from the datapath's description and its schedule.");
    let _ = writeln!(
        w,
        "//\n// Ports (name, direction, width, format, clocks after issue, meaning):"
    );
    for p in &m.ports {
        let _ = writeln!(
            w,
            "//   {:<10} {:<6} {}{:<3} {:<26} {:>3}  {}",
            p.name,
            if p.input { "input" } else { "output" },
            if p.word.signed { "s" } else { "u" },
            p.word.bits,
            p.format
                .clone()
                .unwrap_or_else(|| format!("frac {}", p.word.frac)),
            p.stage,
            p.meaning
        );
    }
    let _ = writeln!(w, "//\n// Tables (tbl_sel, name, words x bits):");
    for t in &m.tables {
        let _ = writeln!(w, "//   {} {} {} x {}", t.sel, t.name, t.depth, t.bits);
    }
    let _ = writeln!(
        w,
        "//\n// Waiver: UNUSEDSIGNAL. A field takes some bits of a word (a position's"
    );
    let _ = writeln!(
        w,
        "// column and fraction, a sample's table index and weight, a remainder's"
    );
    let _ = writeln!(
        w,
        "// bits shifted out by the square root); the bits it leaves are wires that"
    );
    let _ = writeln!(w, "// go nowhere, by design, and synthesis removes them.");
    let _ = writeln!(
        w,
        "//\n// Waiver: WIDTH. Each expression is written at its node's wired word: an"
    );
    let _ = writeln!(
        w,
        "// operand narrower than the result is extended by Verilog's rules (signed"
    );
    let _ = writeln!(
        w,
        "// operands are all $signed, so sign-extended), and a quantiser's shifted"
    );
    let _ = writeln!(
        w,
        "// word is cut to the bits it keeps, whose dropped top bits are copies of"
    );
    let _ = writeln!(
        w,
        "// its sign. The words are the description's, which the bit-exact evaluator"
    );
    let _ = writeln!(w, "// (hw::eval) checks on every value it computes.");
    let _ = writeln!(
        w,
        "/* verilator lint_off UNUSEDSIGNAL */\n/* verilator lint_off WIDTH */"
    );
    let mut decls = Vec::new();
    for p in &m.ports {
        let kind = match (p.input, p.name.as_str()) {
            (true, _) => "input wire",
            (false, "out_valid") => "output reg",
            (false, _) if outs.iter().any(|o| o.0 == p.name) => "output reg",
            (false, _) => "output wire",
        };
        decls.push(format!("  {kind} {} {}", decl(p.word), p.name));
    }
    let _ = writeln!(w, "module {} (\n{}\n);", m.name, decls.join(",\n"));
    for r in regs {
        let _ = writeln!(w, "  reg {} {};", decl(r.word), r.name);
    }
    for (mi, reads) in mem_reads.iter().enumerate() {
        let mem = &g.mems[mi];
        if mem.depth == 0 {
            continue;
        }
        let bits = u32::from(mem.fmt.bits());
        for (d, _) in reads {
            let _ = writeln!(w, "  reg {} {d};", range(bits));
        }
    }
    v.push_str(b.text());
    let w = &mut v;
    // The tables: one host write port, synchronous reads with reset.
    for (mi, reads) in mem_reads.iter().enumerate() {
        let mem = &g.mems[mi];
        if mem.depth == 0 {
            continue;
        }
        let t = m
            .tables
            .iter()
            .find(|t| t.name == mem.name)
            .expect("a table");
        let (ab, bits) = (addr_bits(mem.depth), t.bits);
        let arr = format!("mem_{}", verilog_name(&mem.name));
        // The host writes the tables between frames, never while the
        // datapath reads them: `no_rw_check` tells yosys a read and a write
        // of one address in one clock need no defined result, so it adds
        // no bypass registers and compares around the block (as the
        // calibration `class_table` declares its memory).
        let _ = writeln!(
            w,
            "  (* no_rw_check *) reg {} {arr} [0:{}];",
            range(bits),
            mem.depth - 1
        );
        let addr = if ab == ta {
            "tbl_addr".to_owned()
        } else {
            format!("tbl_addr[{}:0]", ab - 1)
        };
        let data = if bits == td {
            "tbl_data".to_owned()
        } else {
            format!("tbl_data[{}:0]", bits - 1)
        };
        let _ = writeln!(w, "  always @(posedge clk) begin");
        let _ = writeln!(
            w,
            "    if (tbl_we && tbl_sel == {sel_bits}'d{}) {arr}[{addr}] <= {data};",
            t.sel
        );
        let _ = writeln!(w, "  end");
        for (d, a) in reads {
            let _ = writeln!(w, "  always @(posedge clk) begin");
            let _ = writeln!(
                w,
                "    if (rst) {d} <= {bits}'d0;\n    else {d} <= {arr}[{a}];"
            );
            let _ = writeln!(w, "  end");
        }
    }
    // The pipeline: every register resets; the outputs load from a valid
    // sample only.
    let last = format!("valid_d{}", m.depth - 1);
    let last = if m.depth == 1 {
        "in_valid".to_owned()
    } else {
        last
    };
    let _ = writeln!(w, "  always @(posedge clk) begin\n    if (rst) begin");
    for r in regs {
        let _ = writeln!(w, "      {} <= {}'d0;", r.name, r.word.bits);
    }
    for (o, ow, _) in outs {
        let _ = writeln!(w, "      {o} <= {}'d0;", ow.bits);
    }
    let _ = writeln!(w, "      out_valid <= 1'b0;\n    end else begin");
    for r in regs {
        let _ = writeln!(w, "      {} <= {};", r.name, r.src);
    }
    let _ = writeln!(w, "      out_valid <= {last};\n      if ({last}) begin");
    for (o, _, src) in outs {
        let _ = writeln!(w, "        {o} <= {src};");
    }
    let _ = writeln!(w, "      end\n    end\n  end\nendmodule");
    let _ = writeln!(
        w,
        "/* verilator lint_on WIDTH */\n/* verilator lint_on UNUSEDSIGNAL */"
    );
    Ok(v)
}
