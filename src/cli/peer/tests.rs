//! `ercube peer`'s parsing, table and ratio helpers.

use super::*;

#[test]
fn method_tokens() {
    let m = parse_peer_methods("reference, er,er-ftb:2,over").unwrap();
    assert_eq!(m.len(), 4);
    assert_eq!(m[2].label(), "er-ftb:2");
    assert_eq!(m[2].substeps, 2);
    assert_eq!(m[1].label(), "er");
    assert!(parse_peer_methods("er,er").is_err());
    assert!(parse_peer_methods("er:0").is_err());
    assert!(parse_peer_methods("er:x").is_err());
    assert!(parse_peer_methods("pipeline").is_err());
    assert!(parse_peer_methods("reference:2").is_err());
    assert!(parse_peer_methods("reference:pre").is_err());
    let p = parse_peer_methods("er-ftb:pre,er-ftb,er:pre-att").unwrap();
    assert_eq!(p[0].preintegrate, Some(Colouring::Fast));
    assert_eq!(p[1].preintegrate, None);
    assert_eq!(p[2].preintegrate, Some(Colouring::Attenuated));
    assert_eq!(p[0].label(), "er-ftb:pre");
    assert_eq!(p[2].label(), "er:pre-att");
    let x = parse_peer_methods("er-ftb:pre-exact").unwrap();
    assert_eq!(x[0].preintegrate, Some(Colouring::Exact));
    assert_eq!(x[0].label(), "er-ftb:pre-exact");
    assert!(parse_peer_methods("er:pre-x").is_err());
    assert!(parse_peer_methods("").is_err());
    let f = parse_peer_methods("er-ftb,er-ftb:fp").unwrap();
    assert_eq!((f[0].footprint, f[1].footprint), (false, true));
    assert_eq!(f[1].label(), "er-ftb:fp");
    assert!(parse_peer_methods("over:fp").is_err());
    assert!(parse_peer_methods("reference:fp").is_err());
}

#[test]
fn npy_round_trip_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.npy");
    let mut img = Image::new(3, 2);
    img.data[4] = [0.25, 0.5, 0.75, 1.0];
    img.write_npy(&p).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(read_npy_image(&bytes).unwrap(), img);
    assert!(read_npy_image(&bytes[..bytes.len() - 4]).is_err());
    assert!(read_npy_image(b"nonsense!!!!").is_err());
    let mut f8 = golden::image::npy_header("<f8", &[2, 3, 4]);
    f8.extend(vec![0u8; 2 * 3 * 4 * 8]);
    assert!(read_npy_image(&f8)
        .unwrap_err()
        .to_string()
        .contains("float32"));
    let mut rgb = golden::image::npy_header("<f4", &[2, 3, 3]);
    rgb.extend(vec![0u8; 2 * 3 * 3 * 4]);
    assert!(read_npy_image(&rgb).is_err());
    // numpy's own header layout (no trailing comma after the shape).
    let mut np = b"\x93NUMPY\x01\x00".to_vec();
    let h = "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 1, 4)}          \n";
    np.extend((h.len() as u16).to_le_bytes());
    np.extend(h.as_bytes());
    np.extend([0u8; 16]);
    assert_eq!(read_npy_image(&np).unwrap().width, 1);
}

#[test]
fn peer_report_and_table() {
    let out = "vtk.py: making the venv\n{\"peer\": \"vtk\", \"time_s\": 0.015, \"times_s\": [0.015], \"vtk_version\": \"9.7.2\", \"backend\": \"vtkEGLRenderWindow\", \"mapper\": \"m\", \"threads\": 2}\n";
    let r = parse_peer_report(out).unwrap();
    assert_eq!(r.threads, 2);
    assert_eq!(r.backend, "vtkEGLRenderWindow");
    assert!(parse_peer_report("nothing").is_err());
    assert!(parse_peer_report("{\"time_s\": -1}").is_err());
    assert!(parse_peer_report("{\"times\": 1}").is_err());
    let err = ImageError {
        max_abs_255: 12.0,
        rmse: 0.0027,
        psnr: 51.4,
    };
    let t = markdown_table(&[PeerRow {
        method: "vtk".into(),
        time_s: 0.0153,
        speedup: [Some(1.0), None],
        frames: 5,
        err,
    }]);
    assert!(
        t.contains("| vtk | 0.0153 | 1.00x | - | 5 | 0.0027 | 12 | 51.4 |"),
        "{t}"
    );
    // Both clocks, and a bad wall time refused.
    let both = "{\"time_s\": 0.012, \"timer\": \"mapper GetTimeToDraw\", \"wall_time_s\": 0.015}";
    let r = parse_peer_report(both).unwrap();
    assert_eq!((r.time_s, r.wall_time_s), (0.012, Some(0.015)));
    assert_eq!(r.timer, "mapper GetTimeToDraw");
    assert!(parse_peer_report("{\"time_s\": 0.01, \"wall_time_s\": -2}").is_err());
}

#[test]
fn speedups_are_the_peer_time_over_ours_on_each_clock() {
    let err = ImageError {
        max_abs_255: 0.0,
        rmse: 0.0,
        psnr: f64::INFINITY,
    };
    let row = |method: &str, time_s| PeerRow {
        method: method.into(),
        time_s,
        speedup: [None; 2],
        frames: 3,
        err,
    };
    let mut rows = vec![row("er", 0.004), row("vtk", 0.012), row("broken", 0.0)];
    set_speedups(&mut rows, 0.012, Some(0.016));
    assert_eq!(rows[0].speedup, [Some(3.0), Some(4.0)]);
    assert_eq!(rows[1].speedup, [Some(1.0), Some(0.016 / 0.012)]);
    // A zero time has no ratio rather than an infinite one.
    assert_eq!(rows[2].speedup, [None, None]);
    set_speedups(&mut rows, 0.012, None);
    assert_eq!(rows[0].speedup, [Some(3.0), None]);
    let t = markdown_table(&rows);
    assert!(t.contains("| er | 0.0040 | 3.00x | - |"), "{t}");
    assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
    assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
}
