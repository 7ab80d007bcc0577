//! Vector files: a capture's window as per-PE, per-port, per-cycle
//! stimulus and expected responses of the emitted datapath, in
//! `$readmemh` files (`pe<K>_<port>.hex`, `table_<name>.hex`; one hexadecimal word a line, two's complement over
//! the port's width, row `i` the window's cycle `first + i`), with a JSON
//! manifest and a plain Verilog-2005 testbench that replays them, for a
//! team that links nothing of ercube.
//!
//! The window's samples are those issued in cycles `first..=last`; the
//! files run `depth` cycles further (`first..=last + depth`) so that every
//! one of them is written back. A port's row holds the word the module
//! takes or shows in that cycle: the sample's ports in its issue cycle,
//! the voxel taps `stage(v00)` cycles later (one clock after the tap
//! column), `x0` `stage(x0)` cycles after issue (zero in a bubble), and
//! `out_valid` with the accumulators `depth` cycles after issue. Outside a
//! sample an input is zero; an accumulator output's row is zero where
//! `out_valid` is low and is compared only where it is high.

use std::fmt::Write as _;

use serde_json::{json, Value};

use super::capture::Issue;
use super::replay::{masked, Replay, Role};

/// A window's vectors, in memory: every file's relative path and text,
/// and the manifest.
#[derive(Debug, Clone)]
pub struct Vectors {
    /// Files (relative path, text), the manifest and the testbench among
    /// them.
    pub files: Vec<(String, String)>,
    /// The manifest (also `manifest.json` in `files`).
    pub manifest: Value,
    /// Rows per per-cycle file.
    pub rows: u64,
}

/// The testbench's top module.
pub const TB: &str = "ercube_vectors_tb";

/// One PE's words per cycle of the window for every port (inputs and
/// expected outputs), by port name in `replay`'s field order, `in_valid`
/// and `out_valid` first.
fn columns(replay: &Replay, issues: &[&Issue], first: u64, rows: u64) -> Vec<(String, Vec<i64>)> {
    let depth = u64::from(replay.module.depth);
    let mut cols: Vec<(String, Vec<i64>)> = vec![
        ("in_valid".to_owned(), vec![0; rows as usize]),
        ("out_valid".to_owned(), vec![0; rows as usize]),
    ];
    cols.extend(
        replay
            .fields
            .iter()
            .map(|f| (f.port.name.clone(), vec![0; rows as usize])),
    );
    for is in issues {
        let row = |after: u64| {
            let c = is.cycle + after;
            (c >= first && c < first + rows).then(|| (c - first) as usize)
        };
        if let Some(r) = row(0) {
            cols[0].1[r] = 1;
        }
        if let Some(r) = row(depth) {
            cols[1].1[r] = 1;
        }
        for (f, col) in replay.fields.iter().zip(cols.iter_mut().skip(2)) {
            let after = match f.role {
                Role::Issue => 0,
                Role::Late | Role::Probe => u64::from(f.port.stage),
                Role::Result => depth,
            };
            if let Some(r) = row(after) {
                col.1[r] = replay.word(is, &f.port.name);
            }
        }
    }
    cols
}

/// The vectors of `issues` (a capture of `pes` PEs' issues in cycles
/// `first..=last`) with the frame's `tables`, for `replay`'s module whose
/// Verilog is `verilog`; `latency` is the model's write-back latency,
/// recorded in the manifest.
pub fn vectors(
    replay: &Replay,
    verilog: &str,
    (issues, pes): (&[Issue], usize),
    tables: &[(String, Vec<i64>)],
    (first, last): (u64, u64),
    latency: u64,
) -> Vectors {
    let m = &replay.module;
    let depth = u64::from(m.depth);
    let rows = last - first + 1 + depth;
    let mut files = vec![(format!("{}.v", m.name), verilog.to_owned())];
    let mut entries = Vec::new();
    let bits_of = |name: &str| {
        if name.ends_with("_valid") {
            (1, false, None, 0, String::new())
        } else {
            let f = replay
                .fields
                .iter()
                .find(|f| f.port.name == name)
                .expect("a field");
            (
                f.port.word.bits,
                f.port.word.signed,
                f.port.format.clone(),
                f.port.stage,
                f.port.meaning.clone(),
            )
        }
    };
    let mut samples = Vec::new();
    for k in 0..pes {
        let mine: Vec<&Issue> = issues.iter().filter(|i| i.pe == k).collect();
        samples.push(mine.len());
        for (name, words) in columns(replay, &mine, first, rows) {
            let (bits, signed, format, stage, meaning) = bits_of(&name);
            let input = name == "in_valid"
                || replay
                    .fields
                    .iter()
                    .any(|f| f.port.name == name && f.port.input);
            let path = format!("pe{k}_{name}.hex");
            let mut text = String::with_capacity(words.len() * 6);
            for w in &words {
                let _ = writeln!(text, "{:x}", masked(*w, bits));
            }
            files.push((path.clone(), text));
            let checked = match (input, name.as_str()) {
                (true, _) => "stimulus",
                (false, "out_valid") | (false, "x0") => "every cycle",
                _ => "where out_valid is 1",
            };
            let stage = match name.as_str() {
                "out_valid" => m.depth,
                "in_valid" => 0,
                _ => stage,
            };
            let meaning = match name.as_str() {
                "in_valid" => "a sample issues this cycle".to_owned(),
                "out_valid" => format!("the accumulators hold a sample issued {depth} cycles ago"),
                _ => meaning,
            };
            entries.push(json!({
                "path": path,
                "pe": k,
                "signal": name,
                "direction": if input { "in" } else { "out" },
                "width": bits,
                "signed": signed,
                "format": format,
                "clocks_after_issue": stage,
                "meaning": meaning,
                "checked": checked,
                "first_cycle": first,
                "last_cycle": first + rows - 1,
                "rows": rows,
            }));
        }
    }
    let mut table_entries = Vec::new();
    for t in &m.tables {
        let Some((_, words)) = tables.iter().find(|c| c.0 == t.name) else {
            continue;
        };
        let path = format!("table_{}.hex", t.name);
        let mut text = String::new();
        for w in words {
            let _ = writeln!(text, "{:x}", masked(*w, t.bits));
        }
        files.push((path.clone(), text));
        table_entries.push(json!({
            "path": path,
            "table": t.name,
            "tbl_sel": t.sel,
            "words": t.depth,
            "width": t.bits,
        }));
    }
    let manifest = json!({
        "module": m.name,
        "verilog": format!("{}.v", m.name),
        "testbench": "vectors_tb.v",
        "top": TB,
        "pes": pes,
        "depth": m.depth,
        "model_latency": latency,
        "issue_cycles": [first, last],
        "first_cycle": first,
        "last_cycle": first + rows - 1,
        "rows": rows,
        "row": "row i of every per-cycle file is cycle first_cycle + i",
        "samples": samples,
        "files": entries,
        "tables": table_entries,
    });
    files.push(("vectors_tb.v".to_owned(), testbench(replay, pes, rows)));
    files.push((
        "manifest.json".to_owned(),
        serde_json::to_string_pretty(&manifest).unwrap_or_default() + "\n",
    ));
    Vectors {
        files,
        manifest,
        rows,
    }
}

/// The plain testbench: for each PE an instance of the module fed from its
/// files, the tables written through the host port, every row's outputs
/// compared; it prints the first mismatch of each PE and the count.
pub fn testbench(replay: &Replay, pes: usize, rows: u64) -> String {
    let m = &replay.module;
    let mut v = String::new();
    let w = &mut v;
    let port_bits = |n: &str| super::replay::port_bits(m, n);
    let (sb, ab, db) = (
        port_bits("tbl_sel"),
        port_bits("tbl_addr"),
        port_bits("tbl_data"),
    );
    let _ = writeln!(
        w,
        "// {TB}: replays ercube's vector files (manifest.json) against {} and counts\n\
         // mismatches. Run beside the files: iverilog -g2005 -o tb {}.v vectors_tb.v && vvp tb\n\
         `timescale 1ns/1ps\nmodule {TB};\n  reg clk = 1'b0;\n  always #5 clk = ~clk;\n  \
         reg rst = 1'b1;\n  reg tbl_we = 1'b0;\n  reg [{}:0] tbl_sel = {sb}'d0;\n  \
         reg [{}:0] tbl_addr = {ab}'d0;\n  reg [{}:0] tbl_data = {db}'d0;\n  \
         integer row, i, mismatches, checks;",
        m.name,
        m.name,
        sb - 1,
        ab - 1,
        db - 1
    );
    for t in &m.tables {
        let _ = writeln!(
            w,
            "  reg [{}:0] t_{} [0:{}];",
            t.bits - 1,
            t.name,
            t.depth - 1
        );
    }
    let ports: Vec<(&str, u32, bool, bool)> =
        [("in_valid", 1, false, true), ("out_valid", 1, false, false)]
            .into_iter()
            .chain(replay.fields.iter().map(|f| {
                (
                    f.port.name.as_str(),
                    f.port.word.bits,
                    f.port.word.signed,
                    f.port.input,
                )
            }))
            .collect();
    for k in 0..pes {
        for &(name, bits, signed, input) in &ports {
            let s = if signed { "signed " } else { "" };
            let kind = if input { "reg" } else { "wire" };
            let _ = writeln!(w, "  {kind} {s}[{}:0] p{k}_{name};", bits - 1);
            let _ = writeln!(w, "  reg [{}:0] f{k}_{name} [0:{}];", bits - 1, rows - 1);
        }
        let conns: Vec<String> = m
            .ports
            .iter()
            .map(|p| match p.name.as_str() {
                "clk" | "rst" | "tbl_we" | "tbl_sel" | "tbl_addr" | "tbl_data" => {
                    format!(".{0}({0})", p.name)
                }
                n => format!(".{n}(p{k}_{n})"),
            })
            .collect();
        let _ = writeln!(w, "  {} dut{k} ({});", m.name, conns.join(", "));
    }
    let _ = writeln!(w, "  initial begin\n    mismatches = 0; checks = 0;");
    for t in &m.tables {
        let _ = writeln!(w, "    $readmemh(\"table_{0}.hex\", t_{0});", t.name);
    }
    for k in 0..pes {
        for &(name, ..) in &ports {
            let _ = writeln!(w, "    $readmemh(\"pe{k}_{name}.hex\", f{k}_{name});");
        }
        for &(name, bits, _, input) in &ports {
            if input {
                let _ = writeln!(w, "    p{k}_{name} = {bits}'d0;");
            }
        }
    }
    let _ = writeln!(w, "    @(posedge clk); @(posedge clk); #1 rst = 1'b0;");
    for t in &m.tables {
        let _ = writeln!(
            w,
            "    for (i = 0; i < {}; i = i + 1) begin\n      tbl_we = 1'b1; tbl_sel = {sb}'d{}; \
             tbl_addr = i; tbl_data = t_{}[i];\n      @(posedge clk); #1;\n    end",
            t.depth, t.sel, t.name
        );
    }
    let _ = writeln!(
        w,
        "    tbl_we = 1'b0;\n    for (row = 0; row < {rows}; row = row + 1) begin"
    );
    for k in 0..pes {
        for &(name, _, _, input) in &ports {
            if input {
                let _ = writeln!(w, "      p{k}_{name} = f{k}_{name}[row];");
            }
        }
    }
    let _ = writeln!(w, "      #1;");
    for k in 0..pes {
        for &(name, _, _, input) in &ports {
            if input {
                continue;
            }
            let when = match name {
                "out_valid" | "x0" => "1'b1".to_owned(),
                _ => format!("f{k}_out_valid[row]"),
            };
            let _ = writeln!(
                w,
                "      if ({when}) begin\n        checks = checks + 1;\n        \
                 if (p{k}_{name} !== f{k}_{name}[row]) begin\n          \
                 if (mismatches == 0) $display(\"MISMATCH row %0d pe {k} {name} expected %h got %h\", row, f{k}_{name}[row], p{k}_{name});\n          \
                 mismatches = mismatches + 1;\n        end\n      end"
            );
        }
    }
    let _ = writeln!(
        w,
        "      @(posedge clk); #1;\n    end\n    \
         $display(\"vectors: %0d mismatches in %0d checks over {rows} cycles of {pes} PEs\", mismatches, checks);\n    \
         $finish;\n  end\nendmodule"
    );
    v
}
