//! `ercube bench --shard K/N`, `ercube sweep-widths --shard K/N` and
//! `ercube merge-results`: three shards run one after another here (as
//! three machines would) merge into the rows, per-slice counts and files
//! of the unsharded run; only the timings may differ.

use std::path::Path;

use crate::bin::{assert_refused, ercube};

const SWEEP: &str = "bench --scene checker:16 --methods reference,er,er-ftb,pipeline \
                     --distances 4,8,16,32,64 --frames 2 --size 16x16 --pes 4";

fn run(dir: &Path, args: &str) {
    let args: Vec<&str> = args.split_whitespace().collect();
    let out = ercube(dir, &args);
    assert!(
        out.status.success(),
        "ercube {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The CSV's rows without its timing columns (`time_s`, and
/// `unshaded_time_s` where there is one).
fn rows_without_time(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert!(head.contains(&"time_s"), "a time_s column");
    lines
        .map(|l| {
            l.split(',')
                .zip(&head)
                .filter(|(_, h)| !h.ends_with("time_s"))
                .map(|(c, _)| c.to_owned())
                .collect()
        })
        .collect()
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn three_shards_merge_into_the_unsharded_result() {
    three_shards_merge(SWEEP);
}

/// The same with shading: the shaded rows, errors against the shaded
/// reference and unshaded timings survive the shard files.
#[test]
fn shaded_shards_merge_into_the_unsharded_result() {
    let sweep = format!("{SWEEP} --shade");
    three_shards_merge(&sweep);
    let dir = tempfile::tempdir().unwrap();
    run(dir.path(), &format!("{sweep} --out-dir full"));
    let text = std::fs::read_to_string(dir.path().join("full/bench.csv")).unwrap();
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let u = head.iter().position(|&c| c == "unshaded_time_s").unwrap();
    for l in text.lines().skip(1).filter(|l| !l.contains(",reference,")) {
        let cell = l.split(',').nth(u).unwrap();
        assert!(cell.parse::<f64>().is_ok(), "no unshaded time in {l}");
    }
    let md = std::fs::read_to_string(dir.path().join("full/summary.md")).unwrap();
    assert!(md.contains("Shading's cost"), "no shading table");
}

fn three_shards_merge(sweep: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run(d, &format!("{sweep} --out-dir full"));
    for k in 1..=3 {
        run(d, &format!("{sweep} --shard {k}/3 --out-dir s{k}"));
        assert_eq!(
            files(&d.join(format!("s{k}"))),
            [format!("shard-{k}-of-3.json")]
        );
    }
    run(
        d,
        "merge-results s2/shard-2-of-3.json s3/shard-3-of-3.json s1/shard-1-of-3.json --out-dir merged",
    );
    assert_eq!(files(&d.join("merged")), files(&d.join("full")));
    let (want, got) = (
        rows_without_time(&d.join("full/bench.csv")),
        rows_without_time(&d.join("merged/bench.csv")),
    );
    assert_eq!(
        want.len(),
        5 * (1 + 3 * 2),
        "one reference and 2 frames of 3 methods per distance"
    );
    if let Some(i) = (0..want.len().max(got.len())).find(|&i| want.get(i) != got.get(i)) {
        panic!(
            "merged row {i} differs: {:?} against {:?}",
            got.get(i),
            want.get(i)
        );
    }
    let per_slice = |p: &str| std::fs::read(d.join(p)).unwrap();
    assert!(
        per_slice("full/samples_per_slice.csv") == per_slice("merged/samples_per_slice.csv"),
        "the per-slice counts differ"
    );
}

#[test]
fn incomplete_or_mixed_shards_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run(d, &format!("{SWEEP} --shard 1/2 --out-dir a"));
    run(d, &format!("{SWEEP} --seed 2 --shard 2/2 --out-dir b"));
    let args = ["merge-results", "a/shard-1-of-2.json", "--out-dir", "m"];
    assert_refused(&args, &ercube(d, &args), "each of shards 1..=2 once");
    let args = [
        "merge-results",
        "a/shard-1-of-2.json",
        "b/shard-2-of-2.json",
    ];
    assert_refused(&args, &ercube(d, &args), "another sweep");
    let args = ["bench", "--scene", "checker:16", "--shard", "3/2"];
    assert_refused(&args, &ercube(d, &args), "K/N");
}

#[test]
fn three_width_sweep_shards_merge_into_the_unsharded_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sweep = "sweep-widths --scene checker:16 --size 16x16 --alpha-bits 6-8 --accum-bits 12,16 \
                 --position-frac none --weight-bits 5 --color-frac none --sample-frac none";
    run(d, &format!("{sweep} --out-dir full"));
    for k in 1..=3 {
        run(d, &format!("{sweep} --shard {k}/3 --out-dir s{k}"));
    }
    run(
        d,
        "merge-results s1/shard-1-of-3.json s3/shard-3-of-3.json s2/shard-2-of-3.json --out-dir merged",
    );
    assert_eq!(files(&d.join("merged")), files(&d.join("full")));
    let (want, got) = (
        rows_without_time(&d.join("full/widths.csv")),
        rows_without_time(&d.join("merged/widths.csv")),
    );
    assert_eq!(want.len(), 1 + 3 + 2 + 1, "the base and every knob value");
    if let Some(i) = (0..want.len().max(got.len())).find(|&i| want.get(i) != got.get(i)) {
        panic!(
            "merged row {i} differs: {:?} against {:?}",
            got.get(i),
            want.get(i)
        );
    }
    // The plot draws errors against bits, no times: the same bytes.
    let png = |p: &str| std::fs::read(d.join(p)).unwrap();
    assert!(
        png("full/widths.png") == png("merged/widths.png"),
        "the plots differ"
    );
}
