//! `ercube.pe_vectors` against the files of `ercube vectors --stage pe` for
//! the same frame (PE 1 of 3, `ml:16`, 12x12, front to back):
//! `python/tests/check_pe_vectors.py` requires every port's words each
//! clock, the memory writes, the tables, the constants and the counts to
//! be the files', each issued sample's write-back to be
//! `ercube.Datapath.eval`'s on the arrays' bundle, and the errors to raise
//! `ercube.Error` with one-line messages; and the same of the round-robin
//! mappings' frames (`tests/support/round_robin.rs`), their column map and
//! column decoder among the memory writes.

use std::process::Command;

use serde_json::{json, Map, Value};

use super::{installed, ml16_pe1_vectors, root, round_robin, round_robin_pe1_vectors};

#[test]
fn the_python_pe_vectors_are_the_files_words() {
    let Some(py) = installed() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let vec = dir.path().join("vec");
    ml16_pe1_vectors(&vec, &["--tf", "ml"]);
    let out = Command::new(&py)
        .arg(root().join("python/tests/check_pe_vectors.py"))
        .arg(&vec)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_pe_vectors.py failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("pe_vectors: PE 1 (blocks): ")
            && text.contains("equal to the files and the model"),
        "{text}"
    );
    assert!(text.contains("errors raise ercube.Error"), "{text}");
}

/// The frame flags `--scene S` and the rest as `ercube.pe_vectors`'
/// arguments: `--size WxH` a pair, a list of numbers a list, other
/// values text, a flag with no value `True`.
fn frame_json(frame: &str, toml: &str) -> Value {
    let t: Vec<&str> = frame.split_whitespace().collect();
    let (mut scene, mut kw) = (String::new(), Map::new());
    kw.insert("pe".into(), json!(1));
    let mut i = 0;
    while i < t.len() {
        let key = t[i].trim_start_matches("--");
        let value = t.get(i + 1).filter(|v| !v.starts_with("--"));
        i += 1 + usize::from(value.is_some());
        let Some(v) = value else {
            kw.insert(key.replace('-', "_"), json!(true));
            continue;
        };
        match key {
            "scene" => scene = (*v).to_owned(),
            "size" => {
                let (w, h) = v.split_once('x').unwrap();
                kw.insert(
                    "size".into(),
                    json!([w.parse::<u32>().unwrap(), h.parse::<u32>().unwrap()]),
                );
            }
            _ => {
                let n: Result<Vec<f64>, _> = v.split(',').map(str::parse::<f64>).collect();
                let value = n.map_or_else(|_| json!(v), |n| json!(n));
                kw.insert(key.replace('-', "_"), value);
            }
        }
    }
    json!({"scene": scene, "config": toml, "kwargs": kw})
}

#[test]
fn the_python_pe_vectors_of_the_round_robin_mappings_are_the_files_words() {
    let Some(py) = installed() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for (name, toml, frame) in round_robin::FRAMES {
        let vec = dir.path().join(name).join("vec");
        round_robin_pe1_vectors(&vec, name, toml, frame);
        let out = Command::new(&py)
            .arg(root().join("python/tests/check_pe_vectors.py"))
            .arg(&vec)
            .arg(frame_json(frame, toml).to_string())
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "check_pe_vectors.py ({name}) failed:\n{text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            text.contains(&format!("pe_vectors: PE 1 ({name}): "))
                && text.contains("equal to the files and the model"),
            "{text}"
        );
    }
}
