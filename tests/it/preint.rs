//! `--preintegrate` through the program: the slice-order methods and the
//! pipeline model take it (and it changes their image; the pipeline's
//! stays within a grey level of golden's pre-integrated frame), and
//! `ercube cost` prices it; `--pre-colouring attenuated` changes golden's
//! image; the reference and the mip-map refuse it in one line, as do the
//! options it does not combine with (the pipeline refuses the attenuated
//! colouring).

use crate::bin::{assert_refused, describe, ercube};

#[test]
fn preintegrate_is_taken_by_slice_methods_and_refused_elsewhere() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let s = "render --scene sphere:20 --size 20x20";
    for m in [
        "er",
        "er-ftb",
        "under",
        "over",
        "box",
        "pipeline",
        "pipeline-ftb",
    ] {
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
    // The attenuated colouring changes a golden pre-integrated image (the
    // sphere's colours vary along its thick steps).
    for m in ["er", "er-ftb"] {
        let mut images = Vec::new();
        for c in ["fast", "attenuated"] {
            let line = format!(
                "{s} --method {m} --preintegrate --pre-colouring {c} --out q.png --npy q.npy"
            );
            let args: Vec<&str> = line.split_whitespace().collect();
            let out = ercube(d, &args);
            assert!(out.status.success(), "{}", describe(&args, &out));
            images.push(std::fs::read(d.join("q.npy")).unwrap());
        }
        assert_ne!(
            images[0], images[1],
            "{m}: the attenuated colouring changed nothing"
        );
    }
    for m in ["pipeline", "pipeline-ftb"] {
        let line = format!("{s} --method {m} --preintegrate --out q.png --stats q.json");
        let args: Vec<&str> = line.split_whitespace().collect();
        let out = ercube(d, &args);
        assert!(out.status.success(), "{}", describe(&args, &out));
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("q.json")).unwrap()).unwrap();
        let err = &stats["error_vs_golden"];
        let max = err["max_abs_255"]
            .as_f64()
            .expect("the pipeline's error against golden");
        assert!(
            max <= 1.0,
            "{m}: {max} grey levels from golden's pre-integrated frame"
        );
    }
    let args = [
        "cost",
        "--preintegrate",
        "--scene",
        "checker:32",
        "--sweep-pes",
        "none",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("preint"),
        "the report names no pre-integration unit:\n{text}"
    );
    let cases: Vec<(String, &str)> = vec![
        (
            format!("{s} --method pipeline --preintegrate --clip 1,0,0,-10"),
            "clip planes",
        ),
        (
            format!("{s} --method pipeline-ftb --preintegrate --shade"),
            "shade",
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
        (
            format!("{s} --method er --pre-colouring attenuated"),
            "--preintegrate",
        ),
        (
            format!("{s} --method er --preintegrate --pre-colouring thick"),
            "fast, attenuated or exact",
        ),
        (
            format!("{s} --method pipeline --preintegrate --pre-colouring attenuated"),
            "fast and exact colourings",
        ),
    ];
    for (line, needle) in &cases {
        let args: Vec<&str> = line.split_whitespace().collect();
        assert_refused(&args, &ercube(d, &args), needle);
    }
}
