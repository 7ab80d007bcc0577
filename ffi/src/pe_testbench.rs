//! The DPI-C scoreboard testbench of one PE's sample stage,
//! `ercube_pe_sample` (`pipeline::hw::pe_sample_rtl`), in Verilator.
//!
//! The stimulus is the files `ercube vectors --stage pe` writes (read at
//! run time from `+vectors=DIR`): the controller's broadcast, the held
//! range, the plan port and the right neighbour's edge words a clock, the
//! memory writes the model makes without a clock (slice loads, buffer
//! words, termination bits, straight into the module's memories) and the
//! tables through the host port. These are what a PE sees from the rest of
//! the chip; they cannot be derived from the PE's own ports, so a team
//! replays them as a frame's captured environment, as it would replay a
//! bus trace.
//!
//! The scoreboard checks each clock `c` (after the rising edge that starts
//! it):
//!
//! - the issue, tap and write-back stream cycle for cycle against the
//!   files (the valids every clock, `iss_m`, `iss_acc_*`, `tap_v*`,
//!   `wb_addr` and `wb_data` where their valid is 1);
//! - every write-back's data against the model's datapath evaluated
//!   through DPI-C (`ercube_pkg.sv`, the C ABI) on the bundle the module
//!   itself issued: its `iss_m` and the broadcast's row words at the
//!   issue, its `iss_acc_*` a clock later (`acc_valid`), its taps
//!   `tap_stage` clocks later; the four
//!   accumulators packed `{a, b, g, r}` must be `wb_data` exactly `depth`
//!   clocks after the issue, with `wb_valid` high then and only then.
//!
//! The first difference stops the run with `$fatal`, naming the cycle
//! and the signal (`ercube: first mismatch at cycle C (PE K): SIGNAL:
//! model W, rtl W`; a write-back's also names the sample's issue cycle).

use std::fmt::Write as _;

mod manifest;

use pipeline::cosim::pe_vectors::ports;
use pipeline::hw::unit::Unit;
use serde_json::Value;

use manifest::{columns, field, memory_bits, num, text, Col};

/// The datapath inputs fed by the broadcast's row words (`bc_<name>`).
const ROW_WORDS: [&str; 7] = ["a", "t", "b", "k", "row_wy", "sy", "sz"];
/// The compositing channels, in `wb_data`'s order from its low bits.
const CHANNELS: [&str; 4] = ["r", "g", "b", "a"];

/// `signed [b-1:0]` or `[b-1:0]`.
fn range(bits: u32, signed: bool) -> String {
    let s = if signed { "signed " } else { "" };
    format!("{s}[{}:0]", bits - 1)
}

/// The testbench module `tb` for the files whose `manifest.json` is
/// `manifest`, driving the module `ercube_pe_sample` of `pe_verilog` (the
/// vectors' or a team's, with the same ports and memories), checked
/// against `unit` (the whole sample, opened as the frame was: `toml`,
/// `order`). One line when the manifest is not a PE stage's, the module's
/// ports differ from the vectors', or the model's depth is not the
/// vectors'.
pub fn pe_testbench(
    unit: &Unit,
    manifest: &str,
    pe_verilog: &str,
    (toml, order): (&str, &str),
) -> Result<String, String> {
    let man: Value = serde_json::from_str(manifest).map_err(|e| format!("manifest.json: {e}"))?;
    if man.get("stage").and_then(Value::as_str) != Some("pe") {
        return Err("manifest.json: not the files of `ercube vectors --stage pe`".into());
    }
    if unit.name() != "sample" {
        return Err(format!(
            "unit {}: the PE's datapath is the whole sample",
            unit.name()
        ));
    }
    let module = text(&man, "module")?.to_owned();
    let m = unit.pipelined("ercube_sample").map_err(|e| e.to_string())?;
    let depth = num(&man, "depth")?;
    if u64::from(m.depth) != depth {
        return Err(format!(
            "the model's depth {} is not the vectors' {depth}: open it with the frame's --config and --order",
            m.depth
        ));
    }
    let (k, rows, tap) = (
        num(&man, "pe")?,
        num(&man, "rows")?,
        num(&man, "tap_stage")?,
    );
    let samples = num(&man, "samples")?;
    let decls = ports(pe_verilog);
    if decls.is_empty() {
        return Err(format!("the Verilog has no module {module}"));
    }
    let cols = columns(&man, &decls)?;
    let col = |n: &str| {
        cols.iter()
            .find(|c| c.name == n)
            .ok_or_else(|| format!("the vectors have no {n}"))
    };
    let wb_bits = col("wb_data")?.bits;
    // The datapath's inputs, each from the column that carries it.
    let mut feeds = Vec::new();
    for p in m.ports.iter().filter(|p| p.input) {
        if matches!(p.name.as_str(), "clk" | "rst" | "in_valid") || p.name.starts_with("tbl_") {
            continue;
        }
        // The taps enter the datapath at the tap stage, the ray's
        // accumulators a clock after the issue, the rest with it.
        let src = match p.name.as_str() {
            "slot_m" => "iss_m".to_owned(),
            n if ROW_WORDS.contains(&n) => format!("bc_{n}"),
            n if n.starts_with("acc_") => format!("iss_{n}"),
            n if p.stage > 0 => format!("tap_{n}"),
            n => format!("iss_{n}"),
        };
        let late = src.starts_with("tap_");
        let at = if late { 0 } else { p.stage };
        let c = col(&src)?;
        if c.bits != p.word.bits {
            return Err(format!(
                "{src} is {} bits, the datapath's {} {}",
                c.bits, p.name, p.word.bits
            ));
        }
        feeds.push((p.name.clone(), src, p.word.bits, p.word.signed, late, at));
    }
    let cw = m
        .ports
        .iter()
        .find(|p| p.name == "acc_out_r")
        .map_or(0, |p| p.word.bits);
    if cw * 4 != wb_bits {
        return Err(format!(
            "wb_data is {wb_bits} bits, not the four {cw}-bit accumulators"
        ));
    }
    let ring = (depth + 2).next_power_of_two().max(8);
    let tbits = |n: &str| decls.iter().find(|d| d.name == n).map_or(1, |d| d.bits);
    let (sb, ab, db) = (tbits("tbl_sel"), tbits("tbl_addr"), tbits("tbl_data"));
    let tw = 1 + sb + ab + db;
    let tables_rows = num(field(&man, "tables")?, "rows")?;
    let writes = field(&man, "writes")?;
    let nw = num(writes, "count")?;
    let mut wf = Vec::new();
    for f in field(writes, "fields")?
        .as_array()
        .ok_or("manifest.json: writes' fields")?
    {
        wf.push((text(f, "name")?.to_owned(), num(f, "bits")? as u32));
    }
    let wbits = |n: &str| wf.iter().find(|f| f.0 == n).map_or(0, |f| f.1);
    let (wd, wa, wm, wc) = (wbits("data"), wbits("addr"), wbits("mem"), wbits("cycle"));
    let ew = wd + wa + wm + wc;
    if wd == 0 || wa == 0 || wm == 0 || wc == 0 {
        return Err("manifest.json: the writes' fields are not cycle, mem, addr, data".into());
    }
    let mems: Vec<String> = field(writes, "mem")?
        .as_array()
        .ok_or("manifest.json: the writes' memories")?
        .iter()
        .filter_map(|v| v.as_str().map(str::to_owned))
        .collect();
    let tables: Vec<_> = m
        .tables
        .iter()
        .map(|t| {
            let signed = unit
                .tables()
                .find(|u| u.name == t.name)
                .is_some_and(|u| u.fmt.is_signed());
            (t, signed)
        })
        .collect();
    let constants = field(&man, "constants")?
        .as_array()
        .cloned()
        .unwrap_or_default();
    let tied: Vec<String> = man
        .get("tied_off")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default();

    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(
        w,
        "// DPI-C scoreboard testbench of PE {k}'s sample stage ({module}), written by ercube
// (ercube_ffi::pe_testbench) from the manifest of `ercube vectors --stage pe`. Run with
// +vectors=DIR (the files). Every issue, tap and write-back checked each clock against the
// files; every write-back's data against the model's datapath through DPI-C (ercube_pkg) on
// the bundle the module issued.
module tb (input clk);
  import ercube_pkg::*;
  localparam int ROWS = {rows};
  localparam int DEPTH = {depth};
  localparam int TAP = {tap};
  localparam int R = {ring};
  localparam int NT = {nt};
  localparam int NW = {nw1};
  localparam int SAMPLES = {samples};
  logic rst = 1'b1;
  logic tbl_we = 1'b0;
  logic [{s1}:0] tbl_sel = '0;
  logic [{a1}:0] tbl_addr = '0;
  logic [{d1}:0] tbl_data = '0;
  logic [{tw1}:0] tables [NT];
  logic [{ew1}:0] writes [NW];",
        nt = tables_rows.max(1),
        nw1 = nw.max(1),
        s1 = sb - 1,
        a1 = ab - 1,
        d1 = db - 1,
        tw1 = tw - 1,
        ew1 = ew - 1,
    );
    for c in &cols {
        let kind = if c.input { "logic" } else { "wire" };
        let init = if c.input { " = '0" } else { "" };
        let _ = writeln!(
            w,
            "  {kind} {} p_{}{init};",
            range(c.bits, c.signed),
            c.name
        );
        let _ = writeln!(w, "  logic [{}:0] f_{} [ROWS];", c.bits - 1, c.name);
    }
    let conns: Vec<String> = decls
        .iter()
        .map(|d| {
            let n = &d.name;
            let constant = constants
                .iter()
                .find(|c| c.get("signal").and_then(Value::as_str) == Some(n.as_str()));
            if let Some(c) = constant {
                let v = c.get("value").and_then(Value::as_str).unwrap_or("0");
                format!(".{n}({}'h{v})", d.bits)
            } else if cols.iter().any(|c| &c.name == n) {
                format!(".{n}(p_{n})")
            } else if tied.contains(n) {
                format!(".{n}({}'d0)", d.bits)
            } else if !d.input {
                format!(".{n}()")
            } else {
                format!(".{n}({n})")
            }
        })
        .collect();
    let _ = writeln!(w, "  {module} dut (\n    {});", conns.join(",\n    "));
    // The scoreboard's rings: what was issued, what must be written back.
    let _ = writeln!(
        w,
        "  logic issued_at [R];\n  logic e_valid [R];\n  int e_from [R];"
    );
    for (name, _, bits, signed, late, _) in &feeds {
        if !late {
            let _ = writeln!(w, "  logic {} b_{name} [R];", range(*bits, *signed));
        }
        let _ = writeln!(w, "  int unsigned i_{name};");
    }
    for ch in CHANNELS {
        let _ = writeln!(
            w,
            "  logic [{}:0] e_{ch} [R];\n  int unsigned o_{ch};",
            cw - 1
        );
    }
    let _ = writeln!(
        w,
        "  chandle dp;
  string dir;
  int phase = 0, n = 0, r = 0, wi = 0, issued = 0, scored = 0, checks = 0;
  longint word;"
    );
    let _ = writeln!(
        w,
        "  initial begin
    dp = ercube_open(\"{}\", \"{order}\", \"sample\");",
        toml.escape_default()
    );
    for (name, ..) in &feeds {
        let _ = writeln!(w, "    i_{name} = ercube_index(dp, 0, \"{name}\");");
    }
    for ch in CHANNELS {
        let _ = writeln!(w, "    o_{ch} = ercube_index(dp, 1, \"acc_out_{ch}\");");
    }
    let _ = writeln!(
        w,
        "    for (int i = 0; i < R; i++) begin
      issued_at[i] = 1'b0;
      e_valid[i] = 1'b0;
    end
    if (!$value$plusargs(\"vectors=%s\", dir))
      $fatal(1, \"ercube: give the files of `ercube vectors --stage pe` with +vectors=DIR\");"
    );
    if tables_rows > 0 {
        let _ = writeln!(w, "    $readmemh({{dir, \"/tables.hex\"}}, tables);");
    }
    if nw > 0 {
        let _ = writeln!(w, "    $readmemh({{dir, \"/pe{k}_writes.hex\"}}, writes);");
    }
    for c in &cols {
        let _ = writeln!(
            w,
            "    $readmemh({{dir, \"/pe{k}_{0}.hex\"}}, f_{0});",
            c.name
        );
    }
    let _ = writeln!(w, "  end");

    // A host-port row into the module and the model.
    let _ = writeln!(
        w,
        "  task automatic table_row(logic [{tw1}:0] row);
    logic [{s1}:0] sel;
    int unsigned addr;
    {{tbl_we, tbl_sel, tbl_addr, tbl_data}} = row;
    sel = tbl_sel;
    addr = int'(tbl_addr);
    if (tbl_we) case (sel)",
        tw1 = tw - 1,
        s1 = sb - 1
    );
    for (tb, signed) in &tables {
        let ext = if *signed { "$signed" } else { "$unsigned" };
        let _ = writeln!(
            w,
            "      {sb}'d{sel}: ercube_check(ercube_datapath_table_set(dp, \"{name}\", addr, longint'({ext}(tbl_data[{hi}:0]))), \"table_set {name}\");",
            sel = tb.sel,
            name = tb.name,
            hi = tb.bits - 1
        );
    }
    let _ = writeln!(w, "      default: ;\n    endcase\n  endtask");

    // A memory write of the model's, straight into the module.
    let _ = writeln!(
        w,
        "  task automatic memory_write(logic [{ew1}:0] wr);
    int unsigned addr;
    addr = int'(wr[{ah}:{al}]);
    case (int'(wr[{mh}:{ml}]))",
        ew1 = ew - 1,
        ah = wd + wa - 1,
        al = wd,
        mh = wd + wa + wm - 1,
        ml = wd + wa
    );
    for (code, mem) in mems.iter().enumerate() {
        let Some(bits) = memory_bits(pe_verilog, mem) else {
            let _ = writeln!(
                w,
                "      {code}: $fatal(1, \"ercube: a write into {mem}, which {module} does not have\");"
            );
            continue;
        };
        if mem == "term" {
            // One bit of the row's word: `slot << 1 | bit`.
            let _ = writeln!(
                w,
                "      {code}: dut.{mem}[addr][int'(wr[{dh}:1])] = wr[0];",
                dh = wd.min(33) - 1
            );
        } else {
            let _ = writeln!(w, "      {code}: dut.{mem}[addr] = wr[{}:0];", bits - 1);
        }
    }
    let _ = writeln!(
        w,
        "      default: $fatal(1, \"ercube: a write into memory %0d\", int'(wr[{mh}:{ml}]));\n    endcase\n  endtask",
        mh = wd + wa + wm - 1,
        ml = wd + wa
    );

    let miss = |w: &mut String, ind: &str, name: &str, want: &str, got: &str| {
        let _ = writeln!(
            w,
            "{ind}$fatal(1, \"ercube: first mismatch at cycle %0d (PE {k}): {name}: model %h, rtl %h\", r, {want}, {got});"
        );
    };
    let check = |w: &mut String, c: &Col| {
        let cond = match &c.when {
            Some(v) => format!("f_{v}[r] == 1'b1"),
            None => "1'b1".to_owned(),
        };
        let _ = writeln!(
            w,
            "      if ({cond}) begin\n        checks++;\n        if (p_{0} !== f_{0}[r])",
            c.name
        );
        miss(
            w,
            "          ",
            &c.name,
            &format!("f_{}[r]", c.name),
            &format!("p_{}", c.name),
        );
        let _ = writeln!(w, "      end");
    };
    // Each falling edge: the clock's checks, then the next clock's writes
    // and inputs.
    let _ = writeln!(
        w,
        "  always @(negedge clk) begin
    int at, from;
    if (phase == 0) begin
      if (n == 3) begin
        rst = 1'b0;
        phase = 1;
        n = 0;
      end else n++;
    end else if (phase == 1) begin
      if (n < {tables_rows}) begin
        table_row(tables[n]);
        n++;
      end else begin
        tbl_we = 1'b0;
        phase = 2;
      end
    end else begin
      // Clock r's outputs: the issues and taps against the files.
      at = r % R;"
    );
    for c in cols
        .iter()
        .filter(|c| !c.input && !c.name.starts_with("wb_"))
    {
        check(w, c);
    }
    let _ = writeln!(
        w,
        "      if (p_iss_valid == 1'b1) begin\n        issued_at[at] = 1'b1;"
    );
    for (name, src, _, _, late, at) in &feeds {
        if !late && *at == 0 {
            let _ = writeln!(w, "        b_{name}[at] = p_{src};");
        }
    }
    let _ = writeln!(w, "        issued++;\n      end");
    // What the datapath takes a clock or more after the issue (the ray's
    // accumulators), into the issue's bundle.
    for (name, src, _, _, late, at) in &feeds {
        if !late && *at > 0 {
            let _ = writeln!(
                w,
                "      if (r >= {at} && issued_at[(r - {at}) % R]) b_{name}[(r - {at}) % R] = p_{src};"
            );
        }
    }
    // The taps of the sample issued TAP clocks before complete its bundle:
    // the model's write-back through DPI-C.
    let _ = writeln!(
        w,
        "      if (r >= TAP && issued_at[(r - TAP) % R]) begin
        from = (r - TAP) % R;
        issued_at[from] = 1'b0;"
    );
    for (name, src, _, _, late, _) in &feeds {
        let v = if *late {
            format!("p_{src}")
        } else {
            format!("b_{name}[from]")
        };
        let _ = writeln!(
            w,
            "        ercube_check(ercube_datapath_set(dp, i_{name}, longint'({v})), \"set {name}\");"
        );
    }
    let _ = writeln!(
        w,
        "        ercube_check(ercube_datapath_step(dp), \"step\");"
    );
    for ch in CHANNELS {
        let _ = writeln!(
            w,
            "        ercube_check(ercube_datapath_get(dp, o_{ch}, word), \"get acc_out_{ch}\");\n        \
             e_{ch}[(r - TAP + DEPTH) % R] = {cw}'(word);"
        );
    }
    let _ = writeln!(
        w,
        "        e_valid[(r - TAP + DEPTH) % R] = 1'b1;\n        e_from[(r - TAP + DEPTH) % R] = r - TAP;\n      end"
    );
    // The write-back the model expects this clock.
    let _ = writeln!(
        w,
        "      if (e_valid[at]) begin
        if (p_wb_valid !== 1'b1)
          $fatal(1, \"ercube: first mismatch at cycle %0d (PE {k}, sample issued at cycle %0d): wb_valid: model 1, rtl %h\", r, e_from[at], p_wb_valid);"
    );
    for (i, ch) in CHANNELS.iter().enumerate() {
        let (hi, lo) = (cw * (i as u32 + 1) - 1, cw * i as u32);
        let _ = writeln!(
            w,
            "        if (p_wb_data[{hi}:{lo}] !== e_{ch}[at])
          $fatal(1, \"ercube: first mismatch at cycle %0d (PE {k}, sample issued at cycle %0d): wb_data[{hi}:{lo}] (acc_out_{ch}): model %h, rtl %h\", r, e_from[at], e_{ch}[at], p_wb_data[{hi}:{lo}]);"
        );
    }
    let _ = writeln!(
        w,
        "        e_valid[at] = 1'b0;
        scored++;
      end else if (p_wb_valid !== 1'b0)
        $fatal(1, \"ercube: first mismatch at cycle %0d (PE {k}): wb_valid: model 0 (no sample issued %0d clocks before), rtl %h\", r, DEPTH, p_wb_valid);"
    );
    for c in cols
        .iter()
        .filter(|c| !c.input && c.name.starts_with("wb_"))
    {
        check(w, c);
    }
    let _ = writeln!(
        w,
        "      if (r == ROWS - 1) begin
        if (issued != SAMPLES || scored != issued)
          $fatal(1, \"ercube: PE {k} issued %0d samples, %0d written back, the files %0d\", issued, scored, SAMPLES);
        $display(\"ercube: PE {k}: %0d samples' write-backs match the model through DPI-C; %0d checks of the issue, tap and write-back stream over %0d cycles ({module}, %0d memory writes)\",
                 scored, checks, ROWS, wi);
        ercube_datapath_free(dp);
        $finish;
      end
      // Clock r + 1's memory writes (those of clock r), then its inputs.
      r++;
      while (wi < {nw} && int'(writes[wi][{ch}:{cl}]) < r) begin
        memory_write(writes[wi]);
        wi++;
      end",
        ch = ew - 1,
        cl = ew - wc
    );
    let _ = writeln!(w, "    end\n    if (phase == 2 && r < ROWS) begin");
    for c in cols.iter().filter(|c| c.input) {
        let _ = writeln!(w, "      p_{0} = f_{0}[r];", c.name);
    }
    let _ = writeln!(w, "    end\n  end\nendmodule");
    Ok(t)
}
