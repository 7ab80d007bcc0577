//! The FPGA cost estimator against real synthesis.
//!
//! `pipeline::rtl` emits the PE's arithmetic units (ray-index multiplier,
//! slope square, position adder, bilinear interpolation, compositing,
//! classification table) as small Verilog modules at the configured
//! widths. This test synthesizes each with yosys for Xilinx 7-series
//! (`synth_xilinx`) and iCE40 (`synth_ice40 -dsp`, so multipliers map to
//! SB_MAC16 as the estimator assumes), reads `stat -json`, and checks the
//! estimator's counts for the same modules, at three width settings:
//!
//! - DSP blocks and block RAM: exact;
//! - LUTs (LUT6 and LUT-RAM on xc7, SB_LUT4 on iCE40) and flip-flops:
//!   within 10% of yosys at the default widths and 25% at the narrow and
//!   wide ones, or within 3 for units of a dozen or fewer.
//!
//! yosys runs when it is on PATH; without it the synthesis checks print
//! one line and skip, unless `ERCUBE_REQUIRE_TOOLS=1` (`.ci/run` installs
//! Debian's `yosys` and sets it). Run with `--nocapture` to see the
//! comparison table.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::sync::Mutex;

use pipeline::config::PipelineConfig;
use pipeline::cost::{Resources, Target};
use pipeline::rtl::{calibration_modules, shading_modules, CalibrationModule};

/// Relative tolerance on LUT and FF counts at the narrow and wide widths.
const REL_TOL: f64 = 0.25;
/// Relative tolerance at the default widths, the ones `ercube synth`
/// places and `docs/cost.md` tabulates: every unit within 10%.
const DEFAULT_TOL: f64 = 0.10;

/// The LUT and FF tolerance of a width setting.
fn tolerance(setting: &str) -> f64 {
    if setting == "default" {
        DEFAULT_TOL
    } else {
        REL_TOL
    }
}
/// Absolute tolerance for small counts (a handful of LUTs of control or
/// constant logic is below what the estimator models).
const ABS_TOL: u64 = 3;

/// Narrow widths: 8-bit voxels, 256-entry tables, 12-bit accumulators,
/// 14-bit gradients, 8 fraction bits of `|n . L|`.
pub(crate) const NARROW: &str = include_str!("../../data/widths/narrow.toml");

/// Wide widths: 16-bit voxels, 32-bit positions, 24-bit accumulators,
/// 24-bit gradients, 16 fraction bits of `|n . L|`.
pub(crate) const WIDE: &str = include_str!("../../data/widths/wide.toml");

fn settings() -> Vec<(&'static str, PipelineConfig)> {
    vec![
        (
            "narrow",
            PipelineConfig::from_toml_str(NARROW).expect("narrow config is valid"),
        ),
        ("default", PipelineConfig::default()),
        (
            "wide",
            PipelineConfig::from_toml_str(WIDE).expect("wide config is valid"),
        ),
    ]
}

/// yosys's counts, in the estimator's terms.
#[derive(Debug, Clone, Copy, Default)]
struct Counted {
    lut: u64,
    ff: u64,
    dsp: u64,
    bram: u64,
}

/// Maps yosys cell types onto the estimator's resource classes. Cells
/// that cost nothing the estimator counts (I/O buffers, the clock buffer,
/// carry chains and the wide-function muxes inside slices) are listed so
/// that any other type fails the test instead of being ignored.
fn count(target: Target, cells: &BTreeMap<String, u64>) -> Result<Counted, String> {
    let mut c = Counted::default();
    for (ty, &n) in cells {
        let t = ty.as_str();
        match target {
            Target::Xc7 => match t {
                "LUT1" | "LUT2" | "LUT3" | "LUT4" | "LUT5" | "LUT6" | "INV" => c.lut += n,
                "SRL16E" | "SRLC32E" => c.lut += n,
                "RAM32M" | "RAM64M" | "RAM128X1D" => c.lut += 4 * n,
                "RAM64X1D" | "RAM32X1D" => c.lut += 2 * n,
                "FDRE" | "FDSE" | "FDCE" | "FDPE" => c.ff += n,
                "DSP48E1" => c.dsp += n,
                "RAMB18E1" => c.bram += n,
                "RAMB36E1" => c.bram += 2 * n,
                "IBUF" | "OBUF" | "BUFG" | "CARRY4" | "MUXF7" | "MUXF8" => {}
                _ => return Err(format!("unexpected xc7 cell {t}")),
            },
            Target::Ice40 => match t {
                "SB_LUT4" => c.lut += n,
                _ if t.starts_with("SB_DFF") => c.ff += n,
                "SB_MAC16" => c.dsp += n,
                "SB_RAM40_4K" => c.bram += n,
                "SB_CARRY" | "SB_IO" | "SB_GB" => {}
                _ => return Err(format!("unexpected ice40 cell {t}")),
            },
            Target::Ecp5 => return Err("ECP5 is not synthesized by this test".into()),
        }
    }
    Ok(c)
}

fn yosys_script(target: Target, top: &str, json: &Path) -> String {
    let synth = match target {
        Target::Xc7 => format!("synth_xilinx -top {top}"),
        Target::Ice40 => format!("synth_ice40 -dsp -top {top}"),
        Target::Ecp5 => unreachable!("not synthesized"),
    };
    format!(
        "read_verilog {top}.v; {synth}; tee -q -o {} stat -json",
        json.display()
    )
}

/// Synthesizes one module and returns yosys's cell counts.
fn synthesize(dir: &Path, m: &CalibrationModule, target: Target) -> Result<Counted, String> {
    let json = dir.join(format!("{}_{}.json", m.name, target.name()));
    let out = Command::new("yosys")
        .current_dir(dir)
        .args(["-q", "-p", &yosys_script(target, &m.name, &json)])
        .output()
        .map_err(|e| format!("cannot run yosys: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "yosys failed on {} for {}: {}",
            m.name,
            target.name(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let text = std::fs::read_to_string(&json).map_err(|e| format!("{}: {e}", json.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    let cells = v["modules"]
        .as_object()
        .and_then(|mods| mods.values().next())
        .and_then(|m| m["num_cells_by_type"].as_object())
        .ok_or("stat -json has no cell counts")?;
    let cells: BTreeMap<String, u64> = cells
        .iter()
        .map(|(k, n)| (k.clone(), n.as_u64().unwrap_or(0)))
        .collect();
    count(target, &cells)
}

fn within(est: u64, got: u64, tol: f64) -> bool {
    let diff = est.abs_diff(got);
    diff <= ABS_TOL || (diff as f64) <= tol * got as f64
}

/// Whether yosys can run `what` here (see `tests/support/tools.rs`).
fn yosys(what: &str) -> bool {
    crate::tools::have("yosys", "yosys", what)
}

struct Row {
    setting: &'static str,
    module: String,
    description: String,
    target: Target,
    est: Resources,
    got: Counted,
}

/// Synthesizes `modules(cfg)` of every setting in `settings` on both
/// targets, prints the comparison table and fails on any count outside
/// the tolerance; `expect` rows in all.
fn check_against_yosys(
    settings: Vec<(&'static str, PipelineConfig)>,
    modules: impl Fn(&PipelineConfig) -> Vec<CalibrationModule>,
    expect: usize,
) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut jobs = Vec::new();
    for (setting, cfg) in settings {
        let sub = dir.path().join(setting);
        std::fs::create_dir_all(&sub).expect("setting dir");
        for m in modules(&cfg) {
            std::fs::write(sub.join(format!("{}.v", m.name)), &m.verilog).expect("write .v");
            for target in [Target::Xc7, Target::Ice40] {
                jobs.push((setting, sub.clone(), m.clone(), target));
            }
        }
    }
    // Two workers: the CI machine has two cores, and each yosys run is
    // single-threaded.
    let queue = Mutex::new(jobs.into_iter().enumerate().collect::<Vec<_>>());
    let results = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let job = queue.lock().expect("queue").pop();
                let Some((i, (setting, sub, m, target))) = job else {
                    break;
                };
                let got = synthesize(&sub, &m, target);
                results
                    .lock()
                    .expect("results")
                    .push((i, setting, m, target, got));
            });
        }
    });
    let mut results = results.into_inner().expect("results");
    results.sort_by_key(|r| r.0);
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for (_, setting, m, target, got) in results {
        match got {
            Ok(got) => rows.push(Row {
                setting,
                module: m.name.trim_start_matches("ercube_").to_owned(),
                description: m.description.clone(),
                target,
                est: m.estimate(target),
                got,
            }),
            Err(e) => failures.push(e),
        }
    }
    println!(
        "| setting | module | shape | target | DSP est/yosys | BRAM est/yosys | LUT est/yosys | FF est/yosys |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    for r in &rows {
        let mark = |ok: bool| if ok { "" } else { " **X**" };
        let dsp_ok = r.est.dsp == r.got.dsp;
        let bram_ok = r.est.bram == r.got.bram;
        let tol = tolerance(r.setting);
        let lut_ok = within(r.est.lut, r.got.lut, tol);
        let ff_ok = within(r.est.ff, r.got.ff, tol);
        println!(
            "| {} | {} | {} | {} | {}/{}{} | {}/{}{} | {}/{}{} | {}/{}{} |",
            r.setting,
            r.module,
            r.description,
            r.target.name(),
            r.est.dsp,
            r.got.dsp,
            mark(dsp_ok),
            r.est.bram,
            r.got.bram,
            mark(bram_ok),
            r.est.lut,
            r.got.lut,
            mark(lut_ok),
            r.est.ff,
            r.got.ff,
            mark(ff_ok)
        );
        let what = format!("{} {} on {}", r.setting, r.module, r.target.name());
        if !dsp_ok {
            failures.push(format!(
                "{what}: {} DSP estimated, yosys {}",
                r.est.dsp, r.got.dsp
            ));
        }
        if !bram_ok {
            failures.push(format!(
                "{what}: {} BRAM estimated, yosys {}",
                r.est.bram, r.got.bram
            ));
        }
        if !lut_ok {
            failures.push(format!(
                "{what}: {} LUTs estimated, yosys {} (tolerance {:.0}% or {ABS_TOL})",
                r.est.lut,
                r.got.lut,
                100.0 * tol
            ));
        }
        if !ff_ok {
            failures.push(format!(
                "{what}: {} FFs estimated, yosys {} (tolerance {:.0}% or {ABS_TOL})",
                r.est.ff,
                r.got.ff,
                100.0 * tol
            ));
        }
    }
    assert_eq!(
        rows.len(),
        expect,
        "every module synthesized on both targets"
    );
    assert!(
        failures.is_empty(),
        "estimator vs yosys:\n{}",
        failures.join("\n")
    );
}

#[test]
fn estimator_agrees_with_yosys() {
    if !yosys("the estimator-vs-yosys calibration") {
        return;
    }
    check_against_yosys(
        settings(),
        |cfg| calibration_modules(cfg).expect("modules emit"),
        36,
    );
}

/// The shading unit's square root and divider against yosys at the
/// default and the narrow widths (about 40 s on two cores; the wide
/// setting's would double it).
#[test]
fn shading_units_agree_with_yosys() {
    if !yosys("the shading units' calibration") {
        return;
    }
    let two: Vec<_> = settings()
        .into_iter()
        .filter(|(s, _)| *s != "wide")
        .collect();
    check_against_yosys(two, shading_modules, 8);
}

/// The emitted Verilog is exactly what the estimator describes: one
/// module per unit, named as the synthesis expects, at the configured
/// widths.
#[test]
fn modules_follow_the_config() {
    let cfg = PipelineConfig::default();
    let mods = calibration_modules(&cfg).expect("default config emits");
    let names: Vec<&str> = mods.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "ercube_mul_ray",
            "ercube_mul_square",
            "ercube_add_position",
            "ercube_bilinear",
            "ercube_composite",
            "ercube_class_table"
        ]
    );
    for m in &mods {
        assert!(m.verilog.contains(&format!("module {} (", m.name)));
        assert!(m.verilog.trim_end().ends_with("endmodule"));
    }
    // 16-bit ray index times the 25-bit unsigned step: 41 bits signed.
    assert!(mods[0].verilog.contains("input [24:0] t"));
    assert!(mods[0].verilog.contains("output reg [40:0] y"));
    // The table is table_entries deep and R, G, B, opacity wide.
    assert!(mods[5].verilog.contains("reg [38:0] mem [0:4095]"));
    let mods = shading_modules(&cfg);
    // |g|^2 of 20-bit components: a 40-bit radicand, a 20-bit root.
    assert!(mods[0].verilog.contains("input [39:0] x"));
    assert!(mods[0].verilog.contains("output reg [19:0] y"));
    // |g . v| of 20-bit gradients and 16-bit lights over the 20-bit norm,
    // 13 bits of quotient.
    assert!(mods[1].verilog.contains("input [35:0] num"));
    assert!(mods[1].verilog.contains("input [19:0] d"));
    assert!(mods[1].verilog.contains("output reg [12:0] y"));
}

/// Runs `script` in yosys and returns its `eval -show` results, in order.
fn eval_results(script: &str) -> Vec<(String, i64)> {
    let out = Command::new("yosys")
        .args(["-p", script])
        .output()
        .expect("yosys runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // "Eval result: \\y = 16'0000110010000000." per shown signal.
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("Eval result: \\"))
        .map(|r| {
            let (name, val) = r.split_once(" = ").expect("name = value");
            let bits = val
                .trim_end_matches('.')
                .split_once('\'')
                .expect("width'bits")
                .1;
            let v = i64::from_str_radix(bits, 2).expect("binary value");
            (name.to_owned(), v)
        })
        .collect()
}

/// The shading unit's square root and divider modules, made
/// combinational, evaluated by yosys at each width setting, give the raw
/// words of `datapath::isqrt_into` and `shading::divide` bit for bit: on
/// random radicands, and on dividends below, at and above `d` (quotients
/// under 1, exactly 1, and capped).
#[test]
fn shading_verilog_matches_the_model() {
    use pipeline::cost::shading::norm_root;
    use pipeline::fixed::{Fx, QuantStats, Wide};
    use pipeline::rtl::{dividend_bits, divider, sqrt_norm};
    if !yosys("the shading Verilog-vs-model check") {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut rand = |bits: u32| -> u64 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed >> (64 - bits)
    };
    let bin = |w: u32, v: u64| format!("{w}'b{v:0w$b}", w = w as usize);
    const VECTORS: usize = 16;
    let mut checked = 0;
    for (setting, cfg) in settings() {
        let mut st = QuantStats::default();
        let comb = |m: &CalibrationModule| {
            let file = dir.path().join(format!("{setting}_{}.v", m.name));
            let v = m
                .verilog
                .replace("always @(posedge clk) begin", "always @* begin");
            std::fs::write(&file, v).expect("write");
            format!("read_verilog {}; prep -top {};", file.display(), m.name)
        };
        // Square root.
        let n = norm_root(&cfg);
        let pf = i32::from(cfg.grad_norm.frac());
        let m = sqrt_norm(&cfg);
        let mut script = comb(&m);
        let mut want = Vec::new();
        for i in 0..VECTORS {
            // The largest radicand, then random ones of every size.
            let x = if i == 0 {
                (1u64 << (2 * n)) - 1
            } else {
                rand(2 * n) >> (rand(6) % u64::from(2 * n))
            };
            let y = pipeline::datapath::isqrt_into(
                Wide::new(i128::from(x), 2 * pf),
                pipeline::reg!(cfg, grad_norm),
                "test",
                &mut st,
            )
            .expect("root");
            script += &format!(" eval -set x {} -show y;", bin(2 * n, x));
            want.push(("y".to_owned(), y.raw()));
        }
        let got = eval_results(&script);
        assert_eq!(got, want, "{setting} sqrt_norm: yosys eval vs isqrt_into");
        checked += want.len();
        // Divider.
        let w = dividend_bits(&cfg);
        let nb = u32::from(cfg.grad_norm.bits());
        let fd = i32::from(cfg.gradient.frac()) + i32::from(cfg.light.frac());
        // num = d 2^(fd - fn) is a quotient of exactly 1.
        let unit = (fd - pf) as u32;
        let m = divider(&cfg);
        let mut script = comb(&m);
        let mut want = Vec::new();
        for i in 0..VECTORS {
            let d = (rand(nb).max(1) >> (rand(4) % u64::from(nb))) | 1;
            let one = u128::from(d) << unit;
            let top = (1u128 << w) - 1;
            let num = match i % 4 {
                0 => rand(w),
                1 => one.min(top) as u64,
                _ => (u128::from(rand(w)) % one.min(top)) as u64,
            };
            let q = pipeline::shading::divide(
                &cfg,
                i128::from(num),
                fd,
                Fx::from_raw(d as i64, cfg.grad_norm).expect("norm"),
            )
            .expect("divide");
            script += &format!(
                " eval -set num {} -set d {} -show y;",
                bin(w, num),
                bin(nb, d)
            );
            want.push(("y".to_owned(), q.raw as i64));
        }
        let got = eval_results(&script);
        assert_eq!(
            got, want,
            "{setting} divider: yosys eval vs shading::divide"
        );
        checked += want.len();
    }
    assert_eq!(checked, 3 * 2 * VECTORS);
}

/// The calibration Verilog computes what the model computes: the
/// bilinear and compositing modules, made combinational, evaluated by
/// yosys on pseudo-random inputs at each width setting, give the raw words
/// of `Datapath::bilinear` and `Datapath::composite_btf` bit for bit.
#[test]
fn verilog_matches_the_datapath() {
    use pipeline::datapath::{Acc, Datapath};
    use pipeline::fixed::{Fx, QuantStats};
    use pipeline::tables::Tables;
    if !yosys("the Verilog-vs-datapath check") {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut rand = |bits: u8| -> i64 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> (64 - u32::from(bits))) as i64
    };
    const VECTORS: usize = 12;
    let tf = golden::scenes::tf_preset("grey-ramp").expect("preset");
    let mut checked = 0;
    for (setting, cfg) in settings() {
        let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, 8);
        let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).expect("tables"));
        let mods = calibration_modules(&cfg).expect("modules emit");
        for m in mods
            .iter()
            .filter(|m| m.name == "ercube_bilinear" || m.name == "ercube_composite")
        {
            let comb = m
                .verilog
                .replace("always @(posedge clk) begin", "always @* begin");
            let file = dir.path().join(format!("{setting}_{}.v", m.name));
            std::fs::write(&file, comb).expect("write");
            let mut script = format!("read_verilog {}; prep -top {};", file.display(), m.name);
            let mut expected: Vec<Vec<(String, i64)>> = Vec::new();
            for _ in 0..VECTORS {
                let mut st = QuantStats::default();
                if m.name == "ercube_bilinear" {
                    let vb = cfg.voxel.bits();
                    let v = [rand(vb), rand(vb), rand(vb), rand(vb)];
                    let (wx, wy) = (rand(cfg.weight.bits()), rand(cfg.weight.bits()));
                    let fx = |r: i64| Fx::from_raw(r, cfg.weight).expect("weight");
                    let y = dp
                        .bilinear(
                            [[v[0] as u16, v[1] as u16], [v[2] as u16, v[3] as u16]],
                            fx(wx),
                            fx(wy),
                            &mut st,
                        )
                        .expect("bilinear");
                    script += &format!(
                        " eval -set v00 {} -set v01 {} -set v10 {} -set v11 {} -set wx {wx} -set wy {wy} -show y;",
                        v[0], v[1], v[2], v[3]
                    );
                    expected.push(vec![("y".into(), y.raw())]);
                } else {
                    let (fc, fa) = (cfg.accum_color, cfg.accum_alpha);
                    let acc0 = [
                        rand(fc.bits()),
                        rand(fc.bits()),
                        rand(fc.bits()),
                        rand(fa.bits()),
                    ];
                    let c = [
                        rand(cfg.color.bits()),
                        rand(cfg.color.bits()),
                        rand(cfg.color.bits()),
                    ];
                    let a = rand(cfg.opacity_corr.bits());
                    let mut acc = Acc { raw: acc0 };
                    let cf = |r: i64| Fx::from_raw(r, cfg.color).expect("colour");
                    dp.composite_btf(
                        &mut acc,
                        [cf(c[0]), cf(c[1]), cf(c[2])],
                        Fx::from_raw(a, cfg.opacity_corr).expect("opacity"),
                        &mut st,
                    )
                    .expect("composite");
                    script += &format!(
                        " eval -set acc_r {} -set acc_g {} -set acc_b {} -set acc_a {} -set c_r {} -set c_g {} -set c_b {} -set a {a} -show y_r -show y_g -show y_b -show y_a;",
                        acc0[0], acc0[1], acc0[2], acc0[3], c[0], c[1], c[2]
                    );
                    expected.push(
                        ["y_r", "y_g", "y_b", "y_a"]
                            .iter()
                            .zip(acc.raw)
                            .map(|(n, v)| ((*n).to_owned(), v))
                            .collect(),
                    );
                }
            }
            let out = Command::new("yosys")
                .args(["-p", &script])
                .output()
                .expect("yosys runs");
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            // "Eval result: \\y = 16'0000110010000000." per shown signal.
            let text = String::from_utf8_lossy(&out.stdout);
            let got: Vec<(String, i64)> = text
                .lines()
                .filter_map(|l| l.trim().strip_prefix("Eval result: \\"))
                .map(|r| {
                    let (name, val) = r.split_once(" = ").expect("name = value");
                    let bits = val
                        .trim_end_matches('.')
                        .split_once('\'')
                        .expect("width'bits")
                        .1;
                    let v = i64::from_str_radix(bits, 2).expect("binary value");
                    (name.to_owned(), v)
                })
                .collect();
            let want: Vec<(String, i64)> = expected.into_iter().flatten().collect();
            assert_eq!(
                got, want,
                "{setting} {}: yosys eval vs the datapath",
                m.name
            );
            checked += want.len();
        }
    }
    assert_eq!(checked, 3 * VECTORS * 5);
}
