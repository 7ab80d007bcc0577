//! The rustdoc of every library crate builds with its intra-doc links
//! resolved: every pipeline stage links its golden twin, and a renamed or
//! removed golden item breaks this test instead of leaving a dead link.

use std::process::Command;

#[test]
fn intra_doc_links_resolve() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let root = env!("CARGO_MANIFEST_DIR");
    // Its own target directory: the test runs while `cargo test` holds
    // the workspace's.
    let target = std::path::Path::new(root).join("target").join("doc-check");
    let out = Command::new(cargo)
        .current_dir(root)
        .args([
            "doc",
            "--no-deps",
            "--quiet",
            "-p",
            "golden",
            "-p",
            "pipeline",
            "-p",
            "waves",
        ])
        .env("CARGO_TARGET_DIR", &target)
        .env(
            "RUSTDOCFLAGS",
            "-D rustdoc::broken_intra_doc_links -D rustdoc::private_intra_doc_links",
        )
        .output()
        .expect("cargo runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "cargo doc failed:\n{stderr}");
    let index = target
        .join("doc")
        .join("pipeline")
        .join("stages")
        .join("merge")
        .join("index.html");
    let html = std::fs::read_to_string(&index).expect("the merge stage's page");
    assert!(
        html.contains("golden/merge/fn.merge.html"),
        "the merge stage's page links golden's merge"
    );
}
