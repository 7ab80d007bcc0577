//! `ercube.pe_vectors` against the files of `ercube vectors --stage pe` for
//! the same frame (PE 1 of 3, `ml:16`, 12x12, front to back):
//! `python/tests/check_pe_vectors.py` requires every port's words each
//! clock, the memory writes, the tables, the constants and the counts to
//! be the files', each issued sample's write-back to be
//! `ercube.Datapath.eval`'s on the arrays' bundle, and the errors to raise
//! `ercube.Error` with one-line messages.

use std::process::Command;

use super::{installed, ml16_pe1_vectors, root};

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
        text.contains("pe_vectors: PE 1: ") && text.contains("equal to the files and the model"),
        "{text}"
    );
    assert!(text.contains("errors raise ercube.Error"), "{text}");
}
