//! Small synthesizable Verilog modules of the PE's arithmetic units at the
//! configured widths, to calibrate the FPGA cost estimator ([`crate::cost`])
//! against a real synthesis tool.
//!
//! These are not the product's RTL: each module is one unit (a multiplier,
//! an adder, the bilinear interpolation, the compositing step, the
//! classification table) between input ports and an output register, in
//! plain Verilog-2005, computing what `crate::datapath` computes: full
//! precision operators, then `RND` (a half-LSB carry) and `SAT` (a clamp)
//! on assignment into each declared format. Every module carries the list
//! of estimator [`Unit`]s it is made of, built from the same
//! [`crate::cost::shapes`] that size the Verilog, so the estimate and the
//! synthesis result describe the same hardware. `pipeline/tests/it/cost.rs`
//! synthesizes them with yosys (`synth_xilinx`, `synth_ice40 -dsp`) and
//! compares.
//!
//! The shading unit's square root and divider are
//! [`sqrt_norm`] and [`divider`].
//!
//! Quantisation modes other than `TRN` and `RND`, and `SAT_SYM` into a
//! signed format, are not emitted ([`RtlError::Unsupported`]).

use std::fmt::Write as _;

mod shading;
pub use shading::{dividend_bits, divider, sqrt_norm};

use crate::config::PipelineConfig;
use crate::cost::shapes::{table_word, Quantizer, Word, RAY_INDEX_BITS};
use crate::cost::units::{MulShape, Unit};
use crate::cost::{memory::MemPorts, Resources, Target};
use crate::fixed::{Overflow, Quant};

/// Why a module cannot be emitted.
#[derive(Debug, thiserror::Error)]
pub enum RtlError {
    /// A mode without a Verilog emitter.
    #[error("Verilog emission does not support {0}")]
    Unsupported(String),
}

/// One calibration module: its Verilog and the estimator's view of it.
#[derive(Debug, Clone)]
pub struct CalibrationModule {
    /// Verilog module name (also the `-top` for synthesis).
    pub name: String,
    /// What the module is, in a few words.
    pub description: String,
    /// The Verilog source of this module alone.
    pub verilog: String,
    /// The units the estimator sees in it.
    pub units: Vec<Unit>,
}

impl CalibrationModule {
    /// The estimator's resources for this module on `target`.
    pub fn estimate(&self, target: Target) -> Resources {
        crate::cost::units::total(target, &self.units)
    }
}

/// Collects the declarations and statements of one module.
pub(crate) struct Body {
    text: String,
    next: usize,
}

impl Body {
    pub(crate) fn new() -> Body {
        Body {
            text: String::new(),
            next: 0,
        }
    }

    pub(crate) fn fresh(&mut self, stem: &str) -> String {
        self.next += 1;
        format!("{stem}_{}", self.next)
    }

    /// The lines collected.
    pub(crate) fn text(&self) -> &str {
        &self.text
    }

    pub(crate) fn line(&mut self, s: &str) {
        self.text.push_str("  ");
        self.text.push_str(s);
        self.text.push('\n');
    }
}

/// `[n-1:0]`.
pub(crate) fn range(bits: u32) -> String {
    format!("[{}:0]", bits.saturating_sub(1))
}

fn sg(signed: bool) -> &'static str {
    if signed {
        "signed "
    } else {
        ""
    }
}

/// `{x, k'b0}`: `x` shifted up by `k` bits (unsigned concatenation).
pub(crate) fn shl(x: &str, k: i32) -> String {
    if k > 0 {
        format!("{{{x}, {k}'b0}}")
    } else {
        x.to_owned()
    }
}

/// A word's value as a signed expression: unsigned words get a zero sign.
fn as_signed(x: &str, w: Word) -> String {
    if w.signed {
        format!("$signed({x})")
    } else {
        format!("$signed({{1'b0, {x}}})")
    }
}

/// Emits the assignment of `src` (shaped `qz.input`) into `qz.out`;
/// returns the name of the `qz.out.bits`-bit result wire.
pub(crate) fn quantize(b: &mut Body, src: &str, qz: &Quantizer) -> Result<String, RtlError> {
    let i = qz.input;
    let s = sg(i.signed);
    let shr = if i.signed { ">>>" } else { ">>" };
    let q = b.fresh("q");
    if qz.drop > 0 {
        let k = qz.drop as u32;
        match qz.quant {
            Quant::Trn => b.line(&format!(
                "wire {s}{} {q} = {src} {shr} {k};",
                range(qz.q.bits)
            )),
            Quant::Rnd => {
                // floor(x / 2^k + 1/2) = ((x >>> (k-1)) + 1) >>> 1, as the
                // model's fast path computes it.
                let t = b.fresh("t");
                let r = b.fresh("r");
                let tb = (i.bits + 1).saturating_sub(k).max(1);
                let one = if i.signed { "2'sd1" } else { "1'b1" };
                b.line(&format!(
                    "wire {s}{} {t} = {src} {shr} {};",
                    range(tb),
                    k - 1
                ));
                b.line(&format!("wire {s}{} {r} = {t} + {one};", range(tb + 1)));
                b.line(&format!("wire {s}{} {q} = {r} {shr} 1;", range(qz.q.bits)));
            }
            other => {
                return Err(RtlError::Unsupported(format!(
                    "quantisation mode {}",
                    other.name()
                )))
            }
        }
    } else if qz.drop < 0 {
        b.line(&format!(
            "wire {s}{} {q} = {};",
            range(qz.q.bits),
            shl(src, -qz.drop)
        ));
    } else {
        b.line(&format!("wire {s}{} {q} = {src};", range(qz.q.bits)));
    }
    let (qb, ob) = (qz.q.bits, qz.out.bits);
    let y = b.fresh("y");
    if !qz.saturate {
        // WRAP, or no overflow possible: keep (or extend) the low bits.
        if qb >= ob {
            b.line(&format!("wire {} {y} = {q}[{}:0];", range(ob), ob - 1));
        } else {
            let fill = if qz.q.signed {
                format!("{q}[{}]", qb - 1)
            } else {
                "1'b0".to_owned()
            };
            b.line(&format!(
                "wire {} {y} = {{{{{}{{{fill}}}}}, {q}}};",
                range(ob),
                ob - qb
            ));
        }
        return Ok(y);
    }
    let neg = if qz.q.signed {
        format!("{q}[{}]", qb - 1)
    } else {
        "1'b0".to_owned()
    };
    // Magnitude bits above what the format holds.
    let top = qz.q.magnitude();
    if !qz.out.signed {
        let ovf = if qz.over {
            format!("~{neg} & (|{q}[{}:{ob}])", top - 1)
        } else {
            "1'b0".to_owned()
        };
        let (lo, hi) = match qz.overflow {
            Overflow::Sat | Overflow::SatSym => (format!("{ob}'d0"), format!("{{{ob}{{1'b1}}}}")),
            Overflow::SatZero => (format!("{ob}'d0"), format!("{ob}'d0")),
            Overflow::Wrap => unreachable!("WRAP never saturates"),
        };
        let under = if qz.under { neg } else { "1'b0".to_owned() };
        b.line(&format!(
            "wire {} {y} = ({under}) ? {lo} : ({ovf}) ? {hi} : {q}[{}:0];",
            range(ob),
            ob - 1
        ));
    } else {
        if qz.overflow == Overflow::SatSym {
            return Err(RtlError::Unsupported("SAT_SYM into a signed format".into()));
        }
        let ovf = if qz.over {
            format!("~{neg} & (|{q}[{}:{}])", top - 1, ob - 1)
        } else {
            "1'b0".to_owned()
        };
        let und = if qz.under {
            format!("{neg} & ~(&{q}[{}:{}])", qb - 2, ob - 1)
        } else {
            "1'b0".to_owned()
        };
        let (lo, hi) = match qz.overflow {
            Overflow::Sat => (
                format!("{{1'b1, {{{}{{1'b0}}}}}}", ob - 1),
                format!("{{1'b0, {{{}{{1'b1}}}}}}", ob - 1),
            ),
            _ => (format!("{ob}'d0"), format!("{ob}'d0")),
        };
        b.line(&format!(
            "wire {} {y} = ({und}) ? {lo} : ({ovf}) ? {hi} : {q}[{}:0];",
            range(ob),
            ob - 1
        ));
    }
    Ok(y)
}

/// Wraps a body into a module with a clock, `inputs` and registered
/// `outputs` (`(name, bits, source wire)`).
pub(crate) fn module(
    name: &str,
    comment: &str,
    inputs: &[(&str, Word)],
    regs: &[(String, u32, String)],
    outputs: &[(String, u32, String)],
    body: &Body,
) -> String {
    let mut v = String::new();
    let _ = writeln!(v, "// {comment}");
    let _ = writeln!(
        v,
        "// Emitted by ercube (pipeline::rtl) to calibrate the cost estimator; not product RTL."
    );
    let mut ports = vec!["  input clk".to_owned()];
    for (n, w) in inputs {
        ports.push(format!("  input {}{} {n}", sg(w.signed), range(w.bits)));
    }
    for (n, bits, _) in outputs {
        ports.push(format!("  output reg {} {n}", range(*bits)));
    }
    let _ = writeln!(v, "module {name} (\n{}\n);", ports.join(",\n"));
    // Pipeline registers are declared before the logic that reads them.
    for (n, bits, _) in regs {
        let _ = writeln!(v, "  reg {} {n};", range(*bits));
    }
    v.push_str(&body.text);
    let _ = writeln!(v, "  always @(posedge clk) begin");
    for (n, _, src) in regs.iter().chain(outputs) {
        let _ = writeln!(v, "    {n} <= {src};");
    }
    let _ = writeln!(v, "  end\nendmodule");
    v
}

/// The ray-position multiplier `m t`: a 16-bit signed ray index times the
/// unsigned `step`, product registered.
pub fn mul_ray(cfg: &PipelineConfig) -> CalibrationModule {
    let t = Word::from(cfg.step);
    let m = Word::signed(RAY_INDEX_BITS, 0);
    // A signed index times an unsigned step fits m + t bits signed.
    let y = m.bits + t.bits;
    let mut b = Body::new();
    b.line(&format!(
        "wire signed {} p = $signed(m) * {};",
        range(y),
        as_signed("t", t)
    ));
    let name = "ercube_mul_ray".to_owned();
    let verilog = module(
        &name,
        &format!("ray index x step: {}s x {}u -> {y}", m.bits, t.bits),
        &[("m", m), ("t", t)],
        &[],
        &[("y".into(), y, "p".into())],
        &b,
    );
    CalibrationModule {
        name,
        description: format!("m x t ({}s x {}u)", m.bits, t.bits),
        verilog,
        units: vec![Unit::Mul(MulShape {
            a: m.bits,
            a_signed: true,
            b: t.bits,
            b_signed: t.signed,
            y,
            post_add: None,
            registered: true,
            operand_reg: 0,
        })],
    }
}

/// The path-length square `sx^2` of a `position`-format slope.
pub fn mul_square(cfg: &PipelineConfig) -> CalibrationModule {
    let x = Word::from(cfg.position);
    let y = 2 * x.bits;
    let mut b = Body::new();
    let sx = as_signed("x", x);
    b.line(&format!("wire signed {} p = {sx} * {sx};", range(y)));
    let name = "ercube_mul_square".to_owned();
    let verilog = module(
        &name,
        &format!("slope square: {0} x {0} -> {y}", x.bits),
        &[("x", x)],
        &[],
        &[("y".into(), y, "p".into())],
        &b,
    );
    CalibrationModule {
        name,
        description: format!("sx^2 ({0} x {0})", x.bits),
        verilog,
        units: vec![Unit::Mul(MulShape {
            a: x.bits,
            a_signed: x.signed,
            b: x.bits,
            b_signed: x.signed,
            y,
            post_add: None,
            registered: true,
            operand_reg: 0,
        })],
    }
}

/// An adder of two `position`-format words, sum registered.
pub fn add_position(cfg: &PipelineConfig) -> CalibrationModule {
    let x = Word::from(cfg.position);
    let y = x.bits + 1;
    let mut b = Body::new();
    b.line(&format!(
        "wire {}{} s = {} + {};",
        sg(x.signed),
        range(y),
        if x.signed { "$signed(a)" } else { "a" },
        if x.signed { "$signed(b)" } else { "b" }
    ));
    let name = "ercube_add_position".to_owned();
    let verilog = module(
        &name,
        &format!("position adder: {0} + {0} -> {y}", x.bits),
        &[("a", x), ("b", x)],
        &[],
        &[("y".into(), y, "s".into())],
        &b,
    );
    CalibrationModule {
        name,
        description: format!("{} + {}", x.bits, x.bits),
        verilog,
        units: vec![Unit::Add { width: x.bits }, Unit::Reg { bits: y }],
    }
}

/// One calibration module cut from the plain sample's description
/// ([`crate::hw::sample`]): the nodes between `ports` and `outputs`, its
/// units those the description prices for them (a declared register
/// feeding a multiplier alone is the block's input register, priced in
/// the multiplier).
fn from_description(
    g: &crate::hw::Graph,
    (name, comment, description): (&str, String, String),
    spec: &crate::hw::unit::Spec,
) -> Result<CalibrationModule, RtlError> {
    let (ports, outputs) = (&spec.ports, &spec.outputs);
    let node = |n: &str| {
        g.find(n)
            .ok_or_else(|| RtlError::Unsupported(format!("no node {n} in the description")))
    };
    let ports: Vec<(&str, crate::hw::NodeId)> = ports
        .iter()
        .map(|(p, n)| Ok((*p, node(n)?)))
        .collect::<Result<_, RtlError>>()?;
    let outs: Vec<(&str, crate::hw::NodeId)> = outputs
        .iter()
        .map(|(p, n)| Ok((*p, node(n)?)))
        .collect::<Result<_, RtlError>>()?;
    let cut = crate::hw::verilog::cut(g, &ports, &outs)?;
    let consumers = g.consumers();
    let port_ids: Vec<_> = ports.iter().map(|p| p.1).collect();
    let out_ids: Vec<_> = outs.iter().map(|o| o.1).collect();
    let cone = g.cone(&out_ids, &port_ids);
    let mut units = Vec::new();
    for &id in cone.iter().filter(|id| !port_ids.contains(id)) {
        units.extend(crate::hw::units::node_units(g, id, &consumers));
        let n = g.node(id);
        let held_by_mul = matches!(n.op, crate::hw::Op::Reg(_))
            && consumers[id.0].len() == 1
            && matches!(g.node(consumers[id.0][0]).op, crate::hw::Op::Mul(..));
        let registered = matches!(n.op, crate::hw::Op::Reg(_))
            || (n.step_out.is_some() && !out_ids.contains(&id));
        if registered && !held_by_mul {
            units.push(Unit::Reg { bits: n.word.bits });
        }
    }
    units.extend(outs.iter().map(|o| Unit::Reg {
        bits: g.word(o.1).bits,
    }));
    Ok(CalibrationModule {
        name: name.to_owned(),
        description,
        verilog: crate::hw::verilog::cut_module(name, &comment, &cut),
        units,
    })
}

/// The plain sample's description composited back to front (the
/// calibration units are the back-to-front ones).
fn btf_description(cfg: &PipelineConfig) -> crate::hw::Graph {
    crate::hw::sample::plain(&PipelineConfig {
        order: crate::config::Order::BackToFront,
        ..*cfg
    })
}

/// Bilinear interpolation, two pipeline stages: the two x lerps of the
/// voxel rows, registered with the y weight, then the y lerp, registered;
/// cut from the plain sample's description.
pub fn bilinear(cfg: &PipelineConfig) -> Result<CalibrationModule, RtlError> {
    let (v, w, sm) = (cfg.voxel.bits(), cfg.weight.bits(), cfg.sample.bits());
    let g = btf_description(cfg);
    from_description(
        &g,
        (
            "ercube_bilinear",
            format!("bilinear: voxels {v}b, weights {w}b -> sample {sm}b (two stages)"),
            format!("3 lerps, {v}b voxels, {w}b weights"),
        ),
        &cut_spec(&g, "bilinear")?,
    )
}

/// Back-to-front compositing of one sample into a ray's accumulators,
/// `C + a (c - C)` per colour and `A + a (1 - A)`, registered; cut from
/// the plain sample's description.
pub fn composite(cfg: &PipelineConfig) -> Result<CalibrationModule, RtlError> {
    let g = btf_description(cfg);
    let (ac, aa, cb, ob) = (
        cfg.accum_color.bits(),
        cfg.accum_alpha.bits(),
        cfg.color.bits(),
        cfg.opacity_corr.bits(),
    );
    from_description(
        &g,
        (
            "ercube_composite",
            format!("compositing: accumulators {ac}b/{aa}b, colour {cb}b, opacity {ob}b"),
            format!("4 multiply-adds, {ob}b opacity"),
        ),
        &cut_spec(&g, "composite")?,
    )
}

/// The port list of the cut `name` ([`crate::hw::unit::spec`]: the
/// verification kit evaluates the same cuts).
fn cut_spec(g: &crate::hw::Graph, name: &str) -> Result<crate::hw::unit::Spec, RtlError> {
    crate::hw::unit::spec(g, name)
        .ok_or_else(|| RtlError::Unsupported(format!("no cut named {name}")))
}

/// The classification table: `table_entries` words of R, G, B and
/// opacity; port A loads (host) or reads, port B reads, both registered.
/// Loads happen between frames, so read-during-write never occurs
/// (`no_rw_check`).
pub fn class_table(cfg: &PipelineConfig) -> CalibrationModule {
    let depth = u64::from(cfg.table_entries);
    let width = table_word(cfg);
    let abits = (64 - (depth.max(2) - 1).leading_zeros()).max(1);
    let name = "ercube_class_table".to_owned();
    let mut v = String::new();
    let _ = writeln!(
        v,
        "// classification table: {depth} x {width} (R, G, B {}b, opacity {}b)",
        cfg.color.bits(),
        cfg.alpha.bits()
    );
    let _ = writeln!(
        v,
        "// Emitted by ercube (pipeline::rtl) to calibrate the cost estimator; not product RTL."
    );
    let _ = writeln!(
        v,
        "module {name} (\n  input clk,\n  input we,\n  input [{a}:0] a0,\n  input [{w}:0] wd,\n  input [{a}:0] a1,\n  output reg [{w}:0] q0,\n  output reg [{w}:0] q1\n);",
        a = abits - 1,
        w = width - 1
    );
    let _ = writeln!(
        v,
        "  (* no_rw_check *) reg [{}:0] mem [0:{}];",
        width - 1,
        depth - 1
    );
    let _ = writeln!(
        v,
        "  always @(posedge clk) begin\n    if (we) mem[a0] <= wd;\n    q0 <= mem[a0];\n  end"
    );
    let _ = writeln!(v, "  always @(posedge clk) q1 <= mem[a1];\nendmodule");
    CalibrationModule {
        name,
        description: format!("{depth} x {width}, RW + R ports"),
        verilog: v,
        units: vec![Unit::Mem {
            depth,
            width,
            ports: MemPorts::DualRead,
        }],
    }
}

/// Every calibration module for `cfg`.
pub fn calibration_modules(cfg: &PipelineConfig) -> Result<Vec<CalibrationModule>, RtlError> {
    Ok(vec![
        mul_ray(cfg),
        mul_square(cfg),
        add_position(cfg),
        bilinear(cfg)?,
        composite(cfg)?,
        class_table(cfg),
    ])
}

/// The shading unit's calibration modules for `cfg`: the square root and
/// the divider (synthesized at two width settings, being slower to map).
pub fn shading_modules(cfg: &PipelineConfig) -> Vec<CalibrationModule> {
    vec![sqrt_norm(cfg), divider(cfg)]
}
