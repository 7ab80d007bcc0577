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

/// The docs and comments describe the product as it is: no development
/// narrative (the phrases below, or a numbered development step); the
/// history is in git.
#[test]
fn docs_and_comments_tell_no_development_story() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    // Each phrase is a needle, not narrative; the one a repository-wide
    // phrase check also looks for is spelled in two pieces so that this
    // list is not itself a finding.
    let phrases = [
        "this round",
        concat!("other", " sessions"),
        "earlier session",
        "helpers were",
        "two helpers",
        "sessions built",
    ];
    // The word for a development step followed by its number.
    let numbered_stop = |line: &str| {
        ["stop ", "stops "].iter().any(|w| {
            line.match_indices(w)
                .any(|(i, _)| line[i + w.len()..].starts_with(|c: char| c.is_ascii_digit()))
        })
    };
    let mut found = Vec::new();
    let mut stack: Vec<std::path::PathBuf> = [
        "README.md",
        "docs",
        "src",
        "golden/src",
        "pipeline/src",
        "waves/src",
    ]
    .iter()
    .map(|p| root.join(p))
    .collect();
    while let Some(p) = stack.pop() {
        if p.is_dir() {
            stack.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
            continue;
        }
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(ext, "md" | "rs") {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap().to_lowercase();
        for (n, line) in text.lines().enumerate() {
            if numbered_stop(line) || phrases.iter().any(|ph| line.contains(ph)) {
                let name = p.strip_prefix(root).unwrap().display();
                found.push(format!("{name}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "development narrative:\n{}",
        found.join("\n")
    );
}
