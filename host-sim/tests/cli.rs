//! Integration tests of the `vorl` command-line program.
//!
//! Every test runs the real binary (`CARGO_BIN_EXE_vorl`) as a user would, on fixture sets that
//! `vorl gen` writes into private temporary folders, and checks properties that follow from the
//! contracts in DESIGN.md, from the project's accuracy requirements, or from how the inputs
//! were made (a frame converted to RGB holds the same scene; a template taught from a frame sees
//! that frame's part at angle 0) — never numbers copied from the program's own output.
//!
//! Two sets are shared between tests and generated on first use: a default 640×480 set (seed 11,
//! 6 frames) for the accuracy, check and detect tests, and a small 200×200 set (seed 3, 4 frames,
//! one part per frame) for the cheap ones. Each lives in a folder that is removed when the last
//! test holding it finishes; a test's own files live in a [`Scratch`] folder removed on drop.
//!
//! Bad input must give a one-line `error:` on stderr naming the file and the problem, a non-zero
//! exit and no panic; in a batch of frames the good ones are still processed and reported.

use imageproc::drawing::draw_filled_rect_mut;
use imageproc::rect::Rect;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};

use image::{GrayImage, ImageBuffer, Luma, Rgb, RgbImage};
use serde_json::Value;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

mod common;
use common::{vorl, Out, Scratch};

/// A generated fixture set, shared by the tests that hold it.
struct Set {
    dir: Scratch,
}

impl Set {
    fn root(&self) -> PathBuf {
        self.dir.join("set")
    }
    fn background(&self) -> PathBuf {
        self.root().join("background.png")
    }
    fn templates(&self) -> PathBuf {
        self.root().join("templates")
    }
    fn frame(&self, name: &str) -> PathBuf {
        self.root().join("frames").join(name)
    }
    /// Frame file names in frames/, sorted.
    fn frame_names(&self) -> Vec<String> {
        png_names(&self.root().join("frames"))
    }
    fn truth(&self) -> Value {
        let text = std::fs::read_to_string(self.root().join("truth.json")).expect("read truth.json");
        serde_json::from_str(&text).expect("truth.json parses")
    }
    /// Truth parts of one frame.
    fn truth_parts(&self, frame: &str) -> Vec<Part> {
        parts_of(&self.truth(), frame)
    }
}

/// Generates a set with `vorl gen`, or returns the one another running test holds.
fn shared_set(slot: &Mutex<Weak<Set>>, tag: &str, gen_args: &[&str]) -> Arc<Set> {
    let mut guard = slot.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(set) = guard.upgrade() {
        return set;
    }
    let set = Arc::new(Set { dir: Scratch::new(tag) });
    let mut args: Vec<std::ffi::OsString> = vec!["gen".into(), set.root().into()];
    args.extend(gen_args.iter().map(Into::into));
    vorl(args).success();
    *guard = Arc::downgrade(&set);
    set
}

/// The default 640×480 set: seed 11, 6 frames.
fn default_set() -> Arc<Set> {
    static SLOT: Mutex<Weak<Set>> = Mutex::new(Weak::new());
    shared_set(&SLOT, "default", &["--seed", "11", "--frames", "6"])
}

/// A small 200×200 set: seed 3, 4 frames (one part each at this size).
fn small_set() -> Arc<Set> {
    static SLOT: Mutex<Weak<Set>> = Mutex::new(Weak::new());
    shared_set(
        &SLOT,
        "small",
        &["--seed", "3", "--frames", "4", "--width", "200", "--height", "200"],
    )
}

/// File names of the PNG files in a folder, sorted.
fn png_names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.to_ascii_lowercase().ends_with(".png"))
        .collect();
    v.sort();
    v
}

/// Copies a folder tree, leaving out top-level entries named in `skip`.
fn copy_tree(from: &Path, to: &Path, skip: &[&str]) {
    std::fs::create_dir_all(to).expect("create copy");
    for e in std::fs::read_dir(from).expect("read folder") {
        let e = e.expect("entry");
        let name = e.file_name();
        if skip.iter().any(|s| OsStr::new(s) == name) {
            continue;
        }
        let (src, dst) = (e.path(), to.join(&name));
        if src.is_dir() {
            copy_tree(&src, &dst, &[]);
        } else {
            std::fs::copy(&src, &dst).expect("copy file");
        }
    }
}

/// One part of truth.json or of `vorl detect --json`.
#[derive(Debug, Clone)]
struct Part {
    class: Option<String>,
    x: f64,
    y: f64,
    angle: f64,
    symmetry: u32,
}

/// The parts of one frame of a truth or prediction JSON.
fn parts_of(json: &Value, frame: &str) -> Vec<Part> {
    json["frames"][frame]
        .as_array()
        .unwrap_or_else(|| panic!("no frame {frame} in {json}"))
        .iter()
        .map(|p| Part {
            class: p["class"].as_str().map(String::from),
            x: p["x"].as_f64().expect("x"),
            y: p["y"].as_f64().expect("y"),
            angle: p["angle_deg"].as_f64().expect("angle_deg"),
            symmetry: p.get("symmetry").and_then(Value::as_u64).unwrap_or(1) as u32,
        })
        .collect()
}

/// The part of `parts` nearest to (x, y) and its distance.
fn nearest(parts: &[Part], x: f64, y: f64) -> Option<(&Part, f64)> {
    parts
        .iter()
        .map(|p| (p, (p.x - x).hypot(p.y - y)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Angle difference modulo 360/symmetry, in [0, period/2] (symmetry 0 or 1: modulo 360).
fn angle_diff(a: f64, b: f64, symmetry: u32) -> f64 {
    let period = 360.0 / f64::from(symmetry.max(1));
    let d = (a - b).rem_euclid(period);
    d.min(period - d)
}

/// 8-connected blobs of pixels above 127.
fn blobs(img: &GrayImage) -> usize {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let on = |x: i64, y: i64| x >= 0 && y >= 0 && x < w && y < h && img.get_pixel(x as u32, y as u32).0[0] > 127;
    let mut seen = vec![false; (w * h) as usize];
    let mut count = 0;
    for y0 in 0..h {
        for x0 in 0..w {
            if !on(x0, y0) || seen[(y0 * w + x0) as usize] {
                continue;
            }
            count += 1;
            seen[(y0 * w + x0) as usize] = true;
            let mut queue = VecDeque::from([(x0, y0)]);
            while let Some((x, y)) = queue.pop_front() {
                for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    let (nx, ny) = (x + dx, y + dy);
                    if on(nx, ny) && !seen[(ny * w + nx) as usize] {
                        seen[(ny * w + nx) as usize] = true;
                        queue.push_back((nx, ny));
                    }
                }
            }
        }
    }
    count
}

fn gray(path: &Path) -> GrayImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8()
}

/// Asserts the one-line error about `name`: exactly one stderr line mentions it, it starts
/// with `error:` and contains one of `problem` (case-insensitive).
fn assert_error_names(out: &Out, name: &str, problem: &[&str]) {
    let lines = out.stderr_lines_with(name);
    assert_eq!(
        lines.len(),
        1,
        "{}: expected one stderr line naming {name}:\n{}",
        out.cmd,
        out.dump()
    );
    let line = lines[0];
    assert!(line.starts_with("error:"), "{}: not an error line: {line:?}", out.cmd);
    let lower = line.to_lowercase();
    assert!(
        problem.iter().any(|p| lower.contains(&p.to_lowercase())),
        "{}: the error does not say what is wrong (expected one of {problem:?}): {line:?}",
        out.cmd
    );
}

/// Runs `detect --json` on the batch `good bad good2` of the small set and checks that the bad
/// frame is reported by name and the good ones are still detected and printed.
fn assert_batch_survives(bad: &Path, problem: &[&str]) {
    let set = small_set();
    let (g1, g2) = ("f000.png", "f001.png");
    let out = vorl([
        OsStr::new("detect"),
        OsStr::new("--json"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        OsStr::new("--templates"),
        set.templates().as_os_str(),
        set.frame(g1).as_os_str(),
        bad.as_os_str(),
        set.frame(g2).as_os_str(),
    ])
    .failure();
    let name = bad.file_name().expect("file name").to_string_lossy().into_owned();
    assert_error_names(&out, &name, problem);
    let json = out.json();
    let frames: BTreeSet<&str> = json["frames"]
        .as_object()
        .expect("frames")
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(
        frames,
        BTreeSet::from([g1, g2]),
        "{}: good frames not all reported:\n{}",
        out.cmd,
        out.dump()
    );
    for g in [g1, g2] {
        let truth = set.truth_parts(g);
        let pred = parts_of(&json, g);
        assert_eq!(pred.len(), truth.len(), "{g}: parts found in a batch with a bad frame");
        for t in &truth {
            let (p, d) = nearest(&pred, t.x, t.y).expect("a detection");
            assert!(d < 0.5 && p.class == t.class, "{g}: {t:?} detected as {p:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 1–3: eval, check, detect on a generated set
// ---------------------------------------------------------------------------------------------

/// `vorl eval --json --overlay` on the default set meets the project's accuracy requirements
/// (with a little slack for a small set) and writes one RGB overlay per frame at frame size.
#[test]
fn eval_meets_accuracy_requirements_and_writes_overlays() {
    let set = default_set();
    let scratch = Scratch::new("overlay");
    let overlays = scratch.join("overlays");
    let out = vorl([
        OsStr::new("eval"),
        set.root().as_os_str(),
        OsStr::new("--json"),
        OsStr::new("--overlay"),
        overlays.as_os_str(),
    ])
    .success();
    let r = out.json();
    let num = |k: &str| {
        r[k].as_f64()
            .unwrap_or_else(|| panic!("eval JSON has no number {k}: {r}"))
    };
    let nested = |k: &str, f: &str| {
        r[k][f]
            .as_f64()
            .unwrap_or_else(|| panic!("eval JSON has no {k}.{f}: {r}"))
    };
    assert_eq!(num("failed_frames"), 0.0);
    assert!(num("recall") >= 0.99, "recall {}", num("recall"));
    assert!(
        num("classification") >= 0.99,
        "classification {}",
        num("classification")
    );
    assert!(
        num("unknown_rejection") >= 0.95,
        "unknown rejection {}",
        num("unknown_rejection")
    );
    assert!(
        nested("angle", "median") <= 0.05,
        "angle median {}°",
        nested("angle", "median")
    );
    assert!(
        nested("position", "median") <= 0.08,
        "position median {} px",
        nested("position", "median")
    );
    // The scores must cover the whole set, not an empty subset.
    let truth = set.truth();
    let truth_parts: usize = truth["frames"]
        .as_object()
        .expect("frames")
        .values()
        .map(|v| v.as_array().map_or(0, Vec::len))
        .sum();
    assert_eq!(num("frames") as usize, set.frame_names().len());
    assert_eq!(num("truth_parts") as usize, truth_parts);
    assert!(nested("angle", "count") >= 1.0 && nested("position", "count") >= 1.0);

    let frames = set.frame_names();
    assert_eq!(
        png_names(&overlays),
        frames,
        "one overlay per frame, named as the frame"
    );
    for name in &frames {
        let (fw, fh) = image::image_dimensions(set.frame(name)).expect("frame size");
        let ov = image::open(overlays.join(name)).expect("overlay opens");
        assert_eq!((ov.width(), ov.height()), (fw, fh), "{name}: overlay size");
        assert_eq!(ov.color(), image::ColorType::Rgb8, "{name}: overlay is RGB");
    }
}

/// `vorl check` on the default set: the core agrees with the independent reference.
#[test]
fn check_agrees_with_reference() {
    let set = default_set();
    let out = vorl([OsStr::new("check"), set.root().as_os_str()]).success();
    assert!(out.stdout.contains("agreement: yes"), "{}", out.dump());
}

/// `vorl detect SET --json` prints the truth.json shape for every frame of the set, and the
/// explicit form (`--background --templates FRAME…`) finds the same parts in those frames.
///
/// The set also holds backgrounds/ (extra empty captures averaged into the background model),
/// which the explicit form, taking one background file, cannot use; so the two agree only to
/// within noise here (exact agreement without backgrounds/ is
/// [`detect_explicit_form_equals_set_form_exactly`]).
#[test]
fn detect_json_has_truth_shape_and_explicit_form_agrees() {
    let set = default_set();
    let out = vorl([OsStr::new("detect"), set.root().as_os_str(), OsStr::new("--json")]).success();
    let json = out.json();
    let frames = json["frames"].as_object().expect("top-level \"frames\" object");
    let names: Vec<String> = frames.keys().cloned().collect();
    assert_eq!(names, set.frame_names(), "frame names of detect --json against frames/");
    let (w, h) = image::image_dimensions(set.background()).expect("background size");
    let mut total = 0;
    for (name, parts) in frames {
        for p in parts.as_array().unwrap_or_else(|| panic!("{name}: not a list")) {
            total += 1;
            assert!(p["class"].is_string() || p["class"].is_null(), "{name}: class {p}");
            for k in ["x", "y", "angle_deg", "score"] {
                assert!(
                    p[k].as_f64().is_some_and(f64::is_finite),
                    "{name}: {k} is not a finite number: {p}"
                );
            }
            let (x, y, a, s) = (
                p["x"].as_f64().unwrap(),
                p["y"].as_f64().unwrap(),
                p["angle_deg"].as_f64().unwrap(),
                p["score"].as_f64().unwrap(),
            );
            assert!(
                (0.0..f64::from(w)).contains(&x) && (0.0..f64::from(h)).contains(&y),
                "{name}: position off the frame: {p}"
            );
            assert!((0.0..360.0).contains(&a), "{name}: angle not in [0, 360): {p}");
            assert!(s >= 0.0, "{name}: negative f': {p}");
        }
    }
    assert!(total > 0, "no detections at all");

    let picked = &names[..2];
    let mut args: Vec<std::ffi::OsString> = vec![
        "detect".into(),
        "--json".into(),
        "--background".into(),
        set.background().into(),
        "--templates".into(),
        set.templates().into(),
    ];
    args.extend(picked.iter().map(|n| set.frame(n).into_os_string()));
    let explicit = vorl(args).success().json();
    let got: Vec<&String> = explicit["frames"].as_object().expect("frames").keys().collect();
    assert_eq!(got, picked.iter().collect::<Vec<_>>());
    for name in picked {
        let (a, b, truth) = (parts_of(&json, name), parts_of(&explicit, name), set.truth_parts(name));
        assert_eq!(a.len(), b.len(), "{name}: number of parts");
        for p in &a {
            let (q, d) = nearest(&b, p.x, p.y).expect("a part");
            assert!(d < 0.1, "{name}: {p:?} vs {q:?}: {d} px apart");
            assert_eq!(p.class, q.class, "{name}: class");
            if p.class.is_some() {
                let sym = nearest(&truth, p.x, p.y).map_or(1, |(t, _)| t.symmetry);
                if sym != 0 {
                    let da = angle_diff(p.angle, q.angle, sym);
                    assert!(da < 0.1, "{name}: {p:?} vs {q:?}: angles {da}° apart");
                }
            }
        }
    }
}

/// Without backgrounds/ both forms of `vorl detect` see the same inputs and print the same
/// JSON for the same frames.
#[test]
fn detect_explicit_form_equals_set_form_exactly() {
    let set = small_set();
    let scratch = Scratch::new("nobg");
    let root = scratch.join("set");
    copy_tree(&set.root(), &root, &["backgrounds"]);
    let whole = vorl([OsStr::new("detect"), root.as_os_str(), OsStr::new("--json")])
        .success()
        .json();
    let names = png_names(&root.join("frames"));
    let mut args: Vec<std::ffi::OsString> = vec![
        "detect".into(),
        "--json".into(),
        "--background".into(),
        root.join("background.png").into(),
        "--templates".into(),
        root.join("templates").into(),
    ];
    args.extend(names[1..3].iter().map(|n| root.join("frames").join(n).into_os_string()));
    let explicit = vorl(args).success().json();
    for n in &names[1..3] {
        assert_eq!(explicit["frames"][n], whole["frames"][n], "{n}");
    }
    assert_eq!(explicit["frames"].as_object().map(|o| o.len()), Some(2));
}

// ---------------------------------------------------------------------------------------------
// 4: bad input
// ---------------------------------------------------------------------------------------------

/// A frame that does not exist.
#[test]
fn batch_with_missing_frame() {
    let scratch = Scratch::new("missing");
    assert_batch_survives(&scratch.join("missing.png"), &["no such file", "not found"]);
}

/// A folder given as a frame (unreadable as a file, also when running as root).
#[test]
fn batch_with_directory_as_frame() {
    let scratch = Scratch::new("dir");
    let dir = scratch.join("folder.png");
    std::fs::create_dir_all(&dir).expect("mkdir");
    assert_batch_survives(&dir, &["directory", "cannot read", "not a file"]);
}

/// A text file named like a PNG.
#[test]
fn batch_with_text_file_named_png() {
    let scratch = Scratch::new("text");
    let bad = scratch.join("x.png");
    std::fs::write(&bad, "this is not an image\n").expect("write");
    assert_batch_survives(&bad, &["not a png", "unrecognised", "unrecognized"]);
}

/// The first half of a real frame's bytes.
#[test]
fn batch_with_truncated_png() {
    let set = small_set();
    let scratch = Scratch::new("trunc");
    let bytes = std::fs::read(set.frame("f002.png")).expect("read frame");
    let bad = scratch.join("half.png");
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).expect("write");
    assert_batch_survives(&bad, &["truncated", "end of file", "corrupt"]);
}

/// A frame one column narrower than the background.
#[test]
fn batch_with_frame_of_other_size() {
    let set = small_set();
    let scratch = Scratch::new("size");
    let img = gray(&set.frame("f002.png"));
    let cropped = image::imageops::crop_imm(&img, 0, 0, img.width() - 1, img.height()).to_image();
    let bad = scratch.join("narrow.png");
    cropped.save(&bad).expect("save");
    assert_batch_survives(&bad, &["background"]);
}

/// RGB and 16-bit gray frames are converted to 8-bit gray with a note naming the file, and
/// give the detections of the 8-bit gray original (the conversions are exact: equal channels,
/// and v·257 in 16 bits).
#[test]
fn rgb_and_16_bit_frames_are_converted_with_a_note() {
    let set = small_set();
    let scratch = Scratch::new("convert");
    let original = gray(&set.frame("f001.png"));
    let rgb: RgbImage = ImageBuffer::from_fn(original.width(), original.height(), |x, y| {
        let v = original.get_pixel(x, y).0[0];
        Rgb([v, v, v])
    });
    let deep: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_fn(original.width(), original.height(), |x, y| {
        Luma([u16::from(original.get_pixel(x, y).0[0]) * 257])
    });
    let (rgb_path, deep_path) = (scratch.join("colour.png"), scratch.join("deep16.png"));
    rgb.save(&rgb_path).expect("save RGB");
    deep.save(&deep_path).expect("save 16-bit");
    assert_eq!(image::open(&rgb_path).expect("reopen").color(), image::ColorType::Rgb8);
    assert_eq!(image::open(&deep_path).expect("reopen").color(), image::ColorType::L16);

    let out = vorl([
        OsStr::new("detect"),
        OsStr::new("--json"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        OsStr::new("--templates"),
        set.templates().as_os_str(),
        set.frame("f001.png").as_os_str(),
        rgb_path.as_os_str(),
        deep_path.as_os_str(),
    ])
    .success();
    for name in ["colour.png", "deep16.png"] {
        let lines = out.stderr_lines_with(name);
        assert!(
            lines.iter().any(|l| l.starts_with("note:") && l.contains("converted")),
            "no conversion note for {name}:\n{}",
            out.dump()
        );
    }
    assert!(
        out.stderr_lines_with("f001.png").is_empty(),
        "a note for the 8-bit gray frame:\n{}",
        out.dump()
    );
    let json = out.json();
    let base = parts_of(&json, "f001.png");
    assert!(!base.is_empty(), "nothing found in the original frame");
    for name in ["colour.png", "deep16.png"] {
        let conv = parts_of(&json, name);
        assert_eq!(conv.len(), base.len(), "{name}: number of parts");
        for p in &base {
            let (q, d) = nearest(&conv, p.x, p.y).expect("a part");
            assert!(d < 1e-3, "{name}: {q:?} vs gray {p:?}");
            assert_eq!(q.class, p.class, "{name}: class");
            assert!(angle_diff(q.angle, p.angle, 1) < 1e-3, "{name}: {q:?} vs gray {p:?}");
        }
    }
}

/// A template folder in a scratch folder: one good template of the small set (`a_good.png`)
/// and, when given, a bad one written by `bad`.
fn template_folder(tag: &str, bad: Option<fn(&Path)>) -> (Scratch, PathBuf) {
    let set = small_set();
    let scratch = Scratch::new(tag);
    let dir = scratch.join("templates");
    std::fs::create_dir_all(&dir).expect("mkdir");
    if let Some(write) = bad {
        let good = set.templates().join(&png_names(&set.templates())[0]);
        std::fs::copy(good, dir.join("a_good.png")).expect("copy template");
        write(&dir);
    }
    (scratch, dir)
}

/// `black.png`: a 64×64 template with no part.
fn write_black(dir: &Path) {
    GrayImage::new(64, 64).save(dir.join("black.png")).expect("save");
}

/// `twins.png`: two separate 30×30 squares.
fn write_twins(dir: &Path) {
    let img = GrayImage::from_fn(120, 60, |x, y| {
        let inside = (10..40).contains(&y) && ((10..40).contains(&x) || (70..100).contains(&x));
        Luma([if inside { 255 } else { 0 }])
    });
    img.save(dir.join("twins.png")).expect("save");
}

/// Runs `detect` of one frame of the small set with this template folder.
fn detect_with_templates(dir: &Path) -> Out {
    let set = small_set();
    vorl([
        OsStr::new("detect"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        OsStr::new("--templates"),
        dir.as_os_str(),
        set.frame("f000.png").as_os_str(),
    ])
}

/// A template folder without any image.
#[test]
fn empty_template_folder_is_an_error() {
    let (_scratch, dir) = template_folder("emptytpl", None);
    let out = detect_with_templates(&dir).failure();
    assert_error_names(&out, "templates", &["no png", "empty", "no template", "no image"]);
}

/// A template that is all black: no part.
#[test]
fn template_without_part_is_an_error() {
    let (_scratch, dir) = template_folder("blacktpl", Some(write_black));
    let out = detect_with_templates(&dir).failure();
    assert_error_names(&out, "black.png", &["no part"]);
}

/// A template with two separated squares: several blobs, not one part.
#[test]
fn template_with_two_blobs_is_an_error() {
    let (_scratch, dir) = template_folder("twotpl", Some(write_twins));
    let out = detect_with_templates(&dir).failure();
    assert_error_names(&out, "twins.png", &["blob", "one part", "several"]);
}

/// `vorl similarity` names the template file (with its extension) that holds no part.
#[test]
fn similarity_names_the_template_without_part() {
    let (_scratch, dir) = template_folder("simblack", Some(write_black));
    let out = vorl([OsStr::new("similarity"), dir.as_os_str()]).failure();
    assert_error_names(&out, "black.png", &["no part"]);
}

/// `vorl similarity` rejects a silhouette of several blobs, as `detect` does: it is not a
/// template.
#[test]
fn similarity_rejects_a_template_with_two_blobs() {
    let (_scratch, dir) = template_folder("simtwins", Some(write_twins));
    let out = vorl([OsStr::new("similarity"), dir.as_os_str()]).failure();
    assert_error_names(&out, "twins.png", &["blob", "one part", "several"]);
}

/// `vorl eval` on a set whose truth.json does not parse.
#[test]
fn eval_with_unparsable_truth_is_an_error() {
    let set = small_set();
    let scratch = Scratch::new("badtruth");
    let root = scratch.join("set");
    copy_tree(&set.root(), &root, &[]);
    std::fs::write(root.join("truth.json"), "{\"frames\": {\"f000.png\": [ {\"class\": ").expect("write");
    let out = vorl([OsStr::new("eval"), root.as_os_str()]).failure();
    assert_error_names(&out, "truth.json", &["parse", "json", "invalid"]);
}

/// Two frames with the same file name from different folders are both reported by
/// `detect --json` (or the clash is at least said): none is dropped silently.
#[test]
fn detect_json_keeps_frames_of_the_same_name() {
    let set = small_set();
    let scratch = Scratch::new("dupname");
    let other = scratch.join("f001.png");
    std::fs::copy(set.frame("f002.png"), &other).expect("copy");
    let out = vorl([
        OsStr::new("detect"),
        OsStr::new("--json"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        OsStr::new("--templates"),
        set.templates().as_os_str(),
        set.frame("f001.png").as_os_str(),
        other.as_os_str(),
    ])
    .no_panic();
    let reported = out.json()["frames"].as_object().map_or(0, |o| o.len());
    assert!(
        reported == 2 || out.code != Some(0) || out.stderr.contains("f001.png"),
        "one of two frames silently dropped:\n{}",
        out.dump()
    );
}

/// `vorl check` notes a frame it converts to 8-bit gray, as `detect` and `eval` do.
#[test]
fn check_notes_converted_frames() {
    let set = small_set();
    let scratch = Scratch::new("checkrgb");
    let root = scratch.join("set");
    copy_tree(&set.root(), &root, &["backgrounds"]);
    let frames = root.join("frames");
    for n in png_names(&frames).iter().skip(1) {
        std::fs::remove_file(frames.join(n)).expect("remove frame");
    }
    let only = frames.join(&png_names(&frames)[0]);
    let g = gray(&only);
    let rgb: RgbImage = ImageBuffer::from_fn(g.width(), g.height(), |x, y| {
        let v = g.get_pixel(x, y).0[0];
        Rgb([v, v, v])
    });
    rgb.save(&only).expect("save");
    let out = vorl([OsStr::new("check"), root.as_os_str()]).success();
    let name = only.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        out.stderr_lines_with(&name).iter().any(|l| l.contains("converted")),
        "no conversion note:\n{}",
        out.dump()
    );
}

// ---------------------------------------------------------------------------------------------
// 5: teach
// ---------------------------------------------------------------------------------------------

/// `vorl teach` on a frame with one part writes a binary one-blob silhouette, and `vorl detect`
/// with it alone finds that part as the new class at angle 0 (the taught pose) and at the
/// part's true position.
#[test]
fn teach_then_detect_finds_the_part_at_angle_zero() {
    let set = small_set();
    let truth = set.truth();
    let (frame, part) = set
        .frame_names()
        .into_iter()
        .find_map(|n| {
            let parts = parts_of(&truth, &n);
            let fits = parts.len() == 1
                && truth["frames"][&n][0]
                    .get("partial")
                    .is_none_or(|v| v != &Value::Bool(true))
                && parts[0].symmetry >= 1;
            fits.then(|| (n, parts[0].clone()))
        })
        .expect("the small set has a frame with exactly one whole part");
    let scratch = Scratch::new("teach");
    let out_dir = scratch.join("taught");
    let frame_path = set.frame(&frame);
    let out = vorl([
        OsStr::new("teach"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        frame_path.as_os_str(),
        OsStr::new("--name"),
        OsStr::new("newpart"),
        OsStr::new("--out"),
        out_dir.as_os_str(),
    ])
    .success();
    assert!(
        !out.stderr.contains("warning"),
        "warning for a one-part frame:\n{}",
        out.dump()
    );

    let written = out_dir.join("newpart.png");
    assert_eq!(png_names(&out_dir), vec!["newpart.png".to_string()]);
    let sil = image::open(&written).expect("template opens");
    assert_eq!(sil.color(), image::ColorType::L8, "template is 8-bit gray");
    let sil = sil.to_luma8();
    assert!(
        sil.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255),
        "template is not binary"
    );
    assert_eq!(blobs(&sil), 1, "template holds one blob");

    let det = vorl([
        OsStr::new("detect"),
        OsStr::new("--json"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        OsStr::new("--templates"),
        out_dir.as_os_str(),
        frame_path.as_os_str(),
    ])
    .success()
    .json();
    let found = parts_of(&det, &frame);
    assert_eq!(found.len(), 1, "{frame}: {found:?}");
    let p = &found[0];
    assert_eq!(p.class.as_deref(), Some("newpart"), "{p:?}");
    let a = angle_diff(p.angle, 0.0, part.symmetry);
    assert!(
        a < 0.2,
        "taught part found at {}° (symmetry {}), expected 0",
        p.angle,
        part.symmetry
    );
    let d = (p.x - part.x).hypot(p.y - part.y);
    assert!(
        d < 0.2,
        "taught part found {d} px from its true position: {p:?} vs {part:?}"
    );

    // A second teach of the same name does not overwrite without --force.
    let again = vorl([
        OsStr::new("teach"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        frame_path.as_os_str(),
        OsStr::new("--name"),
        OsStr::new("newpart"),
        OsStr::new("--out"),
        out_dir.as_os_str(),
    ])
    .failure();
    assert_error_names(&again, "newpart.png", &["exists"]);
}

/// `vorl teach` warns on a frame with several parts.
#[test]
fn teach_warns_on_several_parts() {
    let set = default_set();
    let truth = set.truth();
    let frame = set
        .frame_names()
        .into_iter()
        .find(|n| parts_of(&truth, n).len() >= 2)
        .expect("the default set has a frame with several parts");
    let scratch = Scratch::new("teachmany");
    let out_dir = scratch.join("taught");
    let out = vorl([
        OsStr::new("teach"),
        OsStr::new("--background"),
        set.background().as_os_str(),
        set.frame(&frame).as_os_str(),
        OsStr::new("--name"),
        OsStr::new("some"),
        OsStr::new("--out"),
        out_dir.as_os_str(),
    ])
    .no_panic();
    assert!(
        out.stderr.lines().any(|l| l.contains("warning") && l.contains(&frame)),
        "no warning naming {frame}:\n{}",
        out.dump()
    );
    if out.code == Some(0) {
        assert_eq!(
            blobs(&gray(&out_dir.join("some.png"))),
            1,
            "the taught silhouette is one part"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 6: similarity
// ---------------------------------------------------------------------------------------------

/// The similarity matrix of a folder of silhouettes as CSV and as JSON.
fn similarity_of(dir: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let out = vorl([OsStr::new("similarity"), dir.as_os_str()]).success();
    let mut lines = out.stdout.lines();
    let header: Vec<String> = lines.next().expect("header row").split(',').map(String::from).collect();
    let names = header[1..].to_vec();
    let mut matrix = Vec::new();
    for (i, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), names.len() + 1, "row {i}: {line}");
        assert_eq!(cells[0], names[i], "row {i} is named as column {i}");
        matrix.push(
            cells[1..]
                .iter()
                .map(|c| c.parse::<f64>().unwrap_or_else(|e| panic!("{c}: {e}")))
                .collect(),
        );
    }
    (names, matrix)
}

/// `vorl similarity` on a set's templates/: a header row and one row per template, named as
/// the files, finite non-negative entries, each silhouette most like itself; `--format json`
/// holds the same names and an n×n matrix, and every `too_alike` pair is below ε.
#[test]
fn similarity_csv_and_json() {
    let set = small_set();
    let dir = set.templates();
    let stems: Vec<String> = png_names(&dir)
        .iter()
        .map(|n| n.trim_end_matches(".png").to_string())
        .collect();
    let (names, matrix) = similarity_of(&dir);
    assert_eq!(names, stems, "header row names the templates");
    assert_eq!(matrix.len(), stems.len(), "one row per template");
    for (i, row) in matrix.iter().enumerate() {
        assert!(row.iter().all(|v| v.is_finite() && *v >= 0.0), "row {i}: {row:?}");
        let min = row.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(row[i], min, "{} is not most like itself: {row:?}", names[i]);
    }

    let out = vorl([
        OsStr::new("similarity"),
        dir.as_os_str(),
        OsStr::new("--format"),
        OsStr::new("json"),
    ])
    .success();
    let j = out.json();
    let jnames: Vec<&str> = j["names"]
        .as_array()
        .expect("names")
        .iter()
        .map(|v| v.as_str().expect("name"))
        .collect();
    assert_eq!(jnames, stems);
    let jm = j["matrix"].as_array().expect("matrix");
    assert_eq!(jm.len(), stems.len());
    for (i, row) in jm.iter().enumerate() {
        let row = row.as_array().expect("matrix row");
        assert_eq!(row.len(), stems.len());
        for (k, v) in row.iter().enumerate() {
            let v = v.as_f64().expect("number");
            assert!(
                (v - matrix[i][k]).abs() <= 1e-5 + 1e-9,
                "json [{i}][{k}] {v} vs csv {}",
                matrix[i][k]
            );
        }
    }
    let eps = j["epsilon"].as_f64().expect("epsilon");
    for pair in j["too_alike"].as_array().expect("too_alike") {
        let (a, b, v) = (
            pair[0].as_u64().unwrap() as usize,
            pair[1].as_u64().unwrap() as usize,
            pair[2].as_f64().unwrap(),
        );
        assert!(a < b && b < stems.len(), "{pair}");
        assert!(v < eps, "{pair} not below ε {eps}");
        assert!(matrix[a][b].min(matrix[b][a]) < eps + 1e-5, "{pair} against the matrix");
    }
    // Every pair below ε in either direction is listed.
    let listed: BTreeSet<(u64, u64)> = j["too_alike"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_u64().unwrap(), p[1].as_u64().unwrap()))
        .collect();
    for (a, row) in matrix.iter().enumerate() {
        for (b, v_ab) in row.iter().enumerate().skip(a + 1) {
            if v_ab.min(matrix[b][a]) < eps - 1e-5 {
                assert!(
                    listed.contains(&(a as u64, b as u64)),
                    "pair {a},{b} below ε not listed"
                );
            }
        }
    }
}

/// A silhouette against itself is far below ε: the part side is resampled to n points and the
/// template side to m (eq. 4.5), so the two samplings differ and f' is not 0, but it must stay
/// under ε/2 (0.04 at the defaults).
#[test]
fn similarity_diagonal_is_near_zero() {
    let set = small_set();
    let (names, matrix) = similarity_of(&set.templates());
    let bad: BTreeMap<&str, f64> = names
        .iter()
        .zip(&matrix)
        .enumerate()
        .filter(|(i, (_, r))| r[*i] >= 0.04)
        .map(|(i, (n, r))| (n.as_str(), r[i]))
        .collect();
    assert!(bad.is_empty(), "f' of a silhouette against itself ≥ ε/2: {bad:?}");
}

/// `vorl similarity` takes a folder of more silhouettes than one library holds (64): 65 ellipses
/// of different proportions and a class of two examples give a 67×67 matrix of finite entries,
/// and the class's tolerance line.
#[test]
fn similarity_of_more_silhouettes_than_a_library_holds() {
    let scratch = Scratch::new("simmany");
    let dir = scratch.join("templates");
    std::fs::create_dir_all(dir.join("pair")).expect("mkdir");
    let ellipse = |a: f64, b: f64| {
        GrayImage::from_fn(64, 64, |x, y| {
            let (dx, dy) = ((x as f64 - 31.5) / a, (y as f64 - 31.5) / b);
            Luma([if dx * dx + dy * dy <= 1.0 { 255 } else { 0 }])
        })
    };
    for i in 0..65u32 {
        let (a, b) = (12.0 + f64::from(i % 13), 6.0 + 1.5 * f64::from(i / 13));
        ellipse(a, b).save(dir.join(format!("e{i:02}.png"))).expect("save");
    }
    ellipse(20.0, 8.0).save(dir.join("pair").join("a.png")).expect("save");
    ellipse(21.0, 8.0).save(dir.join("pair").join("b.png")).expect("save");
    let out = vorl([OsStr::new("similarity"), dir.as_os_str()]).success();
    let (names, matrix) = similarity_of(&dir);
    assert_eq!(names.len(), 67, "{names:?}");
    assert_eq!(matrix.len(), 67, "one row per silhouette");
    for (i, row) in matrix.iter().enumerate() {
        assert_eq!(row.len(), 67, "row {i}");
        assert!(row.iter().all(|v| v.is_finite() && *v >= 0.0), "row {i}: {row:?}");
    }
    assert!(names.contains(&"pair/a.png".to_string()), "{names:?}");
    assert_eq!(
        out.stderr_lines_with("class pair: 2 examples").len(),
        1,
        "the class's tolerance line:\n{}",
        out.dump()
    );
}

// ---------------------------------------------------------------------------------------------
// 7: config
// ---------------------------------------------------------------------------------------------

/// `vorl config --defaults` is a TOML file that `vorl config --check` accepts, giving the same
/// parameters back; and `detect`, `eval` and `check` run with it unchanged.
#[test]
fn config_defaults_parse_and_check() {
    let out = vorl(["config", "--defaults"]).success();
    let defaults: toml::Table = toml::from_str(&out.stdout).expect("defaults are TOML");
    for key in ["alpha", "threshold", "n", "m", "k", "omega", "epsilon"] {
        assert!(defaults.contains_key(key), "defaults lack {key}:\n{}", out.stdout);
    }
    let scratch = Scratch::new("config");
    let file = scratch.join("vorl.toml");
    std::fs::write(&file, &out.stdout).expect("write");
    let checked = vorl([OsStr::new("config"), OsStr::new("--check"), file.as_os_str()]).success();
    let back: toml::Table = toml::from_str(&checked.stdout).expect("--check prints TOML");
    assert_eq!(back.keys().collect::<Vec<_>>(), defaults.keys().collect::<Vec<_>>());
    for (k, v) in &defaults {
        // Numbers compare as numbers: the defaults write `alpha = 1` (a TOML integer) where
        // `--check` writes `1.0`, and f32 values may come back with more digits.
        let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
        let same = match (number(v), number(&back[k])) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-6 * a.abs().max(1.0),
            _ => v == &back[k],
        };
        assert!(same, "{k}: defaults {v} but --check gives {}", back[k]);
    }
}

/// An unknown key in a `--config` file is an error naming the file and the key.
#[test]
fn config_unknown_key_is_an_error_naming_the_file() {
    let set = small_set();
    let scratch = Scratch::new("badconfig");
    let file = scratch.join("typo.toml");
    std::fs::write(&file, "alpha = 0.9\nthresold = 30\n").expect("write");
    let out = vorl([
        OsStr::new("detect"),
        set.root().as_os_str(),
        OsStr::new("--config"),
        file.as_os_str(),
    ])
    .failure();
    assert_error_names(&out, "typo.toml", &["thresold"]);
    assert!(
        out.stdout.trim().is_empty(),
        "detections printed despite a bad config:\n{}",
        out.dump()
    );
    let out = vorl([OsStr::new("config"), OsStr::new("--check"), file.as_os_str()]).failure();
    assert_error_names(&out, "typo.toml", &["thresold"]);
}

// ---------------------------------------------------------------------------------------------
// 8: help
// ---------------------------------------------------------------------------------------------

/// Every subcommand's `--help` exits 0 and shows examples.
#[test]
fn subcommand_help_has_examples() {
    // The subcommands as `vorl --help` lists them, and those of `vorl templates`.
    let listed = |args: &[&str]| -> Vec<String> {
        let out = vorl(args).success();
        let names: Vec<String> = out
            .stdout
            .lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| !l.trim().is_empty())
            .filter_map(|l| l.split_whitespace().next().map(String::from))
            .filter(|n| n != "help")
            .collect();
        assert!(!names.is_empty(), "{} lists no commands:\n{}", out.cmd, out.stdout);
        names
    };
    let mut commands: Vec<Vec<String>> = listed(&["--help"]).into_iter().map(|c| vec![c]).collect();
    assert!(commands.len() >= 9, "{commands:?}");
    commands.extend(
        listed(&["templates", "--help"])
            .into_iter()
            .map(|c| vec!["templates".to_string(), c]),
    );
    for cmd in commands {
        let mut args = cmd.clone();
        args.push("--help".into());
        let out = vorl(&args).success();
        assert!(
            out.stdout.contains("Examples"),
            "{} has no examples:\n{}",
            out.cmd,
            out.stdout
        );
    }
}

/// `vorl --help` exits 0 and shows examples.
#[test]
fn top_level_help_has_examples() {
    let out = vorl(["--help"]).success();
    assert!(out.stdout.contains("Examples"), "{}", out.stdout);
}

/// A candidate ratio below 1 (or not a number) is refused with the parameter's name; `inf`
/// (no limit) is accepted.
#[test]
fn candidate_ratio_is_checked() {
    let set = small_set();
    for bad in ["0.5", "nan"] {
        let out = vorl([
            OsStr::new("detect"),
            set.root().as_os_str(),
            OsStr::new("--candidate-ratio"),
            OsStr::new(bad),
        ])
        .failure();
        assert_error_names(&out, "candidate_ratio", &["out of range"]);
    }
    vorl([
        OsStr::new("detect"),
        set.root().as_os_str(),
        OsStr::new("--candidate-ratio"),
        OsStr::new("inf"),
        OsStr::new("--json"),
    ])
    .success();
}

// ---------------------------------------------------------------------------------------------
// No empty shot: the platform estimated from each frame
// ---------------------------------------------------------------------------------------------

/// The prediction nearest to a truth part, within 5 px.
fn paired<'a>(truth: &Part, pred: &'a [Part]) -> Option<&'a Part> {
    nearest(pred, truth.x, truth.y)
        .filter(|(_, d)| *d < 5.0)
        .map(|(p, _)| p)
}

/// Angle difference modulo 360/symmetry; 0 for round parts (symmetry 0: no angle).
fn angle_gap(a: f64, b: f64, symmetry: u32) -> f64 {
    if symmetry == 0 {
        0.0
    } else {
        angle_diff(a, b, symmetry)
    }
}

/// A set without background.png (and backgrounds/): every frame's platform is estimated from
/// the frame itself, and the known parts are still named right, at the truth's pose.
#[test]
fn set_without_empty_shot_estimates_the_platform() {
    let set = default_set();
    let scratch = Scratch::new("noshot");
    let root = scratch.join("set");
    copy_tree(&set.root(), &root, &["backgrounds", "background.png"]);
    let debug = scratch.join("debug");
    let pred = vorl([
        OsStr::new("detect"),
        root.as_os_str(),
        OsStr::new("--json"),
        OsStr::new("--debug"),
        debug.as_os_str(),
    ])
    .success()
    .json();
    let (mut known, mut right) = (0, 0);
    for frame in png_names(&root.join("frames")) {
        let got = parts_of(&pred, &frame);
        for t in set.truth_parts(&frame).iter().filter(|t| t.class.is_some()) {
            known += 1;
            let Some(p) = paired(t, &got) else { continue };
            if p.class == t.class {
                right += 1;
                assert!(angle_gap(p.angle, t.angle, t.symmetry) < 0.5, "{frame}: {t:?} vs {p:?}");
                assert!(
                    ((p.x - t.x).powi(2) + (p.y - t.y).powi(2)).sqrt() < 0.5,
                    "{frame}: {t:?} vs {p:?}"
                );
            }
        }
        // The estimate and the mask of every frame are written for a look.
        let stem = frame.trim_end_matches(".png");
        assert!(debug.join(format!("{stem}_platform.png")).is_file());
        assert!(debug.join(format!("{stem}_mask.png")).is_file());
    }
    assert!(known >= 10, "{known}");
    assert!(right * 100 >= known * 99, "{right} of {known} known parts named right");
}

/// Without an empty shot the platform estimated from one frame serves the next ones of a fixed
/// camera while they fit it: the default set's frames keep the first frame's estimate; a
/// brighter exposure is estimated anew (and kept again after it); `platform_every = 1`
/// estimates every frame; `--platform-every 0` is a one-line error.
#[test]
fn platform_estimate_is_kept_while_frames_fit_it() {
    use vorl_host_sim::engine::Engine;
    let set = default_set();
    let frames: Vec<GrayImage> = png_names(&set.root().join("frames"))
        .iter()
        .take(3)
        .map(|f| gray(&set.root().join("frames").join(f)))
        .collect();
    let bright = GrayImage::from_fn(frames[0].width(), frames[0].height(), |x, y| {
        Luma([(frames[0].get_pixel(x, y).0[0] as f64 * 1.15).min(255.0).round() as u8])
    });
    let ages = |every: u32| -> Vec<u32> {
        let mut engine = Engine::new(vorl_core::Params::default()).expect("engine");
        engine.set_auto_background();
        engine.set_platform_every(every);
        let mut ages = Vec::new();
        for img in frames.iter().chain([&bright, &frames[1]]) {
            let r = engine.detect(img).expect("detect");
            assert!(r.platform.is_some_and(|p| p.kept > 0));
            ages.push(r.platform_frames_ago);
        }
        ages
    };
    assert_eq!(ages(30), [0, 1, 2, 0, 0]);
    assert_eq!(ages(2), [0, 1, 0, 0, 0]);
    assert_eq!(ages(1), [0, 0, 0, 0, 0]);
    let out = vorl([
        OsStr::new("detect"),
        set.root().as_os_str(),
        OsStr::new("--platform-every"),
        OsStr::new("0"),
    ]);
    assert_ne!(out.code, Some(0));
    assert!(
        out.stderr.contains("platform_every must be at least 1"),
        "{}",
        out.stderr
    );
    // eval counts the frames estimated and those that kept an estimate.
    let scratch = Scratch::new("keep-eval");
    let root = scratch.join("set");
    copy_tree(&set.root(), &root, &["backgrounds", "background.png"]);
    let report = vorl([OsStr::new("eval"), root.as_os_str(), OsStr::new("--json")])
        .success()
        .json();
    let (estimated, kept) = (
        report["platform_estimated"].as_u64().unwrap(),
        report["platform_kept"].as_u64().unwrap(),
    );
    assert_eq!(estimated + kept, png_names(&root.join("frames")).len() as u64);
    assert!(estimated >= 1 && kept >= 1, "{estimated} {kept}");
}

/// The frames of the default set and their dimmer copies (0.7·v + 6), detected with
/// `background` (`auto` or the set's empty shot) and `extra` flags: the compared pairs of truth
/// parts (same class, angles within 0.1°, positions within 0.3 px) and the truth parts missing
/// from the dim frame.
fn exposure_pairs(set: &Set, name: &str, background: std::ffi::OsString, extra: &[&str]) -> (usize, usize) {
    let scratch = Scratch::new(name);
    let frames = png_names(&set.root().join("frames"));
    let mut args: Vec<std::ffi::OsString> = vec![
        "detect".into(),
        "--json".into(),
        "--background".into(),
        background,
        "--templates".into(),
        set.root().join("templates").into(),
    ];
    args.extend(extra.iter().map(|e| e.into()));
    let mut pairs = Vec::new();
    for (i, f) in frames.iter().take(3).enumerate() {
        let img = image::open(set.root().join("frames").join(f))
            .expect("frame")
            .to_luma8();
        let dim = GrayImage::from_fn(img.width(), img.height(), |x, y| {
            Luma([(0.7 * img.get_pixel(x, y).0[0] as f64 + 6.0).round() as u8])
        });
        let (a, b) = (
            scratch.join(format!("bright{i}.png")),
            scratch.join(format!("dim{i}.png")),
        );
        img.save(&a).expect("save");
        dim.save(&b).expect("save");
        args.push(a.into());
        args.push(b.into());
        pairs.push((format!("bright{i}.png"), format!("dim{i}.png"), f.clone()));
    }
    let pred = vorl(args).success().json();
    let (mut compared, mut missing) = (0, 0);
    for (a, b, f) in &pairs {
        let (pa, pb) = (parts_of(&pred, a), parts_of(&pred, b));
        for t in set.truth_parts(f).iter().filter(|t| t.class.is_some()) {
            let Some(x) = paired(t, &pa) else {
                panic!("{f}: {t:?} not found in the frame as it was");
            };
            let Some(y) = paired(t, &pb).filter(|y| y.class == x.class) else {
                missing += 1;
                continue;
            };
            assert!(angle_gap(x.angle, y.angle, t.symmetry) < 0.1, "{f}: {x:?} vs {y:?}");
            assert!(
                ((x.x - y.x).powi(2) + (x.y - y.y).powi(2)).sqrt() < 0.3,
                "{f}: {x:?} vs {y:?}"
            );
            compared += 1;
        }
    }
    (compared, missing)
}

/// The same scene under two exposures gives the same classes and poses (within 0.1° and
/// 0.3 px): with the platform estimated from each frame, and against a fixed empty shot with
/// each frame's gain and offset fitted (the default); with the exposure kept fixed, the dim
/// frame's platform is all foreground against the shot and its parts are lost.
#[test]
fn exposure_change_keeps_the_poses() {
    let set = default_set();
    let (compared, missing) = exposure_pairs(&set, "exposure-auto", "auto".into(), &[]);
    assert!(compared >= 5 && missing == 0, "{compared} {missing}");
    let shot = set.root().join("background.png");
    let (compared, missing) = exposure_pairs(&set, "exposure-fit", shot.clone().into(), &[]);
    assert!(compared >= 5 && missing == 0, "{compared} {missing}");
    let (compared, missing) = exposure_pairs(&set, "exposure-fixed", shot.into(), &["--exposure", "fixed"]);
    assert!(missing > compared, "{compared} {missing}");
}

/// A set's vorl.toml is read by detect and eval; an unknown key or a bad value is a one-line
/// error naming the file.
#[test]
fn set_config_is_read_and_checked() {
    let set = small_set();
    let scratch = Scratch::new("settoml");
    let root = scratch.join("set");
    copy_tree(&set.root(), &root, &[]);
    std::fs::write(root.join("vorl.toml"), "scale_min = 0.85\nscale_max = 1.4\n").expect("write");
    vorl([OsStr::new("eval"), root.as_os_str()]).success();
    std::fs::write(root.join("vorl.toml"), "scale_minimum = 0.85\n").expect("write");
    let out = vorl([OsStr::new("detect"), root.as_os_str()]).failure();
    let err = out.errors().join("\n");
    assert!(
        err.contains("vorl.toml") && err.contains("scale_minimum"),
        "{}",
        out.dump()
    );
    std::fs::write(root.join("vorl.toml"), "scale_max = 0.5\n").expect("write");
    let out = vorl([OsStr::new("detect"), root.as_os_str()]).failure();
    assert!(out.errors().join("\n").contains("scale_max"), "{}", out.dump());
}

/// `vorl teach --list` numbers the parts of a frame (no empty shot needed) and writes the
/// numbered overlay; `--part N` and `--at X,Y` take the listed part (its silhouette is one
/// blob of about the listed area); a part number out of range and a point off every part are
/// one-line errors.
#[test]
fn teach_lists_and_takes_one_part_without_an_empty_shot() {
    let set = default_set();
    let truth = set.truth();
    let frame = set
        .frame_names()
        .into_iter()
        .find(|n| parts_of(&truth, n).len() >= 2)
        .expect("a frame with several parts");
    let scratch = Scratch::new("teachlist");
    let overlay = scratch.join("parts.png");
    let out = vorl([
        OsStr::new("teach"),
        OsStr::new("--list"),
        set.frame(&frame).as_os_str(),
        OsStr::new("--overlay"),
        overlay.as_os_str(),
    ])
    .success();
    let listed: Vec<(f64, f64, f64)> = out
        .stdout
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (w.len() >= 8 && w[1] == "x" && w[3] == "y" && w[5] == "area")
                .then(|| (w[2].parse().unwrap(), w[4].parse().unwrap(), w[6].parse().unwrap()))
        })
        .collect();
    assert_eq!(listed.len(), parts_of(&truth, &frame).len(), "{}", out.dump());
    assert!(overlay.is_file());
    // Every listed centre is a truth part's.
    for &(x, y, _) in &listed {
        assert!(
            nearest(&parts_of(&truth, &frame), x, y).is_some_and(|(_, d)| d < 1.0),
            "{x},{y}"
        );
    }
    let teach = |how: &[&str], name: &str| {
        let mut args: Vec<std::ffi::OsString> = vec!["teach".into(), set.frame(&frame).into()];
        args.extend(how.iter().map(Into::into));
        args.extend(["--name".into(), name.into(), "--out".into(), scratch.join("t").into()]);
        vorl(args)
    };
    // --part N and --at (its listed centre) take the same part; parts 1 and 2 differ.
    for (i, &(x, y, _)) in listed.iter().enumerate().take(2) {
        teach(&["--part", &(i + 1).to_string()], &format!("p{i}")).success();
        teach(&["--at", &format!("{x:.0},{y:.0}")], &format!("a{i}")).success();
        let (p, a) = (
            gray(&scratch.join("t").join(format!("p{i}.png"))),
            gray(&scratch.join("t").join(format!("a{i}.png"))),
        );
        assert_eq!(blobs(&p), 1);
        assert!(p == a, "part {} by number and by point differ", i + 1);
    }
    assert!(gray(&scratch.join("t/p0.png")) != gray(&scratch.join("t/p1.png")));
    let err = teach(&["--part", "99"], "x").failure();
    assert!(err.errors().join(" ").contains("--part 99"), "{}", err.dump());
    let err = teach(&["--at", "-50,-50"], "x").failure();
    assert!(err.errors().join(" ").contains("--at"), "{}", err.dump());
    let err = teach(&["--at", "twelve"], "x").failure();
    assert!(err.errors().join(" ").contains("X,Y"), "{}", err.dump());
}

/// Front light: a bright bar throwing a dark shadow down and to the right, and a bright open
/// ring (a C, its centre off its silhouette) with none, on a flat platform. `vorl teach --at`
/// the bar measures its polarity (brighter: the shadow beside it is not part), keeps it in the
/// set's `vorl.toml` and takes the bar without its shadow; the C is taken at its listed centre;
/// `vorl detect` of the set then finds the bar as the taught class.
#[test]
fn teach_leaves_the_shadow_out_keeps_the_polarity_and_takes_an_open_part_at_its_centre() {
    let scratch = Scratch::new("teachshadow");
    let set = scratch.join("set");
    std::fs::create_dir_all(set.join("frames")).expect("mkdir");
    let mut img = GrayImage::from_pixel(320, 240, Luma([110]));
    // The shadow: the bar's 100×24 rectangle 6 px right and 6 px down, drawn first.
    draw_filled_rect_mut(&mut img, Rect::at(66, 56).of_size(100, 24), Luma([60]));
    draw_filled_rect_mut(&mut img, Rect::at(60, 50).of_size(100, 24), Luma([200]));
    // The C: a ring of radii 18 and 30 about (240, 170), open over 60° to the right.
    for y in 130..212u32 {
        for x in 200..282u32 {
            let (dx, dy) = (x as f64 - 240.0, y as f64 - 170.0);
            let r = dx.hypot(dy);
            if (18.0..=30.0).contains(&r) && dy.atan2(dx).abs() > 30f64.to_radians() {
                img.put_pixel(x, y, Luma([190]));
            }
        }
    }
    let frame = set.join("frames/f0.png");
    img.save(&frame).expect("save");
    let templates = set.join("templates");
    let out = vorl([
        OsStr::new("teach"),
        frame.as_os_str(),
        OsStr::new("--at"),
        OsStr::new("110,62"),
        OsStr::new("--name"),
        OsStr::new("bar"),
        OsStr::new("--out"),
        templates.as_os_str(),
    ])
    .success();
    assert!(out.stdout.contains("polarity: brighter"), "{}", out.dump());
    let toml = std::fs::read_to_string(set.join("vorl.toml")).expect("vorl.toml written");
    assert!(toml.contains("polarity = \"brighter\""), "{toml}");
    let bar = gray(&templates.join("bar.png"));
    let area = bar.pixels().filter(|p| p.0[0] > 127).count();
    assert!(
        (2200..=2500).contains(&area),
        "the bar without its shadow is 2400 px: {area}"
    );
    // The C, at its centre (off its silhouette: it lies in the ring's hole).
    let c: Vec<(f64, f64)> = img
        .enumerate_pixels()
        .filter(|p| p.2 .0[0] == 190)
        .map(|(x, y, _)| (x as f64, y as f64))
        .collect();
    let (cx, cy) = (
        c.iter().map(|p| p.0).sum::<f64>() / c.len() as f64,
        c.iter().map(|p| p.1).sum::<f64>() / c.len() as f64,
    );
    assert!((cx - 240.0).hypot(cy - 170.0) < 17.0, "the centre lies in the hole");
    vorl([
        OsStr::new("teach"),
        frame.as_os_str(),
        OsStr::new("--at"),
        OsStr::new(&format!("{cx:.1},{cy:.1}")),
        OsStr::new("--name"),
        OsStr::new("clip"),
        OsStr::new("--out"),
        templates.as_os_str(),
    ])
    .success();
    assert_eq!(blobs(&gray(&templates.join("clip.png"))), 1);
    let out = vorl([OsStr::new("detect"), set.as_os_str(), OsStr::new("--json")]).success();
    let json: Value = serde_json::from_str(&out.stdout).expect("json");
    let parts = json["frames"]["f0.png"].as_array().expect("parts").clone();
    assert_eq!(parts.len(), 2, "{}", out.dump());
    let bar = parts.iter().find(|p| p["class"] == "bar").expect("the bar named");
    let (x, y) = (bar["x"].as_f64().unwrap(), bar["y"].as_f64().unwrap());
    assert!((x - 109.5).abs() < 0.5 && (y - 61.5).abs() < 0.5, "{x},{y}");
    assert!(parts.iter().any(|p| p["class"] == "clip"), "{}", out.dump());
}

/// A set of both kinds under front light: a dark plate (its shadow of its own sign, joined to
/// it) and a bright bar with its shadow beside it. Taught in either order, the set's polarity
/// ends "either" (a "brighter" set would drop the dark plate); detection then cuts the bar's
/// shadow off it blob by blob (`vorl_core::pixels::shadow`) and names both, with no shadow
/// reported as a part.
#[test]
fn a_set_of_dark_and_bright_parts_keeps_both_and_cuts_the_bright_ones_shadow() {
    let mut img = GrayImage::from_pixel(320, 240, Luma([110]));
    // Shadows first: the bar's 100×24 rectangle and the plate's 60×40, each 6 px right and down.
    draw_filled_rect_mut(&mut img, Rect::at(66, 56).of_size(100, 24), Luma([70]));
    draw_filled_rect_mut(&mut img, Rect::at(206, 146).of_size(60, 40), Luma([70]));
    draw_filled_rect_mut(&mut img, Rect::at(60, 50).of_size(100, 24), Luma([200]));
    // The plate, with a hole that keeps it from being a rectangle turned.
    for y in 140..180u32 {
        for x in 200..260u32 {
            let hole = (x as f64 - 215.0).hypot(y as f64 - 160.0) < 7.0;
            img.put_pixel(x, y, Luma([if hole { 110 } else { 25 }]));
        }
    }
    for (order, name) in [(["plate", "bar"], "darkfirst"), (["bar", "plate"], "brightfirst")] {
        let scratch = Scratch::new(&format!("teachmixed{name}"));
        let set = scratch.join("set");
        std::fs::create_dir_all(set.join("frames")).expect("mkdir");
        let frame = set.join("frames/f0.png");
        img.save(&frame).expect("save");
        let templates = set.join("templates");
        for class in order {
            let at = if class == "bar" { "110,62" } else { "240,160" };
            vorl([
                OsStr::new("teach"),
                frame.as_os_str(),
                OsStr::new("--at"),
                OsStr::new(at),
                OsStr::new("--name"),
                OsStr::new(class),
                OsStr::new("--out"),
                templates.as_os_str(),
            ])
            .success();
        }
        let toml = std::fs::read_to_string(set.join("vorl.toml")).expect("vorl.toml written");
        assert!(toml.contains("polarity = \"either\""), "{name}: {toml}");
        let out = vorl([OsStr::new("detect"), set.as_os_str(), OsStr::new("--json")]).success();
        let json: Value = serde_json::from_str(&out.stdout).expect("json");
        let parts = json["frames"]["f0.png"].as_array().expect("parts").clone();
        assert_eq!(parts.len(), 2, "{name}: {}", out.dump());
        // The bar where it lies; the plate named (its own shadow, of its sign, joins it in the
        // mask and in its template alike, and moves its centre towards the shadow).
        for (class, x, y, off) in [("bar", 109.5, 61.5, 0.5), ("plate", 229.5, 159.5, 6.0)] {
            let p = parts.iter().find(|p| p["class"] == class).expect("named");
            let (px, py) = (p["x"].as_f64().unwrap(), p["y"].as_f64().unwrap());
            assert!(
                (px - x).abs() < off && (py - y).abs() < off,
                "{name} {class}: {px},{py}"
            );
        }
    }
}

/// Untaught look-alikes (`vorl gen --variant lookalike`: a cam, hex nut, 12-tooth gear, disc,
/// oval flange, L and U bracket drawn without their holes) are unknown: their outlines verify
/// against the templates, but a bore the mask resolves is not there
/// (`holes::solid_where_a_hole_is`). Without that rule, 14 of the 46 unknown parts of seed 1's
/// 60 frames were rejected (the rule: 46); every template part stays named. A label printed
/// over a solid part's bore keeps a dip in the difference there: such parts were named until a
/// bore wider than three times the frame's edge blur had to show in the mask. The brackets'
/// holes (6 mm) are narrower than the widest wall the alignment admits: while any hole that
/// narrow was let pass (a wall might hide it), 36 of 44 unknown parts of seed 1's 60 frames
/// were rejected (now: a wall closes a hole only when twice its radius wide; 43 of 43). A hex
/// nut and a washer whose bore is half as wide as the template's are unknown too: a part hole
/// too small to be the template's bore is its trace only where the bore's rim shows an
/// opening.
#[test]
fn look_alikes_without_the_templates_holes_are_unknown() {
    for seed in ["1", "2"] {
        look_alikes_are_unknown(seed);
    }
}

fn look_alikes_are_unknown(seed: &str) {
    let scratch = Scratch::new(&format!("lookalike{seed}"));
    let set = scratch.join("set");
    vorl([
        OsStr::new("gen"),
        set.as_os_str(),
        OsStr::new("--seed"),
        OsStr::new(seed),
        OsStr::new("--frames"),
        OsStr::new("40"),
        OsStr::new("--variant"),
        OsStr::new("lookalike"),
    ])
    .success();
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(set.join("truth.json")).expect("truth")).expect("json");
    let out = vorl([OsStr::new("detect"), set.as_os_str(), OsStr::new("--json")]).success();
    let pred: Value = serde_json::from_str(&out.stdout).expect("json");
    let (mut solids, mut small_bores, mut known) = (0, 0, 0);
    for (frame, parts) in truth["frames"].as_object().expect("frames") {
        let found = pred["frames"][frame].as_array().cloned().unwrap_or_default();
        for t in parts.as_array().expect("parts") {
            let (x, y) = (t["x"].as_f64().unwrap(), t["y"].as_f64().unwrap());
            let Some(p) = found
                .iter()
                .find(|p| (p["x"].as_f64().unwrap() - x).hypot(p["y"].as_f64().unwrap() - y) < 3.0)
            else {
                continue;
            };
            let shape = t["shape"].as_str().unwrap_or("");
            if shape.ends_with("_small_bore") {
                small_bores += 1;
            }
            if shape.ends_with("_solid") || shape == "disc" || shape.ends_with("_small_bore") {
                solids += 1;
                assert!(
                    p["class"].is_null(),
                    "seed {seed}, {frame}: a {shape} named {}",
                    p["class"]
                );
            } else if !t["class"].is_null() {
                known += 1;
                assert_eq!(p["class"], t["class"], "seed {seed}, {frame}: {shape}");
            }
        }
    }
    assert!(
        solids >= 10 && small_bores >= 3 && known >= 40,
        "seed {seed}: {solids} look-alikes ({small_bores} with a small bore), {known} template parts"
    );
}

/// A large part on paper printed with rows of glyphs, without an empty shot (`vorl gen
/// --variant large --no-background`, seed 1): the print is strokes thinner than any taught part
/// (`Report::thin`), not parts, and a bore with print seen through it is still the part's (its
/// parent found by containment where the tracer's labels ran out). Before: 22 of 520
/// predictions true, 6 of 13 known parts named; the two picks of frames 2 and 8 never looked at.
#[test]
fn print_on_the_platform_is_not_parts() {
    let scratch = Scratch::new("large_print");
    let (_, score, out) = gen_and_eval_with(&scratch, "large", 1, 10, &["--no-background"]);
    let n = |k: &str| score[k].as_u64().unwrap_or(0);
    assert_eq!(n("predictions"), n("true_predictions"), "{}", out.stdout);
    assert_eq!(n("detected"), n("truth_parts"), "{}", out.stdout);
    // Every known part named: the nearly 3-fold pick among them, which the DP put a third of
    // a turn off in two of these frames (one then unknown) before its near turn was aligned.
    assert!(n("known") >= 6 && n("known_correct") == n("known"), "{}", out.stdout);
    assert!(
        out.stderr.contains("stroke(s) thinner than any taught part"),
        "{}",
        out.stderr
    );
}

/// A 64×20 bar (with `long` more columns) centred at (`cx`, `cy`), along x or, `upright`, along
/// y, drawn with `value`.
fn draw_bar(img: &mut GrayImage, cx: i64, cy: i64, long: i64, upright: bool, value: u8) {
    let half = (64 + long) / 2;
    for v in -10..10i64 {
        for u in -half..half {
            let (x, y) = if upright { (cx + v, cy + u) } else { (cx + u, cy + v) };
            img.put_pixel(x as u32, y as u32, Luma([value]));
        }
    }
}

#[test]
fn teach_add_makes_a_class_of_several_examples_at_one_reference_pose() {
    let scratch = Scratch::new("teachadd");
    // Two bars of one class, the second 12 px longer and upright.
    let mut frame = GrayImage::from_pixel(240, 200, Luma([200]));
    draw_bar(&mut frame, 70, 30, 0, false, 40);
    draw_bar(&mut frame, 170, 110, 12, true, 40);
    let path = scratch.join("f.png");
    frame.save(&path).unwrap();
    let t = scratch.join("t");
    let teach = |extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = vec!["teach".into(), path.clone().into()];
        args.extend(extra.iter().map(Into::into));
        args.extend(["--name".into(), "bar".into(), "--out".into(), t.clone().into()]);
        vorl(args)
    };
    teach(&["--part", "1"]).success();
    assert!(t.join("bar.png").is_file());
    // A part that is not there changes nothing.
    let err = teach(&["--part", "9", "--add"]).failure();
    assert!(err.errors().join(" ").contains("--part 9"), "{}", err.dump());
    assert!(t.join("bar.png").is_file() && !t.join("bar").exists());
    let out = teach(&["--part", "2", "--add"]).success();
    assert!(!t.join("bar.png").exists(), "{}", out.dump());
    let (first, second) = (gray(&t.join("bar/1.png")), gray(&t.join("bar/2.png")));
    assert_eq!((blobs(&first), blobs(&second)), (1, 1));
    // The upright bar was turned onto the first's pose: both lie along x (within a pixel of
    // their drawn sizes, with the crop's 10 px margins).
    let extent = |img: &GrayImage| {
        let on: Vec<(u32, u32)> = img
            .enumerate_pixels()
            .filter(|p| p.2 .0[0] > 127)
            .map(|p| (p.0, p.1))
            .collect();
        let w = on.iter().map(|p| p.0).max().unwrap() - on.iter().map(|p| p.0).min().unwrap() + 1;
        let h = on.iter().map(|p| p.1).max().unwrap() - on.iter().map(|p| p.1).min().unwrap() + 1;
        (w as i64, h as i64)
    };
    assert_eq!(extent(&first), (64, 20));
    let (w, h) = extent(&second);
    assert!((w - 76).abs() <= 1 && (h - 20).abs() <= 1, "{w}×{h}; {}", out.dump());
    // The class's tolerance: its examples differ, so the limit grows; the scale spans 76/64.
    let line = out
        .stdout
        .lines()
        .find(|l| l.starts_with("class bar: 2 examples"))
        .unwrap_or_else(|| panic!("{}", out.dump()));
    let factor: f64 = line
        .split('×')
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(factor > 1.0, "{line}");
    // The library carries it, for both examples.
    let lib = scratch.join("lib.vtl");
    vorl([
        OsStr::new("templates"),
        OsStr::new("export"),
        t.as_os_str(),
        OsStr::new("--out"),
        lib.as_os_str(),
    ])
    .success();
    let info = vorl([OsStr::new("templates"), OsStr::new("info"), lib.as_os_str()]).success();
    assert_eq!(info.stdout.matches("class tolerance").count(), 2, "{}", info.dump());
    // A class folder mixing a good and an unreadable example is refused, naming the file.
    std::fs::write(t.join("bar/3.png"), b"not a png").unwrap();
    let err = vorl([
        OsStr::new("templates"),
        OsStr::new("export"),
        t.as_os_str(),
        OsStr::new("--out"),
        lib.as_os_str(),
    ])
    .failure();
    assert!(err.errors().join(" ").contains("3.png"), "{}", err.dump());
}

/// `vorl gen` of `variant` (seed, frames) into a scratch folder, then `vorl eval --json` of it:
/// the set's folder, the eval's JSON and the run (for messages).
fn gen_and_eval(scratch: &Scratch, variant: &str, seed: u32, frames: u32) -> (PathBuf, Value, Out) {
    gen_and_eval_with(scratch, variant, seed, frames, &[])
}

/// [`gen_and_eval`] with further `vorl gen` flags (`--no-background`).
fn gen_and_eval_with(
    scratch: &Scratch,
    variant: &str,
    seed: u32,
    frames: u32,
    gen_flags: &[&str],
) -> (PathBuf, Value, Out) {
    let set = scratch.join(variant);
    let (seed, frames) = (seed.to_string(), frames.to_string());
    let mut args = vec![
        OsStr::new("gen"),
        set.as_os_str(),
        OsStr::new("--seed"),
        OsStr::new(&seed),
        OsStr::new("--frames"),
        OsStr::new(&frames),
        OsStr::new("--variant"),
        OsStr::new(variant),
    ];
    args.extend(gen_flags.iter().map(OsStr::new));
    vorl(args).success();
    let out = vorl([OsStr::new("eval"), set.as_os_str(), OsStr::new("--json")]).success();
    let v: Value = serde_json::from_str(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", out.dump()));
    (set, v, out)
}

/// A whole part (not cut by the frame's edge) that the DP puts at least 2ε from its first
/// candidate (`score` ≥ 0.16 at the default ε = 0.08) is of no template's family: its
/// candidate scan ends there, unknown, after one DP search and no alignment (no `verify_px`),
/// its nearest template still reported. The set is the bench set (`bench/compare.sh`), whose
/// distractors include such parts; the scan still goes on for others, and every part keeps
/// its class or its rejection.
#[test]
fn far_off_parts_take_one_search_and_no_alignment() {
    let scratch = Scratch::new("far_off");
    let (set, v, out) = gen_and_eval(&scratch, "default", 5, 30);
    assert_eq!(v["classification"].as_f64(), Some(1.0), "{}", out.dump());
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    let det = vorl([OsStr::new("detect"), set.as_os_str(), OsStr::new("--json")]).success();
    let json = det.json();
    let (mut far, mut more) = (0, 0);
    for (name, parts) in json["frames"].as_object().expect("frames") {
        for p in parts.as_array().expect("a list") {
            let searches = p["searches"]
                .as_u64()
                .unwrap_or_else(|| panic!("{name}: no searches: {p}"));
            let score = p["score"].as_f64().unwrap_or(f64::INFINITY);
            let cut = p["partial"].as_bool().unwrap_or(false);
            if score.is_finite() && score >= 0.16 && !cut {
                assert!(p["class"].is_null(), "{name}: {p}");
                assert!(p["best_class"].is_string(), "{name}: {p}");
                assert_eq!(searches, 1, "{name}: {p}");
                assert!(p.get("verify_px").is_none(), "{name}: {p}");
                far += 1;
            }
            if searches > 1 {
                more += 1;
            }
        }
    }
    // The rule must have had parts to stop, and the scan parts to go on for.
    assert!(far >= 3 && more >= 3, "far {far}, more {more}");
}

/// The `flipped` variant lays about half of the chiral parts upside down: every one is found
/// and named with its side reported right, and no part the right way up (or mirror-symmetric)
/// is called flipped; the angles hold as on the default set, and a pin whose ends only a small
/// hole tells apart is the right way round. The wrench and the shaft key are
/// nearly mirror-symmetric: upside down they fit their template confidently (the verification
/// leaves out the stretch where they differ), and only the mean over every point tells them.
#[test]
fn gen_flipped_parts_are_found_upside_down() {
    let scratch = Scratch::new("flipped");
    let (_, v, out) = gen_and_eval(&scratch, "flipped", 1, 60);
    assert_eq!(v["classification"].as_f64(), Some(1.0), "{}", out.dump());
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    let flipped = v["flipped"].as_u64().unwrap_or(0);
    assert!(flipped >= 10, "{}", out.dump());
    assert_eq!(v["flipped_correct"].as_u64(), Some(flipped), "{}", out.dump());
    assert_eq!(v["flip_right"], v["flip_judged"], "{}", out.dump());
    assert_eq!(v["flip_judged"], v["known_correct"], "{}", out.dump());
    assert!(v["angle"]["median"].as_f64().unwrap() < 0.03, "{}", out.dump());
    assert!(v["angle"]["p95"].as_f64().unwrap() < 0.15, "{}", out.dump());
    // No part half a turn off: the pin's ends differ only by a hole too small for the tracing,
    // which its dip of |D| tells (6 of the set's 12 pins were half a turn off without it).
    assert!(v["angle"]["max"].as_f64().unwrap() < 1.0, "{}", out.dump());
    assert!(v["position"]["median"].as_f64().unwrap() < 0.05, "{}", out.dump());
}

/// The `rods` variant reproduces the real rods' failure: two classes of one outline told apart
/// only by their eyes, every rod with its own proportions. The holes must tell them apart
/// (without them the class of each rod is a coin toss between two equal outlines).
#[test]
fn gen_rods_are_told_apart_by_their_holes() {
    let scratch = Scratch::new("rods");
    let (set, v, out) = gen_and_eval(&scratch, "rods", 3, 20);
    assert!(!set.join("background.png").exists());
    let (known, correct) = (v["known"].as_u64().unwrap(), v["known_correct"].as_u64().unwrap());
    assert!(known >= 40, "{}", out.dump());
    assert!(
        correct as f64 >= 0.95 * known as f64,
        "{correct}/{known}: {}",
        out.dump()
    );
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    assert!(v["angle"]["median"].as_f64().unwrap() < 0.1, "{}", out.dump());
    // rod_b's eyes have thin rims, as the real rods' do: no ring pixel for the partial-volume
    // centroid near them, under a backlight that falls off across the rod. The fallback
    // contrast scaled by the platform's level keeps the positions (p95 0.05 px, max 0.09);
    // the whole ring's median unscaled gave p95 0.19 px, max 0.44 px here.
    let (p95, max) = (
        v["position"]["p95"].as_f64().unwrap(),
        v["position"]["max"].as_f64().unwrap(),
    );
    assert!(p95 < 0.1 && max < 0.2, "position p95 {p95}, max {max}: {}", out.dump());
}

/// The `rods-touching` variant reproduces the real photo `rods/TESI50`: rods lying against
/// one another, each off its template's outline. With the partial search (its `vorl.toml`),
/// the requirement holds: at least 90 % of the parts that touch another are found and 90 % of
/// the touching rods named (seed 3, held out while the search's scales were chosen: 78/82
/// found, 71/76 named with the other scales where the middle's runs point to them, 79/82 and
/// 71/76 at all three scales, 74/82 and 61/76 with the range's middle scale alone, 72/82 and
/// 57/76 before the rest and the holes' ranking), no distractor is named, and the rods that
/// touch nothing keep their classes.
#[test]
fn gen_touching_rods_are_found_by_their_holes() {
    let scratch = Scratch::new("rods_touching");
    let (set, v, out) = gen_and_eval(&scratch, "rods-touching", 3, 40);
    assert!(std::fs::read_to_string(set.join("vorl.toml"))
        .unwrap()
        .contains("touching_parts = true"));
    let t = &v["touching"];
    let (parts, detected) = (t["parts"].as_u64().unwrap(), t["detected"].as_u64().unwrap());
    let (known, correct) = (t["known"].as_u64().unwrap(), t["correct"].as_u64().unwrap());
    assert!(known >= 60, "{}", out.dump());
    assert!(
        10 * detected >= 9 * parts,
        "touching parts found: {detected}/{parts}: {}",
        out.dump()
    );
    assert!(
        10 * correct >= 9 * known,
        "touching rods named: {correct}/{known}: {}",
        out.dump()
    );
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    assert!(v["precision"].as_f64().unwrap() >= 0.95, "{}", out.dump());
    assert_eq!(v["apart"]["correct"], v["apart"]["known"], "{}", out.dump());
}

/// The `thick` set's thickest parts far from the frame's centre show walls that change their
/// silhouette most: in frame 23 a wrench 19 mm thick, whose walls grow its area beyond what the
/// scale range and the old slack allowed (it was never searched), and in frame 33 a washer 20 mm
/// thick, whose DP cost came 4 % above the hex nut's and 40–75 % below two gears' that the scan
/// tried first. Both are named now (the size filter reaches as far as the wall model, and near
/// ties are tried before the wider fallback); before, 84 of the 86 known parts.
///
/// The wall model is tried where an outline grew beyond the scale range, so this holds with the
/// range of a camera at a fixed height (0.9–1.1). With the default range (1/1.4–1.4, which a
/// camera moved between shifts needs) a grown outline fits within the range at scale 1.2–1.3
/// and the wall is not tried: two of the thickest parts are unknown (84 of 86, as before the
/// wall model; `docs/accuracy.md`).
///
/// With the fixed range, one part is unknown: the U bracket in frame 23 (far in the frame's
/// corner), whose walls all but close both its holes. The hole veto lets a hole pass unseen
/// only where the widest wall the alignment admits could close it (twice the hole's radius),
/// no longer wherever that wall is wider than the hole's radius: random blobs that fit a cam
/// but lack its bore passed that way (`docs/accuracy.md`, "Holes a wall or a shadow may
/// hide"). Before that change, 86 of 86.
#[test]
fn gen_thick_walls_keep_their_classes() {
    let scratch = Scratch::new("thick");
    let (set, v, out) = gen_and_eval(&scratch, "thick", 3, 34);
    assert_eq!(v["known"].as_u64(), Some(86), "{}", out.dump());
    let correct = (v["classification"].as_f64().unwrap() * 86.0).round();
    assert!(correct >= 84.0, "defaults: {correct} of 86: {}", out.dump());
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    let out = vorl([
        OsStr::new("eval"),
        set.as_os_str(),
        OsStr::new("--json"),
        OsStr::new("--scale-min"),
        OsStr::new("0.9"),
        OsStr::new("--scale-max"),
        OsStr::new("1.1"),
    ])
    .success();
    let v: Value = serde_json::from_str(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", out.dump()));
    let correct = (v["classification"].as_f64().unwrap() * 86.0).round();
    assert!(correct >= 85.0, "scale 0.9-1.1: {correct} of 86: {}", out.dump());
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
}

/// With nothing set, parts the frame's edge cuts that show half their outline or more are named
/// (the partial search is on by default: a user does not know to switch it on). Issue 37 asks
/// for 80 % of them; with the search off (the old default) 5 of these 26 were.
#[test]
fn gen_border_cut_parts_are_named_with_defaults() {
    let scratch = Scratch::new("border-cut");
    let (_, v, out) = gen_and_eval(&scratch, "border", 2, 30);
    let cut = &v["cut_half"];
    let (known, correct) = (cut["known"].as_u64().unwrap(), cut["correct"].as_u64().unwrap());
    assert!(known >= 20, "{known} known cut parts: {}", out.dump());
    assert!(
        correct * 5 >= known * 4,
        "{correct} of {known} cut parts named: {}",
        out.dump()
    );
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
}

/// The `printed` set's parts carry print and light patches that the mask shows as holes their
/// templates do not have. Such a hole, and the partial-volume weight it takes from the part
/// around it, count as the part (`partial_volume::print_deficit`): position median 0.104 px on
/// these 60 frames, where adding each hole's pixels at its centre gave 0.168 px. (Print holes
/// smaller than the border filter's `min_area` never reach the contour store, so the worst
/// part, a wrench with small dark letters, stays 3.2 px off.)
#[test]
fn gen_printed_holes_count_as_the_part() {
    let scratch = Scratch::new("printed");
    let (_, v, out) = gen_and_eval(&scratch, "printed", 3, 60);
    assert_eq!(v["classification"].as_f64(), Some(1.0), "{}", out.dump());
    let median = v["position"]["median"].as_f64().unwrap();
    assert!(median < 0.14, "position median {median}: {}", out.dump());
}

/// The `sharp` set's distractors include a triangle with a central hole, which fits the snail
/// cam's and the cross's outline loosely (2.3–2.5× the limit) and their central hole too: a
/// central hole is no evidence for a near miss (`recognizer::accepted`), so it stays unknown.
#[test]
fn gen_sharp_distractors_with_a_central_hole_stay_unknown() {
    let scratch = Scratch::new("sharp");
    let (_, v, out) = gen_and_eval(&scratch, "sharp", 3, 30);
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    assert_eq!(v["classification"].as_f64(), Some(1.0), "{}", out.dump());
}

/// The `sharp` set teaches two gears of the same radii and flanks, 10 and 12 teeth, beside each
/// other: the DP's `f′` of either part against the other's template is well below ε (the
/// silhouettes differ only in their number of teeth), so they must be told apart by which
/// template the scan aligns and how well it verifies. Every gear of either kind is named
/// as its truth says, and no other part is called a gear.
#[test]
fn gen_sharp_gears_of_ten_and_twelve_teeth_are_told_apart() {
    let scratch = Scratch::new("sharp_gears");
    let (set, v, out) = gen_and_eval(&scratch, "sharp", 1, 30);
    assert_eq!(v["unknown_rejection"].as_f64(), Some(1.0), "{}", out.dump());
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(set.join("truth.json")).expect("truth.json")).expect("json");
    let det = vorl([OsStr::new("detect"), set.as_os_str(), OsStr::new("--json")]).success();
    let json = det.json();
    let gears = ["gear_sharp_z10", "gear_sharp_z12"];
    let mut seen = BTreeMap::new();
    for frame in truth["frames"].as_object().expect("frames").keys() {
        let found = parts_of(&json, frame);
        for t in parts_of(&truth, frame) {
            let (p, d) = nearest(&found, t.x, t.y).unwrap_or_else(|| panic!("{frame}: nothing found"));
            assert!(d < 2.0, "{frame}: no part within 2 px of {t:?}");
            let gear = |c: &Option<String>| c.as_deref().is_some_and(|c| gears.contains(&c));
            if gear(&t.class) {
                *seen.entry(t.class.clone()).or_insert(0) += 1;
                assert_eq!(p.class, t.class, "{frame}: {t:?} taken for {p:?}");
            } else {
                assert!(!gear(&p.class), "{frame}: {t:?} taken for {p:?}");
            }
        }
    }
    // Both kinds are there, several times each.
    for g in gears {
        let n = seen.get(&Some(g.to_string())).copied().unwrap_or(0);
        assert!(n >= 5, "{n} parts of {g}: {seen:?}");
    }
}
