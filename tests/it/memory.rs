//! The memory check through the program: frames estimated to need more
//! than `--max-memory` (or the machine's available memory) are refused
//! with one line before anything large is allocated. Every case here is
//! small or refused, so the tests allocate little whatever they ask for.

use crate::bin::{assert_refused, ercube};

fn refused(args: &str, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<&str> = args.split_whitespace().collect();
    let out = ercube(dir.path(), &args);
    assert_refused(&args, &out, needle);
    assert!(
        !dir.path().join("o.png").exists(),
        "a refused frame wrote its image"
    );
}

#[test]
fn a_frame_over_max_memory_is_refused_in_one_line() {
    for method in ["er", "er-ftb", "mipmap", "pipeline"] {
        refused(
            &format!("render --scene checker:16 --size 16x16 --method {method} --max-memory 1M --out o.png"),
            &format!("the {method} frame of a 16x16x16 U8 volume needs about"),
        );
    }
    refused(
        "compare --scene checker:16 --size 16x16 --max-memory 1M --out-dir out",
        "more than the 1.00 MiB --max-memory allows",
    );
}

#[test]
fn a_2048_checker_is_parsed_and_refused_before_it_is_built() {
    // 8 GiB of voxels: the check refuses it at once (building it would
    // take seconds and gigabytes).
    let t = std::time::Instant::now();
    refused(
        "render --scene checker:2048 --size 16x16 --max-memory 4G --out o.png",
        "2048x2048x2048 U8 volume needs about 16.",
    );
    assert!(t.elapsed().as_secs() < 30, "the refusal built the scene");
    refused(
        "render --scene checker:2049 --size 16x16 --out o.png",
        "out of range 2..=2048",
    );
}

#[test]
fn a_file_over_max_memory_is_refused_by_its_loader() {
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("v.raw");
    std::fs::write(&vol, vec![100u8; 32 * 32 * 32]).unwrap();
    let v = vol.display();
    // The volume alone is over the budget: the loader refuses it.
    refused(
        &format!(
            "render --volume {v} --raw-dims 32,32,32 --size 16x16 --max-memory 16K --out o.png"
        ),
        "over the memory limit of 16.0 KiB",
    );
    // The volume fits but the frame does not.
    refused(
        &format!(
            "render --volume {v} --raw-dims 32,32,32 --size 16x16 --max-memory 1M --out o.png"
        ),
        "the er frame of a 32x32x32 U8 volume",
    );
    for bad in ["0", "1Q", "lots"] {
        refused(
            &format!("render --scene checker:16 --max-memory {bad} --out o.png"),
            "--max-memory",
        );
    }
}

#[test]
fn a_frame_within_max_memory_renders() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "render",
        "--scene",
        "checker:16",
        "--size",
        "16x16",
        "--max-memory",
        "1G",
        "--out",
        "o.png",
    ];
    let out = ercube(dir.path(), &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("o.png").exists());
}

/// Runs `ercube args` under `ulimit -v` of `kib` KiB (an address-space
/// limit, as a batch system sets), in a fresh folder.
fn under_ulimit(kib: u64, args: &str) -> (std::process::Output, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let script = format!("ulimit -v {kib} && exec \"$0\" {args}");
    let out = std::process::Command::new("sh")
        .args(["-c", &script, crate::bin::BIN])
        .current_dir(dir.path())
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("sh runs");
    (out, dir)
}

#[test]
fn the_process_address_space_limit_bounds_every_frame() {
    // 3 GiB of address space: a 2048 or 1536 checker, a 16384x16384 image
    // and --max-memory past the limit are refused naming the limit, not
    // aborted when the allocation fails.
    for args in [
        "render --scene checker:2048 --size 16x16 --out o.png",
        "render --scene checker:1536 --size 16x16 --out o.png",
        "render --scene checker:16 --size 16384x16384 --out o.png",
        "render --scene checker:1536 --size 16x16 --max-memory 100G --out o.png",
        "compare --scene checker:1536 --size 16x16 --out-dir out",
    ] {
        let (out, dir) = under_ulimit(3 << 20, args);
        let argv: Vec<&str> = args.split_whitespace().collect();
        assert_refused(&argv, &out, "address-space limit (RLIMIT_AS");
        assert!(
            std::fs::read_dir(dir.path()).unwrap().next().is_none(),
            "{args}: left files"
        );
    }
    // A small frame still renders under the same limit.
    let (out, dir) = under_ulimit(
        3 << 20,
        "render --scene checker:16 --size 16x16 --out o.png",
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("o.png").exists());
}
