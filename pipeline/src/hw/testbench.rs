//! Streaming samples through a [`PipelinedModule`] in a Verilog simulator
//! and comparing every output word with the description's evaluator.
//!
//! The testbench is plain Verilog-2005 with delays (Icarus `-g2005`, and
//! Verilator's `--binary`): per module it resets, writes the tables
//! through the host port (`$readmemb` rows of select, address and word),
//! then applies one stimulus row per clock (`in_valid`, the ports of the
//! sample issued that clock, and the voxel taps of the sample whose tap
//! column left the module the clock before) and writes the outputs of
//! every clock, in hex, one line each. [`compare`] then checks each
//! sample's outputs at the clock its port says, and that `out_valid`
//! is set exactly then.

use std::fmt::Write as _;
use std::path::Path;

use super::pipeline_rtl::{PipelinedModule, Port};

/// One sample's port words, by port name (the taps included).
pub type Sample = Vec<(String, i64)>;

/// The outputs a sample must give, by port name.
pub type Expected = Vec<(String, i128)>;

/// The first difference between the module and the evaluator.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cycle {cycle} (sample {sample}): {signal} expected {expected}, got {got}")]
pub struct Mismatch {
    /// Clock after the first issue slot.
    pub cycle: usize,
    /// The sample's index, in issue order (none for a stray `out_valid`).
    pub sample: String,
    /// The port.
    pub signal: String,
    /// The evaluator's word.
    pub expected: String,
    /// The simulator's word.
    pub got: String,
}

/// The inputs a stimulus row carries: `in_valid`, the sample's ports and
/// the taps (every input but the clock, the reset and the host port).
pub fn row_ports(m: &PipelinedModule) -> Vec<&Port> {
    m.ports
        .iter()
        .filter(|p| p.input && !["clk", "rst"].contains(&p.name.as_str()))
        .filter(|p| !p.name.starts_with("tbl_"))
        .collect()
}

/// The outputs a dump line carries, `out_valid` first.
pub fn dump_ports(m: &PipelinedModule) -> Vec<&Port> {
    m.ports.iter().filter(|p| !p.input).collect()
}

/// `v`'s low `bits` bits, most significant first.
fn bits_of(v: i128, bits: u32, out: &mut String) {
    for k in (0..bits).rev() {
        out.push(if (v >> k) & 1 == 1 { '1' } else { '0' });
    }
}

/// The stimulus rows (`$readmemb`): one per clock of `issue`, which gives
/// the sample issued at each clock, or none (a bubble).
pub fn stimulus(m: &PipelinedModule, samples: &[Sample], issue: &[Option<usize>]) -> String {
    let ports = row_ports(m);
    let mut s = String::new();
    for c in 0..issue.len() {
        for p in &ports {
            // A port read `stage` clocks after issue carries the sample
            // issued then.
            let at = c.checked_sub(p.stage as usize).and_then(|t| issue[t]);
            let v = match (p.name.as_str(), at) {
                ("in_valid", _) => i128::from(issue[c].is_some()),
                (_, Some(k)) => samples[k]
                    .iter()
                    .find(|(n, _)| *n == p.name)
                    .map_or(0, |x| i128::from(x.1)),
                (_, None) => 0,
            };
            bits_of(v, p.word.bits, &mut s);
        }
        s.push('\n');
    }
    s
}

/// The host port's rows (`$readmemb`: select, address, word) writing
/// `contents` (by table name, every word of the table).
pub fn table_writes(m: &PipelinedModule, contents: &[(String, Vec<i64>)]) -> String {
    let w = |n: &str| {
        m.ports
            .iter()
            .find(|p| p.name == n)
            .map_or(1, |p| p.word.bits)
    };
    let (sb, ab, db) = (w("tbl_sel"), w("tbl_addr"), w("tbl_data"));
    let mut s = String::new();
    for t in &m.tables {
        let Some((_, words)) = contents.iter().find(|c| c.0 == t.name) else {
            continue;
        };
        for (a, &v) in words.iter().enumerate() {
            s.push('1');
            bits_of(i128::from(t.sel), sb, &mut s);
            bits_of(a as i128, ab, &mut s);
            bits_of(i128::from(v), db, &mut s);
            s.push('\n');
        }
    }
    s
}

/// One module under test: its stimulus, table and output files and how
/// many rows each has.
pub struct Dut<'a> {
    /// The module.
    pub module: &'a PipelinedModule,
    /// Stimulus rows ([`stimulus`]).
    pub stim: &'a Path,
    /// Host port rows ([`table_writes`]).
    pub tables: &'a Path,
    /// Where the outputs go.
    pub out: &'a Path,
    /// Stimulus rows.
    pub rows: usize,
    /// Host port rows.
    pub writes: usize,
}

/// A testbench `tb` driving every module of `duts` from one clock.
pub fn testbench(duts: &[Dut]) -> String {
    let mut v = String::new();
    let w = &mut v;
    let _ = writeln!(
        w,
        "`timescale 1ns/1ps\nmodule tb;\n  reg clk = 1'b0;\n  always #5 clk = ~clk;"
    );
    let mut done = Vec::new();
    for (k, d) in duts.iter().enumerate() {
        let m = d.module;
        let pre = format!("u{k}_");
        let ins = row_ports(m);
        let row_bits: u32 = ins.iter().map(|p| p.word.bits).sum();
        let tw = |n: &str| {
            m.ports
                .iter()
                .find(|p| p.name == n)
                .map_or(1, |p| p.word.bits)
        };
        let wbits = 1 + tw("tbl_sel") + tw("tbl_addr") + tw("tbl_data");
        for p in m.ports.iter().filter(|p| p.name != "clk") {
            let kind = if p.input { "reg" } else { "wire" };
            let sg = if p.word.signed { "signed " } else { "" };
            let _ = writeln!(w, "  {kind} {sg}[{}:0] {pre}{};", p.word.bits - 1, p.name);
        }
        let _ = writeln!(
            w,
            "  reg [{}:0] {pre}stim [0:{}];",
            row_bits - 1,
            d.rows.max(1) - 1
        );
        let _ = writeln!(
            w,
            "  reg [{}:0] {pre}tw [0:{}];",
            wbits - 1,
            d.writes.max(1) - 1
        );
        let _ = writeln!(w, "  reg {pre}done = 1'b0;\n  integer {pre}c, {pre}fd;");
        let conns: Vec<String> = m
            .ports
            .iter()
            .map(|p| {
                let src = if p.name == "clk" {
                    "clk".to_owned()
                } else {
                    format!("{pre}{}", p.name)
                };
                format!(".{}({src})", p.name)
            })
            .collect();
        let _ = writeln!(w, "  {} dut{k} ({});", m.name, conns.join(", "));
        let row: Vec<String> = ins.iter().map(|p| format!("{pre}{}", p.name)).collect();
        let outs = dump_ports(m);
        let fmt = vec!["%h"; outs.len()].join(" ");
        let outv: Vec<String> = outs.iter().map(|p| format!("{pre}{}", p.name)).collect();
        let _ = writeln!(w, "  initial begin");
        let _ = writeln!(w, "    {pre}rst = 1'b1; {pre}tbl_we = 1'b0; {pre}tbl_sel = 0; {pre}tbl_addr = 0; {pre}tbl_data = 0;");
        let _ = writeln!(w, "    {{{}}} = {row_bits}'d0;", row.join(", "));
        let _ = writeln!(w, "    $readmemb(\"{}\", {pre}stim);", d.stim.display());
        if d.writes > 0 {
            let _ = writeln!(w, "    $readmemb(\"{}\", {pre}tw);", d.tables.display());
        }
        let _ = writeln!(w, "    {pre}fd = $fopen(\"{}\", \"w\");", d.out.display());
        let _ = writeln!(w, "    @(posedge clk); @(posedge clk); #1 {pre}rst = 1'b0;");
        let _ = writeln!(
            w,
            "    for ({pre}c = 0; {pre}c < {}; {pre}c = {pre}c + 1) begin",
            d.writes
        );
        let _ = writeln!(
            w,
            "      {{{pre}tbl_we, {pre}tbl_sel, {pre}tbl_addr, {pre}tbl_data}} = {pre}tw[{pre}c];"
        );
        let _ = writeln!(
            w,
            "      @(posedge clk); #1;\n    end\n    {pre}tbl_we = 1'b0;"
        );
        let _ = writeln!(
            w,
            "    for ({pre}c = 0; {pre}c < {}; {pre}c = {pre}c + 1) begin",
            d.rows
        );
        let _ = writeln!(w, "      {{{}}} = {pre}stim[{pre}c];", row.join(", "));
        let _ = writeln!(
            w,
            "      #1 $fwrite({pre}fd, \"{fmt}\\n\", {});",
            outv.join(", ")
        );
        let _ = writeln!(w, "      @(posedge clk); #1;\n    end");
        let _ = writeln!(w, "    $fclose({pre}fd);\n    {pre}done = 1'b1;\n  end");
        done.push(format!("{pre}done"));
    }
    let _ = writeln!(
        w,
        "  initial begin\n    wait ({});\n    $finish;\n  end\nendmodule",
        done.join(" && ")
    );
    v
}

/// Reads a hex word of `p`'s width, sign-extended when signed; `None` for
/// a word with an unknown or high-impedance bit.
fn parse(p: &Port, s: &str) -> Option<i128> {
    let u = u128::from_str_radix(s, 16).ok()?;
    let b = p.word.bits;
    let v = u as i128;
    Some(if p.word.signed && b < 128 && (v >> (b - 1)) & 1 == 1 {
        v - (1i128 << b)
    } else {
        v
    })
}

/// Compares the dump of a run (the lines of [`testbench`]'s output file)
/// with `expected` (per sample, in issue order) under `issue`: each
/// output at the clock its port's stage says after the sample's issue,
/// `out_valid` set exactly at the clocks a sample is due. The first
/// difference, in clock order.
pub fn compare(
    m: &PipelinedModule,
    dump: &str,
    expected: &[Expected],
    issue: &[Option<usize>],
) -> Result<usize, Mismatch> {
    let outs = dump_ports(m);
    let lines: Vec<&str> = dump.lines().collect();
    let mut checked = 0;
    for c in 0..issue.len() {
        let words: Vec<&str> = lines
            .get(c)
            .map_or(vec![], |l| l.split_whitespace().collect());
        for (j, p) in outs.iter().enumerate() {
            let due = c.checked_sub(p.stage as usize).and_then(|t| issue[t]);
            let want = match (p.name.as_str(), due) {
                ("out_valid", d) => Some(i128::from(d.is_some())),
                (_, Some(k)) => expected[k].iter().find(|e| e.0 == p.name).map(|e| e.1),
                (_, None) => None,
            };
            let Some(want) = want else { continue };
            let raw = words.get(j).copied().unwrap_or("(missing)");
            let got = parse(p, raw);
            if got != Some(want) {
                return Err(Mismatch {
                    cycle: c,
                    sample: due.map_or("none".into(), |k| k.to_string()),
                    signal: p.name.clone(),
                    expected: want.to_string(),
                    got: got.map_or(raw.to_owned(), |g| g.to_string()),
                });
            }
            checked += 1;
        }
    }
    Ok(checked)
}
