//! Integration tests of stereo sets and robot coordinates: `vorl eval` and `vorl detect` on
//! sets written by `vorl gen --variant stereo`, bad stereo input, and `vorl calibrate` with
//! `vorl detect --calibration`.
//!
//! Every test runs the real binary on sets generated into its own temporary folder and checks
//! properties that follow from the contracts (DESIGN.md: `camera.json`, the pinhole model,
//! truth keyed by `<name>.png` with `z_mm` and `disparity_px`), from the issue's accuracy
//! requirements, or from how the inputs were made (a known homography or rigid motion).

use std::path::{Path, PathBuf};

use serde_json::Value;

mod common;
use common::{vorl, Scratch};

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A stereo set of `frames` pairs (`w`×`h`) generated into `dir/name`.
fn gen_stereo(dir: &Scratch, name: &str, seed: u64, frames: usize, w: u32, h: u32) -> PathBuf {
    let out = dir.join(name);
    vorl([
        "gen",
        s(&out),
        "--variant",
        "stereo",
        "--seed",
        &seed.to_string(),
        "--frames",
        &frames.to_string(),
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
    ])
    .success();
    out
}

fn num(v: &Value, k: &str) -> f64 {
    v[k].as_f64().unwrap_or_else(|| panic!("no number {k} in {v}"))
}

// ---------------------------------------------------------------------------------------------
// Accuracy (the issue's figures)
// ---------------------------------------------------------------------------------------------

#[test]
fn stereo_eval_meets_the_disparity_and_depth_figures() {
    let dir = Scratch::new("eval");
    let set = gen_stereo(&dir, "set", 21, 8, 640, 480);
    let out = vorl(["eval", s(&set), "--json"]).success();
    let r = out.json();
    let (refined, centroid) = (&r["disparity"], &r["disparity_centroid"]);
    let parts = num(&r, "truth_parts");
    eprintln!(
        "refined: {refined}\ncentroid: {centroid}\npolygon: {}\ndepth: {} mm, {} %",
        r["disparity_polygon"], r["depth_mm"], r["depth_pct"]
    );
    assert!(parts >= 16.0, "{r}");
    // Every part found, paired and given a depth.
    assert_eq!(num(&r, "detected"), parts, "{r}");
    assert_eq!(num(refined, "count"), parts, "{r}");
    assert_eq!(num(&r["depth_pct"], "count"), parts, "{r}");
    assert!(r.get("stereo_without_depth").is_none(), "{r}");
    // The issue's figures.
    assert!(num(refined, "median") <= 0.015, "{refined}");
    assert!(num(refined, "p95") <= 0.05, "{refined}");
    assert!(num(&r["depth_pct"], "median") <= 0.02, "{}", r["depth_pct"]);
    // The refinement beats the paper's centroid disparity.
    assert!(
        num(refined, "median") < num(centroid, "median"),
        "{refined} vs {centroid}"
    );
    assert!(num(refined, "p95") < num(centroid, "p95"), "{refined} vs {centroid}");
    // The table shows both side by side.
    let table = vorl(["eval", s(&set)]).success().stdout;
    assert!(
        table.contains("centroid (paper)") && table.contains("refined"),
        "{table}"
    );
    assert!(table.contains("depth error"), "{table}");
}

#[test]
fn stereo_detect_reports_depth_and_camera_frame_position() {
    let dir = Scratch::new("detect");
    let set = gen_stereo(&dir, "set", 4, 3, 640, 480);
    let cam: Value = serde_json::from_str(&std::fs::read_to_string(set.join("camera.json")).unwrap()).unwrap();
    let truth: Value = serde_json::from_str(&std::fs::read_to_string(set.join("truth.json")).unwrap()).unwrap();
    let (f, b, cx, cy) = (
        num(&cam, "f_px"),
        num(&cam, "baseline_mm"),
        num(&cam, "cx"),
        num(&cam, "cy"),
    );
    let out = vorl(["detect", s(&set), "--json"]).success();
    let pred = out.json();
    let frames = pred["frames"].as_object().unwrap();
    // Keyed like truth: <name>.png, not left_<name>.png.
    let keys: Vec<&String> = frames.keys().collect();
    let truth_keys: Vec<&String> = truth["frames"].as_object().unwrap().keys().collect();
    assert_eq!(keys, truth_keys);
    for (name, parts) in frames {
        for p in parts.as_array().unwrap() {
            let d = num(p, "disparity_px");
            let z = num(p, "z_mm");
            let pos: Vec<f64> = p["position_mm"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            // The pinhole model, in the left camera's frame.
            assert!((z - f * b / d).abs() < 1e-3, "{name}: {p}");
            assert!((pos[2] - z).abs() < 1e-9, "{p}");
            assert!((pos[0] - (num(p, "x") - cx) * z / f).abs() < 1e-3, "{p}");
            assert!((pos[1] - (num(p, "y") - cy) * z / f).abs() < 1e-3, "{p}");
            assert!(
                p["disparity_centroid_px"].is_number() && p["disparity_refined"] == Value::Bool(true),
                "{p}"
            );
            // The nearest truth part has nearly this depth.
            let t = truth["frames"][name]
                .as_array()
                .unwrap()
                .iter()
                .min_by(|a, c| {
                    let da = (num(a, "x") - num(p, "x")).hypot(num(a, "y") - num(p, "y"));
                    let dc = (num(c, "x") - num(p, "x")).hypot(num(c, "y") - num(p, "y"));
                    da.total_cmp(&dc)
                })
                .unwrap();
            assert!((num(t, "z_mm") - z).abs() < 1.0, "{p} vs {t}");
        }
    }
    // The human output says the same.
    let text = vorl(["detect", s(&set)]).success().stdout;
    assert!(text.contains("paired") && text.contains("Z "), "{text}");
}

// ---------------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------------

/// A 3-pair stereo set, small.
fn small_set(dir: &Scratch) -> PathBuf {
    gen_stereo(dir, "small", 9, 3, 400, 300)
}

#[test]
fn missing_right_frame_names_it_and_keeps_the_others() {
    let dir = Scratch::new("missing");
    let set = small_set(&dir);
    std::fs::remove_file(set.join("frames/right_f001.png")).unwrap();
    let out = vorl(["detect", s(&set), "--json"]).failure();
    let errors = out.errors();
    assert_eq!(errors.len(), 1, "{}", out.dump());
    assert!(
        errors[0].contains("right_f001.png") && errors[0].contains("no such file"),
        "{}",
        out.dump()
    );
    let frames = out.json()["frames"].as_object().unwrap().clone();
    assert_eq!(frames.keys().collect::<Vec<_>>(), ["f000.png", "f002.png"]);
    // eval too: the pair is not scored, the others are.
    let out = vorl(["eval", s(&set), "--json"]).failure();
    assert!(
        out.errors().iter().any(|e| e.contains("right_f001.png")),
        "{}",
        out.dump()
    );
    assert_eq!(num(&out.json(), "failed_frames"), 1.0);
}

#[test]
fn right_frame_of_another_size_names_it_and_keeps_the_others() {
    let dir = Scratch::new("size");
    let set = small_set(&dir);
    image::GrayImage::from_pixel(200, 150, image::Luma([128]))
        .save(set.join("frames/right_f002.png"))
        .unwrap();
    let out = vorl(["detect", s(&set), "--json"]).failure();
    let errors = out.errors();
    assert_eq!(errors.len(), 1, "{}", out.dump());
    assert!(
        errors[0].contains("right_f002.png") && errors[0].contains("200×150") && errors[0].contains("400×300"),
        "{}",
        out.dump()
    );
    let frames = out.json()["frames"].as_object().unwrap().clone();
    assert_eq!(frames.keys().collect::<Vec<_>>(), ["f000.png", "f001.png"]);
}

#[test]
fn bad_camera_file_is_named_and_frames_still_processed() {
    let dir = Scratch::new("camera");
    let set = small_set(&dir);
    for (text, needle) in [
        (r#"{"f_px": 0, "baseline_mm": 60, "cx": 199.5, "cy": 149.5}"#, "f_px"),
        (r#"{"f_px": -800, "baseline_mm": 60, "cx": 199.5, "cy": 149.5}"#, "f_px"),
        (
            r#"{"f_px": 800, "baseline_mm": 0, "cx": 199.5, "cy": 149.5}"#,
            "baseline_mm",
        ),
        (
            r#"{"f_px": 800, "baseline_mm": -60, "cx": 199.5, "cy": 149.5}"#,
            "baseline_mm",
        ),
        (r#"{"f_px": 800, "baseline_mm": "#, "does not parse"),
    ] {
        std::fs::write(set.join("camera.json"), text).unwrap();
        let out = vorl(["detect", s(&set), "--json"]).failure();
        let errors = out.errors();
        assert_eq!(errors.len(), 1, "{}", out.dump());
        assert!(
            errors[0].contains("camera.json") && errors[0].contains(needle),
            "{}",
            out.dump()
        );
        let pred = out.json();
        let frames = pred["frames"].as_object().unwrap();
        assert_eq!(frames.len(), 3, "{}", out.dump());
        for p in frames.values().flat_map(|v| v.as_array().unwrap()) {
            assert!(p.get("z_mm").is_none() && p["stereo"].is_string(), "{p}");
            assert!(p["disparity_px"].is_number(), "{p}");
        }
    }
}

#[test]
fn a_part_seen_in_one_view_only_is_reported_without_depth() {
    let dir = Scratch::new("oneview");
    let set = small_set(&dir);
    let truth: Value = serde_json::from_str(&std::fs::read_to_string(set.join("truth.json")).unwrap()).unwrap();
    // f000: the right camera sees the empty platform; f001: the left one does.
    std::fs::copy(set.join("background_right.png"), set.join("frames/right_f000.png")).unwrap();
    std::fs::copy(set.join("background_left.png"), set.join("frames/left_f001.png")).unwrap();
    let out = vorl(["detect", s(&set), "--json"]).success();
    let pred = out.json();
    let count = |name: &str| truth["frames"][name].as_array().unwrap().len();
    let f0 = pred["frames"]["f000.png"].as_array().unwrap();
    assert_eq!(f0.len(), count("f000.png"), "{pred}");
    for p in f0 {
        assert!(p.get("z_mm").is_none(), "{p}");
        assert!(p["stereo"].as_str().unwrap().contains("left image only"), "{p}");
    }
    let f1 = pred["frames"]["f001.png"].as_array().unwrap();
    assert_eq!(f1.len(), count("f001.png"), "{pred}");
    for p in f1 {
        assert_eq!(p["view"], "right", "{p}");
        assert!(p["stereo"].as_str().unwrap().contains("right image only"), "{p}");
    }
    // f002 is untouched and fully paired.
    for p in pred["frames"]["f002.png"].as_array().unwrap() {
        assert!(p["z_mm"].is_number(), "{p}");
    }
}

// ---------------------------------------------------------------------------------------------
// Calibration
// ---------------------------------------------------------------------------------------------

/// A homography pixel → platform mm: a camera ~700 mm up, tilted, 0.9 mm per pixel.
const H: [[f64; 3]; 3] = [[0.91, 0.04, -250.0], [-0.03, -0.88, 260.0], [2.0e-5, -3.0e-5, 1.0]];

fn apply_h(p: [f64; 2]) -> [f64; 2] {
    let w = H[2][0] * p[0] + H[2][1] * p[1] + H[2][2];
    [
        (H[0][0] * p[0] + H[0][1] * p[1] + H[0][2]) / w,
        (H[1][0] * p[0] + H[1][1] * p[1] + H[1][2]) / w,
    ]
}

/// The robot angle of the image direction `angle_deg` at `p` (finite difference in f64).
fn angle_h(p: [f64; 2], angle_deg: f64) -> f64 {
    let a = angle_deg.to_radians();
    let e = 1e-4;
    let q = apply_h([p[0] + e * a.cos(), p[1] - e * a.sin()]);
    let o = apply_h(p);
    (q[1] - o[1]).atan2(q[0] - o[0]).to_degrees().rem_euclid(360.0)
}

#[test]
fn calibrate_homography_then_detect_with_robot_coordinates() {
    let dir = Scratch::new("calib");
    // 16 calibration points spread over a 640×480 image.
    let mut csv = String::from("u,v,x,y\n");
    for j in 0..4 {
        for i in 0..4 {
            let p = [20.0 + 200.0 * i as f64, 15.0 + 150.0 * j as f64];
            let r = apply_h(p);
            csv += &format!("{},{},{},{}\n", p[0], p[1], r[0], r[1]);
        }
    }
    let points = dir.join("points.csv");
    std::fs::write(&points, csv).unwrap();
    let cal = dir.join("cal.json");
    let out = vorl(["calibrate", "--points", s(&points), "--out", s(&cal)]).success();
    assert!(
        out.stdout.contains("homography") && out.stdout.contains("RMS residual"),
        "{}",
        out.dump()
    );
    let file: Value = serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    assert_eq!(file["model"], "homography");
    assert_eq!(file["points"], 16);
    assert!(num(&file, "rms") < 1e-3, "{file}");
    // A mono set: the parts' positions are held-back points.
    let set = dir.join("mono");
    vorl(["gen", s(&set), "--seed", "5", "--frames", "3"]).success();
    let pred = vorl(["detect", s(&set), "--calibration", s(&cal), "--json"])
        .success()
        .json();
    let (mut n, mut worst) = (0, 0.0f64);
    for p in pred["frames"]
        .as_object()
        .unwrap()
        .values()
        .flat_map(|v| v.as_array().unwrap())
    {
        let at = [num(p, "x"), num(p, "y")];
        let want = apply_h(at);
        let r = &p["robot"];
        let err = (num(r, "x") - want[0]).hypot(num(r, "y") - want[1]);
        assert!(err < 1e-3, "{p}: {err} mm");
        worst = worst.max(err);
        let da = (num(r, "angle_deg") - angle_h(at, num(p, "angle_deg"))).rem_euclid(360.0);
        assert!(da.min(360.0 - da) < 1e-3, "{p}");
        n += 1;
    }
    assert!(n >= 6, "{pred}");
    eprintln!("homography: {n} held-back part positions, worst mapped error {worst:.2e} mm");
    // The human output shows them too.
    let text = vorl(["detect", s(&set), "--calibration", s(&cal)]).success().stdout;
    assert!(text.contains("robot"), "{text}");
}

#[test]
fn calibrate_rigid_then_stereo_detect_with_robot_coordinates() {
    let dir = Scratch::new("rigid");
    // Robot = R·camera + t: 30° about z, then 180° about x (robot z up, camera z down).
    let (c, sn) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let r = [[c, -sn, 0.0], [-sn, -c, 0.0], [0.0, 0.0, -1.0]];
    let t = [412.5, -120.25, 905.0];
    let map = |p: [f64; 3]| -> [f64; 3] {
        let mut o = [0.0; 3];
        for i in 0..3 {
            o[i] = r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + t[i];
        }
        o
    };
    let mut csv = String::from("X,Y,Z,x,y,z\n");
    for p in [
        [-200.0, -150.0, 760.0],
        [210.0, -140.0, 790.0],
        [190.0, 160.0, 745.0],
        [-180.0, 170.0, 800.0],
        [5.0, 0.0, 770.0],
        [60.0, -70.0, 755.0],
    ] {
        let q = map(p);
        csv += &format!("{},{},{},{},{},{}\n", p[0], p[1], p[2], q[0], q[1], q[2]);
    }
    let points = dir.join("rig.csv");
    std::fs::write(&points, csv).unwrap();
    let cal = dir.join("cal.json");
    let out = vorl(["calibrate", "--points", s(&points), "--out", s(&cal)]).success();
    assert!(out.stdout.contains("rigid"), "{}", out.dump());
    let set = gen_stereo(&dir, "set", 6, 2, 640, 480);
    let pred = vorl(["detect", s(&set), "--calibration", s(&cal), "--json"])
        .success()
        .json();
    for p in pred["frames"]
        .as_object()
        .unwrap()
        .values()
        .flat_map(|v| v.as_array().unwrap())
    {
        let pos: Vec<f64> = p["position_mm"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let want = map([pos[0], pos[1], pos[2]]);
        let got = &p["robot"];
        for (k, w) in ["x", "y", "z"].iter().zip(want) {
            assert!((num(got, k) - w).abs() < 1e-3, "{p}: {k}");
        }
    }
    // A homography-free rigid calibration on a mono set: no 3-D position, said so.
    let mono = dir.join("mono");
    vorl([
        "gen",
        s(&mono),
        "--seed",
        "2",
        "--frames",
        "1",
        "--width",
        "320",
        "--height",
        "240",
    ])
    .success();
    let pred = vorl(["detect", s(&mono), "--calibration", s(&cal), "--json"])
        .success()
        .json();
    for p in pred["frames"]
        .as_object()
        .unwrap()
        .values()
        .flat_map(|v| v.as_array().unwrap())
    {
        assert!(p.get("robot").is_none() && p["robot_note"].is_string(), "{p}");
    }
}

#[test]
fn calibrate_rejects_bad_points_with_one_line_naming_the_file() {
    let dir = Scratch::new("badpts");
    let points = dir.join("pts.csv");
    let cal = dir.join("cal.json");
    for (text, needle) in [
        ("u,v,x,y\n0,0,0,0\n10,10,5,5\n20,20,10,10\n30,30,15,15\n", "collinear"),
        ("u,v,x,y\n0,0,0,0\n10,0,5,0\n0,10,0,5\n", "at least 4"),
        ("X,Y,Z,x,y,z\n0,0,0,0,0,0\n1,1,1,1,1,1\n", "at least 3"),
        ("X,Y,Z,x,y,z\n0,0,0,0,0,0\n1,1,1,1,1,1\n2,2,2,2,2,2\n", "collinear"),
        ("a,b\n1,2\n", "columns must be"),
        ("u,v,x,y\n1,2,three,4\n", "not a number"),
    ] {
        std::fs::write(&points, text).unwrap();
        let out = vorl(["calibrate", "--points", s(&points), "--out", s(&cal)]).failure();
        let errors = out.errors();
        assert_eq!(errors.len(), 1, "{}", out.dump());
        assert!(
            errors[0].contains("pts.csv") && errors[0].contains(needle),
            "{}",
            out.dump()
        );
        assert!(!cal.exists());
    }
    // A calibration file that is not one.
    std::fs::write(&cal, "{\"model\": \"homography\"}").unwrap();
    let set = dir.join("mono");
    vorl([
        "gen",
        s(&set),
        "--seed",
        "2",
        "--frames",
        "1",
        "--width",
        "320",
        "--height",
        "240",
    ])
    .success();
    let out = vorl(["detect", s(&set), "--calibration", s(&cal)]).failure();
    assert!(
        out.errors().len() == 1 && out.errors()[0].contains("cal.json"),
        "{}",
        out.dump()
    );
}
