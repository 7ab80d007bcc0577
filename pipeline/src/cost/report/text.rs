//! The cost report as a readable table: the text `ercube cost` prints.

use std::fmt::Write as _;

use super::*;

/// `1234567` as `1.23 M`.
pub(in crate::cost) fn si(x: f64) -> String {
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

/// PE indices as runs: `0, 2-13, 15`.
fn pe_list(pes: &[usize]) -> String {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for &k in pes {
        match runs.last_mut() {
            Some((_, hi)) if *hi + 1 == k => *hi = k,
            _ => runs.push((k, k)),
        }
    }
    runs.iter()
        .map(|&(lo, hi)| {
            if lo == hi {
                lo.to_string()
            } else {
                format!("{lo}-{hi}")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Renders rows as a text table with aligned columns.
pub(in crate::cost) fn table(out: &mut String, head: &[&str], rows: &[Vec<String>]) {
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
        let predicted: Vec<String> = self
            .predicted_clocks
            .iter()
            .map(|p| {
                format!(
                    "{} {:.1} MHz (stage {:.1}, routing +{:.2} ns; slowest: {})",
                    p.target.name(),
                    p.mhz,
                    p.stage_mhz,
                    p.routing_ns,
                    p.critical
                )
            })
            .collect();
        let _ = writeln!(
            o,
            "  predicted clock (the slowest of the datapath's slowest scheduled stage and the PE sample stage's issue and tap address, plus a whole design's routing; models fitted to ercube synth runs): {}; none for xc7 (no open timing flow)",
            predicted.join(", ")
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
        if g.units.preint {
            let n = crate::cost::preint::bins(c) + 1;
            let _ = writeln!(
                o,
                "  pre-integration: {n} x {n} table of {} bits ({:.2} Mbit per PE), tau {}, colour {}, in place of the classification and -log2(1 - a) tables",
                crate::cost::preint::table_word(c),
                crate::cost::preint::table_bits(c) as f64 / 1e6,
                c.preint_tau.bits(),
                c.preint_color.bits()
            );
            let _ = writeln!(
                o,
                "  pre-integration, exact colouring (--pre-colouring exact): {} more depth layers of {n} x {n} x 3 colour words, {:.2} Mbit per PE",
                golden::preint::LAYERS - 1,
                crate::cost::preint::exact_layer_bits(c) as f64 / 1e6,
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
            "PE total (the deepest)".into(),
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
        if self.ray_memory_bits > 0 {
            let _ = writeln!(
                o,
                "  external ray memory: {:.2} Mbit for the deepest PE, {:.1} Mbit for the array (no block RAM)",
                self.ray_memory_bits_per_pe as f64 / 1e6,
                self.ray_memory_bits as f64 / 1e6
            );
        }
        let [rc, rr] = self.run.largest_region;
        let _ = writeln!(
            o,
            "  rays: the deepest PE's buffers hold {} columns x {} rows = {} rays, all PEs' {} in all (each PE at its own depths); this view's largest region has {rc} x {rr} = {} rays",
            g.rays.columns,
            g.rays.rows,
            g.rays_per_pe(),
            g.rays_in_array(),
            rc * rr
        );
        let groups: Vec<Vec<String>> = self
            .pe_groups
            .iter()
            .map(|p| {
                let [d, l, f, b] = res_cells(t, &p.resources);
                vec![
                    pe_list(&p.pes),
                    format!(
                        "{} x {}, {} children, {} kept",
                        p.rays.columns, p.rays.rows, p.rays.children, p.rays.kept
                    ),
                    p.pes.len().to_string(),
                    d,
                    l,
                    f,
                    b,
                ]
            })
            .collect();
        let _ = writeln!(
            o,
            "\nPEs by their own ray depths (columns x rows, a pass's children, kept final rays)"
        );
        table(
            &mut o,
            &[
                "PEs",
                "ray depths",
                "n",
                t.dsp_name(),
                t.lut_name(),
                "FF",
                t.bram_name(),
            ],
            &groups,
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
            crate::cost::clock::rate_line(r.cycles, self.clock_mhz, self.clock_source)
        );
        let _ = writeln!(
            o,
            "  run: {} cycles/frame (sample {}, migrate {}, merge {}, readout {}, drain {}, stall {}, plan {}), utilization {:.3}, {:.1} frames/s",
            r.cycles,
            r.stages.sample,
            r.stages.migrate,
            r.stages.merge,
            r.stages.readout,
            r.stages.drain,
            r.stages.stall,
            r.stages.plan,
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
