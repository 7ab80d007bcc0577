//! Every writing command checks its outputs before it starts, and a run
//! whose writing fails late (a file grown past the process's size limit,
//! after the rendering is done) reports it in one line and leaves no
//! output and no temporary file behind.

use std::path::Path;
use std::process::{Command, Output};

use crate::bin::{assert_refused, describe, ercube, BIN};

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn argv(args: &str) -> Vec<String> {
    args.split_whitespace().map(String::from).collect()
}

/// A folder no one can write in, root included (sysfs is read-only).
const UNWRITABLE: &str = "/sys";

/// Each writing command with its output folder (`{}`) refused before any
/// work when the folder is a file, its parent is missing, or it cannot be
/// written; the same for the commands' output files. The default scenes
/// and sweeps of these commands take seconds to minutes, so a check made
/// after the work would show in the test's time, and an error from the
/// work (a missing tool, a missing shard) would replace the one expected.
#[test]
fn every_writing_command_checks_its_outputs_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("file"), "mine").unwrap();
    std::fs::create_dir(d.join("folder")).unwrap();
    let folders = [
        "compare --scene checker:16 --size 16x16 --out-dir {}",
        "demo --out-dir {}",
        "animate --scene checker:16 --size 16x16 --frames 2 --out-dir {}",
        "cost --scene checker:16 --verilog-dir {}",
        "explore --scene checker:16 --out-dir {}",
        "peer vtk --scene checker:16 --out-dir {}",
        "refine --scene checker:16 --method reference --out-dir {}",
        "skip-bench --report {}",
        "synth --target ice40-up5k --unit divider --keep {}",
        "bench --out-dir {}",
        "bench --report {}",
        "merge-results shard-1-of-2.json shard-2-of-2.json --out-dir {}",
        "sweep-widths --scene checker:16 --out-dir {}",
        "rtl --out-dir {}",
    ];
    for cmd in folders {
        for (out, needle) in [
            (
                "file".to_string(),
                "output folder file is a file".to_string(),
            ),
            (
                "missing/out".to_string(),
                "output folder missing/out: the folder missing does not exist".to_string(),
            ),
            (
                format!("{UNWRITABLE}/ercube-out"),
                format!("cannot write in {UNWRITABLE}"),
            ),
        ] {
            let args = argv(&cmd.replace("{}", &out));
            let run = ercube(d, &args);
            assert_refused(&args, &run, &needle);
        }
    }
    let files = [
        "cost --scene checker:16 --stats {}",
        "synth --target ice40-up5k --unit divider --stats {}",
    ];
    for cmd in files {
        for (out, needle) in [
            ("folder", "output folder is a folder"),
            ("missing/x.json", "the folder missing does not exist"),
            ("/sys/x.json", "cannot write in /sys"),
        ] {
            let args = argv(&cmd.replace("{}", out));
            let run = ercube(d, &args);
            assert_refused(&args, &run, needle);
        }
    }
    assert_eq!(names(d), ["file", "folder"], "a refused run left files");
    assert!(names(&d.join("folder")).is_empty());
    assert_eq!(std::fs::read_to_string(d.join("file")).unwrap(), "mine");
}

/// Runs `ercube args` in `dir` with files limited to `max_bytes`
/// (`RLIMIT_FSIZE`, what `ulimit -f` sets): a write past it fails with
/// EFBIG (the process ignores SIGXFSZ, which would otherwise kill it).
fn ercube_limited(dir: &Path, args: &[String], max_bytes: u64) -> Output {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(BIN);
    cmd.args(args).current_dir(dir).env_remove("RUST_BACKTRACE");
    // SAFETY: setrlimit is async-signal-safe, as pre_exec requires.
    unsafe {
        cmd.pre_exec(move || {
            let lim = libc::rlimit {
                rlim_cur: max_bytes as libc::rlim_t,
                rlim_max: max_bytes as libc::rlim_t,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    cmd.output().expect("the ercube binary runs")
}

/// Every file under `dir` (recursively) with its size.
fn sizes(dir: &Path) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            out.extend(sizes(&p));
        } else {
            out.push((
                e.file_name().to_string_lossy().into_owned(),
                e.metadata().unwrap().len(),
            ));
        }
    }
    out
}

/// Runs `args` (writing under `out`, relative to a fresh folder) once
/// without a limit to learn its files' sizes, then with a file-size limit
/// half-way between `late`'s size and the largest other file's, so that
/// `late` fails after the others were written: the run must exit 2 with
/// one line naming `late` and "File too large", and leave nothing (no
/// output, no temporary file, no folder it made).
#[track_caller]
fn fails_late_leaving_nothing(args: &str, late: &str) {
    let argv = argv(args);
    let whole = tempfile::tempdir().unwrap();
    let run = ercube(whole.path(), &argv);
    assert!(run.status.success(), "{}", describe(&argv, &run));
    let files = sizes(whole.path());
    let big = files.iter().find(|(n, _)| n == late).expect("late file").1;
    let others = files
        .iter()
        .filter(|(n, _)| n != late)
        .map(|f| f.1)
        .max()
        .unwrap_or(0);
    assert!(
        others > 0 && big > others + 1024,
        "{late} ({big} bytes) must be the largest file: {files:?}"
    );
    let limit = (big + others) / 2;
    let dir = tempfile::tempdir().unwrap();
    let run = ercube_limited(dir.path(), &argv, limit);
    assert_refused(&argv, &run, late);
    assert_refused(&argv, &run, "File too large");
    assert!(
        names(dir.path()).is_empty(),
        "{args}: a run failing at {late} (limit {limit} bytes) left {:?}",
        names(dir.path())
    );
}

#[test]
fn a_render_failing_at_its_last_write_leaves_nothing() {
    fails_late_leaving_nothing(
        "render --scene checker:32 --size 96x96 --out a.png --stats a.json --npy a.npy",
        "a.npy",
    );
}

/// The trace is written during the frame (on the thread pool's side of
/// the run), before the images: it must not outlive the failed run.
#[test]
fn a_traced_render_failing_late_leaves_no_trace() {
    fails_late_leaving_nothing(
        "render --scene checker:16 --size 96x96 --method pipeline --pes 4 --vcd t.vcd \
         --trace-cycles 0-40 --threads 2 --out a.png --npy a.npy",
        "a.npy",
    );
}

#[test]
fn a_comparison_failing_at_its_montage_leaves_nothing() {
    fails_late_leaving_nothing(
        "compare --scene checker:32 --size 48x48 --methods er,box --out-dir out",
        "montage.png",
    );
}

#[test]
fn an_animation_failing_at_its_gif_leaves_nothing() {
    fails_late_leaving_nothing(
        "animate --scene checker:32 --size 48x48 --frames 12 --out-dir anim",
        "animation.gif",
    );
}

#[test]
fn a_width_sweep_failing_at_its_chart_leaves_nothing() {
    fails_late_leaving_nothing(
        "sweep-widths --scene checker:16 --out-dir out",
        "widths.png",
    );
}
