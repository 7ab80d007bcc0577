//! The DPI-C scoreboard testbench of the whole pipelined sample datapath,
//! `ercube_sample` as `ercube rtl` emits it (or a team's module with its
//! ports): the model evaluates every issued bundle through DPI-C
//! (`ercube_pkg.sv`), and every output is compared on every cycle at the
//! clock the module shows it.
//!
//! The stimulus, chosen at run time by plusargs:
//!
//! - `+vectors=DIR +pe=K` (and `+first=N`, the window's first cycle, for
//!   the messages): PE `K`'s captured issue stream of a real frame, the
//!   files `ercube vectors` writes (`pe<K>_<port>.hex`, one row a cycle,
//!   bubbles included; the taps' rows four clocks after issue), with the
//!   frame's tables (`table_<name>.hex`) loaded into the model and, through
//!   the host port, into the module;
//! - otherwise `+samples=N +bubbles=P` (default 5000 and 25): random words
//!   over every port's full range, `P` percent of the cycles bubbles (whose
//!   ports and taps are random too, and must be ignored), with the tables
//!   the model fills from the transfer function.
//!
//! Per cycle `c` (checked at the falling edge, after the rising edge that
//! ended `c - 1`): `out_valid` exactly when a sample issued `depth` clocks
//! before, then its accumulators; otherwise the accumulators hold the last
//! sample's; the tap column `x0` of the sample issued `stage(x0)` clocks
//! before (zero in a bubble). The voxel taps of a sample are driven
//! `stage(v00)` clocks after its issue, as a block RAM addressed by `x0`
//! returns them. The first difference stops the run with `$fatal`, naming
//! the cycle, the sample's issue cycle and the signal.

use std::fmt::Write as _;

use pipeline::hw::pipeline_rtl::{PipelinedModule, Port};
use pipeline::hw::unit::Unit;
use pipeline::synth::wrap::{ports, Dir};

/// The host port's and handshake's ports, driven by the testbench itself.
const CONTROL: [&str; 8] = [
    "clk",
    "rst",
    "in_valid",
    "out_valid",
    "tbl_we",
    "tbl_sel",
    "tbl_addr",
    "tbl_data",
];

/// Checks that `module` in `verilog` has exactly the ports of the emitted
/// module `m`, in direction and width; one line naming the first that
/// differs.
fn check_ports(m: &PipelinedModule, verilog: &str, module: &str) -> Result<(), String> {
    let have = ports(verilog, module)?;
    for p in &m.ports {
        let dir = if p.input { Dir::In } else { Dir::Out };
        match have.iter().find(|v| v.name == p.name) {
            Some(v) if v.dir == dir && v.bits == p.word.bits => {}
            Some(v) => {
                return Err(format!(
                    "module {module}: port {} is {} bits {:?}, {}'s is {} bits {dir:?}",
                    p.name, v.bits, v.dir, m.name, p.word.bits
                ))
            }
            None => return Err(format!("module {module} has no port {}", p.name)),
        }
    }
    if let Some(v) = have
        .iter()
        .find(|v| !m.ports.iter().any(|p| p.name == v.name))
    {
        return Err(format!(
            "module {module}: port {} is not one of {}'s",
            v.name, m.name
        ));
    }
    Ok(())
}

/// `signed [b-1:0]` or `[b-1:0]`.
fn decl(p: &Port) -> String {
    let s = if p.word.signed { "signed " } else { "" };
    format!("{s}[{}:0]", p.word.bits - 1)
}

/// The testbench module `tb` driving `dut` (the module of that name in
/// `verilog`, with the ports of the emitted `m`) and checking it against
/// `unit` (the whole sample of the same configuration) through DPI-C;
/// `toml`, `order` and `tf` are what the model is opened with (`""`:
/// defaults). One line when the module's ports are not `m`'s or `unit` is
/// not the whole sample.
pub fn sample_testbench(
    unit: &Unit,
    m: &PipelinedModule,
    (verilog, dut): (&str, &str),
    (toml, order, tf): (&str, &str, &str),
) -> Result<String, String> {
    if unit.name() != "sample" {
        return Err(format!(
            "unit {}: the pipelined testbench is the whole sample's",
            unit.name()
        ));
    }
    check_ports(m, verilog, dut)?;
    let depth = m.depth;
    let data: Vec<&Port> = m
        .ports
        .iter()
        .filter(|p| !CONTROL.contains(&p.name.as_str()))
        .collect();
    for p in &data {
        let known = if p.input {
            unit.input_index(&p.name).is_some()
        } else {
            unit.output_index(&p.name).is_some()
        };
        if !known {
            return Err(format!(
                "{}: port {} is not one of the model's",
                m.name, p.name
            ));
        }
    }
    let issue: Vec<&Port> = data
        .iter()
        .copied()
        .filter(|p| p.input && p.stage == 0)
        .collect();
    let late: Vec<&Port> = data
        .iter()
        .copied()
        .filter(|p| p.input && p.stage > 0)
        .collect();
    let probes: Vec<&Port> = data
        .iter()
        .copied()
        .filter(|p| !p.input && p.stage != depth)
        .collect();
    let results: Vec<&Port> = data
        .iter()
        .copied()
        .filter(|p| !p.input && p.stage == depth)
        .collect();
    let ring = (depth + 2).next_power_of_two().max(8);
    let width = |n: &str| {
        m.ports
            .iter()
            .find(|p| p.name == n)
            .map_or(1, |p| p.word.bits)
    };
    let (sb, ab, db) = (width("tbl_sel"), width("tbl_addr"), width("tbl_data"));
    let table_words: u64 = m.tables.iter().map(|t| t.depth).sum();

    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(
        w,
        "// Scoreboard testbench of {dut} (the pipelined sample datapath, depth {depth}), written\n\
         // by ercube (ercube_ffi::sample_testbench). Stimulus: +vectors=DIR +pe=K [+first=N]\n\
         // (a frame's captured issue stream, `ercube vectors`) or +samples=N +bubbles=P\n\
         // (random bundles). The model's words through DPI-C (ercube_pkg); every output\n\
         // compared every cycle.\n\
         module tb (input clk);\n  import ercube_pkg::*;\n  localparam int DEPTH = {depth};\n  \
         localparam int R = {ring};\n  localparam int TABLE_WORDS = {table_words};"
    );
    let _ = writeln!(
        w,
        "  logic rst = 1'b1, in_valid = 1'b0, tbl_we = 1'b0;\n  wire out_valid;\n  \
         logic [{}:0] tbl_sel = '0;\n  logic [{}:0] tbl_addr = '0;\n  logic [{}:0] tbl_data = '0;",
        sb - 1,
        ab - 1,
        db - 1
    );
    for p in &data {
        if p.input {
            let _ = writeln!(w, "  logic {} {} = '0;", decl(p), p.name);
        } else {
            let _ = writeln!(w, "  wire {} {};", decl(p), p.name);
        }
    }
    let conns: Vec<String> = m
        .ports
        .iter()
        .map(|p| format!(".{0}({0})", p.name))
        .collect();
    let _ = writeln!(w, "  {dut} dut ({});", conns.join(", "));
    // The next bundle, the rings of what each cycle drives or expects.
    let _ = writeln!(w, "  logic b_valid;");
    for p in issue.iter().chain(&late) {
        let _ = writeln!(w, "  logic {} b_{};", decl(p), p.name);
    }
    for p in &late {
        let _ = writeln!(w, "  logic {} r_{} [R];", decl(p), p.name);
    }
    let _ = writeln!(
        w,
        "  logic e_valid [R];\n  int e_from [R];\n  int held_from = 0;"
    );
    for p in probes.iter().chain(&results) {
        let _ = writeln!(w, "  logic {} e_{} [R];", decl(p), p.name);
        let _ = writeln!(w, "  int unsigned i_{};", p.name);
    }
    for p in &probes {
        let _ = writeln!(w, "  int e_{}_from [R];", p.name);
    }
    for p in &results {
        let _ = writeln!(w, "  logic {} held_{} = '0;", decl(p), p.name);
    }
    for p in issue.iter().chain(&late) {
        let _ = writeln!(w, "  int unsigned i_{0};\n  int fd_{0};", p.name);
    }
    let tables: Vec<_> = m
        .tables
        .iter()
        .map(|tb| {
            let signed = unit
                .tables()
                .find(|u| u.name == tb.name)
                .is_some_and(|u| u.fmt.is_signed());
            (tb, signed)
        })
        .collect();
    for (tb, signed) in &tables {
        let s = if *signed { "signed " } else { "" };
        let _ = writeln!(
            w,
            "  logic {s}[{}:0] t_{} [{}];",
            tb.bits - 1,
            tb.name,
            tb.depth
        );
    }
    let _ = writeln!(
        w,
        "  chandle dp;\n  string dir;\n  int fd_in_valid, pe = 0, first = 0, samples = 5000, bubbles = 25;\n  \
         bit from_files = 1'b0, done = 1'b0;\n  int phase = 0, tw = 0, c = 0, last_c = 0, issued = 0, checked = 0;\n  \
         longint word;"
    );

    // Opening: the model, the stimulus, the tables.
    let _ = writeln!(
        w,
        "  initial begin\n    int ix, got;\n    logic [63:0] skip;\n    dp = ercube_open(\"{}\", \"{order}\", \"sample\");\n    \
         ercube_check(ercube_datapath_fill_tables(dp, \"{tf}\"), \"fill tables\");",
        toml.escape_default()
    );
    for p in issue.iter().chain(&late) {
        let _ = writeln!(w, "    i_{0} = ercube_index(dp, 0, \"{0}\");", p.name);
    }
    for p in probes.iter().chain(&results) {
        let _ = writeln!(w, "    i_{0} = ercube_index(dp, 1, \"{0}\");", p.name);
    }
    let _ = writeln!(
        w,
        "    for (ix = 0; ix < R; ix++) begin\n      e_valid[ix] = 1'b0;\n      e_from[ix] = 0;"
    );
    for p in &late {
        let _ = writeln!(w, "      r_{}[ix] = '0;", p.name);
    }
    for p in &probes {
        let _ = writeln!(
            w,
            "      e_{0}[ix] = '0;\n      e_{0}_from[ix] = 0;",
            p.name
        );
    }
    for p in &results {
        let _ = writeln!(w, "      e_{}[ix] = '0;", p.name);
    }
    let _ = writeln!(
        w,
        "    end\n    void'($value$plusargs(\"samples=%d\", samples));\n    \
         void'($value$plusargs(\"bubbles=%d\", bubbles));\n    \
         void'($value$plusargs(\"pe=%d\", pe));\n    void'($value$plusargs(\"first=%d\", first));\n    \
         if ($value$plusargs(\"vectors=%s\", dir)) begin\n      from_files = 1'b1;\n      \
         fd_in_valid = $fopen($sformatf(\"%s/pe%0d_in_valid.hex\", dir, pe), \"r\");\n      \
         if (fd_in_valid == 0) $fatal(1, \"ercube: cannot open %s/pe%0d_in_valid.hex\", dir, pe);"
    );
    for p in issue.iter().chain(&late) {
        let _ = writeln!(
            w,
            "      fd_{0} = $fopen($sformatf(\"%s/pe%0d_{0}.hex\", dir, pe), \"r\");\n      \
             if (fd_{0} == 0) $fatal(1, \"ercube: cannot open %s/pe%0d_{0}.hex\", dir, pe);",
            p.name
        );
    }
    // A tap's row r holds the taps of the sample issued at r - stage: skip
    // to the first issue's.
    for p in &late {
        let _ = writeln!(
            w,
            "      for (ix = 0; ix < {}; ix++) got = $fscanf(fd_{}, \"%h\\n\", skip);",
            p.stage, p.name
        );
    }
    for (tb, _) in &tables {
        let _ = writeln!(
            w,
            "      $readmemh({{dir, \"/table_{0}.hex\"}}, t_{0});\n      \
             for (ix = 0; ix < {1}; ix++)\n        \
             ercube_check(ercube_datapath_table_set(dp, \"{0}\", ix, longint'(t_{0}[ix])), \"table_set {0}\");",
            tb.name, tb.depth
        );
    }
    let _ = writeln!(w, "    end else begin");
    for (tb, _) in &tables {
        let _ = writeln!(
            w,
            "      for (ix = 0; ix < {1}; ix++) begin\n        \
             ercube_check(ercube_datapath_table_get(dp, \"{0}\", ix, word), \"table_get {0}\");\n        \
             t_{0}[ix] = {2}'(word);\n      end",
            tb.name, tb.depth, tb.bits
        );
    }
    let _ = writeln!(w, "    end\n  end");

    // The host port's writes: word `tw` of the tables in `tbl_sel` order.
    let _ = writeln!(w, "  task automatic table_write(int n);");
    let mut base = 0u64;
    for (i, (tb, _)) in tables.iter().enumerate() {
        let cond = if i == 0 { "if" } else { "else if" };
        let _ = writeln!(
            w,
            "    {cond} (n < {end}) begin\n      tbl_sel = {sb}'d{sel};\n      \
             tbl_addr = {ab}'(n - {base});\n      tbl_data = {db}'(t_{name}[n - {base}]);\n    end",
            end = base + tb.depth,
            sel = tb.sel,
            name = tb.name
        );
        base += tb.depth;
    }
    let _ = writeln!(w, "  endtask");

    // The next bundle: a row of the files, or random words.
    let _ = writeln!(
        w,
        "  task automatic next_bundle();\n    int got;\n    logic [63:0] v;\n    if (from_files) begin\n      \
         got = $fscanf(fd_in_valid, \"%h\\n\", v);\n      if (got != 1) begin\n        done = 1'b1;\n        \
         b_valid = 1'b0;\n      end else b_valid = v[0];"
    );
    for p in issue.iter().chain(&late) {
        let _ = writeln!(
            w,
            "      got = $fscanf(fd_{0}, \"%h\\n\", v);\n      b_{0} = (got == 1) ? {1}'(v) : '0;",
            p.name, p.word.bits
        );
    }
    let _ = writeln!(
        w,
        "    end else begin\n      done = issued >= samples;\n      \
         b_valid = !done && ($urandom_range(99) >= bubbles);"
    );
    for p in issue.iter().chain(&late) {
        let _ = writeln!(
            w,
            "      b_{} = {}'({{$urandom, $urandom}});",
            p.name, p.word.bits
        );
    }
    let _ = writeln!(w, "    end\n  endtask");

    let miss = |w: &mut String, ind: &str, name: &str, want: &str, from: &str| {
        let _ = writeln!(
            w,
            "{ind}$fatal(1, \"ercube: first mismatch at cycle %0d (sample issued at cycle %0d): {name}: model %h, rtl %h\", first + c, first + {from}, {want}, {name});"
        );
    };
    let _ = writeln!(
        w,
        "  always @(negedge clk) begin\n    int at;\n    if (phase == 0) begin\n      \
         if (tw == 1) begin\n        rst = 1'b0;\n        phase = 1;\n        tw = 0;\n      end else tw++;\n    \
         end else if (phase == 1) begin\n      if (tw < TABLE_WORDS) begin\n        tbl_we = 1'b1;\n        \
         table_write(tw);\n        tw++;\n      end else begin\n        tbl_we = 1'b0;\n        phase = 2;\n      end\n    end"
    );
    let _ = writeln!(
        w,
        "    if (phase == 2) begin\n      at = c % R;\n      // This cycle's outputs.\n      \
         if (out_valid !== e_valid[at])\n        \
         $fatal(1, \"ercube: first mismatch at cycle %0d: out_valid: model %0d, rtl %0d\", first + c, e_valid[at], out_valid);"
    );
    let _ = writeln!(w, "      if (e_valid[at]) begin");
    for p in &results {
        let _ = writeln!(w, "        held_{0} = e_{0}[at];", p.name);
    }
    let _ = writeln!(
        w,
        "        held_from = e_from[at];\n        checked++;\n      end"
    );
    for p in &results {
        let _ = writeln!(w, "      if ({0} !== held_{0})", p.name);
        miss(
            w,
            "        ",
            &p.name,
            &format!("held_{}", p.name),
            "held_from",
        );
    }
    for p in &probes {
        let _ = writeln!(w, "      if ({0} !== e_{0}[at])", p.name);
        miss(
            w,
            "        ",
            &p.name,
            &format!("e_{}[at]", p.name),
            &format!("e_{}_from[at]", p.name),
        );
        let _ = writeln!(w, "      e_{}[at] = '0;", p.name);
    }
    let _ = writeln!(
        w,
        "      e_valid[at] = 1'b0;\n      // This cycle's inputs."
    );
    for p in &late {
        let _ = writeln!(w, "      {0} = r_{0}[at];", p.name);
    }
    let _ = writeln!(
        w,
        "      if (!done) next_bundle();\n      else b_valid = 1'b0;"
    );
    let _ = writeln!(w, "      in_valid = b_valid;");
    for p in &issue {
        let _ = writeln!(w, "      {0} = b_{0};", p.name);
    }
    for p in &late {
        let _ = writeln!(w, "      r_{0}[(c + {1}) % R] = b_{0};", p.name, p.stage);
    }
    let _ = writeln!(w, "      if (b_valid) begin");
    for p in issue.iter().chain(&late) {
        let _ = writeln!(
            w,
            "        ercube_check(ercube_datapath_set(dp, i_{0}, longint'(b_{0})), \"set {0}\");",
            p.name
        );
    }
    let _ = writeln!(
        w,
        "        ercube_check(ercube_datapath_step(dp), \"step\");"
    );
    for p in probes.iter().chain(&results) {
        let after = if p.stage == depth {
            "DEPTH".to_owned()
        } else {
            p.stage.to_string()
        };
        let _ = writeln!(
            w,
            "        ercube_check(ercube_datapath_get(dp, i_{0}, word), \"get {0}\");\n        \
             e_{0}[(c + {after}) % R] = {1}'(word);",
            p.name, p.word.bits
        );
    }
    for p in &probes {
        let _ = writeln!(w, "        e_{}_from[(c + {}) % R] = c;", p.name, p.stage);
    }
    let _ = writeln!(
        w,
        "        e_valid[(c + DEPTH) % R] = 1'b1;\n        e_from[(c + DEPTH) % R] = c;\n        \
         issued++;\n        last_c = c;\n      end"
    );
    let _ = writeln!(
        w,
        "      if (done && c > last_c + DEPTH) begin\n        \
         if (checked != issued) $fatal(1, \"ercube: %0d samples issued, %0d checked\", issued, checked);\n        \
         if (issued == 0) $fatal(1, \"ercube: no sample issued\");\n        \
         $display(\"ercube: %0d samples match the model over %0d cycles ({dut}, depth %0d, %s)\", checked, c + 1, DEPTH,\n                 \
         from_files ? $sformatf(\"%s pe %0d\", dir, pe) : \"random\");\n        \
         ercube_datapath_free(dp);\n        $finish;\n      end\n      c++;\n    end\n  end\nendmodule"
    );
    Ok(t)
}
