//! `ercube rtl`: the sample datapath's Verilog, its file list and a README
//! naming every port the module declares; what is not emitted yet is
//! refused in one line naming it, leaving nothing behind.

use super::{assert_one_line_error, entries, ercube, tempdir};

/// The ports a module declares, from its port list.
fn declared_ports(v: &str) -> Vec<String> {
    let head = v.split("module ").nth(1).expect("a module");
    let list = head.split(");").next().expect("a port list");
    list.lines()
        .filter(|l| l.trim_start().starts_with("input") || l.trim_start().starts_with("output"))
        .map(|l| {
            l.trim()
                .trim_end_matches(',')
                .rsplit(' ')
                .next()
                .expect("a name")
                .to_owned()
        })
        .collect()
}

/// Both orders: the files, the README's port table lists every declared
/// port with its width, and states the depth the run printed; in both
/// orders the PE's sample stage too (its README section naming every port
/// it declares).
#[test]
fn rtl_writes_the_module_filelist_and_readme() {
    let dir = tempdir();
    let d = dir.path();
    for (order, depth) in [("btf", 35), ("ftb", 36)] {
        let out = format!("out_{order}");
        let run = ercube(d, &format!("rtl --out-dir {out} --order {order}")).ok();
        assert!(
            run.stdout().contains(&format!("{depth} clocks")),
            "{}",
            run.describe()
        );
        let o = d.join(&out);
        let mut want = vec![
            "README.md",
            "ercube_pe_readout.v",
            "ercube_pe_sample.v",
            "ercube_readout_array.v",
            "ercube_sample.v",
            "filelist.f",
        ];
        // Front to back, the PE's dense split and fold too; back to front
        // its dense merge.
        let split = if order == "ftb" {
            want.insert(3, "ercube_pe_split.v");
            want.insert(1, "ercube_pe_fold.v");
            "ercube_pe_split.v\nercube_pe_fold.v\n"
        } else {
            want.insert(1, "ercube_pe_merge.v");
            "ercube_pe_merge.v\n"
        };
        assert_eq!(entries(&o), want);
        let v = std::fs::read_to_string(o.join("ercube_sample.v")).unwrap();
        let readme = std::fs::read_to_string(o.join("README.md")).unwrap();
        assert_eq!(
            std::fs::read_to_string(o.join("filelist.f")).unwrap(),
            format!(
                "ercube_sample.v\nercube_pe_sample.v\nercube_pe_readout.v\nercube_readout_array.v\n{split}"
            )
        );
        for m in ["ercube_pe_readout", "ercube_readout_array"] {
            let text = std::fs::read_to_string(o.join(format!("{m}.v"))).unwrap();
            for p in declared_ports(&text) {
                assert!(
                    readme.contains(&format!("| `{p}` |")),
                    "{order}: README does not name {m}'s {p}"
                );
            }
        }
        let text = std::fs::read_to_string(o.join("ercube_pe_sample.v")).unwrap();
        assert!(
            text.contains("ercube_sample u_dp ("),
            "the PE instantiates the datapath"
        );
        let section = readme
            .split("## ercube_pe_sample: the PE's sample stage\n")
            .nth(1)
            .expect("README has the sample stage's section");
        let ports = declared_ports(&text);
        for p in [
            "clk",
            "bc_go",
            "edge_in",
            "edge_out",
            "iss_valid",
            "wb_data",
            "vld_data",
            "map_n_in",
            "map_sl_in",
            "pl_valid",
            "pl_hi",
        ] {
            assert!(ports.iter().any(|q| q == p), "no port {p} in {ports:?}");
        }
        for p in &ports {
            assert!(
                section.contains(&format!("| `{p}` |")),
                "README does not name ercube_pe_sample's {p}"
            );
        }
        assert!(
            run.stdout().contains("ercube_pe_sample.v ("),
            "{}",
            run.describe()
        );
        let ports = declared_ports(&v);
        for p in [
            "clk",
            "rst",
            "in_valid",
            "out_valid",
            "slot_m",
            "row_wy",
            "acc_a",
            "v11",
            "x0",
            "acc_out_r",
            "acc_out_a",
            "tbl_we",
            "tbl_sel",
            "tbl_addr",
            "tbl_data",
        ] {
            assert!(
                ports.iter().any(|q| q == p),
                "{order}: no port {p} in {ports:?}"
            );
        }
        for p in &ports {
            assert!(
                readme.contains(&format!("| `{p}` |")),
                "{order}: README does not name {p}"
            );
        }
        assert!(readme.contains(&format!("**{depth} clocks**")), "{order}");
    }
}

/// `--shading --voi --preint`: the three units' modules, the sample
/// composed with shading and the VOI and the sample with the
/// pre-integration unit beside the sample's, in the file list, each with its section in the README naming every port it
/// declares.
#[test]
fn rtl_writes_the_units() {
    let dir = tempdir();
    let d = dir.path();
    let run = ercube(d, "rtl --out-dir out --shading --voi --preint").ok();
    let o = d.join("out");
    let units = [
        "ercube_preint",
        "ercube_sample_composed",
        "ercube_sample_preint",
        "ercube_shading",
        "ercube_voi",
    ];
    let mut want: Vec<String> = [
        "README.md",
        "ercube_pe_merge.v",
        "ercube_pe_readout.v",
        "ercube_pe_sample.v",
        "ercube_readout_array.v",
        "ercube_sample.v",
        "filelist.f",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    want.extend(units.iter().map(|u| format!("{u}.v")));
    want.sort();
    assert_eq!(entries(&o), want);
    let list = std::fs::read_to_string(o.join("filelist.f")).unwrap();
    assert_eq!(
        list,
        "ercube_sample.v\nercube_shading.v\nercube_voi.v\nercube_preint.v\nercube_sample_composed.v\nercube_sample_preint.v\nercube_pe_sample.v\nercube_pe_readout.v\nercube_readout_array.v\nercube_pe_merge.v\n"
    );
    let readme = std::fs::read_to_string(o.join("README.md")).unwrap();
    for u in units {
        let v = std::fs::read_to_string(o.join(format!("{u}.v"))).unwrap();
        assert!(
            run.stdout().contains(&format!("{u}.v (")),
            "{}",
            run.describe()
        );
        let section = readme
            .split(&format!("## {u}\n"))
            .nth(1)
            .unwrap_or_else(|| panic!("README has no section {u}"));
        for p in declared_ports(&v) {
            assert!(
                section.contains(&format!("| `{p}` |")),
                "{u}: README does not name {p}"
            );
        }
    }
}

/// Each part not emitted yet, and a rounding mode without an emitter, is
/// refused in one line naming it, exit 2, nothing written.
#[test]
fn rtl_refuses_what_it_does_not_emit() {
    let dir = tempdir();
    let d = dir.path();
    for (flag, word) in [
        ("--pe", "state machines"),
        ("--array", "array"),
        ("--controller", "controller"),
    ] {
        let run = ercube(d, &format!("rtl --out-dir out {flag}"));
        assert_eq!(run.out.status.code(), Some(2), "{}", run.describe());
        assert_one_line_error(&run, word);
        assert!(entries(d).is_empty(), "{flag}: left {:?}", entries(d));
    }
    std::fs::write(
        d.join("conv.toml"),
        "color = { bits = 12, frac = 11, quant = \"RND_CONV\", overflow = \"SAT\", signed = false }\n",
    )
    .unwrap();
    let run = ercube(d, "rtl --out-dir out --config conv.toml");
    assert_eq!(run.out.status.code(), Some(2), "{}", run.describe());
    assert_one_line_error(&run, "RND_CONV");
    assert_eq!(entries(d), ["conv.toml"]);
    let run = ercube(d, "rtl --out-dir out --dims 64,0,64");
    assert_eq!(run.out.status.code(), Some(2), "{}", run.describe());
    assert_one_line_error(&run, "--dims");
    assert_eq!(entries(d), ["conv.toml"]);
}

/// With the rays in external memory the readout stage is not written, and
/// the run says so in one line.
#[test]
fn rtl_leaves_out_the_readout_of_an_external_ray_buffer() {
    let dir = tempdir();
    let d = dir.path();
    std::fs::write(d.join("ext.toml"), "ray_buffer = \"external\"\n").unwrap();
    let run = ercube(d, "rtl --out-dir out --config ext.toml").ok();
    assert!(
        run.stdout()
            .contains("readout not written: the readout from an external ray buffer"),
        "{}",
        run.describe()
    );
    assert_eq!(
        entries(&d.join("out")),
        [
            "README.md",
            "ercube_pe_merge.v",
            "ercube_sample.v",
            "filelist.f"
        ]
    );
}
