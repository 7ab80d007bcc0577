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

/// `verilog` with the sum assigned to the wire `wire` (`n_comp_r_s`, a
/// `+`) made a difference, and the line changed; `None` if no such sum.
pub fn break_sum(verilog: &str, wire: &str) -> Option<(String, String)> {
    let head = format!(" {wire} = ");
    let mut out = String::with_capacity(verilog.len());
    let mut changed = None;
    for line in verilog.lines() {
        let is_it = line.trim_start().starts_with("wire") && line.contains(&head);
        if changed.is_none() && is_it && line.contains(" + ") {
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

/// `verilog` (module `inner`, ports `(name, bits, signed, is_input)`)
/// inside a module `outer` with `rst`, `in_valid` and `out_valid` besides
/// (`out_valid` follows `in_valid` `latency` clocks later): the shape of a
/// handshaking unit, for the testbenches' handshake path.
pub fn with_handshake(
    verilog: &str,
    inner: &str,
    outer: &str,
    ports: &[(String, u32, bool, bool)],
    latency: u32,
) -> String {
    let mut decl = vec![
        "  input clk".to_owned(),
        "  input rst".to_owned(),
        "  input in_valid".to_owned(),
        "  output out_valid".to_owned(),
    ];
    let mut conns = vec![".clk(clk)".to_owned()];
    for (name, bits, signed, input) in ports {
        let dir = if *input { "input" } else { "output" };
        let s = if *signed { "signed " } else { "" };
        decl.push(format!("  {dir} {s}[{}:0] {name}", bits - 1));
        conns.push(format!(".{name}({name})"));
    }
    format!(
        "{verilog}\nmodule {outer} (\n{}\n);\n  reg [{l}:0] v;\n  always @(posedge clk) v <= rst ? {n}'d0 : {{v[{l}:0], in_valid}};\n  assign out_valid = v[{l}];\n  {inner} u ({});\nendmodule\n",
        decl.join(",\n"),
        conns.join(", "),
        l = latency - 1,
        n = latency,
    )
}
