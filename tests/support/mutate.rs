//! A deliberately broken copy of emitted Verilog, for the testbenches'
//! mutation tests: one operator changed.
#![allow(dead_code)]

/// `verilog` with the first sum of its datapath (a `+` in a wire named
/// `..._s`, a lerp's or a multiply-add's) made a difference, and the line
/// changed; `None` if it has no such sum.
pub fn break_one_sum(verilog: &str) -> Option<(String, String)> {
    let mut out = String::with_capacity(verilog.len());
    let mut changed = None;
    for line in verilog.lines() {
        let is_sum = line.trim_start().starts_with("wire") && line.contains("_s = ");
        if changed.is_none() && is_sum && line.contains(" + ") {
            let l = line.replacen(" + ", " - ", 1);
            changed = Some(l.trim().to_owned());
            out.push_str(&l);
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    changed.map(|c| (out, c))
}
