//! `vorl calibrate`: fit the camera-to-robot map from point pairs and write it as `cal.json`;
//! [`Calibration`] is what `vorl detect --calibration cal.json` loads and applies.
//!
//! The model follows from the columns of the points file (CSV with a header row, or JSON):
//!
//! - `u,v,x,y`: pixel `(u, v)` ↔ robot platform `(x, y)`: a plane [`Homography`] (at least 4
//!   pairs, no 3 of 4 on a line). `detect` then adds `"robot": {"x", "y", "angle_deg"}` from
//!   each part's position and angle.
//! - `X,Y,Z,x,y,z`: camera frame `(X, Y, Z)` (mm, the left camera's, as `position_mm` of a
//!   stereo detection) ↔ robot `(x, y, z)`: a [`RigidTransform`] (at least 3 pairs, not on one
//!   line). `detect` then adds `"robot": {"x", "y", "z"}` from each part's `position_mm`.
//!
//! Column names are matched exactly (`X` is not `x`); other columns are ignored.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde::{Deserialize, Serialize};
use serde_json::json;
use vorl_core::location::calibrate::{Homography, RigidTransform};

use crate::truth::PartJson;

/// Arguments of `vorl calibrate`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    vorl calibrate --points platform.csv --out cal.json      (columns u,v,x,y: pixel → platform)\n  \
    vorl calibrate --points rig.csv --out cal.json           (columns X,Y,Z,x,y,z: camera mm → robot)\n  \
    vorl calibrate --points points.json --out cal.json       ([{\"u\": …, \"v\": …, \"x\": …, \"y\": …}, …])\n  \
    vorl detect examples/plant --calibration cal.json --json")]
pub struct CalibrateArgs {
    /// Point pairs: CSV with a header row (u,v,x,y or X,Y,Z,x,y,z), or JSON (a list of objects
    /// with those keys, or {"points": [...]}).
    #[arg(long, value_name = "FILE")]
    pub points: PathBuf,
    /// Where to write the calibration (JSON).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// The calibration file, as written and read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct CalFile {
    /// `"homography"` or `"rigid"`.
    model: String,
    /// What the model maps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    maps: Option<String>,
    /// Homography, row-major, pixel → robot.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    matrix: Option<[[f32; 3]; 3]>,
    /// Rigid: rotation, row-major.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rotation: Option<[[f32; 3]; 3]>,
    /// Rigid: translation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    translation: Option<[f32; 3]>,
    /// RMS residual over the calibration points, robot units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rms: Option<f32>,
    /// Number of calibration points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    points: Option<usize>,
}

/// A loaded camera-to-robot map.
#[derive(Debug, Clone, PartialEq)]
pub enum Calibration {
    /// Pixel → platform `(x, y)`, and image angle → robot angle.
    Homography(Homography),
    /// Camera frame (mm) → robot frame.
    Rigid(RigidTransform),
}

impl Calibration {
    /// Reads a `cal.json` written by `vorl calibrate`.
    ///
    /// # Errors
    /// One line naming the file: missing, unreadable, not of that shape, an unknown model, or
    /// a matrix the core refuses (singular, not finite, not a rotation).
    pub fn load(path: &Path) -> Result<Calibration, String> {
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("{}: {}", path.display(), crate::io::io_problem(&e)))?;
        let f: CalFile = serde_json::from_str(&text)
            .map_err(|e| format!("{}: does not parse as a vorl calibration: {e}", path.display()))?;
        let bad = |what: &str| format!("{}: {what}", path.display());
        match f.model.as_str() {
            "homography" => {
                let m = f
                    .matrix
                    .ok_or_else(|| bad("a homography calibration needs \"matrix\""))?;
                Homography::from_matrix(m)
                    .map(Calibration::Homography)
                    .map_err(|e| bad(&e.to_string()))
            }
            "rigid" => {
                let r = f
                    .rotation
                    .ok_or_else(|| bad("a rigid calibration needs \"rotation\""))?;
                let t = f
                    .translation
                    .ok_or_else(|| bad("a rigid calibration needs \"translation\""))?;
                RigidTransform::from_parts(r, t)
                    .map(Calibration::Rigid)
                    .map_err(|e| bad(&e.to_string()))
            }
            other => Err(bad(&format!(
                "unknown model \"{other}\" (expected \"homography\" or \"rigid\")"
            ))),
        }
    }

    /// Adds `"robot"` to a part (or `"robot_note"` saying why not).
    pub fn apply(&self, part: &mut PartJson) {
        let value = match self {
            Calibration::Homography(h) => {
                let at = [part.x as f32, part.y as f32];
                match (h.map(at), h.map_angle(at, part.angle_deg as f32)) {
                    (Some([x, y]), Some(a)) => Ok(json!({"x": round6(x), "y": round6(y), "angle_deg": round6(a)})),
                    _ => Err("the position maps to infinity (on the platform's horizon line)"),
                }
            }
            Calibration::Rigid(rt) => {
                let p: Option<Vec<f32>> = part
                    .extra
                    .get("position_mm")
                    .and_then(|v| v.as_array())
                    .map(|a| a.iter().filter_map(|v| v.as_f64()).map(|v| v as f32).collect());
                match p.as_deref() {
                    Some(&[x, y, z]) => {
                        let [rx, ry, rz] = rt.map([x, y, z]);
                        Ok(json!({"x": round6(rx), "y": round6(ry), "z": round6(rz)}))
                    }
                    _ => Err("no 3-D position: a rigid calibration needs the stereo depth"),
                }
            }
        };
        match value {
            Ok(v) => {
                part.extra.insert("robot".into(), v);
            }
            Err(why) => {
                part.extra.insert("robot_note".into(), json!(why));
            }
        }
    }

    /// [`Calibration::apply`] to every part.
    pub fn apply_all(&self, parts: &mut [PartJson]) {
        for p in parts {
            self.apply(p);
        }
    }
}

/// The `"robot"` field of a part in words (`robot x 268.93 y 157.84 angle 20.44°`, or with
/// `z … mm`), or the `"robot_note"`; `None` when the part has neither.
pub fn robot_text(part: &PartJson) -> Option<String> {
    if let Some(r) = part.extra.get("robot") {
        let v = |k: &str| r.get(k).and_then(|v| v.as_f64());
        let mut t = format!(
            "robot x {:.2} y {:.2}",
            v("x").unwrap_or(f64::NAN),
            v("y").unwrap_or(f64::NAN)
        );
        if let Some(z) = v("z") {
            t += &format!(" z {z:.2}");
        }
        if let Some(a) = v("angle_deg") {
            t += &format!(" angle {a:.2}°");
        }
        return Some(t);
    }
    part.extra
        .get("robot_note")
        .and_then(|n| n.as_str())
        .map(|n| format!("no robot position: {n}"))
}

fn round6(v: f32) -> f64 {
    (f64::from(v) * 1e6).round() / 1e6
}

/// Point pairs read from a file.
#[derive(Debug, Clone, PartialEq)]
pub enum Points {
    /// `u,v,x,y`: pixel → platform.
    Plane(Vec<([f32; 2], [f32; 2])>),
    /// `X,Y,Z,x,y,z`: camera → robot.
    Space(Vec<([f32; 3], [f32; 3])>),
}

const PLANE: [&str; 4] = ["u", "v", "x", "y"];
const SPACE: [&str; 6] = ["X", "Y", "Z", "x", "y", "z"];

/// Which model a set of column names asks for: the rigid one when all of `X,Y,Z,x,y,z` are
/// there, else the homography when all of `u,v,x,y` are.
fn model_of<'a>(columns: impl Iterator<Item = &'a str> + Clone) -> Option<bool> {
    let has = |c: &str| columns.clone().any(|k| k == c);
    if SPACE.iter().all(|c| has(c)) {
        Some(true)
    } else if PLANE.iter().all(|c| has(c)) {
        Some(false)
    } else {
        None
    }
}

fn columns_problem(found: &[String]) -> String {
    format!(
        "columns must be u,v,x,y (pixel → platform homography) or X,Y,Z,x,y,z (camera mm → robot rigid transform); found: {}",
        if found.is_empty() {
            "none".to_string()
        } else {
            found.join(",")
        }
    )
}

/// Builds the pairs from rows of named values.
fn to_points(space: bool, rows: &[BTreeMap<String, f32>]) -> Points {
    let g = |r: &BTreeMap<String, f32>, k: &str| r.get(k).copied().unwrap_or(f32::NAN);
    if space {
        Points::Space(
            rows.iter()
                .map(|r| ([g(r, "X"), g(r, "Y"), g(r, "Z")], [g(r, "x"), g(r, "y"), g(r, "z")]))
                .collect(),
        )
    } else {
        Points::Plane(
            rows.iter()
                .map(|r| ([g(r, "u"), g(r, "v")], [g(r, "x"), g(r, "y")]))
                .collect(),
        )
    }
}

/// Reads the points file (CSV with a header row, or JSON).
///
/// # Errors
/// One line naming the file (and the line, for CSV): unreadable, no header, columns of neither
/// model, a value that is not a number.
pub fn read_points(path: &Path) -> Result<Points, String> {
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("{}: {}", path.display(), crate::io::io_problem(&e)))?;
    let json_like =
        path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) || text.trim_start().starts_with(['[', '{']);
    if json_like {
        read_json(path, &text)
    } else {
        read_csv(path, &text)
    }
}

fn read_csv(path: &Path, text: &str) -> Result<Points, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (_, header) = lines
        .next()
        .ok_or_else(|| format!("{}: empty file (expected a header row and point rows)", path.display()))?;
    let delim = [',', ';', '\t'].into_iter().find(|d| header.contains(*d));
    let split = |l: &str| -> Vec<String> {
        match delim {
            Some(d) => l.split(d).map(|s| s.trim().to_string()).collect(),
            None => l.split_whitespace().map(str::to_string).collect(),
        }
    };
    let names = split(header);
    let space = model_of(names.iter().map(String::as_str))
        .ok_or_else(|| format!("{}: {}", path.display(), columns_problem(&names)))?;
    let wanted: &[&str] = if space { &SPACE } else { &PLANE };
    let mut rows = Vec::new();
    for (no, line) in lines {
        let cells = split(line);
        let mut row = BTreeMap::new();
        for (name, cell) in names.iter().zip(&cells) {
            if !wanted.contains(&name.as_str()) {
                continue;
            }
            let v: f32 = cell
                .parse()
                .map_err(|_| format!("{}:{no}: '{cell}' in column {name} is not a number", path.display()))?;
            row.insert(name.clone(), v);
        }
        if let Some(missing) = wanted.iter().find(|c| !row.contains_key(**c)) {
            return Err(format!(
                "{}:{no}: no value in column {missing} ({} values for {} columns)",
                path.display(),
                cells.len(),
                names.len()
            ));
        }
        rows.push(row);
    }
    Ok(to_points(space, &rows))
}

fn read_json(path: &Path, text: &str) -> Result<Points, String> {
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("{}: does not parse as JSON: {e}", path.display()))?;
    let list = match &v {
        serde_json::Value::Array(a) => a,
        serde_json::Value::Object(o) => match o.get("points") {
            Some(serde_json::Value::Array(a)) => a,
            _ => {
                return Err(format!(
                    "{}: expected a list of points or {{\"points\": [...]}}",
                    path.display()
                ))
            }
        },
        _ => {
            return Err(format!(
                "{}: expected a list of points or {{\"points\": [...]}}",
                path.display()
            ))
        }
    };
    let first_keys: Vec<String> = list
        .first()
        .and_then(|p| p.as_object())
        .map(|o| o.keys().cloned().collect())
        .unwrap_or_default();
    let space = model_of(first_keys.iter().map(String::as_str))
        .ok_or_else(|| format!("{}: {}", path.display(), columns_problem(&first_keys)))?;
    let wanted: &[&str] = if space { &SPACE } else { &PLANE };
    let mut rows = Vec::new();
    for (i, p) in list.iter().enumerate() {
        let mut row = BTreeMap::new();
        for k in wanted {
            let value = p
                .get(*k)
                .and_then(|v| v.as_f64())
                .ok_or_else(|| format!("{}: point {} has no number \"{k}\"", path.display(), i + 1))?;
            row.insert(k.to_string(), value as f32);
        }
        rows.push(row);
    }
    Ok(to_points(space, &rows))
}

/// Fits the model the points ask for; the calibration file's contents and a summary line.
///
/// # Errors
/// The core's error (too few points, degenerate or non-finite points, singular), naming the
/// points file.
fn fit(path: &Path, points: &Points) -> Result<(CalFile, String), String> {
    let named = |e: vorl_core::Error| format!("{}: {e}", path.display());
    Ok(match points {
        Points::Plane(pairs) => {
            let (h, rms) = Homography::fit(pairs).map_err(named)?;
            (
                CalFile {
                    model: "homography".into(),
                    maps: Some("pixel (x, y) → robot platform (x, y); image angle → robot angle".into()),
                    matrix: Some(h.matrix()),
                    rotation: None,
                    translation: None,
                    rms: Some(rms),
                    points: Some(pairs.len()),
                },
                format!("homography (pixel → platform) from {} points", pairs.len()),
            )
        }
        Points::Space(pairs) => {
            let (rt, rms) = RigidTransform::fit(pairs).map_err(named)?;
            (
                CalFile {
                    model: "rigid".into(),
                    maps: Some("camera frame (X, Y, Z) mm → robot (x, y, z)".into()),
                    matrix: None,
                    rotation: Some(rt.rotation()),
                    translation: Some(rt.translation()),
                    rms: Some(rms),
                    points: Some(pairs.len()),
                },
                format!("rigid transform (camera → robot) from {} points", pairs.len()),
            )
        }
    })
}

/// Runs `vorl calibrate`.
///
/// # Errors
/// The points file cannot be read or fitted, or the output cannot be written: one line naming
/// the file.
pub fn run(args: CalibrateArgs) -> Result<ExitCode, String> {
    let points = read_points(&args.points)?;
    let (file, what) = fit(&args.points, &points)?;
    let text = serde_json::to_string_pretty(&file).map_err(|e| e.to_string())?;
    std::fs::write(&args.out, text + "\n").map_err(|e| format!("{}: cannot write ({e})", args.out.display()))?;
    println!(
        "{what}: RMS residual {:.6} (robot units); written to {}",
        file.rms.unwrap_or(f32::NAN),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let p = std::env::temp_dir().join(format!("vorl-calibrate-unit-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).expect("mkdir");
        p
    }

    #[test]
    fn reads_csv_and_json_and_picks_the_model() {
        let d = scratch("read");
        let csv = d.join("p.csv");
        std::fs::write(
            &csv,
            "# platform\nname, u, v, x, y\na, 0, 0, 10, 20\nb, 1.5, 2, 11, 22\n",
        )
        .unwrap();
        assert_eq!(
            read_points(&csv).unwrap(),
            Points::Plane(vec![([0.0, 0.0], [10.0, 20.0]), ([1.5, 2.0], [11.0, 22.0])])
        );
        let csv3 = d.join("r.csv");
        std::fs::write(&csv3, "X;Y;Z;x;y;z\n1;2;3;4;5;6\n").unwrap();
        assert_eq!(
            read_points(&csv3).unwrap(),
            Points::Space(vec![([1.0, 2.0, 3.0], [4.0, 5.0, 6.0])])
        );
        let js = d.join("p.json");
        std::fs::write(&js, r#"{"points": [{"u": 1, "v": 2, "x": 3, "y": 4}]}"#).unwrap();
        assert_eq!(read_points(&js).unwrap(), Points::Plane(vec![([1.0, 2.0], [3.0, 4.0])]));
        // Problems name the file (and the line).
        std::fs::write(&csv, "a,b,c\n1,2,3\n").unwrap();
        let e = read_points(&csv).unwrap_err();
        assert!(
            e.contains("p.csv: columns must be") && e.contains("found: a,b,c"),
            "{e}"
        );
        std::fs::write(&csv, "u,v,x,y\n1,2,oops,4\n").unwrap();
        let e = read_points(&csv).unwrap_err();
        assert!(e.contains("p.csv:2: 'oops' in column x is not a number"), "{e}");
        std::fs::write(&csv, "u,v,x,y\n1,2,3\n").unwrap();
        let e = read_points(&csv).unwrap_err();
        assert!(e.contains("p.csv:2: no value in column y"), "{e}");
        std::fs::write(&js, r#"[{"u": 1, "v": 2, "x": 3}]"#).unwrap();
        assert!(read_points(&js).unwrap_err().contains("columns must be"));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn homography_round_trip_through_the_file() {
        let d = scratch("fit");
        let robot = |u: f32, v: f32| [100.0 + 0.5 * u, 300.0 - 0.5 * v];
        let mut text = String::from("u,v,x,y\n");
        for (u, v) in [(0.0, 0.0), (640.0, 0.0), (640.0, 480.0), (0.0, 480.0), (320.0, 200.0)] {
            let [x, y] = robot(u, v);
            text += &format!("{u},{v},{x},{y}\n");
        }
        let pts = d.join("p.csv");
        std::fs::write(&pts, text).unwrap();
        let out = d.join("cal.json");
        run(CalibrateArgs {
            points: pts.clone(),
            out: out.clone(),
        })
        .unwrap();
        let cal = Calibration::load(&out).unwrap();
        let mut part = PartJson {
            class: None,
            x: 200.0,
            y: 100.0,
            angle_deg: 30.0,
            symmetry: None,
            score: None,
            partial: None,
            flipped: None,
            touching: None,
            extra: Default::default(),
        };
        cal.apply(&mut part);
        let r = &part.extra["robot"];
        assert!((r["x"].as_f64().unwrap() - 200.0).abs() < 1e-3, "{r}");
        assert!((r["y"].as_f64().unwrap() - 250.0).abs() < 1e-3, "{r}");
        assert!((r["angle_deg"].as_f64().unwrap() - 30.0).abs() < 1e-3, "{r}");
        // Rigid needs position_mm.
        let rigid = Calibration::Rigid(
            RigidTransform::from_parts([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [1.0, 2.0, 3.0]).unwrap(),
        );
        let mut p2 = part.clone();
        rigid.apply(&mut p2);
        assert!(p2.extra["robot_note"].as_str().unwrap().contains("no 3-D position"));
        p2.extra.insert("position_mm".into(), json!([10.0, 20.0, 30.0]));
        rigid.apply(&mut p2);
        assert_eq!(p2.extra["robot"], json!({"x": 11.0, "y": 22.0, "z": 33.0}));
        // Degenerate points: the core's error, naming the file.
        std::fs::write(&pts, "u,v,x,y\n0,0,0,0\n1,1,1,1\n2,2,2,2\n3,3,3,3\n").unwrap();
        let e = run(CalibrateArgs {
            points: pts.clone(),
            out: out.clone(),
        })
        .unwrap_err();
        assert!(e.contains("p.csv: ") && e.contains("collinear"), "{e}");
        std::fs::write(&pts, "u,v,x,y\n0,0,0,0\n1,0,1,0\n").unwrap();
        let e = run(CalibrateArgs {
            points: pts,
            out: out.clone(),
        })
        .unwrap_err();
        assert!(e.contains("2 point pairs given but at least 4 are needed"), "{e}");
        // Bad calibration files.
        std::fs::write(&out, r#"{"model": "affine"}"#).unwrap();
        assert!(Calibration::load(&out).unwrap_err().contains("unknown model"));
        std::fs::write(&out, r#"{"model": "homography", "matrix": [[0,0,0],[0,0,0],[0,0,0]]}"#).unwrap();
        assert!(Calibration::load(&out).unwrap_err().contains("cal.json: "));
        std::fs::write(&out, "{").unwrap();
        assert!(Calibration::load(&out).unwrap_err().contains("does not parse"));
        let _ = std::fs::remove_dir_all(&d);
    }
}
