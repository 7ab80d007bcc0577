//! The co-simulation's readout stage: the emitted array of PE readout
//! stages ([`crate::hw::readout_rtl`]) loaded with each PE's compositing
//! buffer and column map as the model held them when the controller
//! broadcast `BeginReadout`, then clocked through the readout and compared
//! with the model on every clock (every PE's host port and `done` line);
//! the host's baseplane is assembled from the RTL's host stream and
//! compared word for word with the model's final raw words.
//!
//! The buffers' contents come from the model at the readout's start: the
//! sampling, the merges and the migrations that fill them are not in RTL
//! yet.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

use super::capture::{Capture, Issue, IssueSink, ReadoutStart, ReadoutTick};
use super::outcome::Mismatch;
use super::replay::parse_hex;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::datapath::Datapath;
use crate::hw::readout_rtl::{
    ReadoutShape, ARRAY_MODULE, SEL_BUFFER, SEL_COUNTS, SEL_MAP, SEL_VALID,
};

/// The generated testbench's module name.
pub const TOP: &str = "ercube_readout_cosim";

/// A sink keeping what the readout starts from and its clocks.
#[derive(Debug, Clone, Default)]
pub struct ReadoutRecord {
    /// The buffers at the readout's start.
    pub start: Option<ReadoutStart>,
    /// The readout's clocks as the model ran them.
    pub ticks: Vec<ReadoutTick>,
}

impl IssueSink for ReadoutRecord {
    fn issue(&mut self, _issue: &Issue) {}

    fn readout_begin(&mut self, start: &ReadoutStart) {
        self.start = Some(start.clone());
    }

    fn readout_tick(&mut self, tick: &ReadoutTick) {
        self.ticks.push(tick.clone());
    }
}

/// Two captures fed the same frame.
pub struct Tee(pub Capture, pub Capture);

impl Tee {
    /// `a` and `b` as one capture.
    pub fn capture(a: Capture, b: Capture) -> Capture {
        Arc::new(std::sync::Mutex::new(Tee(a, b)))
    }

    fn each(&self, mut f: impl FnMut(&mut dyn IssueSink)) {
        for c in [&self.0, &self.1] {
            f(&mut *c.lock().unwrap_or_else(|e| e.into_inner()));
        }
    }
}

impl IssueSink for Tee {
    fn begin(&mut self, dp: &Datapath) {
        self.each(|s| s.begin(dp));
    }
    fn issue(&mut self, issue: &Issue) {
        self.each(|s| s.issue(issue));
    }
    fn readout_begin(&mut self, start: &ReadoutStart) {
        self.each(|s| s.readout_begin(start));
    }
    fn readout_tick(&mut self, tick: &ReadoutTick) {
        self.each(|s| s.readout_tick(tick));
    }
}

/// Each PE's `(ncols, rows)`: the counts the readout module is loaded
/// with. Refused in one line where a PE's rays do not fit the module: held
/// columns of different row counts, more columns or rays than declared, an
/// index wider than the column map's.
pub fn counts(shape: &ReadoutShape, start: &ReadoutStart) -> Result<Vec<(u64, u64)>, String> {
    if start.pes.len() != shape.pes {
        return Err(format!(
            "the readout module has {} PEs, the frame {}",
            shape.pes,
            start.pes.len()
        ));
    }
    let half = 1i64 << (RAY_INDEX_BITS - 1);
    let mut out = Vec::new();
    for (k, pe) in start.pes.iter().enumerate() {
        let rows = pe.rows.first().copied().unwrap_or(0) as u64;
        if pe.rows.iter().any(|&r| r as u64 != rows) {
            return Err(format!(
                "PE {k} holds columns of different row counts at the readout"
            ));
        }
        let ncols = pe.mx.len() as u64;
        if ncols > shape.map_depth || ncols * rows > 2 * shape.bank_depth || rows > shape.max_rows {
            return Err(format!(
                "PE {k} holds {ncols} columns of {rows} rows, past the declared {} slots of {} rays",
                shape.map_depth,
                2 * shape.bank_depth
            ));
        }
        if let Some(mx) = pe.mx.iter().find(|&&m| !(-half..half).contains(&m)) {
            return Err(format!(
                "PE {k}'s ray index {mx} is wider than {RAY_INDEX_BITS} bits"
            ));
        }
        out.push((ncols, rows));
    }
    Ok(out)
}

/// `fields` (value, bits), the first at bit 0, as one hexadecimal word
/// (two's complement within each field's bits).
fn pack(fields: &[(i64, u32)]) -> String {
    let mut bits: Vec<bool> = Vec::new();
    for &(v, n) in fields {
        for i in 0..n {
            bits.push(i < 64 && (v >> i) & 1 == 1);
        }
    }
    if bits.is_empty() {
        return "0".into();
    }
    let mut s = String::new();
    for chunk in bits.chunks(4).rev() {
        let d = chunk
            .iter()
            .enumerate()
            .fold(0u32, |a, (i, &b)| a | (u32::from(b) << i));
        s.push(char::from_digit(d, 16).unwrap_or('0'));
    }
    s
}

/// The accumulators' fields of `w` as the buffer packs them.
fn acc_fields(shape: &ReadoutShape, w: &[i64; 4]) -> [(i64, u32); 4] {
    let (c, a) = (shape.color_bits, shape.alpha_bits);
    [(w[0], c), (w[1], c), (w[2], c), (w[3], a)]
}

/// Writes `load.hex` (the host's load words: PE, select, address, data)
/// and `expect.hex` (per clock, per PE: host port fields and `done`) into
/// `dir`.
pub fn write_files(
    shape: &ReadoutShape,
    start: &ReadoutStart,
    ticks: &[ReadoutTick],
    dir: &Path,
) -> Result<(), String> {
    let counts = counts(shape, start)?;
    let rb = shape.row_bits();
    let mut load = String::new();
    for (k, (pe, &(ncols, rows))) in start.pes.iter().zip(&counts).enumerate() {
        let _ = writeln!(
            load,
            "{k:x} {SEL_COUNTS:x} 0 {}",
            pack(&[(rows as i64, rb), (ncols as i64, shape.slot_bits())])
        );
        for (s, &mx) in pe.mx.iter().enumerate() {
            let valid = i64::from(pe.rows[s] > 0);
            let _ = writeln!(
                load,
                "{k:x} {SEL_MAP:x} {s:x} {}",
                pack(&[(mx, RAY_INDEX_BITS), (valid, 1)])
            );
        }
        // Ray (c, r) at r * slots + c; the start lists them column after
        // column.
        let rows_n = rows as usize;
        for (i, w) in pe.words.iter().enumerate() {
            let (c, r) = (i / rows_n.max(1), i % rows_n.max(1));
            let a = r as u64 * shape.map_depth + c as u64;
            let _ = writeln!(
                load,
                "{k:x} {SEL_BUFFER:x} {a:x} {}",
                pack(&acc_fields(shape, w))
            );
        }
        if shape.sparse {
            for r in 0..rows_n {
                let bits: Vec<(i64, u32)> = (0..pe.mx.len())
                    .map(|c| (i64::from(pe.words[c * rows_n + r] != [0; 4]), 1))
                    .collect();
                let _ = writeln!(load, "{k:x} {SEL_VALID:x} {r:x} {}", pack(&bits));
            }
        }
    }
    let mut expect = String::new();
    for (i, t) in ticks.iter().enumerate() {
        if t.cycle != start.cycle + i as u64 + 1 || t.host.len() != shape.pes {
            return Err(format!(
                "the readout's clock {} is not the frame's cycle {} of {} PEs",
                i + 1,
                start.cycle + i as u64 + 1,
                shape.pes
            ));
        }
        for (h, &done) in t.host.iter().zip(&t.done) {
            let (v, mx, row, w) = match h {
                Some(o) => (1, o.mx, i64::from(o.row), o.acc.raw),
                None => (0, 0, 0, [0; 4]),
            };
            let f = acc_fields(shape, &w);
            let _ = writeln!(
                expect,
                "{v} {} {} {} {} {} {} {}",
                pack(&[(mx, RAY_INDEX_BITS)]),
                pack(&[(row, rb)]),
                pack(&f[0..1]),
                pack(&f[1..2]),
                pack(&f[2..3]),
                pack(&f[3..4]),
                u8::from(done)
            );
        }
    }
    let err = |e: std::io::Error| format!("cosim readout files in {}: {e}", dir.display());
    std::fs::write(dir.join("load.hex"), load).map_err(err)?;
    std::fs::write(dir.join("expect.hex"), expect).map_err(err)?;
    Ok(())
}

/// The testbench: the array top of `shape` loaded from `load.hex`, then
/// clocked `+ticks=N` readout clocks (the first with `begin_readout`), every
/// PE's host port compared before each clock edge and its `done` after it
/// with `expect.hex`; every valid host word printed for the host's
/// baseplane.
pub fn testbench(shape: &ReadoutShape) -> String {
    let p = shape.pes;
    let (cw, aw, rb, ib) = (
        shape.color_bits,
        shape.alpha_bits,
        shape.row_bits(),
        RAY_INDEX_BITS,
    );
    let (la, ld, pb) = (shape.ld_addr_bits(), shape.ld_data_bits(), shape.pe_bits());
    let checks = [
        (
            "host_valid",
            "e_valid[0:0]".to_owned(),
            "host_valid[k]".to_owned(),
        ),
        (
            "host_mx",
            format!("e_mx[{}:0]", ib - 1),
            format!("host_mx[k*{ib} +: {ib}]"),
        ),
        (
            "host_row",
            format!("e_row[{}:0]", rb - 1),
            format!("host_row[k*{rb} +: {rb}]"),
        ),
        (
            "host_r",
            format!("e_r[{}:0]", cw - 1),
            format!("host_r[k*{cw} +: {cw}]"),
        ),
        (
            "host_g",
            format!("e_g[{}:0]", cw - 1),
            format!("host_g[k*{cw} +: {cw}]"),
        ),
        (
            "host_b",
            format!("e_b[{}:0]", cw - 1),
            format!("host_b[k*{cw} +: {cw}]"),
        ),
        (
            "host_a",
            format!("e_a[{}:0]", aw - 1),
            format!("host_a[k*{aw} +: {aw}]"),
        ),
    ];
    let mut cmp = String::new();
    for (name, want, have) in &checks {
        let _ = writeln!(
            cmp,
            "        if ({want} !== {have}) begin\n          if (mism[k] < 64'd4) $display(\"RMISMATCH %0d %0d {name} %h %h\", first + t, k, {want}, {have});\n          mism[k] = mism[k] + 64'd1;\n        end"
        );
    }
    format!(
        "// {TOP}: the readout stage's co-simulation testbench, generated by ercube
// (pipeline::cosim::readout).
`timescale 1ns/1ps
module {TOP};
  reg clk = 1'b0;
  always #5 clk = ~clk;
  reg rst = 1'b1;
  reg ld_we = 1'b0;
  reg [{pb1}:0] ld_pe = {pb}'d0;
  reg [1:0] ld_sel = 2'd0;
  reg [{la1}:0] ld_addr = {la}'d0;
  reg [{ld1}:0] ld_data = {ld}'d0;
  reg begin_readout = 1'b0;
  wire [{p1}:0] host_valid;
  wire [{pib1}:0] host_mx;
  wire [{prb1}:0] host_row;
  wire [{pcw1}:0] host_r;
  wire [{pcw1}:0] host_g;
  wire [{pcw1}:0] host_b;
  wire [{paw1}:0] host_a;
  wire [{p1}:0] done;
  wire all_done;
  {ARRAY_MODULE} dut (
    .clk(clk), .rst(rst), .ld_we(ld_we), .ld_pe(ld_pe), .ld_sel(ld_sel),
    .ld_addr(ld_addr), .ld_data(ld_data), .begin_readout(begin_readout),
    .host_valid(host_valid), .host_mx(host_mx), .host_row(host_row),
    .host_r(host_r), .host_g(host_g), .host_b(host_b), .host_a(host_a),
    .done(done), .all_done(all_done)
  );
  integer fd;
  integer got;
  integer k;
  reg [63:0] t;
  reg [63:0] ticks;
  reg [63:0] first;
  reg [63:0] loads;
  reg [31:0] a_pe;
  reg [31:0] a_sel;
  reg [63:0] a_addr;
  reg [{ld1}:0] a_data;
  reg [63:0] e_valid, e_mx, e_row, e_r, e_g, e_b, e_a, e_done;
  reg edone [0:{p1}];
  reg [63:0] mism [0:{p1}];
  reg [63:0] words [0:{p1}];
  initial begin
    if (!$value$plusargs(\"ticks=%d\", ticks)) ticks = 64'd0;
    if (!$value$plusargs(\"first=%d\", first)) first = 64'd0;
`ifdef ERCUBE_VCD
    $dumpfile(\"rtl.vcd\");
    $dumpvars(0, {TOP});
`endif
    loads = 64'd0;
    for (k = 0; k < {p}; k = k + 1) begin
      mism[k] = 64'd0;
      words[k] = 64'd0;
      edone[k] = 1'b0;
    end
    @(posedge clk); @(posedge clk); #1 rst = 1'b0;
    fd = $fopen(\"load.hex\", \"r\");
    if (fd == 0) $display(\"ERROR cannot open load.hex\");
    else begin
      while (!$feof(fd)) begin
        got = $fscanf(fd, \"%h %h %h %h\\n\", a_pe, a_sel, a_addr, a_data);
        if (got == 4) begin
          ld_we = 1'b1; ld_pe = a_pe[{pb1}:0]; ld_sel = a_sel[1:0];
          ld_addr = a_addr[{la1}:0]; ld_data = a_data;
          loads = loads + 64'd1;
          @(posedge clk); #1;
        end
      end
      $fclose(fd);
    end
    ld_we = 1'b0;
    fd = $fopen(\"expect.hex\", \"r\");
    if (fd == 0) $display(\"ERROR cannot open expect.hex\");
    for (t = 64'd1; t <= ticks; t = t + 64'd1) begin
      begin_readout = (t == 64'd1);
      for (k = 0; k < {p}; k = k + 1) begin
        got = $fscanf(fd, \"%h %h %h %h %h %h %h %h\\n\", e_valid, e_mx, e_row, e_r, e_g, e_b, e_a, e_done);
        if (got != 8) $display(\"ERROR expect.hex ends at clock %0d\", t);
        edone[k] = e_done[0];
{cmp}        if (host_valid[k]) begin
          words[k] = words[k] + 64'd1;
          $display(\"HOST %0d %h %h %h %h %h %h\", k, host_mx[k*{ib} +: {ib}], host_row[k*{rb} +: {rb}], host_r[k*{cw} +: {cw}], host_g[k*{cw} +: {cw}], host_b[k*{cw} +: {cw}], host_a[k*{aw} +: {aw}]);
        end
      end
      @(posedge clk); #1;
      begin_readout = 1'b0;
      for (k = 0; k < {p}; k = k + 1) begin
        if (edone[k] !== done[k]) begin
          if (mism[k] < 64'd4) $display(\"RMISMATCH %0d %0d done %h %h\", first + t, k, edone[k], done[k]);
          mism[k] = mism[k] + 64'd1;
        end
      end
    end
    $display(\"RLOADS %0d\", loads);
    $display(\"RTICKS %0d\", ticks);
    for (k = 0; k < {p}; k = k + 1) $display(\"RPE %0d %0d %0d\", k, words[k], mism[k]);
    $finish;
  end
endmodule
",
        pb1 = pb - 1,
        la1 = la - 1,
        ld1 = ld - 1,
        p1 = p - 1,
        pib1 = p as u32 * ib - 1,
        prb1 = p as u32 * rb - 1,
        pcw1 = p as u32 * cw - 1,
        paw1 = p as u32 * aw - 1,
    )
}

/// What the readout's simulation printed, read back.
#[derive(Debug, Clone, Default)]
pub struct ReadoutOutcome {
    /// Readout clocks simulated.
    pub ticks: u64,
    /// Load words the host wrote.
    pub loads: u64,
    /// Per PE: host words streamed, mismatches.
    pub pes: Vec<(u64, u64)>,
    /// The earliest mismatch (by cycle, then PE).
    pub first: Option<Mismatch>,
    /// The host's baseplane from the RTL's stream (raw words, row-major).
    pub raw: Vec<[i64; 4]>,
    /// Lines that say something went wrong.
    pub errors: Vec<String>,
}

impl ReadoutOutcome {
    /// Mismatches over every PE.
    pub fn mismatches(&self) -> u64 {
        self.pes.iter().map(|p| p.1).sum()
    }

    /// Host words over every PE.
    pub fn words(&self) -> u64 {
        self.pes.iter().map(|p| p.0).sum()
    }
}

/// Reads what the readout testbench printed, assembling the host's
/// baseplane of `start`'s region 0 from the host words.
pub fn parse(shape: &ReadoutShape, start: &ReadoutStart, text: &str) -> ReadoutOutcome {
    let [w, h] = start.size;
    let mut o = ReadoutOutcome {
        pes: vec![(0, 0); shape.pes],
        raw: vec![[0; 4]; w * h],
        ..ReadoutOutcome::default()
    };
    let (cw, aw, rb) = (shape.color_bits, shape.alpha_bits, shape.row_bits());
    let field = |s: &str, bits: u32, signed: bool| parse_hex(s, bits, signed).map(|v| v as i64);
    let widths = [
        (cw, shape.color_signed),
        (cw, shape.color_signed),
        (cw, shape.color_signed),
        (aw, shape.alpha_signed),
    ];
    let mut seen = vec![false; shape.pes];
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["RTICKS", n] => o.ticks = n.parse().unwrap_or(0),
            ["RLOADS", n] => o.loads = n.parse().unwrap_or(0),
            ["RPE", k, words, mism] => match k.parse::<usize>().ok().filter(|&k| k < shape.pes) {
                Some(k) => {
                    seen[k] = true;
                    o.pes[k] = (words.parse().unwrap_or(0), mism.parse().unwrap_or(u64::MAX));
                }
                None => o.errors.push(line.to_owned()),
            },
            ["RMISMATCH", cycle, pe, signal, model, rtl] => {
                let bits = match *signal {
                    "host_valid" | "done" => (1, false),
                    "host_mx" => (RAY_INDEX_BITS, true),
                    "host_row" => (rb, false),
                    "host_a" => widths[3],
                    _ => widths[0],
                };
                let dec =
                    |s: &str| field(s, bits.0, bits.1).map_or(s.to_owned(), |v| v.to_string());
                let m = Mismatch {
                    cycle: cycle.parse().unwrap_or(u64::MAX),
                    pe: pe.parse().unwrap_or(usize::MAX),
                    signal: (*signal).to_owned(),
                    model: dec(model),
                    rtl: dec(rtl),
                };
                if o.first
                    .as_ref()
                    .is_none_or(|f| (m.cycle, m.pe) < (f.cycle, f.pe))
                {
                    o.first = Some(m);
                }
            }
            ["HOST", _k, mx, row, r, g, b, a] => {
                let mx = field(mx, RAY_INDEX_BITS, true);
                let row = field(row, rb, false);
                let words: Vec<Option<i64>> = [r, g, b, a]
                    .iter()
                    .zip(widths)
                    .map(|(s, (n, sg))| field(s, n, sg))
                    .collect();
                let at = match (mx, row) {
                    (Some(mx), Some(row)) => {
                        let x = mx - start.lo;
                        ((0..w as i64).contains(&x) && (0..h as i64).contains(&row))
                            .then(|| row as usize * w + x as usize)
                    }
                    _ => None,
                };
                match (at, words.iter().all(Option::is_some)) {
                    (Some(i), true) => {
                        for (c, v) in words.iter().enumerate() {
                            o.raw[i][c] = v.unwrap_or(0);
                        }
                    }
                    _ => o
                        .errors
                        .push(format!("a host word outside region 0: {line}")),
                }
            }
            ["ERROR", ..] => o.errors.push(line.to_owned()),
            _ => {}
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        o.errors.push(format!("readout PE {k} reported nothing"));
    }
    o
}

/// Raw words compared: how many, how many differ, and the first that does
/// (`x`, `y`, the model's words, the RTL's).
pub type RawCompare = (u64, u64, Option<(usize, usize, [i64; 4], [i64; 4])>);

/// The raw words compared: how many, how many differ, and the first that
/// does (`x`, `y`, the model's words, the RTL's).
pub fn compare_raw(model: &[[i64; 4]], rtl: &[[i64; 4]], width: usize) -> RawCompare {
    let mut diff = 0;
    let mut first = None;
    for (i, (m, r)) in model.iter().zip(rtl).enumerate() {
        if m != r {
            diff += 1;
            if first.is_none() {
                first = Some((i % width.max(1), i / width.max(1), *m, *r));
            }
        }
    }
    if model.len() != rtl.len() {
        diff += model.len().abs_diff(rtl.len()) as u64;
    }
    (model.len().min(rtl.len()) as u64, diff, first)
}

/// A readout stage simulated and compared.
#[derive(Debug, Clone)]
pub struct StageRun {
    /// What the simulation reported, the host's baseplane assembled.
    pub outcome: ReadoutOutcome,
    /// Raw words compared with the model's final ones, how many differ,
    /// and the first that does (`x`, `y`, model, RTL).
    pub raw: RawCompare,
    /// The model's readout clocks.
    pub model_ticks: u64,
    /// The build.
    pub built: super::build::Built,
    /// Seconds the simulation ran.
    pub run_s: f64,
    /// Lines of Verilog: the PE module, the array, the testbench.
    pub lines: [usize; 3],
}

impl StageRun {
    /// Every way the run failed, most telling first: mismatches on the
    /// ports, raw words that differ, clocks or words missing.
    pub fn problems(&self) -> Vec<String> {
        let o = &self.outcome;
        let mut v = Vec::new();
        match &o.first {
            Some(m) => v.push(format!(
                "readout: {} mismatches; the first: {m}",
                o.mismatches()
            )),
            None if o.mismatches() > 0 => v.push(format!("readout: {} mismatches", o.mismatches())),
            None => {}
        }
        if let (_, n, Some((x, y, m, r))) = self.raw {
            v.push(format!(
                "readout: {n} raw words differ; the first at x {x}, y {y}: model {m:?}, RTL {r:?}"
            ));
        }
        if o.ticks != self.model_ticks {
            v.push(format!(
                "readout: the RTL ran {} clocks of the model's {}",
                o.ticks, self.model_ticks
            ));
        }
        v.extend(o.errors.iter().map(|e| format!("readout: {e}")));
        v
    }
}

/// Builds the readout stage (`pe`, the PE module's text, possibly a
/// modified copy of `rtl.pe`) with `sim` under `cache`, runs it in `dir`
/// on the model's readout (`start`, `ticks`) and compares the host's
/// baseplane with `model_raw`.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    rtl: &crate::hw::readout_rtl::ReadoutRtl,
    pe: &str,
    start: &ReadoutStart,
    ticks: &[ReadoutTick],
    model_raw: &[[i64; 4]],
    sim: super::build::Simulator,
    cache: &Path,
    dir: &Path,
    vcd: bool,
) -> Result<StageRun, String> {
    use crate::hw::readout_rtl::PE_MODULE;
    let shape = &rtl.shape;
    write_files(shape, start, ticks, dir)?;
    let tb = testbench(shape);
    let sources = [
        (format!("{PE_MODULE}.v"), pe),
        (format!("{ARRAY_MODULE}.v"), rtl.array.as_str()),
        (format!("{TOP}.v"), tb.as_str()),
    ];
    let sources: Vec<(&str, &str)> = sources.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    let built = super::build::build(sim, cache, &sources, TOP, vcd).map_err(|e| e.to_string())?;
    let mut args = vec![
        format!("+ticks={}", ticks.len()),
        format!("+first={}", start.cycle),
    ];
    if vcd {
        args.push("+vcd".into());
    }
    let (text, run_s) = super::build::run(&built, dir, &args).map_err(|e| e.to_string())?;
    let outcome = parse(shape, start, &text);
    let raw = compare_raw(model_raw, &outcome.raw, start.size[0]);
    Ok(StageRun {
        outcome,
        raw,
        model_ticks: ticks.len() as u64,
        built,
        run_s,
        lines: [
            pe.lines().count(),
            rtl.array.lines().count(),
            tb.lines().count(),
        ],
    })
}
