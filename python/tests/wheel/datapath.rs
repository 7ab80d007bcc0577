//! `ercube.Datapath` against the description: random samples of every
//! unit in both orders, the words `Datapath.eval` returns equal to
//! [`Unit::eval`]'s (which the C ABI's test and `hw`'s tests prove equal
//! to the model's `Datapath`), its ports and latency equal, and its errors
//! raised as `ercube.Error` with one-line messages.

use std::collections::BTreeMap;
use std::process::Command;

use pipeline::hw::unit::{Port, Unit};
use serde_json::{json, Value};

use super::{installed, root};

fn ports(ps: &[Port]) -> Value {
    ps.iter()
        .map(|p| {
            json!({"name": p.name, "bits": p.word.bits, "frac": p.word.frac, "signed": p.word.signed})
        })
        .collect()
}

#[test]
fn the_python_datapath_gives_the_models_words() {
    let Some(py) = installed() else {
        return;
    };
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed as i64
    };
    let mut cases = Vec::new();
    for (unit, order, tf) in [
        ("sample", "btf", "brain"),
        ("sample", "ftb", "ml"),
        ("bilinear", "btf", ""),
        ("composite", "btf", ""),
        ("composite", "ftb", ""),
    ] {
        let mut u = Unit::from_toml(None, Some(order), unit).unwrap();
        if !tf.is_empty() {
            u.fill_tables(tf).unwrap();
        }
        let mut samples = Vec::new();
        while samples.len() < 100 {
            let words: Vec<i64> = u
                .inputs()
                .iter()
                .map(|p| {
                    let span = 1i128 << p.word.bits;
                    let lo = if p.word.signed { -(span / 2) } else { 0 };
                    let w = (i128::from(next()).rem_euclid(span) + lo) as i64;
                    // Ray index and positions as a frame has them.
                    match p.name.as_str() {
                        "slot_m" => w % 400,
                        "a" | "b" | "sy" | "sz" => w >> 20,
                        _ => w,
                    }
                })
                .collect();
            let Ok(out) = u.eval(&words) else {
                continue;
            };
            let ins: BTreeMap<&str, i64> = u
                .inputs()
                .iter()
                .map(|p| p.name.as_str())
                .zip(words)
                .collect();
            let outs: BTreeMap<&str, i64> = u
                .outputs()
                .iter()
                .map(|p| p.name.as_str())
                .zip(out)
                .collect();
            samples.push(json!([ins, outs]));
        }
        cases.push(json!({
            "unit": unit, "order": order, "tf": tf, "latency": u.latency(),
            "inputs": ports(u.inputs()), "outputs": ports(u.outputs()), "samples": samples,
        }));
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cases.json");
    std::fs::write(&file, serde_json::to_string(&cases).unwrap()).unwrap();
    let out = Command::new(&py)
        .arg(root().join("python/tests/check_datapath.py"))
        .arg(&file)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_datapath.py failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(text.matches("100 samples same").count(), 5, "{text}");
    assert!(text.contains("errors raise ercube.Error"), "{text}");
}
