//! The firmware example (`firmware-example/`) against the host.
//!
//! - `fixtures_are_current`: the QVGA fixture of the firmware (raw 8-bit gray frames, template
//!   silhouettes and the template library in `firmware-example/fixtures/`) is what the generator
//!   below makes. The generator writes a PNG fixture set (`target/firmware-fixture-set/`:
//!   background.png, backgrounds/, templates/, frames/, truth.json; usable with `vorl detect` and
//!   `vorl eval`), and the raw files are converted from those PNGs; the library is
//!   `vorl templates export firmware-example/fixtures/templates`. To regenerate after a change:
//!   `VORL_REGEN_FIXTURES=1 cargo test -p vorl-tests --test firmware fixtures_are_current`.
//! - `firmware_matches_host`: builds the firmware (`cargo build --release` in firmware-example),
//!   runs it in `qemu-system-arm -machine mps2-an386 -icount shift=0` (killed after 120 s, so a
//!   hard fault cannot hang CI), and holds every detection against the host's
//!   [`vorl_host_sim::engine::Engine`] on the same frames, background frames, templates and
//!   parameters: same classes, positions within 0.5 px, angles within 0.5°. Without
//!   qemu-system-arm it fails, saying to run `scripts/setup.sh`, unless `VORL_SKIP_QEMU=1`.
//! - `linker_static_ram_matches_budget`: the linker's static RAM (`.data + .bss`, from the
//!   llvm-tools' `llvm-size`) equals `vorl budget`'s total for the firmware's configuration within
//!   [`RUNTIME_MARGIN`] bytes, and fits the 256 KiB RAM region with the stack reserve.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use image::GrayImage;
use vorl_core::library::Library;
use vorl_core::Params;
use vorl_host_sim::cli::budget::{self, BudgetArgs, Target};
use vorl_host_sim::cli::params::ParamArgs;
use vorl_host_sim::cli::templates::{self, ExportArgs, TemplatesAction, TemplatesArgs};
use vorl_host_sim::engine::{load_silhouettes, Engine};

/// Frame width of the firmware fixture (QVGA).
const W: usize = 320;
/// Frame height of the firmware fixture.
const H: usize = 240;
/// Size of a template silhouette image.
const SIL: usize = 160;
/// Seconds QEMU may run before it is killed.
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);
/// Seconds the firmware build may take.
const BUILD_TIMEOUT: Duration = Duration::from_secs(900);
/// Bytes of `.data + .bss` allowed above `vorl budget`'s total: the runtime's own statics
/// (semihosting stdout handle, SysTick wrap counter, flags; 20-odd bytes) and section alignment.
/// The stack is not in `.data + .bss`: it is the RAM above them (memory.x keeps ≥ 24 KiB).
const RUNTIME_MARGIN: usize = 256;
/// RAM region of memory.x.
const RAM_REGION: usize = 256 * 1024;
/// Stack floor of memory.x (`_vorl_min_stack`).
const STACK_RESERVE: usize = 24 * 1024;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

fn firmware_dir() -> PathBuf {
    root().join("firmware-example")
}

fn fixture_dir() -> PathBuf {
    firmware_dir().join("fixtures")
}

// ---------------------------------------------------------------------------------------------
// The fixture generator.

/// A flat part: its outline and holes (even–odd), in px around its own origin, at angle 0.
struct Shape {
    name: &'static str,
    rings: Vec<Vec<(f64, f64)>>,
    /// Whether it is a template (the unknown part is not).
    template: bool,
    /// n-fold rotational symmetry (1 = none).
    symmetry: u32,
}

fn shape(name: &'static str, outline: &[(f64, f64)]) -> Shape {
    Shape {
        name,
        rings: vec![outline.to_vec()],
        template: true,
        symmetry: 1,
    }
}

/// The eight templates (asymmetric, so every angle is defined) and one part that is not taught.
fn shapes() -> Vec<Shape> {
    let hexagon: Vec<(f64, f64)> = (0..6)
        .map(|i| {
            let a = f64::from(i) * std::f64::consts::PI / 3.0;
            (26.0 * a.cos(), 26.0 * a.sin())
        })
        .collect();
    vec![
        shape(
            "arrow",
            &[
                (-32.0, -6.0),
                (8.0, -6.0),
                (8.0, -17.0),
                (32.0, 0.0),
                (8.0, 17.0),
                (8.0, 6.0),
                (-32.0, 6.0),
            ],
        ),
        shape(
            "crank",
            &[
                (-30.0, -20.0),
                (2.0, -20.0),
                (2.0, 4.0),
                (30.0, 4.0),
                (30.0, 18.0),
                (-12.0, 18.0),
                (-12.0, -6.0),
                (-30.0, -6.0),
            ],
        ),
        shape(
            "key",
            &[
                (-30.0, -10.0),
                (18.0, -10.0),
                (30.0, 0.0),
                (18.0, 10.0),
                (4.0, 10.0),
                (4.0, 20.0),
                (-8.0, 20.0),
                (-8.0, 10.0),
                (-30.0, 10.0),
            ],
        ),
        shape(
            "l_bracket",
            &[
                (-18.0, -26.0),
                (-6.0, -26.0),
                (-6.0, 12.0),
                (24.0, 12.0),
                (24.0, 24.0),
                (-18.0, 24.0),
            ],
        ),
        shape(
            "pennant",
            &[
                (-24.0, -28.0),
                (-14.0, -28.0),
                (-14.0, -20.0),
                (28.0, -6.0),
                (-14.0, 8.0),
                (-14.0, 28.0),
                (-24.0, 28.0),
            ],
        ),
        Shape {
            name: "plate_hole",
            rings: vec![
                vec![
                    (-28.0, -18.0),
                    (20.0, -18.0),
                    (28.0, -10.0),
                    (28.0, 18.0),
                    (-28.0, 18.0),
                ],
                vec![(6.0, -8.0), (18.0, -8.0), (18.0, 6.0), (6.0, 6.0)],
            ],
            template: true,
            symmetry: 1,
        },
        shape(
            "t_piece",
            &[
                (-28.0, -22.0),
                (28.0, -22.0),
                (28.0, -8.0),
                (7.0, -8.0),
                (7.0, 26.0),
                (-7.0, 26.0),
                (-7.0, -8.0),
                (-28.0, -8.0),
            ],
        ),
        shape("triangle", &[(-30.0, 18.0), (30.0, 18.0), (-8.0, -26.0)]),
        Shape {
            name: "hexagon",
            rings: vec![hexagon],
            template: false,
            symmetry: 6,
        },
    ]
}

/// A part placed in a scene: shape index, area-centroid-free pose (origin at `x`, `y`), angle,
/// and whether it lies upside down (mirrored left-right about its own origin before it is
/// turned: the contract of `../shared/DESIGN.md`, up to the move of the centroid, which the
/// truth measures on the posed rings).
struct Placement {
    shape: usize,
    x: f64,
    y: f64,
    angle: f64,
    flipped: bool,
}

const fn place(shape: usize, x: f64, y: f64, angle: f64) -> Placement {
    Placement {
        shape,
        x,
        y,
        angle,
        flipped: false,
    }
}

const fn place_flipped(shape: usize, x: f64, y: f64, angle: f64) -> Placement {
    Placement {
        flipped: true,
        ..place(shape, x, y, angle)
    }
}

/// Three QVGA scenes of four parts, one per quadrant; frame_2 holds the untaught hexagon.
fn scenes() -> Vec<(&'static str, Vec<Placement>)> {
    vec![
        (
            "frame_0",
            vec![
                place(3, 78.0, 62.0, 17.0),
                place(0, 236.0, 58.0, 140.0),
                place(2, 84.0, 178.0, 255.0),
                place(6, 242.0, 182.0, 300.0),
            ],
        ),
        (
            "frame_1",
            vec![
                place(7, 80.0, 60.0, 35.0),
                place(1, 240.0, 64.0, 200.0),
                place(4, 76.0, 176.0, 95.0),
                place(5, 238.0, 178.0, 330.0),
            ],
        ),
        (
            "frame_2",
            vec![
                place(0, 82.0, 58.0, 275.0),
                place(5, 240.0, 60.0, 48.0),
                place(1, 80.0, 182.0, 123.0),
                place(8, 242.0, 180.0, 10.0),
            ],
        ),
    ]
}

/// The scene the firmware runs with the partial search on (`touching_parts`): a T piece and an
/// L bracket lying against each other (they overlap by 5 % of the smaller one's area, worked
/// out by bisection along the line between them: both are drawn the same grey, so they merge
/// into one blob), a key upside down, and a pennant that touches nothing.
fn touching_scene() -> (&'static str, Vec<Placement>) {
    (
        "frame_touching",
        vec![
            place(6, 80.0, 80.0, 20.0),
            place(3, 109.0, 119.0, 200.0),
            place_flipped(2, 240.0, 70.0, 60.0),
            place(4, 240.0, 180.0, 200.0),
        ],
    )
}

/// Indices (into [`touching_scene`]'s parts) of the two parts that touch.
const TOUCHING_PAIR: [usize; 2] = [0, 1];

/// The rings of `shape` turned counter-clockwise on screen by `angle` degrees and moved to
/// `(cx, cy)` (image coordinates, y down: `docs/pipeline-spec.md` conventions).
fn posed(shape: &Shape, angle: f64, cx: f64, cy: f64) -> Vec<Vec<(f64, f64)>> {
    posed_side(shape, angle, cx, cy, false)
}

/// [`posed`], mirrored left-right (x → −x) first when `flipped`.
fn posed_side(shape: &Shape, angle: f64, cx: f64, cy: f64, flipped: bool) -> Vec<Vec<(f64, f64)>> {
    let (s, c) = angle.to_radians().sin_cos();
    let side = if flipped { -1.0 } else { 1.0 };
    shape
        .rings
        .iter()
        .map(|r| {
            r.iter()
                .map(|&(x, y)| (side * x, y))
                .map(|(x, y)| (cx + x * c + y * s, cy - x * s + y * c))
                .collect()
        })
        .collect()
}

/// The rings of a placed part.
fn placed(shape: &Shape, p: &Placement) -> Vec<Vec<(f64, f64)>> {
    posed_side(shape, p.angle, p.x, p.y, p.flipped)
}

/// Even–odd point-in-polygon over every ring.
fn inside(rings: &[Vec<(f64, f64)>], x: f64, y: f64) -> bool {
    let mut inside = false;
    for ring in rings {
        for i in 0..ring.len() {
            let (x0, y0) = ring[i];
            let (x1, y1) = ring[(i + 1) % ring.len()];
            if (y0 > y) != (y1 > y) && x < x0 + (y - y0) / (y1 - y0) * (x1 - x0) {
                inside = !inside;
            }
        }
    }
    inside
}

/// Fraction of pixel `(px, py)` covered, from 4×4 samples.
fn coverage(rings: &[Vec<(f64, f64)>], px: usize, py: usize) -> f64 {
    let mut hits = 0;
    for sy in 0..4 {
        for sx in 0..4 {
            let x = px as f64 - 0.375 + 0.25 * f64::from(sx);
            let y = py as f64 - 0.375 + 0.25 * f64::from(sy);
            hits += u32::from(inside(rings, x, y));
        }
    }
    f64::from(hits) / 16.0
}

/// Area centroid of the rings (holes subtract, whatever their orientation).
fn area_centroid(rings: &[Vec<(f64, f64)>]) -> (f64, f64) {
    let (mut a, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (k, ring) in rings.iter().enumerate() {
        let (mut ra, mut rx, mut ry) = (0.0, 0.0, 0.0);
        for i in 0..ring.len() {
            let (x0, y0) = ring[i];
            let (x1, y1) = ring[(i + 1) % ring.len()];
            let cross = x0 * y1 - x1 * y0;
            ra += cross;
            rx += (x0 + x1) * cross;
            ry += (y0 + y1) * cross;
        }
        let sign = if (k == 0) == (ra >= 0.0) { 1.0 } else { -1.0 };
        a += sign * ra;
        sx += sign * rx;
        sy += sign * ry;
    }
    (sx / (3.0 * a), sy / (3.0 * a))
}

/// splitmix64: a small deterministic generator for the sensor noise.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform integer noise in `[−5, 5]`.
    fn noise(&mut self) -> f64 {
        (self.next() % 11) as f64 - 5.0
    }
}

/// A QVGA capture: a lit platform (grey 150 with a gentle gradient), dark parts (grey 45) with
/// anti-aliased edges, and ±5 grey levels of sensor noise.
fn render(parts: &[Placement], seed: u64) -> GrayImage {
    let all = shapes();
    let posed: Vec<Vec<Vec<(f64, f64)>>> = parts.iter().map(|p| placed(&all[p.shape], p)).collect();
    let mut rng = Rng(seed);
    let mut img = GrayImage::new(W as u32, H as u32);
    for y in 0..H {
        for x in 0..W {
            let platform = 150.0 + 20.0 * x as f64 / W as f64 - 10.0 * y as f64 / H as f64;
            let cover = posed.iter().map(|r| coverage(r, x, y)).fold(0.0, f64::max);
            let v = platform * (1.0 - cover) + 45.0 * cover + rng.noise();
            img.put_pixel(x as u32, y as u32, image::Luma([v.round().clamp(0.0, 255.0) as u8]));
        }
    }
    img
}

/// A template silhouette: the shape at angle 0 in the middle of a 160×160 image (part 255).
fn silhouette(shape: &Shape) -> GrayImage {
    let rings = posed(shape, 0.0, SIL as f64 / 2.0, SIL as f64 / 2.0);
    GrayImage::from_fn(SIL as u32, SIL as u32, |x, y| {
        image::Luma([if inside(&rings, f64::from(x), f64::from(y)) {
            255
        } else {
            0
        }])
    })
}

/// Writes the PNG fixture set into `dir` and returns it.
fn write_png_set(dir: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    for sub in ["backgrounds", "templates", "frames"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    render(&[], 1).save(dir.join("background.png")).unwrap();
    render(&[], 2).save(dir.join("backgrounds/background_1.png")).unwrap();
    let all = shapes();
    for s in all.iter().filter(|s| s.template) {
        silhouette(s)
            .save(dir.join(format!("templates/{}.png", s.name)))
            .unwrap();
    }
    let mut truth = serde_json::Map::new();
    for (k, (name, parts)) in scenes().iter().chain([touching_scene()].iter()).enumerate() {
        render(parts, 100 + k as u64)
            .save(dir.join(format!("frames/{name}.png")))
            .unwrap();
        let list: Vec<serde_json::Value> = parts
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let s = &all[p.shape];
                let (x, y) = area_centroid(&placed(s, p));
                let mut part = serde_json::json!({
                    "class": s.template.then_some(s.name),
                    "x": (x * 1e4).round() / 1e4,
                    "y": (y * 1e4).round() / 1e4,
                    "angle_deg": p.angle,
                    "symmetry": s.symmetry,
                });
                if p.flipped {
                    part["flipped"] = true.into();
                }
                if *name == touching_scene().0 && TOUCHING_PAIR.contains(&i) {
                    part["touching"] = true.into();
                }
                part
            })
            .collect();
        truth.insert(format!("{name}.png"), list.into());
    }
    let text = serde_json::to_string_pretty(&serde_json::json!({ "frames": truth })).unwrap();
    std::fs::write(dir.join("truth.json"), text + "\n").unwrap();
    dir.to_path_buf()
}

/// The raw fixture files (name, bytes) converted from the PNG set.
fn raw_files(set: &Path) -> Vec<(String, Vec<u8>)> {
    let load = |p: PathBuf| vorl_host_sim::io::load_gray(&p).unwrap().image.into_raw();
    let mut out = vec![
        ("background_0.gray".to_string(), load(set.join("background.png"))),
        (
            "background_1.gray".to_string(),
            load(set.join("backgrounds/background_1.png")),
        ),
    ];
    for (name, _) in scenes().into_iter().chain([touching_scene()]) {
        out.push((format!("{name}.gray"), load(set.join(format!("frames/{name}.png")))));
    }
    out
}

/// Pixels that differ, and the largest difference.
fn differences(a: &[u8], b: &[u8]) -> (usize, u8) {
    let diffs: Vec<u8> = a
        .iter()
        .zip(b)
        .map(|(x, y)| x.abs_diff(*y))
        .filter(|&d| d > 0)
        .collect();
    (diffs.len(), diffs.iter().copied().max().unwrap_or(0))
}

#[test]
fn fixtures_are_current() {
    let regen = std::env::var("VORL_REGEN_FIXTURES").is_ok_and(|v| v == "1");
    let set = write_png_set(&root().join("target").join("firmware-fixture-set"));
    let fixtures = fixture_dir();
    let hint = "regenerate with VORL_REGEN_FIXTURES=1 cargo test -p vorl-tests --test firmware fixtures_are_current";
    if regen {
        std::fs::create_dir_all(fixtures.join("templates")).unwrap();
        for (name, bytes) in raw_files(&set) {
            std::fs::write(fixtures.join(name), bytes).unwrap();
        }
        for entry in std::fs::read_dir(set.join("templates")).unwrap() {
            let path = entry.unwrap().path();
            std::fs::copy(&path, fixtures.join("templates").join(path.file_name().unwrap())).unwrap();
        }
        let (bytes, _) = templates::export_library(&fixtures.join("templates"), Params::DEFAULT).unwrap();
        std::fs::write(fixtures.join("templates.vtl"), bytes).unwrap();
        eprintln!("regenerated {}", fixtures.display());
    }
    // Frames: rendering uses sin/cos of the platform's libm, so allow a few pixels one level off.
    for (name, bytes) in raw_files(&set) {
        assert_eq!(bytes.len(), W * H, "{name}");
        let stored = std::fs::read(fixtures.join(&name)).unwrap_or_else(|e| panic!("{name}: {e}; {hint}"));
        assert_eq!(stored.len(), W * H, "{name}: not a raw 320×240 8-bit file; {hint}");
        let (count, max) = differences(&bytes, &stored);
        assert!(
            count <= 16 && max <= 2,
            "{name}: {count} pixels differ (up to {max} levels) from the generator; {hint}"
        );
    }
    // Silhouettes: exact (no trigonometry at angle 0).
    let generated = load_silhouettes(&set.join("templates")).unwrap();
    let stored = load_silhouettes(&fixtures.join("templates")).unwrap();
    assert_eq!(generated.len(), stored.len(), "template count; {hint}");
    for (g, s) in generated.iter().zip(&stored) {
        assert_eq!(
            (&g.name, g.image.as_raw()),
            (&s.name, s.image.as_raw()),
            "template {}; {hint}",
            g.name
        );
    }
    // The library is what `vorl templates export firmware-example/fixtures/templates` writes.
    let (bytes, names) = templates::export_library(&fixtures.join("templates"), Params::DEFAULT).unwrap();
    let stored = std::fs::read(fixtures.join("templates.vtl")).unwrap();
    assert!(
        bytes == stored,
        "templates.vtl differs from the export of fixtures/templates; {hint}"
    );
    let lib = Library::parse(&stored).unwrap();
    assert_eq!(lib.len(), 8);
    assert_eq!(
        (0..lib.len())
            .map(|i| lib.name(i).unwrap().to_string())
            .collect::<Vec<_>>(),
        names
    );
    // The export through the command line writes the same bytes.
    let out = root().join("target").join("firmware-fixture-set").join("templates.vtl");
    let args = TemplatesArgs {
        action: TemplatesAction::Export(Box::new(ExportArgs {
            dir: fixtures.join("templates"),
            out: out.clone(),
            params: ParamArgs::default(),
        })),
    };
    templates::run(args).unwrap();
    assert!(
        std::fs::read(&out).unwrap() == stored,
        "vorl templates export wrote other bytes"
    );
}

// ---------------------------------------------------------------------------------------------
// Building and running the firmware.

/// Runs `cmd` with a deadline; kills it when the deadline passes. Returns (status, stdout, stderr).
fn run_with_timeout(
    mut cmd: Command,
    limit: Duration,
    what: &str,
) -> Result<(std::process::ExitStatus, String, String), String> {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut out, &mut s);
        s
    });
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut err, &mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| format!("{what}: {e}"))? {
            break status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            let stdout = out_thread.join().unwrap_or_default();
            return Err(format!(
                "{what}: killed after {} s (hung or hard fault?); output so far:\n{stdout}",
                limit.as_secs()
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    Ok((
        status,
        out_thread.join().unwrap_or_default(),
        err_thread.join().unwrap_or_default(),
    ))
}

/// Builds the firmware once per test run; the ELF's path.
fn firmware_elf() -> &'static Result<PathBuf, String> {
    static ELF: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    ELF.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let target_dir = firmware_dir().join("target");
        let mut cmd = Command::new(cargo);
        cmd.current_dir(firmware_dir())
            .args(["build", "--release", "--target", "thumbv7em-none-eabihf", "--target-dir"])
            .arg(&target_dir);
        // The firmware's link flags come from its .cargo/config.toml; flags meant for the host
        // build must not replace them.
        for var in ["RUSTFLAGS", "CARGO_ENCODED_RUSTFLAGS", "CARGO_BUILD_RUSTFLAGS", "CARGO_BUILD_TARGET", "CARGO_TARGET_DIR"] {
            cmd.env_remove(var);
        }
        let (status, _, stderr) = run_with_timeout(cmd, BUILD_TIMEOUT, "cargo build --release (firmware-example)")?;
        if !status.success() {
            return Err(format!(
                "the firmware does not build ({status}); is the thumbv7em-none-eabihf target installed (scripts/setup.sh)?\n{stderr}"
            ));
        }
        Ok(target_dir.join("thumbv7em-none-eabihf/release/vorl-firmware-example"))
    })
}

fn qemu_available() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The `key=value` fields of an output line.
fn fields(line: &str) -> BTreeMap<&str, &str> {
    line.split_whitespace().filter_map(|f| f.split_once('=')).collect()
}

/// One detection, from either side.
#[derive(Debug, Clone)]
struct Det {
    class: Option<String>,
    x: f64,
    y: f64,
    angle: f64,
    /// Reported upside down.
    flipped: bool,
    /// Found by the partial search in a blob of several parts.
    touching: bool,
}

fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// Runs the firmware in QEMU (with `-append ARGS` when given: the semihosting command line),
/// writes its output to `target/NAME` and returns it; panics when it fails.
fn run_firmware(append: Option<&str>, name: &str) -> String {
    let elf = firmware_elf().as_ref().unwrap_or_else(|e| panic!("{e}"));
    let mut qemu = Command::new("qemu-system-arm");
    qemu.args(["-cpu", "cortex-m4", "-machine", "mps2-an386", "-nographic"])
        .args([
            "-semihosting-config",
            "enable=on,target=native",
            "-icount",
            "shift=0",
            "-kernel",
        ])
        .arg(elf);
    if let Some(args) = append {
        qemu.args(["-append", args]);
    }
    let started = Instant::now();
    let (status, stdout, stderr) =
        run_with_timeout(qemu, QEMU_TIMEOUT, "qemu-system-arm").unwrap_or_else(|e| panic!("{e}"));
    let seconds = started.elapsed().as_secs_f64();
    let _ = std::fs::write(root().join("target").join(name), &stdout);
    assert!(status.success(), "the firmware failed ({status}):\n{stdout}\n{stderr}");
    eprintln!("firmware ran {seconds:.1} s in QEMU:\n{stdout}");
    stdout
}

/// Skips (with `VORL_SKIP_QEMU=1`) or fails when qemu-system-arm is missing; true to go on.
fn need_qemu(test: &str) -> bool {
    if qemu_available() {
        return true;
    }
    if std::env::var("VORL_SKIP_QEMU").is_ok_and(|v| v == "1") {
        eprintln!("SKIPPED {test}: qemu-system-arm is not installed (VORL_SKIP_QEMU=1)");
        return false;
    }
    panic!("qemu-system-arm is not installed: run scripts/setup.sh (or set VORL_SKIP_QEMU=1 to skip this test)");
}

/// The firmware's `<tag> frame=NAME …` detection lines, by frame name.
fn firmware_detections(stdout: &str, tag: &str) -> BTreeMap<String, Vec<Det>> {
    let mut fw: BTreeMap<String, Vec<Det>> = BTreeMap::new();
    let prefix = format!("{tag} ");
    for line in stdout.lines().filter(|l| l.starts_with(&prefix)) {
        let f = fields(line);
        let class = (f["template"] != "-").then(|| f["class"].to_string());
        let num = |k: &str| f[k].parse::<f64>().unwrap_or_else(|_| panic!("{k} in {line}"));
        let flag = |k: &str| match f.get(k) {
            Some(&"1") => true,
            Some(&"0") => false,
            _ => panic!("{k} in {line}"),
        };
        fw.entry(f["frame"].to_string()).or_default().push(Det {
            class,
            x: num("x"),
            y: num("y"),
            angle: num("angle"),
            flipped: flag("flipped"),
            touching: flag("touching"),
        });
    }
    fw
}

/// The host's detections of one frame.
fn host_detections(engine: &mut Engine, img: &GrayImage) -> Vec<Det> {
    dets(&engine.detect(img).unwrap())
}

/// The detections of one frame's result, as [`Det`]s.
fn dets(result: &vorl_host_sim::engine::FrameResult) -> Vec<Det> {
    result
        .detections
        .iter()
        .map(|d| Det {
            class: d.class.clone(),
            x: f64::from(d.core.x),
            y: f64::from(d.core.y),
            angle: f64::from(d.core.angle_deg),
            flipped: d.core.flipped,
            touching: d.core.touching,
        })
        .collect()
}

/// Holds the firmware's detections of a frame against the host's: same classes, sides and
/// touching flags in the same order, positions within 0.5 px, angles within 0.5°. Returns the
/// largest differences.
fn agree(what: &str, firmware: &[Det], host: &[Det]) -> (f64, f64) {
    assert_eq!(
        firmware.len(),
        host.len(),
        "{what}: firmware {firmware:?}\nhost {host:?}"
    );
    let (mut worst_pos, mut worst_angle) = (0.0f64, 0.0f64);
    for (f, h) in firmware.iter().zip(host) {
        assert_eq!(
            (&f.class, f.flipped, f.touching),
            (&h.class, h.flipped, h.touching),
            "{what}: firmware {f:?}, host {h:?}"
        );
        let pos = (f.x - h.x).abs().max((f.y - h.y).abs());
        let ang = angle_diff(f.angle, h.angle);
        assert!(pos < 0.5 && ang < 0.5, "{what}: firmware {f:?}, host {h:?}");
        worst_pos = worst_pos.max(pos);
        worst_angle = worst_angle.max(ang);
    }
    (worst_pos, worst_angle)
}

/// A host engine with the fixture's library and parameters (no background yet).
fn fixture_engine(params: impl FnOnce(Params) -> Params) -> Engine {
    let fixtures = fixture_dir();
    let lib_bytes = std::fs::read(fixtures.join("templates.vtl")).unwrap();
    let lib = Library::parse(&lib_bytes).unwrap();
    let mut engine = Engine::new(params(lib.params(Params::DEFAULT))).unwrap();
    for s in load_silhouettes(&fixtures.join("templates")).unwrap() {
        engine.add_silhouette(&s.name, &s.image).unwrap();
    }
    engine
}

/// A raw 320×240 fixture file as an image.
fn fixture_gray(name: &str) -> GrayImage {
    GrayImage::from_raw(W as u32, H as u32, std::fs::read(fixture_dir().join(name)).unwrap()).unwrap()
}

#[test]
fn firmware_matches_host() {
    if !need_qemu("firmware_matches_host") {
        return;
    }
    let stdout = run_firmware(None, "firmware-output.txt");

    // Instruction counting works: one SysTick tick is 40 instructions under -icount shift=0.
    let calibration = stdout
        .lines()
        .find(|l| l.starts_with("calibration "))
        .expect("calibration line");
    assert_eq!(fields(calibration)["instructions_per_tick"], "40", "{calibration}");

    // The stack stayed within the reserve memory.x keeps for it.
    let summary = stdout
        .lines()
        .find(|l| l.starts_with("summary "))
        .expect("summary line");
    let stack: usize = fields(summary)["stack_peak"].parse().unwrap();
    assert!(
        stack < STACK_RESERVE,
        "stack peak {stack} bytes reaches the {STACK_RESERVE}-byte reserve of memory.x"
    );

    // The firmware's detections (every frame it reported, with or without parts).
    let mut fw = firmware_detections(&stdout, "det");
    for line in stdout.lines().filter(|l| l.starts_with("frame ")) {
        fw.entry(fields(line)["name"].to_string()).or_default();
    }
    for (name, _) in scenes() {
        let line = stdout
            .lines()
            .find(|l| l.starts_with("instructions ") && fields(l)["frame"] == name)
            .unwrap_or_else(|| panic!("no instruction counts for {name}"));
        let f = fields(line);
        let count = |k: &str| f[k].parse::<u64>().unwrap();
        assert!(
            count("mask") > 0 && count("borders") > 0 && count("descriptors_matching") > 0,
            "{line}"
        );
        assert!(
            count("mask") + count("borders") + count("descriptors_matching") <= count("total"),
            "{line}"
        );
    }

    // The host on the same inputs.
    let fixtures = fixture_dir();
    let gray =
        |name: &str| GrayImage::from_raw(W as u32, H as u32, std::fs::read(fixtures.join(name)).unwrap()).unwrap();
    let lib_bytes = std::fs::read(fixtures.join("templates.vtl")).unwrap();
    let lib = Library::parse(&lib_bytes).unwrap();
    let mut engine = Engine::new(lib.params(Params::DEFAULT)).unwrap();
    engine
        .learn_background(&[gray("background_0.gray"), gray("background_1.gray")])
        .unwrap();
    for s in load_silhouettes(&fixtures.join("templates")).unwrap() {
        engine.add_silhouette(&s.name, &s.image).unwrap();
    }
    for (i, t) in engine.templates().iter().enumerate() {
        assert_eq!(
            lib.template::<{ vorl_host_sim::engine::HOST_M }>(i).unwrap(),
            *t,
            "template {i}"
        );
        assert_eq!(lib.name(i), Some(engine.names()[i].as_str()));
    }
    let (mut worst_pos, mut worst_angle, mut compared) = (0.0f64, 0.0f64, 0usize);
    for (name, parts) in scenes() {
        let result = engine.detect(&gray(&format!("{name}.gray"))).unwrap();
        let host = dets(&result);
        let firmware = fw
            .get(name)
            .unwrap_or_else(|| panic!("the firmware printed nothing for {name}"));
        assert_eq!(
            host.len(),
            parts.len(),
            "{name}: the host finds {} parts, the scene has {}",
            host.len(),
            parts.len()
        );
        let (p, a) = agree(name, firmware, &host);
        (worst_pos, worst_angle) = (worst_pos.max(p), worst_angle.max(a));
        compared += host.len();
    }
    eprintln!(
        "{compared} detections agree: largest difference {worst_pos:.5} px, {worst_angle:.5}° (print precision 1e-4)"
    );

    // The frame of touching parts, with the partial search on (`det_touching`): the host with the
    // same parameter finds every part drawn, with its class, the pair that touches reported
    // `touching` and the key upside down reported `flipped` (no other part either), and the
    // camera agrees with it.
    let all = shapes();
    let (name, parts) = touching_scene();
    let mut touching_engine = fixture_engine(|p| Params {
        touching_parts: true,
        ..p
    });
    touching_engine
        .learn_background(&[gray("background_0.gray"), gray("background_1.gray")])
        .unwrap();
    let host = dets(&touching_engine.detect(&gray(&format!("{name}.gray"))).unwrap());
    let mut drawn: Vec<(Option<&str>, bool, bool)> = parts
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = &all[p.shape];
            (s.template.then_some(s.name), p.flipped, TOUCHING_PAIR.contains(&i))
        })
        .collect();
    let mut found: Vec<(Option<&str>, bool, bool)> = host
        .iter()
        .map(|d| (d.class.as_deref(), d.flipped, d.touching))
        .collect();
    drawn.sort();
    found.sort();
    assert_eq!(found, drawn, "{name}: the host's (class, flipped, touching)");
    let fw_touching = firmware_detections(&stdout, "det_touching");
    let firmware = fw_touching.get(name).map(Vec::as_slice).unwrap_or(&[]);
    let (p, a) = agree(&format!("{name} (touching parts)"), firmware, &host);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("instructions_touching "))
        .expect("instructions_touching line");
    eprintln!(
        "{} detections of {name} agree (largest difference {p:.5} px, {a:.5}°); {line}",
        host.len()
    );

    // No empty shot: the platform estimated on the camera from the frames (`det_auto`; from the
    // first, kept for the next while they fit it), against the host with the platform estimated
    // (`vorl detect --background auto`, a set without background.png): the same detections,
    // the same estimate kept or made anew, and the scene's parts classified as drawn.
    let fw_auto = firmware_detections(&stdout, "det_auto");
    let mut auto_engine = fixture_engine(|p| p);
    auto_engine.set_auto_background();
    let (mut auto_pos, mut auto_angle, mut auto_compared) = (0.0f64, 0.0f64, 0usize);
    for (name, parts) in scenes() {
        let result = auto_engine.detect(&gray(&format!("{name}.gray"))).unwrap();
        let host = dets(&result);
        let platform_line = stdout
            .lines()
            .find(|l| l.starts_with("platform ") && fields(l)["frame"] == name)
            .unwrap_or_else(|| panic!("no platform line for {name}"));
        assert_eq!(
            fields(platform_line)["frames_ago"].parse::<u32>().unwrap(),
            result.platform_frames_ago,
            "{name}: the camera and the host keep the platform estimate alike"
        );
        let firmware = fw_auto.get(name).map(Vec::as_slice).unwrap_or(&[]);
        let (p, a) = agree(&format!("{name} (platform estimated)"), firmware, &host);
        (auto_pos, auto_angle) = (auto_pos.max(p), auto_angle.max(a));
        auto_compared += host.len();
        let mut drawn: Vec<Option<&str>> = parts
            .iter()
            .map(|p| all[p.shape].template.then_some(all[p.shape].name))
            .collect();
        let mut found: Vec<Option<&str>> = host.iter().map(|d| d.class.as_deref()).collect();
        drawn.sort();
        found.sort();
        assert_eq!(found, drawn, "{name} (platform estimated): classes");
        let line = stdout
            .lines()
            .find(|l| l.starts_with("instructions_auto ") && fields(l)["frame"] == name)
            .unwrap_or_else(|| panic!("no instruction counts for {name} with the platform estimated"));
        let f = fields(line);
        let count = |k: &str| f[k].parse::<u64>().unwrap();
        assert!(count("platform") > 0, "{line}");
        assert!(
            count("platform") + count("mask") + count("borders") + count("descriptors_matching") <= count("total"),
            "{line}"
        );
    }
    assert_eq!(auto_compared, 12);
    eprintln!(
        "{auto_compared} detections agree with the platform estimated: largest difference {auto_pos:.5} px, {auto_angle:.5}°"
    );
}

/// The soak's short run: 20 frames of the soak's variants (scene × view × parameters, drawn
/// at random on the camera) through the firmware's one recognizer. No error, every repeat of a
/// variant gives the report of its first frame bit for bit (the firmware's fingerprints), the
/// stack stays within memory.x's reserve, and each variant's detections are the host's on the
/// same view (a fresh engine per variant). The long run: `scripts/soak.sh --firmware 10000`.
#[test]
fn firmware_soak_short() {
    if !need_qemu("firmware_soak_short") {
        return;
    }
    let frames = 20;
    let stdout = run_firmware(Some(&format!("soak {frames}")), "firmware-soak-output.txt");
    let summary = stdout
        .lines()
        .find(|l| l.starts_with("soak_summary "))
        .expect("soak_summary line");
    let f = fields(summary);
    let num = |k: &str| f[k].parse::<u64>().unwrap_or_else(|_| panic!("{k} in {summary}"));
    assert_eq!(num("frames"), frames, "{summary}");
    assert_eq!(num("mismatches"), 0, "{summary}");
    assert_eq!(num("errors"), 0, "{summary}");
    assert!((num("stack_peak") as usize) < STACK_RESERVE, "{summary}");
    let seen = num("seen") as usize;
    assert!(
        seen >= 2 && seen < frames as usize,
        "{summary}: repeats are needed to compare"
    );
    let fw = firmware_detections(&stdout, "det_soak");
    let variants: Vec<&str> = stdout.lines().filter(|l| l.starts_with("soak_variant ")).collect();
    assert_eq!(variants.len(), seen, "{summary}");
    let mut compared = 0;
    for line in variants {
        let v = fields(line);
        let at = |k: &str| v[k].parse::<u32>().unwrap_or_else(|_| panic!("{k} in {line}"));
        let scene = match v["scene"] {
            "background_0" => "background_0.gray".to_string(),
            s => format!("{s}.gray"),
        };
        let full = fixture_gray(&scene);
        let img = image::imageops::crop_imm(&full, at("x0"), at("y0"), at("width"), at("height")).to_image();
        let refine = match v["refine"] {
            "off" => vorl_core::params::Refine::Off,
            _ => vorl_core::params::Refine::Verify,
        };
        let mut engine = fixture_engine(|p| Params { refine, ..p });
        match v["platform"] {
            "estimated" => engine.set_auto_background(),
            _ => engine
                .learn_background(&[fixture_gray("background_0.gray"), fixture_gray("background_1.gray")])
                .unwrap(),
        }
        let host = host_detections(&mut engine, &img);
        let firmware = fw.get(v["variant"]).map(Vec::as_slice).unwrap_or(&[]);
        assert_eq!(firmware.len() as u32, at("parts"), "{line}");
        agree(line, firmware, &host);
        compared += host.len();
    }
    eprintln!("soak: {frames} frames, {seen} variants, {compared} detections agree with the host");
}

#[test]
fn linker_static_ram_matches_budget() {
    let elf = firmware_elf().as_ref().unwrap_or_else(|e| panic!("{e}"));
    let sysroot = Command::new(std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into()))
        .args(["--print", "sysroot"])
        .output()
        .expect("rustc --print sysroot");
    let sysroot = PathBuf::from(String::from_utf8_lossy(&sysroot.stdout).trim());
    let llvm_size = std::fs::read_dir(sysroot.join("lib/rustlib"))
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path().join("bin/llvm-size"))
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "llvm-size not found under {}/lib/rustlib/*/bin: run scripts/setup.sh (llvm-tools)",
                sysroot.display()
            )
        });
    let out = Command::new(&llvm_size)
        .args(["-A", "-d"])
        .arg(elf)
        .output()
        .expect("llvm-size");
    let text = String::from_utf8_lossy(&out.stdout);
    let section = |name: &str| -> usize {
        text.lines()
            .find_map(|l| {
                let mut cols = l.split_whitespace();
                (cols.next() == Some(name))
                    .then(|| cols.next().and_then(|s| s.parse().ok()))
                    .flatten()
            })
            .unwrap_or(0)
    };
    let (data, bss, uninit) = (section(".data"), section(".bss"), section(".uninit"));
    let flash = section(".vector_table") + section(".text") + section(".rodata") + data;

    // `vorl budget --width 320 --height 240 --points 64 --template-points 96 --templates 8
    //  --max-contours 64 --border-points 4096` (Cortex-M layout).
    let args = BudgetArgs {
        width: 320,
        height: 240,
        points: Some(64),
        template_points: Some(96),
        templates: 8,
        max_contours: 64,
        border_points: Some(4096),
        dp_cells: None,
        target: Target::CortexM,
        sweep: false,
        markdown: false,
        json: false,
    };
    let rows = budget::rows(&args).unwrap();
    // The firmware also estimates the platform (frames without an empty shot): its grid is the
    // "+ platform grid" line of `vorl budget` (9·G bytes, G the cells of 16 px a QVGA frame has).
    let s = vorl_core::pixels::platform::cell_size(320, 240, usize::MAX).unwrap();
    let grid = 9 * 320usize.div_ceil(s) * 240usize.div_ceil(s);
    let total = rows[0].budget.total + grid;
    let static_ram = data + bss + uninit;
    eprintln!(
        "linker: .data {data} + .bss {bss} + .uninit {uninit} = {static_ram} bytes of RAM (flash {flash}); vorl budget: {total} (platform grid {grid} included); \
         difference {} bytes (margin {RUNTIME_MARGIN})",
        static_ram as i64 - total as i64
    );
    assert!(
        static_ram >= total,
        "the linker's static RAM {static_ram} is below the budget {total}: the budget counts too much"
    );
    assert!(
        static_ram - total <= RUNTIME_MARGIN,
        "the linker's static RAM {static_ram} exceeds the budget {total} by more than {RUNTIME_MARGIN}"
    );
    assert!(
        static_ram + STACK_RESERVE <= RAM_REGION,
        "{static_ram} bytes + {STACK_RESERVE} of stack do not fit 256 KiB"
    );
}
