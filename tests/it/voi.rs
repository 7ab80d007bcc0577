//! The volume of interest through the program's pipeline: `render
//! --method pipeline --voi` renders, and its image is within the derived
//! bound (`pipeline::bound::voi_error_bound`) of golden `er` with the same
//! VOI; a VOI the stage cannot hold is refused in one line.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::tf::Lut;
use golden::voi::{Shape, Voi};
use pipeline::bound::{voi_error_bound, BoundInputs, VoiInputs};
use pipeline::config::PipelineConfig;

use crate::bin::{assert_refused, describe, ercube};

const EYE: [f64; 3] = [20.0, 14.0, -30.0];
const LOOK: [f64; 3] = [12.0, 12.0, 12.0];

/// The derived bound of the default pipeline on `scene` seen as the
/// program sees it, with `voi`.
fn bound(scene: &str, voi: &Voi) -> f64 {
    let s: golden::scenes::Scene = scene.parse().unwrap();
    let vol = s.build(golden::volume::DEFAULT_MEMORY_LIMIT).unwrap();
    let cam = Camera::new(
        DVec3::from_array(EYE),
        DVec3::from_array(LOOK),
        DVec3::Y,
        40.0,
        32,
        32,
    )
    .unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    let cfg = PipelineConfig::default();
    let lut = Lut::for_bits(&s.preset(), cfg.table_entries as usize, vol.kind().bits());
    let d = BoundInputs::measure(&vol, &lut, &prep.view).unwrap();
    let v = VoiInputs::measure(&cfg, &d, &prep.view, &lut, voi).unwrap();
    voi_error_bound(&cfg, &d, None, &v)
}

#[test]
fn pipeline_renders_a_voi_within_the_bound_of_golden() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let eye = format!("{},{},{}", EYE[0], EYE[1], EYE[2]);
    let look = format!("{},{},{}", LOOK[0], LOOK[1], LOOK[2]);
    for (spec, ramp, scale, outside) in [
        ("sphere:12,11,13,6", "3", 2.0, false),
        ("box:4,5,6,16,18,14", "0", 0.5, true),
    ] {
        let scale_s = scale.to_string();
        let mut args = vec![
            "render",
            "--scene",
            "sphere:24",
            "--size",
            "32x32",
            "--eye",
            &eye,
            "--look-at",
            &look,
            "--up",
            "0,1,0",
            "--fov",
            "40",
            "--method",
            "pipeline",
            "--voi",
            spec,
            "--voi-ramp",
            ramp,
            "--voi-scale",
            &scale_s,
            "--out",
            "p.png",
            "--stats",
            "p.json",
        ];
        if outside {
            args.push("--voi-outside");
        }
        let out = ercube(dir.path(), &args);
        assert!(out.status.success(), "{}", describe(&args, &out));
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("p.json")).unwrap()).unwrap();
        let e = &stats["error_vs_golden"];
        let voi = Voi {
            shape: spec.parse::<Shape>().unwrap(),
            scale,
            outside,
            ramp: ramp.parse().unwrap(),
        };
        let b = bound("sphere:24", &voi);
        let max = e["max_abs_255"].as_f64().unwrap();
        let rmse = e["rmse"].as_f64().unwrap();
        eprintln!(
            "{spec} ramp {ramp} scale {scale}: max {max} /255, rmse {rmse:.2e}, bound {b:.2e}"
        );
        // Each side rounds to 8 bits once: one level beyond the bound.
        assert!(
            max <= (255.0 * b).floor() + 1.0,
            "max {max} /255, bound {b}"
        );
        assert!(rmse <= b, "rmse {rmse}, bound {b}");
    }
}

#[test]
fn pipeline_refuses_a_voi_its_stage_cannot_hold() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let args = [
        "render",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--method",
        "pipeline",
        "--voi",
        "sphere:8,8,8,4",
        "--voi-ramp",
        "0.001",
        "--out",
        "p.png",
    ];
    assert_refused(&args, &ercube(dir.path(), &args), "voi_axis");
}
