//! A wrapper giving a unit register-to-register paths on a few pins.
//!
//! A unit whose ports go straight to pins has no path nextpnr can time
//! (nor pins enough: a compositing unit has over 100 input bits). The
//! wrapper shifts every input bit in serially from one pin into a shift
//! register that drives the unit's inputs, and loads the unit's (registered)
//! outputs in parallel into a second shift register that shifts out on one
//! pin. Every output bit stays observable, so synthesis removes nothing
//! (reducing the outputs with XOR instead lets yosys remove most of the
//! logic). The timed paths are the unit's own: input shift register ->
//! the unit's logic -> the unit's output register. The wrapper itself
//! adds one flip-flop per input and output bit and a LUT per output bit
//! (the load multiplexer).

use std::fmt::Write as _;

/// The name of the wrapper module.
pub const TOP: &str = "ercube_synth_top";

/// A port's direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dir {
    /// An input.
    In,
    /// An output.
    Out,
}

/// One port of a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Port {
    /// The port's name.
    pub name: String,
    /// Its width in bits.
    pub bits: u32,
    /// Input or output.
    pub dir: Dir,
    /// Declared `signed`.
    pub signed: bool,
}

/// The ports of module `module` in `verilog` (ANSI port list, one port a
/// line, as [`crate::rtl`] emits them), or why they cannot be read.
pub fn ports(verilog: &str, module: &str) -> Result<Vec<Port>, String> {
    let head = format!("module {module} (");
    let start = verilog
        .find(&head)
        .ok_or_else(|| format!("no module {module} in the Verilog"))?
        + head.len();
    let end = verilog[start..]
        .find(");")
        .ok_or_else(|| format!("module {module}: unterminated port list"))?;
    // Line comments between the declarations are not ports.
    let list: String = verilog[start..start + end]
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = Vec::new();
    for decl in list.split(',') {
        let toks: Vec<&str> = decl.split_whitespace().collect();
        let Some((&first, rest)) = toks.split_first() else {
            continue;
        };
        let dir = match first {
            "input" => Dir::In,
            "output" => Dir::Out,
            other => return Err(format!("module {module}: cannot read port '{other}'")),
        };
        let mut bits = 1;
        let mut name = None;
        let mut signed = false;
        for t in rest {
            match *t {
                "signed" => signed = true,
                "reg" | "wire" => {}
                r if r.starts_with('[') => {
                    let hi = r
                        .trim_start_matches('[')
                        .split(':')
                        .next()
                        .and_then(|h| h.parse::<u32>().ok())
                        .ok_or_else(|| format!("module {module}: cannot read range {r}"))?;
                    bits = hi + 1;
                }
                n => name = Some(n.to_owned()),
            }
        }
        let name = name.ok_or_else(|| format!("module {module}: a port without a name"))?;
        out.push(Port {
            name,
            bits,
            dir,
            signed,
        });
    }
    Ok(out)
}

/// Input and output bits the wrapper shifts (the clock excluded).
pub fn shifted_bits(ports: &[Port]) -> (u32, u32) {
    let sum = |d: Dir| -> u32 {
        ports
            .iter()
            .filter(|p| p.dir == d && p.name != "clk")
            .map(|p| p.bits)
            .sum()
    };
    (sum(Dir::In), sum(Dir::Out))
}

/// The wrapper of module `module` with `ports` (an input `clk` among
/// them): top module [`TOP`] with pins `clk`, `sin`, `ld` and `sout`.
pub fn wrapper(module: &str, ports: &[Port]) -> Result<String, String> {
    if !ports.iter().any(|p| p.name == "clk" && p.dir == Dir::In) {
        return Err(format!("module {module} has no clock input"));
    }
    let (ni, no) = shifted_bits(ports);
    if ni == 0 || no == 0 {
        return Err(format!("module {module} has no inputs or no outputs"));
    }
    let mut v = String::new();
    let _ = writeln!(
        v,
        "// {module} between shift registers: {ni} input bits in on sin, {no} output bits\n\
         // loaded on ld and out on sout. Emitted by ercube synth."
    );
    let _ = writeln!(
        v,
        "module {TOP} (input clk, input sin, input ld, output sout);"
    );
    let _ = writeln!(v, "  reg [{}:0] shin;", ni - 1);
    let _ = writeln!(v, "  reg [{}:0] shout;", no - 1);
    let shift_in = if ni == 1 {
        "sin".to_owned()
    } else {
        format!("{{shin[{}:0], sin}}", ni - 2)
    };
    let _ = writeln!(v, "  always @(posedge clk) shin <= {shift_in};");
    let mut conns = vec![".clk(clk)".to_owned()];
    let mut lo = 0;
    let mut outs = Vec::new();
    for p in ports.iter().filter(|p| p.name != "clk") {
        match p.dir {
            Dir::In => {
                conns.push(format!(".{}(shin[{}:{lo}])", p.name, lo + p.bits - 1));
                lo += p.bits;
            }
            Dir::Out => {
                let _ = writeln!(v, "  wire [{}:0] o_{};", p.bits - 1, p.name);
                conns.push(format!(".{0}(o_{0})", p.name));
                outs.push(format!("o_{}", p.name));
            }
        }
    }
    let _ = writeln!(v, "  {module} unit ({});", conns.join(", "));
    let shift_out = if no == 1 {
        "1'b0".to_owned()
    } else {
        format!("{{shout[{}:0], 1'b0}}", no - 2)
    };
    let _ = writeln!(
        v,
        "  always @(posedge clk) shout <= ld ? {{{}}} : {shift_out};",
        outs.join(", ")
    );
    let _ = writeln!(v, "  assign sout = shout[{}];\nendmodule", no - 1);
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PipelineConfig;

    #[test]
    fn reads_every_units_ports_and_wraps_them() {
        let cfg = PipelineConfig::default();
        for m in super::super::units(&cfg).unwrap() {
            let ps = ports(&m.verilog, &m.name).unwrap();
            let (ni, no) = shifted_bits(&ps);
            assert!(ni > 0 && no > 0, "{}: {ps:?}", m.name);
            let w = wrapper(&m.name, &ps).unwrap();
            assert!(w.contains(&format!("reg [{}:0] shin;", ni - 1)), "{w}");
            assert!(w.contains(&format!("reg [{}:0] shout;", no - 1)), "{w}");
        }
    }

    #[test]
    fn composite_ports_have_their_widths() {
        let cfg = PipelineConfig::default();
        let m = crate::rtl::composite(&cfg).unwrap();
        let ps = ports(&m.verilog, &m.name).unwrap();
        let acc = ps.iter().find(|p| p.name == "acc_r").unwrap();
        assert_eq!(acc.bits, u32::from(cfg.accum_color.bits()));
        assert_eq!(acc.dir, Dir::In);
        let y = ps.iter().find(|p| p.name == "y_a").unwrap();
        assert_eq!(
            (y.bits, y.dir),
            (u32::from(cfg.accum_alpha.bits()), Dir::Out)
        );
    }

    #[test]
    fn the_sample_stage_ports_are_read_past_their_comments() {
        let cfg = PipelineConfig::default();
        let m = super::super::pe::sample_stage(&cfg, [16, 16, 16]).unwrap();
        let ps = ports(&m.verilog, &m.name).unwrap();
        let find = |n: &str| ps.iter().find(|p| p.name == n).map(|p| (p.bits, p.dir));
        // `// The host's voxel load ...` precedes `vld_we` in the list.
        assert_eq!(find("vld_we"), Some((1, Dir::In)));
        assert_eq!(find("pl_lo"), Some((16, Dir::In)));
        assert_eq!(
            find("vld_data"),
            Some((u32::from(cfg.voxel.bits()), Dir::In))
        );
        assert!(ps.iter().all(|p| !p.name.contains('/')), "{ps:?}");
    }
}
