//! `vorl detect`: run the core on frames and print what it finds.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::cli::params::ParamArgs;
use crate::engine::{frame_notes, Engine, FrameResult};
use crate::io::file_name;
use crate::run::{run_frame, to_json};
use crate::set::{load_background_frames, FixtureSet};
use crate::truth::FramesJson;

/// Arguments of `vorl detect`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    vorl detect examples/plant\n  \
    vorl detect examples/plant --json > predictions.json\n  \
    vorl detect examples/plant --overlay out/overlays\n  \
    vorl detect --background bg.png --templates templates/ frame1.png frame2.png\n  \
    vorl detect stereo_set --json          (a set with camera.json: disparity, depth, position_mm)\n  \
    vorl detect examples/plant --calibration cal.json --json   (adds \"robot\" coordinates)")]
pub struct DetectArgs {
    /// A fixture set folder (background.png, templates/, frames/) — or, with --background and
    /// --templates, the frame files to run.
    #[arg(value_name = "SET | FRAME…", required = true)]
    pub inputs: Vec<PathBuf>,
    /// Background image (then the inputs are frames, not a set), or "auto": the platform is
    /// estimated from the frames themselves, an estimate kept for the next frames while they
    /// fit it (--platform-every; also what a set without background.png does).
    #[arg(long, value_name = "BG|auto", requires = "templates")]
    pub background: Option<PathBuf>,
    /// Template folder (with --background).
    #[arg(long, value_name = "DIR", requires = "background")]
    pub templates: Option<PathBuf>,
    /// Print the predictions as JSON (the truth.json shape).
    #[arg(long)]
    pub json: bool,
    /// Write an overlay PNG per frame into this folder.
    #[arg(long, value_name = "DIR")]
    pub overlay: Option<PathBuf>,
    /// Write the platform (the empty shot's model or the estimate) and the mask of each frame
    /// into this folder, as `<frame>_platform.png` and `<frame>_mask.png`.
    #[arg(long, value_name = "DIR")]
    pub debug: Option<PathBuf>,
    /// Camera-to-robot calibration from `vorl calibrate`: adds "robot" to each part.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// Pipeline parameters.
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Where the inputs of a run come from.
pub struct Inputs {
    /// The engine with background and templates.
    pub engine: Engine,
    /// The frames to run.
    pub frames: Vec<PathBuf>,
}

/// Builds the engine from a set or from explicit files.
///
/// # Errors
/// Any unreadable background or template, or a template that is not one part.
pub fn prepare(
    set: Option<&Path>,
    background: Option<&Path>,
    templates: Option<&Path>,
    frames: &[PathBuf],
    params: &ParamArgs,
) -> Result<Inputs, String> {
    let opened = set.map(FixtureSet::open).transpose().map_err(|e| e.to_string())?;
    let base = match opened.as_ref() {
        Some(s) => s.config().map_err(|e| e.to_string())?,
        None => None,
    };
    let config = params.config_over(base.as_deref())?;
    let (bgs, tpls, frames) = match opened {
        Some(s) => (
            s.load_backgrounds().map_err(|e| e.to_string())?,
            s.load_templates().map_err(|e| e.to_string())?,
            s.frames,
        ),
        None => {
            let bg = background.ok_or("--background is needed without a SET")?.to_path_buf();
            let dir = templates.ok_or("--templates is needed without a SET")?;
            let bgs = if is_auto(&bg) {
                Vec::new()
            } else {
                load_background_frames([&bg]).map_err(|e| e.to_string())?
            };
            let tpls = crate::engine::load_silhouettes(dir).map_err(|e| e.to_string())?;
            (bgs, tpls, frames.to_vec())
        }
    };
    for t in &tpls {
        if let Some(n) = &t.note {
            eprintln!("note: {n}");
        }
    }
    let (engine, notes) = build_engine(&config, &bgs, &tpls)?;
    for n in notes {
        eprintln!("note: {n}");
    }
    Ok(Inputs { engine, frames })
}

/// An engine with these parameters, backgrounds (none: the platform is estimated from the
/// frames) and templates, as `vorl detect` builds it; the notes of
/// [`Engine::add_silhouettes`] beside it. `vorl serve` builds it again when a parameter
/// changes or a part is taught.
///
/// # Errors
/// Invalid parameters, backgrounds of different sizes, a template that is not one part.
pub fn build_engine(
    config: &crate::config::Config,
    backgrounds: &[image::GrayImage],
    templates: &[crate::engine::NamedSilhouette],
) -> Result<(Engine, Vec<String>), String> {
    let mut engine = Engine::new(config.to_params()?)?;
    engine.set_exposure_fit(config.exposure == crate::config::ExposureSetting::Fit);
    engine.set_platform_every(config.platform_every);
    if backgrounds.is_empty() {
        engine.set_auto_background();
    } else {
        engine.learn_background(backgrounds)?;
    }
    let notes = engine.add_silhouettes(templates)?;
    Ok((engine, notes))
}

/// Whether a `--background` argument asks for the platform to be estimated from each frame.
pub fn is_auto(bg: &Path) -> bool {
    bg.as_os_str().eq_ignore_ascii_case("auto")
}

/// Writes the platform model and the mask of the last frame into `dir` as
/// `<stem>_platform.png` and `<stem>_mask.png` (mask 255, rest 0).
///
/// # Errors
/// A file cannot be written.
pub fn write_debug(dir: &Path, name: &str, engine: &Engine) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s).replace(['/', '\\'], "_");
    if let Some(bg) = engine.background() {
        let (w, h) = (bg.width() as u32, bg.height() as u32);
        let plane = image::GrayImage::from_raw(w, h, bg.plane().to_vec()).ok_or("platform plane of the wrong size")?;
        let p = dir.join(format!("{stem}_platform.png"));
        plane
            .save(&p)
            .map_err(|e| format!("{}: cannot write: {e}", p.display()))?;
        let mask: Vec<u8> = engine
            .labels()
            .iter()
            .take((w * h) as usize)
            .map(|&l| if l != 0 { 255 } else { 0 })
            .collect();
        let mask = image::GrayImage::from_raw(w, h, mask).ok_or("mask of the wrong size")?;
        let p = dir.join(format!("{stem}_mask.png"));
        mask.save(&p)
            .map_err(|e| format!("{}: cannot write: {e}", p.display()))?;
    }
    Ok(())
}

/// Runs `vorl detect`.
///
/// # Errors
/// Set-up problems (background, templates, parameters); frame problems are reported per frame
/// and make the exit code 1.
pub fn run(args: DetectArgs) -> Result<ExitCode, String> {
    let (set, frames) = match (&args.background, args.inputs.as_slice()) {
        (Some(_), frames) => (None, frames.to_vec()),
        (None, [set]) => (Some(set.clone()), Vec::new()),
        (None, _) => return Err("give one SET folder, or --background BG --templates DIR and the frame files".into()),
    };
    let calibration = args
        .calibration
        .as_deref()
        .map(crate::cli::calibrate::Calibration::load)
        .transpose()?;
    if let Some(root) = set.as_deref().filter(|r| crate::cli::stereo::is_stereo_set(r)) {
        return crate::cli::stereo::run_detect(
            root,
            &args.params,
            args.overlay.as_deref(),
            args.json,
            calibration.as_ref(),
        );
    }
    let mut inputs = prepare(
        set.as_deref(),
        args.background.as_deref(),
        args.templates.as_deref(),
        &frames,
        &args.params,
    )?;
    if inputs.frames.is_empty() {
        return Err("no frames to process".into());
    }
    if let Some(dir) = &args.overlay {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    }
    let mut out = FramesJson::default();
    let mut failed = 0usize;
    for path in inputs.frames.clone() {
        // Frames of the same file name from different folders keep their folder in the key.
        let mut name = file_name(&path);
        if out.frames.contains_key(&name) {
            name = path.display().to_string();
        }
        match run_frame(&mut inputs.engine, &path) {
            Ok((result, image, note)) => {
                if let Some(n) = note {
                    eprintln!("note: {n}");
                }
                if let Some(dir) = &args.debug {
                    if let Err(e) = write_debug(dir, &name, &inputs.engine) {
                        eprintln!("error: {e}");
                        failed += 1;
                    }
                }
                if let Some(dir) = &args.overlay {
                    let target = dir.join(name.replace(['/', '\\'], "_"));
                    let pic = crate::overlay::draw(&image, &result);
                    if let Err(e) = pic.save(&target) {
                        eprintln!("error: {}: cannot write overlay: {e}", target.display());
                        failed += 1;
                    }
                }
                for n in frame_notes(&result) {
                    eprintln!("note: {name}: {n}");
                }
                let mut parts = to_json(&result);
                if let Some(c) = &calibration {
                    c.apply_all(&mut parts);
                }
                if !args.json {
                    print_human(&name, &result);
                    if calibration.is_some() {
                        for p in &parts {
                            let class = p.class.as_deref().unwrap_or("unknown");
                            let text = crate::cli::calibrate::robot_text(p).unwrap_or_default();
                            println!("    {class:<14} {text}");
                        }
                    }
                }
                out.frames.insert(name, parts);
            }
            Err(e) => {
                eprintln!("error: {e}");
                failed += 1;
            }
        }
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
    }
    if failed > 0 {
        eprintln!("{failed} frame(s) failed");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

fn print_human(name: &str, result: &FrameResult) {
    println!(
        "{name}: {} part(s) in {:.1} ms",
        result.detections.len(),
        result.seconds * 1e3
    );
    for d in &result.detections {
        let class = d.class.as_deref().unwrap_or("unknown");
        let best = match (&d.class, &d.best_class) {
            (None, Some(b)) => format!(" (nearest {b})"),
            _ => String::new(),
        };
        println!(
            "  {class:<14} x {:8.2}  y {:8.2}  angle {:7.2}°  f' {:.4}{best}{}",
            d.core.x,
            d.core.y,
            d.core.angle_deg,
            d.core.score,
            if d.core.touches_edge { "  [touches edge]" } else { "" }
        );
    }
}
