//! The example SystemVerilog scoreboard testbench of a datapath unit
//! (`ffi/sv/`): random stimulus into the unit's Verilog every clock, the
//! model's words for the same stimulus through DPI-C (`ercube_pkg.sv`),
//! each output compared when the unit gives it (its latency later, or when
//! `out_valid` rises), the first differing cycle and signal stopping the
//! simulation with `$fatal`.
//!
//! The testbench is written from the unit's ports as the model lists them
//! ([`Unit::inputs`], [`Unit::outputs`]) and checked against the module's
//! port list in its Verilog, so it drives any module whose ports carry the
//! model's names and widths: the cuts `ercube` emits (`clk`, the ports,
//! registered outputs) or a whole-sample module with `clk`, `rst`,
//! `in_valid` and `out_valid` besides.

use std::fmt::Write as _;

use pipeline::hw::unit::Unit;
use pipeline::synth::wrap::{ports, Dir};

/// The DPI-C package, as shipped in `ffi/sv/`.
pub const PACKAGE: &str = include_str!("../sv/ercube_pkg.sv");

/// The Verilator main of the testbench (module `tb`), as shipped.
pub const MAIN: &str = include_str!("../sv/sim_main.cpp");

/// The Verilator control file waiving the emitted unit's WIDTH lint
/// (`unit.v`), as shipped.
pub const WAIVER: &str = include_str!("../sv/unit.vlt");

/// The handshake ports a module may have besides the model's.
const HANDSHAKE: [&str; 3] = ["rst", "in_valid", "out_valid"];

/// The testbench module `tb` for `unit` as the module `module` in
/// `verilog`, checking `samples` samples; `toml` and `order` are what the
/// model is opened with (`""`: defaults), `tf` the tables' transfer
/// function. Fails with one line when the module's ports are not the
/// unit's.
pub fn testbench(
    unit: &Unit,
    verilog: &str,
    module: &str,
    (toml, order, tf): (&str, &str, &str),
    samples: u32,
) -> Result<String, String> {
    let vports = ports(verilog, module)?;
    let find = |n: &str| vports.iter().find(|p| p.name == n);
    for p in unit.inputs().iter().chain(unit.outputs()) {
        let dir = if unit.input_index(&p.name).is_some() {
            Dir::In
        } else {
            Dir::Out
        };
        match find(&p.name) {
            Some(v) if v.dir == dir && v.bits == p.word.bits => {}
            Some(v) => {
                return Err(format!(
                    "module {module}: port {} is {} bits {:?}, the model's is {} bits {dir:?}",
                    p.name, v.bits, v.dir, p.word.bits
                ))
            }
            None => return Err(format!("module {module} has no port {}", p.name)),
        }
    }
    for v in &vports {
        let known = v.name == "clk"
            || HANDSHAKE.contains(&v.name.as_str())
            || unit.input_index(&v.name).is_some()
            || unit.output_index(&v.name).is_some();
        if !known {
            return Err(format!(
                "module {module}: port {} is not one of unit {}'s",
                v.name,
                unit.name()
            ));
        }
    }
    if find("clk").is_none() {
        return Err(format!("module {module} has no clk"));
    }
    let handshake = HANDSHAKE.iter().all(|h| find(h).is_some());
    let latency = unit.latency();
    let ports: Vec<_> = unit.inputs().iter().chain(unit.outputs()).collect();
    let is_in = |n: &str| unit.input_index(n).is_some();

    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(
        w,
        "// Scoreboard testbench of {module} (unit {}, latency {latency}), written by ercube\n\
         // (ercube_ffi::testbench): random words into every input each clock, the\n\
         // model's words through DPI-C (ercube_pkg), outputs compared {}.\n\
         module tb (input clk);\n  import ercube_pkg::*;\n  localparam int unsigned LATENCY = {latency};\n  localparam int SAMPLES = {samples};",
        unit.name(),
        if handshake {
            "when out_valid rises (latency clocks after in_valid)"
        } else {
            "latency clocks later"
        }
    );
    for p in &ports {
        let b = p.word.bits;
        let s = if p.word.signed { "signed " } else { "" };
        if is_in(&p.name) {
            let _ = writeln!(w, "  logic {s}[{}:0] {};", b - 1, p.name);
        } else {
            let _ = writeln!(w, "  wire [{}:0] {};", b - 1, p.name);
            let _ = writeln!(w, "  longint q_{}[$];", p.name);
        }
        let _ = writeln!(w, "  int unsigned i_{};", p.name);
    }
    let mut conns = vec![".clk(clk)".to_owned()];
    if handshake {
        let _ = writeln!(w, "  logic rst = 1'b1, in_valid = 1'b0;\n  wire out_valid;");
        conns.extend(HANDSHAKE.iter().map(|h| format!(".{h}({h})")));
    }
    conns.extend(ports.iter().map(|p| format!(".{0}({0})", p.name)));
    let _ = writeln!(w, "  {module} dut ({});", conns.join(", "));
    let _ = writeln!(
        w,
        "  chandle dp;\n  int cycle = 0, checked = 0;\n  int q_cycle[$];\n  longint word;\n  initial begin\n    int unsigned n_in, n_out, lat;\n    dp = ercube_open(\"{}\", \"{order}\", \"{}\");",
        toml.escape_default(),
        unit.name()
    );
    if unit.tables().next().is_some() {
        let _ = writeln!(
            w,
            "    ercube_check(ercube_datapath_fill_tables(dp, \"{tf}\"), \"fill tables\");"
        );
    }
    let _ = writeln!(
        w,
        "    ercube_check(ercube_datapath_shape(dp, n_in, n_out, lat), \"shape\");\n    if (lat != LATENCY) $fatal(1, \"ercube: model latency %0d, testbench %0d\", lat, LATENCY);"
    );
    for p in &ports {
        let side = if is_in(&p.name) { 0 } else { 1 };
        let _ = writeln!(w, "    i_{0} = ercube_index(dp, {side}, \"{0}\");", p.name);
    }
    let _ = writeln!(w, "  end");
    // Negative edges: the outputs of the last rising edge are settled;
    // the next stimulus is taken at the next rising edge.
    let due = if handshake {
        "out_valid".to_owned()
    } else {
        "q_cycle.size() > 0 && cycle - q_cycle[0] == LATENCY".to_owned()
    };
    let _ = writeln!(w, "  always @(negedge clk) begin");
    if handshake {
        let _ = writeln!(w, "    if (cycle == 2) rst <= 1'b0;");
    }
    let _ = writeln!(
        w,
        "    if (q_cycle.size() > 0 && cycle - q_cycle[0] > LATENCY)\n      $fatal(1, \"ercube: cycle %0d: no output %0d clocks after the sample of cycle %0d\", cycle, LATENCY, q_cycle[0]);\n    if ({due}) begin\n      int driven = q_cycle.pop_front();\n      if (cycle - driven != LATENCY)\n        $fatal(1, \"ercube: cycle %0d: output after %0d clocks, latency %0d\", cycle, cycle - driven, LATENCY);"
    );
    for p in unit.outputs() {
        let b = p.word.bits;
        let _ = writeln!(
            w,
            "      word = q_{n}.pop_front();\n      if ({n} !== {b}'(word))\n        $fatal(1, \"ercube: first mismatch at cycle %0d (sample driven at cycle %0d): {n}: model %h, rtl %h\", cycle, driven, {b}'(word), {n});",
            n = p.name
        );
    }
    let _ = writeln!(w, "      checked++;\n    end");
    let start = if handshake { "cycle >= 2 && " } else { "" };
    let _ = writeln!(
        w,
        "    if ({start}cycle - {} < SAMPLES) begin",
        if handshake { "2" } else { "0" }
    );
    for p in unit.inputs() {
        let b = p.word.bits;
        let _ = writeln!(
            w,
            "      {n} = {b}'({{$urandom, $urandom}});\n      ercube_check(ercube_datapath_set(dp, i_{n}, longint'({n})), \"set {n}\");",
            n = p.name
        );
    }
    let _ = writeln!(w, "      ercube_check(ercube_datapath_step(dp), \"step\");");
    for p in unit.outputs() {
        let _ = writeln!(
            w,
            "      ercube_check(ercube_datapath_get(dp, i_{n}, word), \"get {n}\");\n      q_{n}.push_back(word);",
            n = p.name
        );
    }
    let _ = writeln!(w, "      q_cycle.push_back(cycle);");
    if handshake {
        let _ = writeln!(
            w,
            "      in_valid = 1'b1;\n    end else begin\n      in_valid = 1'b0;"
        );
    }
    let _ = writeln!(
        w,
        "    end\n    if (checked == SAMPLES) begin\n      $display(\"ercube: %0d samples match the model\", checked);\n      ercube_datapath_free(dp);\n      $finish;\n    end\n    cycle++;\n  end\nendmodule"
    );
    Ok(t)
}
