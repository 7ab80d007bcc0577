//! `--preintegrate` through the program: the slice-order methods take it
//! (and it changes their image), everything else refuses it in one line:
//! the pipeline model, the reference and the mip-map, and the options it
//! does not combine with.

use crate::bin::{assert_refused, describe, ercube};

#[test]
fn preintegrate_is_taken_by_slice_methods_and_refused_elsewhere() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let s = "render --scene sphere:20 --size 20x20";
    for m in ["er", "er-ftb", "under", "over", "box"] {
        let plain = format!("{s} --method {m} --out p.png --npy p.npy");
        let pre = format!("{s} --method {m} --preintegrate --out q.png --npy q.npy");
        for line in [&plain, &pre] {
            let args: Vec<&str> = line.split_whitespace().collect();
            let out = ercube(d, &args);
            assert!(out.status.success(), "{}", describe(&args, &out));
        }
        let (p, q) = (
            std::fs::read(d.join("p.npy")),
            std::fs::read(d.join("q.npy")),
        );
        assert_ne!(
            p.unwrap(),
            q.unwrap(),
            "{m}: --preintegrate changed nothing"
        );
    }
    let cases: Vec<(String, &str)> = vec![
        (
            format!("{s} --method pipeline --preintegrate"),
            "pre-integrated",
        ),
        (
            format!("{s} --method pipeline-ftb --preintegrate"),
            "pre-integrated",
        ),
        (
            format!("{s} --method reference --preintegrate"),
            "slice-order",
        ),
        (format!("{s} --method mipmap --preintegrate"), "slice-order"),
        (
            format!("{s} --method er --preintegrate --substeps 2"),
            "--substeps",
        ),
        (format!("{s} --method er --preintegrate --shade"), "shade"),
        (
            format!("{s} --method er --preintegrate --voi sphere:10,10,10,5 --voi-ramp -1"),
            "ramp",
        ),
    ];
    for (line, needle) in &cases {
        let args: Vec<&str> = line.split_whitespace().collect();
        assert_refused(&args, &ercube(d, &args), needle);
    }
}
