//! The replay's generated Verilog ([`Replay::testbench`]): the replayer
//! module ([`REPLAYER`]), which feeds one PE's captured issue stream to
//! its emitted datapath and checks every output every cycle, and the top
//! ([`TOP`]) with one replayer per PE (the parent module describes both).

use std::fmt::Write as _;

use super::{port_bits, Field, Replay, Role, REPLAYER, TOP};
use crate::hw::pipeline_rtl::Port;

impl Replay {
    /// The generated Verilog: the replayer and a top with `pes` of them.
    pub fn testbench(&self, pes: usize) -> String {
        let mut v = String::new();
        self.replayer(&mut v);
        self.top(&mut v, pes);
        v
    }

    /// `[w-1:0]` or `signed [w-1:0]`.
    fn decl(p: &Port) -> String {
        format!(
            "{}[{}:0]",
            if p.word.signed { "signed " } else { "" },
            p.word.bits - 1
        )
    }

    fn host_widths(&self) -> (u32, u32, u32) {
        let m = &self.module;
        (
            port_bits(m, "tbl_sel"),
            port_bits(m, "tbl_addr"),
            port_bits(m, "tbl_data"),
        )
    }

    fn of(&self, role: Role) -> impl Iterator<Item = &Field> {
        self.fields.iter().filter(move |f| f.role == role)
    }

    /// The replayer module.
    fn replayer(&self, v: &mut String) {
        let m = &self.module;
        let (sb, ab, db) = self.host_widths();
        let l = self.ring_bits;
        let r = 1u32 << l;
        let _ = writeln!(
            v,
            "// {REPLAYER}: replays one PE's captured issue stream (pe<K>.stim) through {} and\n\
             // checks its outputs every cycle. Emitted by ercube (pipeline::cosim::replay).\n\
             `timescale 1ns/1ps\n\
             module {REPLAYER} (\n  input wire clk,\n  input wire rst,\n  input wire run,\n  \
             input wire [63:0] cyc,\n  input wire [31:0] pe,\n  input wire tbl_we,\n  \
             input wire [{}:0] tbl_sel,\n  input wire [{}:0] tbl_addr,\n  input wire [{}:0] tbl_data,\n  \
             output reg [63:0] issued,\n  output reg [63:0] checked,\n  output reg [63:0] mismatches,\n  \
             output reg pending\n);",
            m.name,
            sb - 1,
            ab - 1,
            db - 1
        );
        let _ = writeln!(v, "  reg in_valid;\n  wire out_valid;");
        for f in &self.fields {
            let kind = if f.port.input { "reg" } else { "wire" };
            let _ = writeln!(v, "  {kind} {} {};", Self::decl(&f.port), f.port.name);
        }
        let conns: Vec<String> = m
            .ports
            .iter()
            .map(|p| format!(".{0}({0})", p.name))
            .collect();
        let _ = writeln!(v, "  {} dut ({});", m.name, conns.join(", "));
        let _ = writeln!(
            v,
            "  // The next captured sample.\n  reg [63:0] n_cycle, n_land;"
        );
        for f in &self.fields {
            let _ = writeln!(v, "  reg [{}:0] n_{};", f.port.word.bits - 1, f.port.name);
        }
        let _ = writeln!(
            v,
            "  // What each cycle (modulo {r}) expects or serves.\n  reg r_valid [0:{}];",
            r - 1
        );
        for f in self.fields.iter().filter(|f| f.role != Role::Issue) {
            let _ = writeln!(
                v,
                "  reg [{}:0] r_{} [0:{}];",
                f.port.word.bits - 1,
                f.port.name,
                r - 1
            );
        }
        let _ = writeln!(
            v,
            "  reg opened;\n  reg [255:0] fname;\n  reg [{0}:0] now, nxt, at;\n  integer fd, got, i;",
            l - 1
        );
        // Initial values: nothing issued, nothing expected.
        let _ = writeln!(
            v,
            "  initial begin\n    opened = 1'b0; fd = 0; got = 0; pending = 1'b0;\n    \
             issued = 64'd0; checked = 64'd0; mismatches = 64'd0; in_valid = 1'b0;"
        );
        for f in self.fields.iter().filter(|f| f.port.input) {
            let _ = writeln!(v, "    {} = {}'d0;", f.port.name, f.port.word.bits);
        }
        let _ = writeln!(
            v,
            "    for (i = 0; i < {r}; i = i + 1) begin\n      r_valid[i] = 1'b0;"
        );
        for f in self.fields.iter().filter(|f| f.role != Role::Issue) {
            let _ = writeln!(v, "      r_{}[i] = {}'d0;", f.port.name, f.port.word.bits);
        }
        let _ = writeln!(v, "    end\n  end");
        // Reading the next line.
        let n = self.fields.len() + 2;
        let fmt = vec!["%h"; n].join(" ");
        let mut args = vec!["n_cycle".to_owned(), "n_land".to_owned()];
        args.extend(self.fields.iter().map(|f| format!("n_{}", f.port.name)));
        let _ = writeln!(
            v,
            "  task fetch;\n    begin\n      got = $fscanf(fd, \"{fmt}\\n\", {});\n      \
             pending = (got == {n});\n    end\n  endtask",
            args.join(", ")
        );
        let miss = |v: &mut String, ind: &str, name: &str, want: &str, have: &str| {
            let _ = writeln!(
                v,
                "{ind}if (mismatches == 64'd0) $display(\"MISMATCH %0d %0d {name} %h %h\", cyc, pe, {want}, {have});\n\
                 {ind}mismatches = mismatches + 64'd1;"
            );
        };
        let _ = writeln!(
            v,
            "  always @(posedge clk) begin\n    if (rst) begin\n      if (!opened) begin\n        \
             opened = 1'b1;\n        $sformat(fname, \"pe%0d.stim\", pe);\n        \
             fd = $fopen(fname, \"r\");\n        if (fd == 0) $display(\"ERROR %0d cannot open its stream\", pe);\n        \
             else fetch;\n      end\n    end else if (run) begin\n      now = cyc[{}:0];",
            l - 1
        );
        // 1. This cycle's outputs.
        let _ = writeln!(v, "      if (out_valid !== r_valid[now]) begin");
        miss(v, "        ", "out_valid", "r_valid[now]", "out_valid");
        let _ = writeln!(
            v,
            "      end else if (r_valid[now]) begin\n        checked = checked + 64'd1;"
        );
        for f in self.of(Role::Result) {
            let name = &f.port.name;
            let _ = writeln!(v, "        if ({name} !== r_{name}[now]) begin");
            miss(v, "          ", name, &format!("r_{name}[now]"), name);
            let _ = writeln!(v, "        end");
        }
        let _ = writeln!(v, "      end\n      r_valid[now] = 1'b0;");
        for f in self.of(Role::Probe) {
            let name = &f.port.name;
            let _ = writeln!(v, "      if ({name} !== r_{name}[now]) begin");
            miss(v, "        ", name, &format!("r_{name}[now]"), name);
            let _ = writeln!(
                v,
                "      end\n      r_{name}[now] = {}'d0;",
                f.port.word.bits
            );
        }
        // 2. The next cycle's inputs.
        let _ = writeln!(v, "      nxt = now + {l}'d1;");
        for f in self.of(Role::Late) {
            let name = &f.port.name;
            let _ = writeln!(
                v,
                "      {name} <= r_{name}[nxt];\n      r_{name}[nxt] = {}'d0;",
                f.port.word.bits
            );
        }
        let _ = writeln!(
            v,
            "      if (pending && n_cycle <= cyc) begin\n        \
             if (mismatches == 64'd0) $display(\"MISMATCH %0d %0d issue_order %h %h\", cyc, pe, cyc + 64'd1, n_cycle);\n        \
             mismatches = mismatches + 64'd1;\n        pending = 1'b0;\n      end\n      \
             if (pending && n_cycle == cyc + 64'd1) begin\n        in_valid <= 1'b1;"
        );
        for f in self.of(Role::Issue) {
            let _ = writeln!(v, "        {0} <= n_{0};", f.port.name);
        }
        // Each index is computed into a register of the ring's width, so
        // that it wraps (Icarus widens an index expression).
        for f in self
            .fields
            .iter()
            .filter(|f| matches!(f.role, Role::Late | Role::Probe))
        {
            let _ = writeln!(
                v,
                "        at = nxt + {l}'d{1};\n        r_{0}[at] = n_{0};",
                f.port.name,
                f.port.stage % r
            );
        }
        for f in self.of(Role::Result) {
            let _ = writeln!(
                v,
                "        r_{0}[n_land[{1}:0]] = n_{0};",
                f.port.name,
                l - 1
            );
        }
        let _ = writeln!(
            v,
            "        r_valid[n_land[{}:0]] = 1'b1;\n        issued = issued + 64'd1;\n        fetch;\n      end else begin\n        in_valid <= 1'b0;",
            l - 1
        );
        for f in self.of(Role::Issue) {
            let _ = writeln!(v, "        {} <= {}'d0;", f.port.name, f.port.word.bits);
        }
        let _ = writeln!(v, "      end\n    end\n  end\nendmodule\n");
    }

    /// The top: clock, reset, the tables through the host port, `pes`
    /// replayers.
    fn top(&self, v: &mut String, pes: usize) {
        let (sb, ab, db) = self.host_widths();
        let nt = self.table_words().max(1);
        let wb = 1 + sb + ab + db;
        let _ = writeln!(
            v,
            "// {TOP}: {pes} PEs' datapaths, each replaying its captured issue stream. Run with\n\
             // +cycles=N (the last cycle checked) beside tables.hex and pe<K>.stim.\n\
             module {TOP};\n  reg clk = 1'b0;\n  always #5 clk = ~clk;\n  reg rst = 1'b1;\n  \
             reg run = 1'b0;\n  reg [63:0] cyc = 64'd0;\n  reg [63:0] last = 64'd0;\n  \
             reg tbl_we = 1'b0;\n  reg [{}:0] tbl_sel = {sb}'d0;\n  reg [{}:0] tbl_addr = {ab}'d0;\n  \
             reg [{}:0] tbl_data = {db}'d0;\n  reg [{}:0] tw [0:{}];\n  integer c;",
            sb - 1,
            ab - 1,
            db - 1,
            wb - 1,
            nt - 1
        );
        for k in 0..pes {
            let _ = writeln!(
                v,
                "  wire [63:0] issued{k}, checked{k}, mismatches{k};\n  wire pending{k};\n  \
                 {REPLAYER} pe{k} (.clk(clk), .rst(rst), .run(run), .cyc(cyc), .pe(32'd{k}), \
                 .tbl_we(tbl_we), .tbl_sel(tbl_sel), .tbl_addr(tbl_addr), .tbl_data(tbl_data), \
                 .issued(issued{k}), .checked(checked{k}), .mismatches(mismatches{k}), .pending(pending{k}));"
            );
        }
        let _ = writeln!(
            v,
            "  always @(posedge clk) if (run) cyc <= cyc + 64'd1;\n  initial begin\n    \
             if (!$value$plusargs(\"cycles=%d\", last)) last = 64'd0;\n\
             `ifdef ERCUBE_VCD\n    $dumpfile(\"rtl.vcd\");\n    $dumpvars(0, {TOP});\n`endif\n    \
             $readmemh(\"tables.hex\", tw);\n    @(posedge clk); @(posedge clk); #1 rst = 1'b0;\n    \
             for (c = 0; c < {}; c = c + 1) begin\n      {{tbl_we, tbl_sel, tbl_addr, tbl_data}} = tw[c];\n      \
             @(posedge clk); #1;\n    end\n    tbl_we = 1'b0;\n    run = 1'b1;\n    \
             while (cyc <= last) begin\n      @(posedge clk); #1;\n    end\n    \
             $display(\"CYCLES %0d\", last);",
            self.table_words()
        );
        for k in 0..pes {
            let _ = writeln!(
                v,
                "    $display(\"PE {k} %0d %0d %0d %0d\", issued{k}, checked{k}, mismatches{k}, pending{k});"
            );
        }
        let _ = writeln!(v, "    $finish;\n  end\nendmodule");
    }
}
