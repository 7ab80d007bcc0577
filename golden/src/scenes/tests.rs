use super::*;
use crate::volume::DEFAULT_MEMORY_LIMIT;

fn build(spec: &str) -> Volume {
    spec.parse::<Scene>()
        .unwrap()
        .build(DEFAULT_MEMORY_LIMIT)
        .unwrap()
}

fn parse_err(spec: &str) -> String {
    let e = spec.parse::<Scene>().unwrap_err().to_string();
    assert!(!e.contains('\n'), "{e}");
    e
}

#[test]
fn specs_parse_with_defaults_and_round_trip() {
    let cases = [
        ("checker", Scene::Checker { n: 256, cube: 5 }),
        ("checker:32", Scene::Checker { n: 32, cube: 5 }),
        ("checker:3", Scene::Checker { n: 3, cube: 3 }),
        ("Checker:32:4", Scene::Checker { n: 32, cube: 4 }),
        ("ml", Scene::MarschnerLobb { n: 64 }),
        ("marschner-lobb:41", Scene::MarschnerLobb { n: 41 }),
        ("sphere", Scene::Sphere { n: 64 }),
        ("impulse", Scene::Impulse { n: 16 }),
        ("impulse:1024", Scene::Impulse { n: 1024 }),
    ];
    for (spec, want) in cases {
        let got: Scene = spec.parse().unwrap();
        assert_eq!(got, want, "{spec}");
        assert_eq!(got.to_string().parse::<Scene>().unwrap(), got);
        assert_eq!(got.dims(), [got.size(); 3]);
    }
}

#[test]
fn bad_specs_name_the_problem() {
    assert!(parse_err("checker:0").contains("size 0 is out of range 2..=2048"));
    assert!(parse_err("checker:2049").contains("size 2049 is out of range 2..=2048"));
    assert!(parse_err("checker:16:0").contains("cube size 0 is out of range 1..=16"));
    assert!(parse_err("checker:16:17").contains("cube size 17"));
    let e = parse_err("foo");
    assert!(
        e.contains("unknown scene 'foo'") && e.contains(USAGE),
        "{e}"
    );
    assert!(parse_err("ml:abc").contains("size 'abc' is not a whole number"));
    assert!(parse_err("ml:99999").contains("size 99999 is out of range"));
    assert!(parse_err("ml:-3").contains("'-3' is not a whole number"));
    assert!(parse_err("sphere:1").contains("size 1 is out of range"));
    assert!(parse_err("impulse:8:2").contains("too many fields"));
    assert!(parse_err("checker:8:2:1").contains("too many fields"));
    assert!(parse_err("").contains("unknown scene ''"));
    assert!(parse_err("checker::3").contains("'' is not a whole number"));
}

/// Reads the checker in its unmirrored frame (side wall at x = 0).
fn g(v: &Volume, x: usize, y: usize, z: usize) -> u16 {
    v.get(v.dims()[0] - 1 - x, y, z)
}

#[test]
fn checker_has_a_checkered_floor_and_walls() {
    let (n, c) = (32, 4);
    let v = build("checker:32:4");
    assert_eq!((v.dims(), v.kind()), ([n; 3], VoxelType::U8));
    let last = n - 1;
    // The closed corner cube is filled floor; its floor neighbours in x
    // and z are empty, the next ones filled again.
    assert_eq!(g(&v, 0, 0, last), CHECKER_FLOOR);
    assert_eq!(g(&v, c - 1, c - 1, last - (c - 1)), CHECKER_FLOOR);
    assert_eq!(g(&v, c, 0, last - c), CHECKER_FLOOR);
    assert_eq!(g(&v, 2 * c, 0, last - 2 * c), CHECKER_FLOOR);
    assert_eq!(g(&v, 2 * c + 1, 1, last - 2), CHECKER_FLOOR);
    assert_eq!(g(&v, 2 * c, c - 1, 5), CHECKER_FLOOR);
    assert_eq!(g(&v, 3 * c, c - 1, 5), 0);
    // Left wall (x < c) and rear wall (z > last - c) above the floor.
    assert_eq!(g(&v, 0, c, last - c), CHECKER_WALL);
    assert_eq!(g(&v, c - 1, 2 * c, last - 2 * c), CHECKER_WALL);
    assert_eq!(g(&v, 0, 2 * c, last - 3 * c), 0);
    assert_eq!(g(&v, c, c, last), CHECKER_WALL);
    assert_eq!(g(&v, 2 * c, c, last), 0);
    assert_eq!(g(&v, 3 * c, 5 * c, last - c + 1), CHECKER_WALL);
    // One cube thick: nothing in the room's interior.
    for z in 0..n - c {
        for y in c..n {
            for x in c..n {
                assert_eq!(g(&v, x, y, z), 0, "({x}, {y}, {z})");
            }
        }
    }
    // Floor and walls are half filled: the pattern alternates.
    let count = |val| v.data().iter().filter(|&&x| x == val).count();
    let floor_cells = n * n * c;
    assert_eq!(count(CHECKER_FLOOR), floor_cells / 2);
    assert!(count(CHECKER_WALL) > 0);
    assert_eq!(v.value_range(), (0, CHECKER_FLOOR));
}

#[test]
fn checker_with_partial_cubes_keeps_walls_one_cube_thick() {
    let v = build("checker:23:5");
    assert_eq!(g(&v, 0, 0, 22), CHECKER_FLOOR);
    assert_eq!(g(&v, 0, 7, 22 - 4), 0); // i + j + k = 0 + 1 + 0
    assert_eq!(g(&v, 0, 12, 22), CHECKER_WALL);
    for (x, y, z) in [(5, 5, 17), (22, 22, 0), (10, 10, 10)] {
        assert_eq!(g(&v, x, y, z), 0);
    }
    let whole = build("checker:2:2");
    assert!(whole.data().iter().all(|&x| x == CHECKER_FLOOR));
}

#[test]
fn marschner_lobb_matches_the_formula() {
    // Closed forms: at (0, 0, z), rho_r = cos(12 pi) = 1.
    assert!((marschner_lobb(0.0, 0.0, 0.0) - 0.6).abs() < 1e-12);
    assert!((marschner_lobb(0.0, 0.0, 1.0) - 0.2).abs() < 1e-12);
    assert!((marschner_lobb(0.0, 0.0, -1.0) - 1.0).abs() < 1e-12);
    let v = build("ml:65");
    assert_eq!(v.dims(), [65; 3]);
    assert_eq!(v.get(32, 32, 32), 153);
    assert_eq!(v.get(32, 32, 64), 51);
    assert_eq!(v.get(32, 32, 0), 255);
    let (x, y, z) = (3, 50, 17);
    let p = |i: usize| -1.0 + 2.0 * i as f64 / 64.0;
    let r = (p(x).powi(2) + p(y).powi(2)).sqrt();
    let rho_r = (2.0 * PI * 6.0 * (PI * r / 2.0).cos()).cos();
    let want = (1.0 - (PI * p(z) / 2.0).sin() + 0.25 * (1.0 + rho_r)) / 2.5;
    assert_eq!(v.get(x, y, z), (want * 255.0).round() as u16);
}

#[test]
fn sphere_is_a_smooth_shell() {
    let n = 64;
    let v = build("sphere:64");
    let c = 31.5;
    let (radius, half) = (0.4 * n as f64, 2.0);
    let mut full = 0;
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let d = ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2))
                    .sqrt();
                let val = v.get(x, y, z);
                if (d - radius).abs() <= half - 0.5 {
                    assert_eq!(val, 255);
                } else if (d - radius).abs() >= half + 0.5 {
                    assert_eq!(val, 0);
                }
                full += (val == 255) as usize;
            }
        }
    }
    // Shell volume 4 pi R^2 (T - 1) for the fully covered part.
    let expect = 4.0 * PI * radius * radius * (2.0 * half - 1.0);
    assert!(
        (full as f64 / expect - 1.0).abs() < 0.1,
        "{full} vs {expect}"
    );
    let (lo, hi) = v.value_range();
    assert_eq!((lo, hi), (0, 255));
    assert!(
        v.data().iter().any(|&x| x > 0 && x < 255),
        "edges are smooth"
    );
    assert_eq!(v.get(0, 0, 0), 0);
    assert_eq!(v.get(32, 32, 32), 0);
}

#[test]
fn impulse_is_one_voxel() {
    for spec in ["impulse:16", "impulse:7", "impulse:2"] {
        let v = build(spec);
        let n = v.dims()[0];
        assert_eq!(v.get(n / 2, n / 2, n / 2), 255);
        assert_eq!(v.data().iter().filter(|&&x| x != 0).count(), 1);
    }
}

#[test]
fn build_respects_the_memory_limit() {
    let s = Scene::Sphere { n: 1024 };
    let e = s.build(1 << 20).unwrap_err().to_string();
    assert!(e.contains("over the memory limit"), "{e}");
    let bad = Scene::Checker { n: 8, cube: 0 };
    assert!(bad.build(DEFAULT_MEMORY_LIMIT).is_err());
}

#[test]
fn presets_parse_validate_and_cover_their_scenes() {
    for &name in PRESETS {
        let tf = tf_preset(name).unwrap();
        let plain = TransferFunction::new(tf.points.clone()).unwrap();
        assert_eq!(plain.points, tf.points);
        assert_eq!(tf.material.is_some(), name == "brain-shaded", "{name}");
        let back = TransferFunction::from_toml_str(&tf.to_toml_string()).unwrap();
        assert_eq!(back, tf, "{name}");
    }
    let e = tf_preset("rainbow").unwrap_err().to_string();
    assert!(
        e.contains("'rainbow'") && e.contains(&PRESETS.join(", ")),
        "{e}"
    );
    for spec in ["checker", "ml", "sphere", "impulse"] {
        let scene: Scene = spec.parse().unwrap();
        assert_eq!(scene.preset(), tf_preset(spec).unwrap());
    }
    let checker = tf_preset("checker").unwrap();
    assert_eq!(checker.eval(0.0)[3], 0.0);
    assert_eq!(checker.eval(40.0)[3], 0.0);
    let close = |a: [f64; 4], b: [f64; 4]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12);
    assert!(close(
        checker.eval(CHECKER_WALL as f64),
        [1.0, 1.0, 1.0, 0.9]
    ));
    assert!(close(
        checker.eval(CHECKER_FLOOR as f64),
        [0.2, 0.3, 1.0, 0.9]
    ));
    let ramp = tf_preset("grey-ramp").unwrap();
    assert_eq!(ramp.eval(30.0)[3], 0.0);
    assert!((ramp.eval(90.0)[3] - 0.5).abs() < 1e-12);
    assert!((ramp.eval(90.0)[0] - 90.0 / 255.0).abs() < 1e-12);
    assert_eq!(ramp.eval(200.0)[3], 1.0);
    let ml = tf_preset("ml").unwrap();
    assert_eq!(ml.eval(99.0)[3], 0.0);
    assert!(ml.eval(140.0)[3] >= 0.9 - 1e-12);
    assert_eq!(tf_preset("impulse").unwrap().eval(255.0), [1.0; 4]);
}
