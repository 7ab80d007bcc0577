//! `ercube rtl`: the PE's sample datapath as synthesizable Verilog, from
//! the datapath's description (`pipeline::hw::sample`) and its pipelined
//! schedule (`pipeline::hw::pipeline_rtl`), with a file list and a README
//! naming every port; with `--shading`, `--voi`, `--preint` also those
//! units, each its own pipelined module from its description
//! (`pipeline::hw::shading`, `voi`, `preint`); and the readout stage (the
//! PE's compositing buffer, column map and readout state machine, and the
//! array of P of them with their host ports, `pipeline::hw::readout_rtl`);
//! the PE's sample stage around the datapath (its control, voxel memory,
//! edge register and compositing buffer, `pipeline::hw::pe_sample_rtl`);
//! with `--shading` or `--voi`, the sample's datapath with those units
//! composed into one module, as the model's PE runs them
//! (`pipeline::hw::compose`); front to back, the PE's dense split (its
//! filters and line buffer, `pipeline::hw::split_rtl`) and dense fold (its
//! differences, tents, line buffer and adds, `pipeline::hw::fold_rtl`),
//! back to front its dense merge (its tents and line buffer,
//! `pipeline::hw::merge_rtl`).
//! What is not
//! emitted yet (the other stages' state machines, the array's links, the
//! controller) is refused in one line naming it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Result};
use clap::Args;

use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::fold::Fold;
use pipeline::cosim::merge::Merge;
use pipeline::cosim::split::Split;
use pipeline::cost::inventory::Geometry;
use pipeline::hw::compose::Units;
use pipeline::hw::pe_sample_rtl::{emit as emit_pe_sample, PeSampleShape, MODULE as PE_SAMPLE};
use pipeline::hw::pipeline_rtl::{emit, emit_scheduled, PipelinedModule};
use pipeline::hw::readout_rtl::{
    emit as emit_readout, ReadoutRtl, ReadoutShape, ARRAY_MODULE, PE_MODULE,
};

/// The emitted module's name.
pub const MODULE: &str = "ercube_sample";

/// The composed datapath's module name (the sample with `--shading`,
/// `--voi` spliced in).
pub const COMPOSED: &str = "ercube_sample_composed";

/// The pre-integrated datapath's module name (the sample with `--preint`'s
/// unit in the classification's and the log table's place).
pub const COMPOSED_PREINT: &str = "ercube_sample_preint";

/// A unit's description from the configuration.
type Builder = fn(&PipelineConfig) -> pipeline::hw::Graph;

/// Arguments of `ercube rtl`.
#[derive(Debug, Args)]
pub struct RtlArgs {
    /// Directory the Verilog, `filelist.f` and `README.md` go to (created
    /// if missing).
    #[arg(long)]
    pub out_dir: PathBuf,
    /// Pipeline configuration (TOML; missing keys keep their defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Compositing order (overrides the configuration): btf or ftb.
    #[arg(long, value_parser = ["btf", "ftb"])]
    pub order: Option<String>,
    /// PEs of the readout array (default: the configuration's).
    #[arg(long)]
    pub pes: Option<u16>,
    /// The view-space volume dimensions the PEs' memories are declared
    /// for (the compositing buffer's and column map's depths), as
    /// NX,NY,NZ.
    #[arg(long, default_value = "256,256,256")]
    pub dims: String,
    /// The PE with its control and stage state machines (refused: not
    /// emitted yet).
    #[arg(long)]
    pub pe: bool,
    /// The PE array (refused: not emitted yet).
    #[arg(long)]
    pub array: bool,
    /// The controller (refused: not emitted yet).
    #[arg(long)]
    pub controller: bool,
    /// Also the gradient and shading unit (`ercube_shading.v`, built for
    /// one light).
    #[arg(long)]
    pub shading: bool,
    /// Also the volume-of-interest stage (`ercube_voi.v`).
    #[arg(long)]
    pub voi: bool,
    /// Also the pre-integration unit (`ercube_preint.v`).
    #[arg(long)]
    pub preint: bool,
}

/// Runs `ercube rtl`.
pub fn run(a: &RtlArgs) -> Result<()> {
    let refused = [
        (
            a.pe,
            "the PE's control and stage state machines other than the sample stage, the dense split, the dense merge, the dense fold and the readout are",
        ),
        (a.array, "the PE array with its links is"),
        (a.controller, "the controller is"),
    ];
    if let Some((_, what)) = refused.iter().find(|r| r.0) {
        bail!("rtl: {what} not emitted yet (only the datapath's units, the sample stage, the dense split, the dense merge, the dense fold and the readout stage are)");
    }
    super::outputs::check_dirs(&[Some(a.out_dir.as_path())])?;
    let mut cfg = match &a.config {
        Some(p) => PipelineConfig::from_toml_file(p)?,
        None => PipelineConfig::default(),
    };
    match a.order.as_deref() {
        Some("ftb") => cfg.order = Order::FrontToBack,
        Some(_) => cfg.order = Order::BackToFront,
        None => {}
    }
    if let Some(p) = a.pes {
        cfg.pes = p;
    }
    cfg.validate()?;
    let dims = parse_dims(&a.dims)?;
    let readout = ReadoutShape::new(&cfg, &Geometry::new(dims, cfg.pes))
        .map(|shape| emit_readout(&shape))
        .map_err(|e| format!("rtl: readout not written: {e}"));
    let g = pipeline::hw::sample::plain(&cfg);
    // The schedule the cycle model's latency is read from (one operator a
    // stage, or the configuration's target_mhz).
    let sch = pipeline::cost::latency::sample_schedule(&cfg);
    let m = emit_scheduled(&g, &sch, MODULE).map_err(|e| anyhow!("rtl: {e}"))?;
    let mut units = Vec::new();
    let builders: [(bool, &str, Builder); 3] = [
        (a.shading, "shading", |c| {
            pipeline::hw::shading::shading(c, 1)
        }),
        (a.voi, "voi", pipeline::hw::voi::voi),
        (a.preint, "preint", pipeline::hw::preint::preint),
    ];
    for (on, name, g) in builders {
        if on {
            let module = format!("ercube_{name}");
            let u = emit(&g(&cfg), &module).map_err(|e| anyhow!("rtl: {name}: {e}"))?;
            units.push(u);
        }
    }
    if a.shading || a.voi {
        let with = Units {
            lights: a.shading.then_some(1),
            voi: a.voi,
            ..Units::default()
        };
        let g = pipeline::hw::compose::sample(&cfg, with);
        let sch = pipeline::cost::latency::graph_schedule(&cfg, &g);
        let u = emit_scheduled(&g, &sch, COMPOSED).map_err(|e| anyhow!("rtl: {COMPOSED}: {e}"))?;
        units.push(u);
    }
    if a.preint {
        let with = Units {
            preint: true,
            ..Units::default()
        };
        let g = pipeline::hw::compose::sample(&cfg, with);
        let sch = pipeline::cost::latency::graph_schedule(&cfg, &g);
        let u = emit_scheduled(&g, &sch, COMPOSED_PREINT)
            .map_err(|e| anyhow!("rtl: {COMPOSED_PREINT}: {e}"))?;
        units.push(u);
    }
    // The sample stage around the plain datapath, at the depths the PE
    // declares for `--dims`.
    let pe_sample = PeSampleShape::new(&cfg, &Geometry::new(dims, cfg.pes))
        .and_then(|shape| emit_pe_sample(&shape, &m).map(|r| (shape, r)))
        .map_err(|e| format!("rtl: {PE_SAMPLE} not written: {e}"));
    // The boundary passes of the order: (module, Verilog, summary, README
    // section), or why not written.
    let passes = [
        super::rtl_pass::written::<Split>(&cfg, dims),
        super::rtl_pass::written::<Merge>(&cfg, dims),
        super::rtl_pass::written::<Fold>(&cfg, dims),
    ];
    super::outputs::all_or_nothing(&[&a.out_dir], || {
        std::fs::create_dir_all(&a.out_dir)
            .map_err(|e| anyhow!("cannot create {}: {e}", a.out_dir.display()))?;
        let mut list = String::new();
        for u in std::iter::once(&m).chain(&units) {
            let v = format!("{}.v", u.name);
            write(&a.out_dir.join(&v), &u.verilog)?;
            list.push_str(&v);
            list.push('\n');
        }
        if let Ok((_, r)) = &pe_sample {
            let v = format!("{PE_SAMPLE}.v");
            write(&a.out_dir.join(&v), &r.verilog)?;
            list.push_str(&v);
            list.push('\n');
        }
        if let Ok(r) = &readout {
            for (name, text) in [(PE_MODULE, &r.pe), (ARRAY_MODULE, &r.array)] {
                let v = format!("{name}.v");
                write(&a.out_dir.join(&v), text)?;
                list.push_str(&v);
                list.push('\n');
            }
        }
        for (module, v, _, _) in passes.iter().flatten() {
            let name = format!("{module}.v");
            write(&a.out_dir.join(&name), v)?;
            list.push_str(&name);
            list.push('\n');
        }
        write(&a.out_dir.join("filelist.f"), &list)?;
        let mut text = readme(&cfg, &m);
        for u in &units {
            text.push_str(&unit_section(u));
        }
        if let Ok((shape, r)) = &pe_sample {
            text.push_str(&super::rtl_pe::section(shape, r, dims));
        }
        if let Ok(r) = &readout {
            text.push_str(&readout_section(r, dims));
        }
        for (_, _, _, section) in passes.iter().flatten() {
            text.push_str(section);
        }
        write(&a.out_dir.join("README.md"), &text)?;
        Ok(())
    })?;
    for u in std::iter::once(&m).chain(&units) {
        super::say(&format!(
            "{}: {}.v ({} lines), {} clocks from issue to the outputs, {} register bits ({} in the schedule's pipeline), {} table bits",
            a.out_dir.display(),
            u.name,
            u.verilog.lines().count(),
            u.depth,
            u.register_bits,
            u.schedule_register_bits,
            u.memory_bits
        ));
    }
    match &pe_sample {
        Ok((shape, r)) => super::say(&format!(
            "{}: {PE_SAMPLE}.v ({} lines), {} memory bits and {} control register bits a PE",
            a.out_dir.display(),
            r.verilog.lines().count(),
            shape.memory_bits(),
            r.register_bits
        )),
        Err(e) => super::say(e),
    }
    match &readout {
        Ok(r) => super::say(&format!(
            "{}: {PE_MODULE}.v ({} lines), {ARRAY_MODULE}.v ({} lines, {} PEs), {} memory bits and {} register bits a PE",
            a.out_dir.display(),
            r.pe.lines().count(),
            r.array.lines().count(),
            r.shape.pes,
            r.shape.memory_bits(),
            r.shape.register_bits()
        )),
        Err(e) => super::say(e),
    }
    for p in &passes {
        match p {
            Ok((_, _, said, _)) => super::say(&format!("{}: {said}", a.out_dir.display())),
            Err(e) => super::say(e),
        }
    }
    super::say(&format!("{}: filelist.f, README.md", a.out_dir.display()));
    Ok(())
}

/// Writes `text` to `path` atomically (staged with the run's other files).
fn write(path: &Path, text: &str) -> Result<()> {
    golden::image::write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// The README: what the module is, every port, the tables, how to build.
fn readme(cfg: &PipelineConfig, m: &PipelinedModule) -> String {
    let mut s = String::new();
    let w = &mut s;
    let order = match cfg.order {
        Order::BackToFront => "back to front",
        Order::FrontToBack => "front to back",
    };
    let staging = if cfg.target_mhz > 0 {
        format!(
            "stages packed for {} MHz on {} by the delay model of `pipeline::cost::fmax`",
            cfg.target_mhz,
            cfg.target_family.name()
        )
    } else {
        "at most one multiplier or one carry chain per stage".to_owned()
    };
    let _ = writeln!(w, "# {MODULE}: the PE's sample datapath\n");
    let _ = writeln!(
        w,
        "Emitted by `ercube rtl` from the datapath's description (`pipeline::hw::sample::plain`) \
         and its pipelined schedule ({staging}), \
         compositing {order}. One sample issues per clock (`in_valid`); its outputs appear \
         **{} clocks** later with `out_valid`. Every register resets synchronously to zero; \
         the outputs load only from a valid sample.\n",
        m.depth
    );
    let _ = writeln!(
        w,
        "Declared: {} register bits ({} of them the schedule's pipeline registers and delay \
         lines of datapath values; the rest carry the sample's ports down the pipeline, the \
         valid bits, the table reads and the outputs), {} table bits. Files: `{MODULE}.v`, \
         `filelist.f`.\n",
        m.register_bits, m.schedule_register_bits, m.memory_bits
    );
    let _ = writeln!(w, "## Ports\n");
    ports_table(w, m);
    let _ = writeln!(
        w,
        "\nThe voxel taps are read outside the module like a block RAM: `x0` leaves at its \
         clock (zero for a bubble) and `v00`..`v11` of that sample are taken one clock later.\n"
    );
    let _ = writeln!(w, "## Tables (host write port)\n");
    let _ = writeln!(
        w,
        "Written one word per clock with `tbl_we`, `tbl_sel`, `tbl_addr` and the low bits of \
         `tbl_data`; read synchronously (one clock) by the datapath.\n"
    );
    let _ = writeln!(w, "| tbl_sel | table | words | bits |\n|---|---|---|---|");
    for t in &m.tables {
        let _ = writeln!(w, "| {} | `{}` | {} | {} |", t.sel, t.name, t.depth, t.bits);
    }
    let _ = writeln!(w, "\n## Not emitted yet\n");
    let _ = writeln!(
        w,
        "The PE's control and stage state machines other than the sample stage, the readout and \
         the dense split's filters, the dense merge's tents and the dense fold's differences, \
         tents and adds with their line buffers (migrate, the sparse split's, merge's and fold's \
         work lists, the parents' fetch), its FIFOs, the array's links and \
         the controller: `ercube rtl` refuses them by name. The shading unit, the volume-of-interest stage and the \
         pre-integration unit are written with `--shading`, `--voi`, `--preint`, and with \
         `--shading` or `--voi` the datapath with them composed (`{COMPOSED}`), with `--preint` \
         the datapath with the pre-integration unit (`{COMPOSED_PREINT}`).\n"
    );
    let _ = writeln!(w, "## Checking it\n");
    let _ = writeln!(
        w,
        "```\nverilator --lint-only -Wall --top-module TOP -f filelist.f\n\
         iverilog -g2005 -o /dev/null -c filelist.f\n\
         yosys -p 'read_verilog {MODULE}.v; synth -top {MODULE}'\n```\n\n\
         The file list holds several top-level modules (the PE's sample stage or the datapath \
         alone, the readout array, each unit written on its own), so Verilator lints one \
         `TOP` at a time (without `--top-module` it warns `MULTITOP`).\n"
    );
    let _ = writeln!(
        w,
        "`cargo test --release -p pipeline --test it -- rtl::` streams random samples through \
         it in Verilator and Icarus and compares every output word with the description's \
         evaluator (docs/rtl.md)."
    );
    s
}

/// The ports of `m` as a table.
fn ports_table(w: &mut String, m: &PipelinedModule) {
    let _ = writeln!(
        w,
        "| port | dir | width | format | clocks after issue | meaning |\n|---|---|---|---|---|---|"
    );
    for p in &m.ports {
        let _ = writeln!(
            w,
            "| `{}` | {} | {}{} | {} | {} | {} |",
            p.name,
            if p.input { "in" } else { "out" },
            if p.word.signed { "s" } else { "u" },
            p.word.bits,
            p.format
                .clone()
                .unwrap_or_else(|| format!("{} fraction bits", p.word.frac)),
            p.stage,
            p.meaning
        );
    }
}

/// A unit module's section of the README: depth, registers, ports and
/// tables.
fn unit_section(m: &PipelinedModule) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "\n## {}\n", m.name);
    let from = if m.name == COMPOSED {
        "the sample's description with the units given (`--shading`, built for one \
         light; `--voi`) spliced in as the model's PE runs them \
         (`pipeline::hw::compose`; `ercube cosim` checks it on frames with `--shade`, `--voi`)"
            .to_owned()
    } else if m.name == COMPOSED_PREINT {
        "the sample's description with the pre-integration unit in the classification's and \
         the log table's place (`pipeline::hw::compose`; `ercube cosim --preintegrate` checks \
         it, back to front with a second copy a PE for slice 0's second step)"
            .to_owned()
    } else {
        format!(
            "its description (`pipeline::hw::{}`; its rustdoc names every port; `cargo test \
             --release -p pipeline --test it -- rtl_units::` checks it in Verilator and Icarus \
             against the evaluator)",
            m.name.trim_start_matches("ercube_")
        )
    };
    let _ = writeln!(
        w,
        "From {from}, on the same schedule rules: **{} clocks** from `in_valid` to \
         `out_valid`; {} register bits ({} the schedule's), {} table bits.\n",
        m.depth, m.register_bits, m.schedule_register_bits, m.memory_bits
    );
    ports_table(w, m);
    if !m.tables.is_empty() {
        let _ = writeln!(w, "\n| tbl_sel | table | words | bits |\n|---|---|---|---|");
        for t in &m.tables {
            let _ = writeln!(w, "| {} | `{}` | {} | {} |", t.sel, t.name, t.depth, t.bits);
        }
    }
    s
}

/// `NX,NY,NZ`, each at least 1, refused in one line otherwise.
pub(crate) fn parse_dims(s: &str) -> Result<[usize; 3]> {
    let v: Vec<usize> = s
        .split(',')
        .map(|w| {
            w.trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| (1..=65536).contains(&n))
        })
        .collect::<Option<_>>()
        .ok_or_else(|| anyhow!("--dims '{s}': give NX,NY,NZ, each 1..=65536"))?;
    match v.as_slice() {
        &[x, y, z] => Ok([x, y, z]),
        _ => bail!("--dims '{s}': give three sizes NX,NY,NZ"),
    }
}

fn readout_section(r: &ReadoutRtl, dims: [usize; 3]) -> String {
    let s = &r.shape;
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(w, "\n## {PE_MODULE}, {ARRAY_MODULE}: the readout stage\n");
    let _ = writeln!(
        w,
        "From `pipeline::hw::readout_rtl`, for a view-space volume of {}x{}x{} (`--dims`): each \
         PE's compositing buffer (2 banks x {} words x {} bits) and column map ({} words x {} \
         bits) as the PE declares them (`ercube cost` charges the same entries), the readout's \
         cursor as a state machine, and the array of {} PEs with their host ports. {} memory \
         bits and {} register bits a PE. `begin_readout` is the controller's broadcast; each \
         clock a PE reads one ray and drives the ray it read the clock before on its host port{}; \
         `done` is its report line. The host loads the buffers through `ld_we`, `ld_pe`, \
         `ld_sel` (0 buffer word, 1 column map slot, 2 the counts `{{ncols, rows}}`), `ld_addr`, \
         `ld_data`; each module's header names every port.\n",
        dims[0],
        dims[1],
        dims[2],
        s.bank_depth,
        s.buffer_width,
        s.map_depth,
        s.map_width,
        s.pes,
        s.memory_bits(),
        s.register_bits(),
        if s.sparse {
            " (an all-zero ray left off: `pass_skip_empty`)"
        } else {
            ""
        }
    );
    let _ = writeln!(
        w,
        "| port | module | dir | width | meaning |\n|---|---|---|---|---|"
    );
    let (p, rb) = (s.pes as u32, s.row_bits());
    let ports: [(&str, &str, &str, String, &str); 15] = [
        ("clk", "both", "in", "1".into(), "clock"),
        (
            "rst",
            "both",
            "in",
            "1".into(),
            "synchronous reset of every register",
        ),
        (
            "ld_we",
            "both",
            "in",
            "1".into(),
            "host load: write this clock",
        ),
        (
            "ld_pe",
            ARRAY_MODULE,
            "in",
            s.pe_bits().to_string(),
            "host load: the PE written",
        ),
        (
            "ld_sel",
            "both",
            "in",
            "2".into(),
            "host load: 0 buffer, 1 column map, 2 counts, 3 valid word",
        ),
        (
            "ld_addr",
            "both",
            "in",
            s.ld_addr_bits().to_string(),
            "host load: address (buffer: row * slots + column)",
        ),
        (
            "ld_data",
            "both",
            "in",
            s.ld_data_bits().to_string(),
            "host load: word (low bits)",
        ),
        (
            "begin_readout",
            "both",
            "in",
            "1".into(),
            "the controller's BeginReadout broadcast",
        ),
        (
            "host_valid",
            "both",
            "out",
            format!("1 a PE ({p} in the array)"),
            "a ray on the host port",
        ),
        (
            "host_mx",
            "both",
            "out",
            "16 a PE".to_string(),
            "its ray index (two's complement)",
        ),
        (
            "host_row",
            "both",
            "out",
            format!("{rb} a PE"),
            "its row in region 0",
        ),
        (
            "host_r",
            "both",
            "out",
            format!("{} a PE (also host_g, host_b)", s.color_bits),
            "its colour accumulators",
        ),
        (
            "host_a",
            "both",
            "out",
            format!("{} a PE", s.alpha_bits),
            "its opacity accumulator",
        ),
        (
            "done",
            "both",
            "out",
            "1 a PE".into(),
            "the PE's readout_done report line",
        ),
        (
            "all_done",
            ARRAY_MODULE,
            "out",
            "1".into(),
            "every PE's done",
        ),
    ];
    for (name, module, dir, width, meaning) in ports {
        let _ = writeln!(w, "| `{name}` | {module} | {dir} | {width} | {meaning} |");
    }
    for extra in ["host_g", "host_b"] {
        let _ = writeln!(
            w,
            "| `{extra}` | both | out | {} a PE | its colour accumulators |",
            s.color_bits
        );
    }
    t
}
