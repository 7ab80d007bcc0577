//! The full cost report: per-PE and array resources, fit on real parts,
//! throughput from runs and from the bound, and scaling with `P` and `N`,
//! as JSON (serde) and as a readable table.

use std::fmt::Write as _;

use super::design::{self, Design};
use super::inventory::{controller_inventory, pe_inventory, Geometry, Item, PeInventory};
use super::parts::{fit_memories, parts, Fit, Part};
use super::target::{Resources, Target};
use super::throughput::{bound_cycles, rate, Rate, RunSummary};
use crate::config::{PipelineConfig, MAX_PES};
use serde::Serialize;

/// Volume edges of the scaling table.
pub const SCALE_N: [usize; 4] = [128, 256, 512, 1024];
/// PE counts of the scaling table.
pub const SCALE_P: [u16; 6] = [8, 16, 32, 64, 128, 256];

/// One inventory line with its cost.
#[derive(Debug, Clone, Serialize)]
pub struct ItemRow {
    /// Stage or block.
    pub group: &'static str,
    /// What it is.
    pub name: String,
    /// Copies.
    pub count: u32,
    /// Main unit's widths.
    pub shape: String,
    /// All copies' resources.
    pub resources: Resources,
}

fn rows(items: &[Item], t: Target) -> Vec<ItemRow> {
    items
        .iter()
        .map(|i| ItemRow {
            group: i.group,
            name: i.name.clone(),
            count: i.count,
            shape: i.shape(),
            resources: i.cost(t),
        })
        .collect()
}

/// The largest PE count that fits a part.
#[derive(Debug, Clone, Serialize)]
pub struct MaxPes {
    /// Part.
    pub part: &'static str,
    /// Largest `P` whose array fits (0: not even one PE).
    pub pes: u16,
    /// What runs out first at `P + 1` (or at `P = 1`).
    pub limit: &'static str,
}

/// One run of the `P` sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepRow {
    /// PEs.
    pub pes: u16,
    /// Measured cycles per frame.
    pub cycles: u64,
    /// Measured utilisation.
    pub utilization: f64,
    /// Rate at the clock.
    pub rate: Rate,
    /// Array resources.
    pub resources: Resources,
    /// Parts it fits.
    pub fits: Vec<&'static str>,
}

/// One cell of the scaling table (cubic volumes, worst-case bound).
#[derive(Debug, Clone, Serialize)]
pub struct ScaleRow {
    /// Volume edge.
    pub n: usize,
    /// PEs.
    pub pes: u16,
    /// Worst-case sampling cycles ([`bound_cycles`]) and rate.
    pub bound: Rate,
    /// The bound scaled by the measured run's ratio of cycles to its own
    /// bound: a typical view like the measured one.
    pub scaled: Rate,
    /// Array resources.
    pub resources: Resources,
    /// Parts it fits.
    pub fits: Vec<&'static str>,
}

/// The report.
#[derive(Debug, Clone, Serialize)]
pub struct CostReport {
    /// Family.
    pub target: Target,
    /// Its primitives.
    pub target_description: &'static str,
    /// The clock the rates are quoted at (MHz).
    pub clock_mhz: f64,
    /// Where it comes from: assumed, until the PE's Verilog is placed and
    /// routed.
    pub clock_source: super::clock::ClockSource,
    /// The configuration.
    pub config: PipelineConfig,
    /// Volume and PEs of the main run.
    pub geometry: Geometry,
    /// One PE's units.
    pub pe_items: Vec<ItemRow>,
    /// One PE.
    pub pe: Resources,
    /// Sample pipeline depth in clocks.
    pub pipeline_depth: u32,
    /// External voxel memory per PE (bits).
    pub voxel_memory_bits_per_pe: u64,
    /// The controller's units.
    pub controller_items: Vec<ItemRow>,
    /// The controller.
    pub controller: Resources,
    /// `P` PEs plus the controller.
    pub array: Resources,
    /// The array on each part of the family.
    pub fits: Vec<Fit>,
    /// The most PEs each part holds, for this volume.
    pub max_pes: Vec<MaxPes>,
    /// The measured run.
    pub run: RunSummary,
    /// Its rate at the clock.
    pub run_rate: Rate,
    /// The worst-case bound's rate.
    pub bound_rate: Rate,
    /// Slice-buffer reads per PE per cycle in the run.
    pub buffer_reads_per_pe_cycle: f64,
    /// Runs at other `P`.
    pub sweep: Vec<SweepRow>,
    /// Cubic volumes and `P` by the bound.
    pub scaling: Vec<ScaleRow>,
    /// The mappings and placements at the main run's `P`, each from its
    /// own run.
    pub architectures: Vec<Design>,
    /// What the figures mean.
    pub notes: Vec<String>,
}

/// Array resources for `geo`.
pub fn array_cost(cfg: &PipelineConfig, geo: &Geometry, t: Target) -> Resources {
    design::array(cfg, geo, t).0
}

/// The parts of `parts` that `cfg` on `geo` fits (UltraRAM taking memories
/// block RAM cannot hold).
fn fitting(cfg: &PipelineConfig, geo: &Geometry, parts: &[Part]) -> Vec<&'static str> {
    let Some(first) = parts.first() else {
        return Vec::new();
    };
    let (r, _, mems) = design::array(cfg, geo, first.target);
    parts
        .iter()
        .filter(|p| fit_memories(p, &r, &mems).fits)
        .map(|p| p.name)
        .collect()
}

/// The most PEs of `cfg` (with the shading unit, the volume-of-interest
/// stage and the pre-integration unit as `geo` has them) that fit `part`
/// for a volume of `geo.dims`.
pub fn max_pes(cfg: &PipelineConfig, geo: &Geometry, part: &Part) -> MaxPes {
    let dims = geo.dims;
    let top = (MAX_PES as usize).min(dims[0].max(1)) as u16;
    let fit_at = |p: u16| {
        let g = Geometry::new(dims, p)
            .with_shading(geo.shading)
            .with_voi(geo.voi)
            .with_preint(geo.preint);
        let (r, _, mems) = design::array(cfg, &g, part.target);
        fit_memories(part, &r, &mems)
    };
    let best = (1..=top).filter(|&p| fit_at(p).fits).max().unwrap_or(0);
    let limit = if best == top {
        "nothing up to one PE per column"
    } else {
        fit_at(best + 1).limit
    };
    MaxPes {
        part: part.name,
        pes: best,
        limit,
    }
}

/// Builds the report for `cfg` on `target` at `clock_mhz`, from the main
/// run (at `cfg.pes`) and the sweep's runs.
pub fn build(
    cfg: &PipelineConfig,
    target: Target,
    clock_mhz: f64,
    run: RunSummary,
    sweep: &[RunSummary],
    archs: &[(PipelineConfig, RunSummary)],
) -> CostReport {
    let clock = clock_mhz * 1e6;
    let geo = run.geometry;
    let vb = u32::from(cfg.voxel.bits());
    let pe: PeInventory = pe_inventory(cfg, &geo);
    let pe_res = pe.cost(target);
    let ctrl_items = controller_inventory(cfg, &geo);
    let ctrl: Resources = ctrl_items.iter().map(|i| i.cost(target)).sum();
    let array = pe_res * u64::from(geo.pes) + ctrl;
    let family = parts(target);
    let (_, _, mems) = design::array(cfg, &geo, target);
    let fits = family
        .iter()
        .map(|p| fit_memories(p, &array, &mems))
        .collect();
    let max = family.iter().map(|p| max_pes(cfg, &geo, p)).collect();
    let run_rate = rate(&geo, run.cycles, clock, vb);
    let bound = bound_cycles(&geo);
    let bound_rate = rate(&geo, bound, clock, vb);
    let ratio = if bound == 0 {
        1.0
    } else {
        run.cycles as f64 / bound as f64
    };
    let sweep_rows = sweep
        .iter()
        .map(|s| {
            let r = array_cost(cfg, &s.geometry, target);
            SweepRow {
                pes: s.geometry.pes,
                cycles: s.cycles,
                utilization: s.utilization,
                rate: rate(&s.geometry, s.cycles, clock, vb),
                resources: r,
                fits: fitting(cfg, &s.geometry, &family),
            }
        })
        .collect();
    let mut scaling = Vec::new();
    for n in SCALE_N {
        for p in SCALE_P {
            let g = Geometry::new([n, n, n], p)
                .with_shading(geo.shading)
                .with_voi(geo.voi)
                .with_preint(geo.preint);
            let b = bound_cycles(&g);
            let r = array_cost(cfg, &g, target);
            scaling.push(ScaleRow {
                n,
                pes: p,
                bound: rate(&g, b, clock, vb),
                scaled: rate(&g, (b as f64 * ratio).round() as u64, clock, vb),
                resources: r,
                fits: fitting(cfg, &g, &family),
            });
        }
    }
    let pes = u64::from(geo.pes.max(1));
    let notes = vec![
        format!(
            "Clock {clock_mhz} MHz is an assumption; no timing analysis is done. The datapath is pipelined one unit per clock ({} clocks deep).",
            pe.schedule.depth
        ),
        format!(
            "Voxel memory is external: each PE's {} of the volume is {:.2} Mbit ({:.1} Mbit for the array), read once per frame into double-buffered slice buffers.",
            if super::arch::round_robin_width(cfg).is_some() { "share (its blocks with their aprons)" } else { "block" },
            pe.voxel_memory_bits as f64 / 1e6,
            pe.voxel_memory_bits as f64 * pes as f64 / 1e6
        ),
        format!(
            "Resources are sized for the worst view (compositing buffer (2W+1)(2ny+1) rays per PE); {} units are counted in {}.",
            target.bram_name(),
            if target == Target::Xc7 { "RAMB18 halves of a RAMB36" } else { "blocks" }
        ),
        "Worst-case cycles count sampling only (every slice at (2W+1)(2ny+1) rays per PE); migration, merges and readout add a few percent in measured runs. 'Scaled' rows multiply the bound by this run's ratio of measured to bound cycles.".to_owned(),
        "Resource models are calibrated against yosys 0.23 (synth_xilinx, synth_ice40 -dsp) on the PE's units at three width settings (pipeline/tests/it/cost.rs); vendor tools differ in packing, and place-and-route needs headroom (plan for 70-80% LUT use).".to_owned(),
    ];
    CostReport {
        target,
        target_description: target.describe(),
        clock_mhz,
        clock_source: super::clock::ClockSource::Assumed,
        config: *cfg,
        geometry: geo,
        pe_items: rows(&pe.items, target),
        pe: pe_res,
        pipeline_depth: pe.schedule.depth,
        voxel_memory_bits_per_pe: pe.voxel_memory_bits,
        controller_items: rows(&ctrl_items, target),
        controller: ctrl,
        array,
        fits,
        max_pes: max,
        buffer_reads_per_pe_cycle: if run.cycles == 0 {
            0.0
        } else {
            run.buffer_reads as f64 / (run.cycles as f64 * pes as f64)
        },
        run,
        run_rate,
        bound_rate,
        sweep: sweep_rows,
        scaling,
        architectures: archs
            .iter()
            .map(|(c, r)| design::design(c, target, r))
            .collect(),
        notes,
    }
}

/// `1234567` as `1.23 M`.
pub(super) fn si(x: f64) -> String {
    let a = x.abs();
    if a >= 1e9 {
        format!("{:.2} G", x / 1e9)
    } else if a >= 1e6 {
        format!("{:.2} M", x / 1e6)
    } else if a >= 1e3 {
        format!("{:.1} k", x / 1e3)
    } else {
        format!("{x:.1} ")
    }
}

fn res_cells(t: Target, r: &Resources) -> [String; 4] {
    let lut = if t == Target::Ice40 {
        format!("{} ({} LC)", r.lut, r.logic_cells())
    } else {
        r.lut.to_string()
    };
    [r.dsp.to_string(), lut, r.ff.to_string(), r.bram.to_string()]
}

/// Renders rows as a text table with aligned columns.
pub(super) fn table(out: &mut String, head: &[&str], rows: &[Vec<String>]) {
    let n = head.len();
    let mut width: Vec<usize> = head.iter().map(|h| h.len()).collect();
    for r in rows {
        for (k, c) in r.iter().enumerate().take(n) {
            width[k] = width[k].max(c.len());
        }
    }
    let line = |cells: Vec<&str>| -> String {
        cells
            .iter()
            .enumerate()
            .map(|(k, c)| {
                if k < 2 {
                    format!("{c:<w$}", w = width[k])
                } else {
                    format!("{c:>w$}", w = width[k])
                }
            })
            .collect::<Vec<_>>()
            .join("  ")
            .trim_end()
            .to_owned()
    };
    let _ = writeln!(out, "{}", line(head.to_vec()));
    let _ = writeln!(
        out,
        "{}",
        width
            .iter()
            .map(|w| "-".repeat(*w))
            .collect::<Vec<_>>()
            .join("  ")
    );
    for r in rows {
        let _ = writeln!(out, "{}", line(r.iter().map(String::as_str).collect()));
    }
}

impl CostReport {
    /// The readable report.
    pub fn text(&self) -> String {
        let t = self.target;
        let mut o = String::new();
        let g = &self.geometry;
        let _ = writeln!(
            o,
            "ercube cost: {} at {} MHz ({} clock)\n  {}",
            t.name(),
            self.clock_mhz,
            self.clock_source.name(),
            t.describe()
        );
        let c = &self.config;
        let _ = writeln!(
            o,
            "  widths: voxel {}, position {}, weight {}, sample {}, colour {}, alpha {}, table {} entries, opacity {}, accumulators {}/{}",
            c.voxel.bits(),
            c.position.bits(),
            c.weight.bits(),
            c.sample.bits(),
            c.color.bits(),
            c.alpha.bits(),
            c.table_entries,
            c.opacity_corr.bits(),
            c.accum_color.bits(),
            c.accum_alpha.bits()
        );
        if g.preint {
            let n = super::preint::bins(c) + 1;
            let _ = writeln!(
                o,
                "  pre-integration: {n} x {n} table of {} bits ({:.2} Mbit per PE), tau {}, colour {}, in place of the classification and -log2(1 - a) tables",
                super::preint::table_word(c),
                super::preint::table_bits(c) as f64 / 1e6,
                c.preint_tau.bits(),
                c.preint_color.bits()
            );
        }
        let _ = writeln!(
            o,
            "  array: P = {} PEs, volume {}x{}x{} (view space), W = {} columns per PE; run: {}\n",
            g.pes,
            g.dims[0],
            g.dims[1],
            g.dims[2],
            g.block(),
            self.run.label
        );
        let head = [
            "unit",
            "shape",
            "n",
            t.dsp_name(),
            t.lut_name(),
            "FF",
            t.bram_name(),
        ];
        let mut rows_txt = Vec::new();
        for r in &self.pe_items {
            let [d, l, f, b] = res_cells(t, &r.resources);
            rows_txt.push(vec![
                format!("{}: {}", r.group, r.name),
                r.shape.clone(),
                r.count.to_string(),
                d,
                l,
                f,
                b,
            ]);
        }
        let [d, l, f, b] = res_cells(t, &self.pe);
        rows_txt.push(vec![
            "PE total".into(),
            format!("pipeline {} clocks", self.pipeline_depth),
            String::new(),
            d,
            l,
            f,
            b,
        ]);
        let [d, l, f, b] = res_cells(t, &self.controller);
        rows_txt.push(vec![
            "controller (once)".into(),
            String::new(),
            String::new(),
            d,
            l,
            f,
            b,
        ]);
        let [d, l, f, b] = res_cells(t, &self.array);
        rows_txt.push(vec![
            format!("array ({} PEs + controller)", g.pes),
            String::new(),
            String::new(),
            d,
            l,
            f,
            b,
        ]);
        let _ = writeln!(o, "Per PE and array");
        table(&mut o, &head, &rows_txt);
        let _ = writeln!(
            o,
            "  LUT-RAM/SRL LUTs per PE: {}; carry cells per PE: {}; external voxel memory per PE: {:.2} Mbit",
            self.pe.lutram,
            self.pe.carry,
            self.voxel_memory_bits_per_pe as f64 / 1e6
        );
        let [rc, rr] = self.run.largest_region;
        let _ = writeln!(
            o,
            "  rays: buffers hold (2W+1)(2ny+1) = {} per PE ({} in all); this view's largest region has {rc} x {rr} = {} rays",
            g.rays_per_pe(),
            g.rays_per_pe() * u64::from(g.pes),
            rc * rr
        );

        let _ = writeln!(o, "\nFit ({} PEs)", g.pes);
        let mut fr = Vec::new();
        for (f, m) in self.fits.iter().zip(&self.max_pes) {
            let used = f
                .used
                .iter()
                .map(|(k, v)| format!("{k} {:.0}%", v * 100.0))
                .collect::<Vec<_>>()
                .join(", ");
            fr.push(vec![
                f.part.to_owned(),
                used,
                if f.fits { "yes" } else { "no" }.to_owned(),
                m.pes.to_string(),
                m.limit.to_owned(),
            ]);
        }
        table(&mut o, &["part", "use", "fits", "max P", "limited by"], &fr);

        let r = &self.run;
        let _ = writeln!(
            o,
            "\nThroughput at {} MHz ({} clock)",
            self.clock_mhz,
            self.clock_source.name()
        );
        let _ = writeln!(
            o,
            "  frame: {}",
            super::clock::rate_line(r.cycles, self.clock_mhz, self.clock_source)
        );
        let _ = writeln!(
            o,
            "  run: {} cycles/frame (sample {}, migrate {}, merge {}, readout {}, drain {}, stall {}), utilization {:.3}, {:.1} frames/s",
            r.cycles,
            r.stages.sample,
            r.stages.migrate,
            r.stages.merge,
            r.stages.readout,
            r.stages.drain,
            r.stages.stall,
            r.utilization,
            self.run_rate.fps
        );
        let _ = writeln!(
            o,
            "  worst case (sampling bound N (2W+1)(2N+1)): {} cycles/frame, {:.1} frames/s",
            self.bound_rate.cycles, self.bound_rate.fps
        );
        let _ = writeln!(
            o,
            "  voxel bandwidth: {}B/s at the run's rate ({}B/s per PE), {}B/s at the bound's; slice-buffer reads {:.2} per PE per cycle",
            si(self.run_rate.bandwidth),
            si(self.run_rate.bandwidth_per_pe),
            si(self.bound_rate.bandwidth),
            self.buffer_reads_per_pe_cycle
        );

        if !self.sweep.is_empty() {
            let _ = writeln!(o, "\nP sweep (measured runs, {})", self.run.label);
            let mut sr = Vec::new();
            for s in &self.sweep {
                let [d, l, f, b] = res_cells(t, &s.resources);
                sr.push(vec![
                    s.pes.to_string(),
                    s.cycles.to_string(),
                    format!("{:.3}", s.utilization),
                    format!("{:.1}", s.rate.fps),
                    format!("{}B/s", si(s.rate.bandwidth)),
                    d,
                    l,
                    f,
                    b,
                    if s.fits.is_empty() {
                        "-".to_owned()
                    } else {
                        s.fits.join(" ")
                    },
                ]);
            }
            table(
                &mut o,
                &[
                    "P",
                    "cycles",
                    "util",
                    "fps",
                    "bandwidth",
                    t.dsp_name(),
                    t.lut_name(),
                    "FF",
                    t.bram_name(),
                    "fits",
                ],
                &sr,
            );
        }

        let _ = writeln!(
            o,
            "\nScaling (cubic N^3, worst-case bound; 'scaled' = bound x {:.2}, this run's measured/bound)",
            if self.bound_rate.cycles == 0 {
                0.0
            } else {
                self.run.cycles as f64 / self.bound_rate.cycles as f64
            }
        );
        let mut sc = Vec::new();
        for s in &self.scaling {
            sc.push(vec![
                s.n.to_string(),
                s.pes.to_string(),
                format!("{:.1}", s.bound.fps),
                format!("{:.1}", s.scaled.fps),
                format!("{}B/s", si(s.bound.bandwidth)),
                s.resources.dsp.to_string(),
                s.resources.lut.to_string(),
                s.resources.bram.to_string(),
                if s.fits.is_empty() {
                    "-".to_owned()
                } else {
                    s.fits.join(" ")
                },
            ]);
        }
        table(
            &mut o,
            &[
                "N",
                "P",
                "fps bound",
                "fps scaled",
                "bw at bound",
                t.dsp_name(),
                t.lut_name(),
                t.bram_name(),
                "fits",
            ],
            &sc,
        );
        if !self.architectures.is_empty() {
            let _ = writeln!(
                o,
                "\nArchitectures (P = {}, measured runs, {})",
                g.pes, self.run.label
            );
            design::text(&mut o, t, &self.architectures);
        }
        let _ = writeln!(o);
        for n in &self.notes {
            let _ = writeln!(o, "- {n}");
        }
        o
    }
}
