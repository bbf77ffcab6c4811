//! `vorl teach`: take the part in a frame as a new template.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::process::ExitCode;

use image::{GrayImage, Luma};

use crate::cli::params::ParamArgs;
use crate::engine::{Engine, FrameResult};
use crate::io::load_gray;
use crate::set::load_background_frames;
use vorl_core::pixels::frame::Frame;
use vorl_core::pixels::mask::{foreground_mask, Polarity, Threshold};

/// Arguments of `vorl teach`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "The part's silhouette at its pose in FRAME becomes the template's reference pose \
    (angle 0). Without --part or --at the frame should hold one part (the largest is taken), \
    clear of the frame's edge. Without --background the platform is estimated from the frame \
    itself (no empty shot needed).\n\n\
    Examples:\n  vorl teach --list set/frames/f000.png                 (numbered parts, and f000_parts.png)\n  \
    vorl teach set/frames/f000.png --part 2 --name bracket --out set/templates\n  \
    vorl teach set/frames/f000.png --at 312,140 --name bracket --out set/templates\n  \
    vorl teach --background set/background.png set/frames/f000.png --name bracket --out set/templates\n  \
    vorl teach set/frames/f007.png --part 1 --name bracket --out set/templates --add   (another example of the class)"
)]
pub struct TeachArgs {
    /// The empty platform, or "auto" (the default): the platform estimated from the frame.
    #[arg(long, value_name = "BG|auto")]
    pub background: Option<PathBuf>,
    /// A frame with the part on the platform.
    #[arg(value_name = "FRAME")]
    pub frame: PathBuf,
    /// Print the numbered parts of the frame and write a numbered overlay
    /// (`<frame>_parts.png`, or --overlay FILE); teaches nothing.
    #[arg(long, conflicts_with_all = ["part", "at", "name", "out"])]
    pub list: bool,
    /// With --list: where to write the numbered overlay.
    #[arg(long, value_name = "FILE", requires = "list")]
    pub overlay: Option<PathBuf>,
    /// Teach part N of `--list` (1-based).
    #[arg(long, value_name = "N", conflicts_with = "at")]
    pub part: Option<usize>,
    /// Teach the part at pixel X,Y (inside its outer border, holes included, or within 3 px of it).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    pub at: Option<String>,
    /// Class name of the new template (the file name in DIR).
    #[arg(long, required_unless_present = "list")]
    pub name: Option<String>,
    /// Template folder to write `<name>.png` into (created if missing).
    #[arg(long, value_name = "DIR", required_unless_present = "list")]
    pub out: Option<PathBuf>,
    /// Overwrite an existing template of that name.
    #[arg(long, conflicts_with = "add")]
    pub force: bool,
    /// Add the part as another example of the class: into `DIR/<name>/` (an existing
    /// `DIR/<name>.png` moves there first). A class of several examples carries the tolerance
    /// its examples need (printed here, and by `vorl templates info` after an export).
    #[arg(long)]
    pub add: bool,
    /// Pipeline parameters (threshold, α, … used to segment the part).
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Runs `vorl teach`.
///
/// # Errors
/// Unreadable inputs, no part in the frame, a part number or point that names no part, or the
/// template cannot be written.
pub fn run(args: TeachArgs) -> Result<ExitCode, String> {
    let params = args.params.params()?;
    let frame = load_gray(&args.frame).map_err(|e| e.to_string())?;
    if let Some(n) = &frame.note {
        eprintln!("note: {}: {n}", args.frame.display());
    }
    let shots = match args.background.as_deref().filter(|b| !crate::cli::detect::is_auto(b)) {
        Some(bg) => Some(load_background_frames([&bg.to_path_buf()]).map_err(|e| e.to_string())?),
        None => None,
    };
    let label = args.frame.display().to_string();
    let segmented = segment(params, &frame.image, shots, &label)?;
    if args.list {
        return list(&args, &frame.image, &segmented.result);
    }
    let (Some(name), Some(out)) = (args.name.as_deref(), args.out.as_deref()) else {
        return Err("--name and --out are needed to teach (or --list to see the parts)".into());
    };
    if name.is_empty() || name.contains(['/', '\\']) || name.starts_with('.') {
        return Err(format!("--name {name:?}: a class name must be a plain file name"));
    }
    let folder = out.join(name);
    let single = out.join(format!("{name}.png"));
    // With --add: the next free example of the class's folder, and a single template of the
    // class to move in first (nothing moves or is written until the part is taken).
    let (target, move_first) = if args.add {
        example_paths(&folder, &single)
    } else if folder.is_dir() {
        return Err(format!(
            "{}: the class has several examples; use --add to add one more",
            folder.display()
        ));
    } else {
        (single.clone(), None)
    };
    if target.exists() && !args.force {
        return Err(format!(
            "{}: template exists already (use --force to replace it, or --add for another example)",
            target.display()
        ));
    }
    let choice = match (args.part, args.at.clone()) {
        (Some(n), _) => PartChoice::Number(n),
        (None, Some(at)) => PartChoice::At(at),
        (None, None) => PartChoice::Largest,
    };
    let taken = take_part(segmented, &frame.image, &choice, &label)?;
    if let Some(evidence) = &taken.evidence {
        println!("{}", evidence.describe());
    }
    for w in &taken.warnings {
        eprintln!("warning: {w}");
    }
    let mut silhouette = taken.silhouette;
    if args.add {
        // Turned to the class's reference pose: the pose of its first example.
        let first = match &move_first {
            Some((from, _)) => Some(load_gray(from).map_err(|e| e.to_string())?.image),
            None if folder.is_dir() => crate::engine::load_silhouettes(&folder)
                .ok()
                .and_then(|v| v.into_iter().next())
                .map(|e| e.image),
            None => None,
        };
        if let Some(first) = first {
            let (turned, angle) = to_reference_pose(&silhouette, &first, taken.params)?;
            println!("turned by {:.2}° onto the pose of the class's first example", -angle);
            silhouette = turned;
        }
    }
    if let Some((from, to)) = &move_first {
        std::fs::create_dir_all(&folder).map_err(|e| format!("{}: cannot create folder: {e}", folder.display()))?;
        std::fs::rename(from, to)
            .map_err(|e| format!("{}: cannot move into {}: {e}", from.display(), folder.display()))?;
        println!(
            "moved {} → {} (the class's first example)",
            from.display(),
            to.display()
        );
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: cannot create folder: {e}", out.display()))?;
    silhouette
        .save(&target)
        .map_err(|e| format!("{}: cannot write: {e}", target.display()))?;
    println!(
        "taught {:?} from {} ({}×{} silhouette, area {:.0} px²{}) → {}",
        name,
        args.frame.display(),
        silhouette.width(),
        silhouette.height(),
        taken.area,
        if taken.auto_background {
            ", platform estimated from the frame"
        } else {
            ""
        },
        target.display()
    );
    if let Some(e) = taken.evidence {
        let ask = match e.polarity {
            Polarity::Either if e.brighter_share < 0.5 => PolarityAsk::Admit(Polarity::Darker),
            Polarity::Either => PolarityAsk::Admit(Polarity::Brighter),
            one_sided => PolarityAsk::OneSided(one_sided),
        };
        keep_polarity(out, ask)?;
    }
    if args.add {
        let examples = crate::engine::load_silhouettes(&folder).map_err(|e| e.to_string())?;
        let examples: Vec<_> = examples
            .into_iter()
            .map(|e| crate::engine::NamedSilhouette {
                name: name.to_string(),
                ..e
            })
            .collect();
        let mut check = Engine::new(taken.params)?;
        for n in check.add_silhouettes(&examples)? {
            println!("{n}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Which part of a frame [`take_part`] takes.
#[derive(Debug, Clone, PartialEq)]
pub enum PartChoice {
    /// Part N as `--list` numbers them (1-based): `--part N`.
    Number(usize),
    /// The part at a point, `X,Y` in pixels as `--at` takes it.
    At(String),
    /// The largest part (a warning when the frame holds several).
    Largest,
}

/// A frame segmented for teaching ([`segment`]).
pub struct Segmented {
    /// The engine that ran on the frame (its labels and platform are the frame's).
    pub engine: Engine,
    /// What the frame gave.
    pub result: FrameResult,
    /// The empty shots it was run against (`None`: the platform estimated from the frame).
    pub shots: Option<Vec<GrayImage>>,
}

/// What [`take_part`] took from a frame: what `vorl teach` saves, and what it says about it.
pub struct Taken {
    /// The silhouette, part 255 and rest 0, cropped with a 10 px margin: the template file.
    pub silhouette: GrayImage,
    /// The part's polarity as measured (`None`: no platform or no contrast to measure).
    pub evidence: Option<crate::teaching::PolarityEvidence>,
    /// The parameters the part was segmented with (a measured one-sided polarity included).
    pub params: vorl_core::Params,
    /// The part's area as detected, px².
    pub area: f32,
    /// Whether the platform was estimated from the frame (no empty shot).
    pub auto_background: bool,
    /// Warnings, one line each without the `warning: ` prefix (several parts and the largest
    /// taken, a part cut by the frame's edge, a polarity under which the part was not found).
    pub warnings: Vec<String>,
}

/// Runs `frame` (named `label` in messages) through an engine of `params` against the empty
/// `shots`, or against the platform estimated from the frame: the first step of `vorl teach`.
///
/// # Errors
/// Invalid parameters, a frame of another size than the shots, or no part in the frame.
pub fn segment(
    params: vorl_core::Params,
    frame: &GrayImage,
    shots: Option<Vec<GrayImage>>,
    label: &str,
) -> Result<Segmented, String> {
    let mut engine = Engine::new(params)?;
    match &shots {
        Some(bgs) => {
            let first = bgs.first().ok_or("no background frame")?;
            if frame.dimensions() != first.dimensions() {
                return Err(format!(
                    "{label}: frame is {}×{} but the background is {}×{}",
                    frame.width(),
                    frame.height(),
                    first.width(),
                    first.height()
                ));
            }
            engine.learn_background(bgs)?;
        }
        None => engine.set_auto_background(),
    }
    let result = engine.detect(frame).map_err(|e| format!("{label}: {e}"))?;
    if result.detections.is_empty() {
        return Err(format!(
            "{label}: no part found against the platform (try a lower --threshold)"
        ));
    }
    Ok(Segmented { engine, result, shots })
}

/// Takes the chosen part of a [`segment`]ed frame as `vorl teach` does: measures its polarity
/// ([`crate::teaching::measure_polarity`]; a one-sided one segments the frame again with it, so
/// a shadow beside the part is not part of it) and cuts its silhouette at half its contrast
/// along its outline ([`crate::teaching::half_contrast_silhouette`]), where detection puts a
/// part's border.
///
/// # Errors
/// A part number or point that names no part of the frame.
pub fn take_part(segmented: Segmented, image: &GrayImage, choice: &PartChoice, label: &str) -> Result<Taken, String> {
    let Segmented {
        mut engine,
        mut result,
        shots,
    } = segmented;
    let mut warnings = Vec::new();
    let (w, h) = (image.width() as usize, image.height() as usize);
    let mut part_index = choose_part(choice, label, &result, engine.labels(), w, h, &mut warnings)?;
    // Polarity: a shadow beside the part is not part of it (crate::teaching). Measured on the
    // blob as the mask first takes it, shadow and all (the recognizer's shadow pass,
    // vorl_core::pixels::shadow, has taken it out of the engine's mask since); where it is
    // one-sided, the frame is segmented again with it.
    let mut measured = None;
    if let Some(background) = engine.background() {
        let part = &result.detections[part_index];
        if let (Some(&(sx, sy)), Ok(frame)) = (part.border.first(), Frame::new_checked(image.as_raw().as_slice(), w, h))
        {
            let params = engine.params();
            let mut whole = vec![0u8; w * h];
            let tau = Threshold::Fixed(result.report.mask.threshold);
            foreground_mask(
                &frame,
                background,
                params.alpha(),
                tau,
                params.polarity,
                params.cleanup,
                &mut whole,
            )
            .map_err(|e| format!("{label}: {e}"))?;
            // (The part's border pixel lies in the mask before the shadow pass as after it.)
            let pixels = component_pixels(&whole, w, h, sx as usize, sy as usize);
            measured = crate::teaching::measure_polarity(
                image.as_raw(),
                background.plane(),
                w,
                h,
                &pixels,
                result.report.mask.threshold,
            );
        }
    }
    if let Some(evidence) = &measured {
        if evidence.polarity != engine.params().polarity && evidence.polarity != Polarity::Either {
            let (cx, cy) = (
                result.detections[part_index].core.x,
                result.detections[part_index].core.y,
            );
            let mut params = *engine.params();
            params.polarity = evidence.polarity;
            let mut again = Engine::new(params)?;
            match &shots {
                Some(bgs) => again.learn_background(bgs)?,
                None => again.set_auto_background(),
            }
            let second = again.detect(image).map_err(|e| format!("{label}: {e}"))?;
            // The same part: the one at the teach point, else the one nearest the first centroid.
            let at = match choice {
                PartChoice::At(text) => Some(parse_point(text)?),
                _ => None,
            };
            let (px, py) = at.unwrap_or((f64::from(cx), f64::from(cy)));
            let index = part_at(&second, again.labels(), w, h, px, py)
                .or_else(|| nearest(&second, f64::from(cx), f64::from(cy)))
                .and_then(|d| second.detections.iter().position(|e| std::ptr::eq(e, d)));
            match index {
                Some(i) => {
                    engine = again;
                    result = second;
                    part_index = i;
                }
                None => warnings.push(format!(
                    "{label}: with polarity {:?} no part lies at the taught one; taught as segmented",
                    evidence.polarity
                )),
            }
        }
    }
    let part = &result.detections[part_index];
    if part.core.touches_edge {
        warnings.push(format!(
            "{label}: the part touches the frame's edge; the template may be cut"
        ));
    }
    let Some(&(sx, sy)) = part.border.first() else {
        return Err("the part has no border".into());
    };
    // Cut along its outline where detection puts a part's border, midway between the part's
    // and the platform's levels nearby (crate::teaching), rather than where the blurred edge
    // first rises above τ.
    let silhouette = match engine.background().map(|b| b.plane()) {
        Some(platform) => {
            let blob = component_pixels(engine.labels(), w, h, sx as usize, sy as usize);
            let cut = crate::teaching::half_contrast_silhouette(
                image.as_raw(),
                platform,
                w,
                h,
                &blob,
                engine.params().polarity,
            );
            largest_component(&cut, w, h).unwrap_or_else(|| component(engine.labels(), w, h, sx as usize, sy as usize))
        }
        None => component(engine.labels(), w, h, sx as usize, sy as usize),
    };
    Ok(Taken {
        silhouette,
        evidence: measured,
        params: *engine.params(),
        area: part.core.area,
        auto_background: engine.auto_background(),
        warnings,
    })
}

/// The index of the part to teach: part N, the part at a point, or the largest.
fn choose_part(
    choice: &PartChoice,
    label: &str,
    result: &FrameResult,
    labels: &[u8],
    w: usize,
    h: usize,
    warnings: &mut Vec<String>,
) -> Result<usize, String> {
    let index_of = |d: &crate::engine::HostDetection| {
        result
            .detections
            .iter()
            .position(|e| std::ptr::eq(e, d))
            .ok_or_else(|| "no part".to_string())
    };
    match choice {
        PartChoice::Number(n) => {
            let n = *n;
            if n == 0 || n > result.detections.len() {
                return Err(format!(
                    "--part {n}: {label} has {} part(s), numbered 1 to {} (see --list)",
                    result.detections.len(),
                    result.detections.len()
                ));
            }
            Ok(n - 1)
        }
        PartChoice::At(at) => {
            let (x, y) = parse_point(at)?;
            let d = part_at(result, labels, w, h, x, y).ok_or_else(|| {
                format!("--at {at}: no part of {label} lies there (see --list for the parts and their centres)")
            })?;
            index_of(d)
        }
        PartChoice::Largest => {
            let largest = result
                .detections
                .iter()
                .max_by(|a, b| a.core.area.total_cmp(&b.core.area))
                .ok_or("no part")?;
            if result.detections.len() > 1 {
                warnings.push(format!(
                    "{label}: {} parts in the frame; teaching the largest (area {:.0} px²; --list, --part, --at choose another)",
                    result.detections.len(),
                    largest.core.area
                ));
            }
            index_of(largest)
        }
    }
}

/// What a taught part asks of its set's polarity ([`keep_polarity`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum PolarityAsk {
    /// A shadow (or a halo) lies beside it: this one-sided polarity, so that it is not part.
    OneSided(Polarity),
    /// Nothing lies beside it, and it lies on this side of the platform: any polarity that
    /// keeps it.
    Admit(Polarity),
}

/// Keeps what a taught part asks of the set's polarity where `detect` and `eval` read it: the
/// `vorl.toml` of the set whose `templates/` folder `out` is (a key added or replaced, the rest
/// of the file left as it was).
///
/// - A measured one-sided polarity is written where the set has none.
/// - A set whose classes ask for opposite sides gets `either`: a one-sided polarity would drop
///   every part of the other side.
/// - A part darker than the platform with nothing beside it sets `either` where the set has
///   none: its own shadow is of its sign and joins it, so it never asks for `darker`, and a
///   bright class taught after it must not make the set `brighter` (a shadow beside a bright
///   part is then cut off blob by blob, `vorl_core::pixels::shadow`).
///
/// With `out` not named `templates`, the line to add is printed instead.
fn keep_polarity(out: &std::path::Path, ask: PolarityAsk) -> Result<(), String> {
    let value = |p: crate::config::PolaritySetting| {
        serde_json::to_value(p)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default()
    };
    let (name, write_if_none) = match ask {
        PolarityAsk::OneSided(p) => (crate::config::PolaritySetting::from_core(p), true),
        PolarityAsk::Admit(Polarity::Darker) => (crate::config::PolaritySetting::Either, true),
        PolarityAsk::Admit(_) => (crate::config::PolaritySetting::Either, false),
    };
    // The side the part lies on, which a one-sided polarity must be to keep it.
    let side = match ask {
        PolarityAsk::OneSided(p) | PolarityAsk::Admit(p) => crate::config::PolaritySetting::from_core(p),
    };
    let set = match (out.file_name(), out.parent()) {
        (Some(n), Some(parent)) if n == "templates" => parent,
        _ => {
            if matches!(ask, PolarityAsk::OneSided(_)) {
                println!(
                    "add `polarity = \"{}\"` to the set's vorl.toml (detect and eval read it there)",
                    value(name)
                );
            }
            return Ok(());
        }
    };
    let file = set.join("vorl.toml");
    let text = match std::fs::read_to_string(&file) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(e) => return Err(format!("{}: {}", file.display(), crate::io::io_problem(&e))),
    };
    let is_key = |l: &str| {
        l.trim_start()
            .strip_prefix("polarity")
            .is_some_and(|r| r.trim_start().starts_with('='))
    };
    let before = text.lines().find(|l| is_key(l)).map(|l| {
        let v = l.split_once('=').map_or("", |(_, v)| v).trim().trim_matches('"');
        v.to_string()
    });
    let wanted = match before.as_deref() {
        Some(v) if v == value(name) || v == value(side) => return Ok(()),
        Some("either") => return Ok(()),
        Some(v) if !v.is_empty() => {
            println!(
                "note: {} says polarity {v}, this part is {}: the set's classes differ, so it becomes \"either\"",
                file.display(),
                value(side)
            );
            crate::config::PolaritySetting::Either
        }
        _ if write_if_none => name,
        _ => return Ok(()),
    };
    let why = if wanted == crate::config::PolaritySetting::Either {
        "# Measured by `vorl teach`: a part darker than the platform; the set keeps parts of either sign (a bright part's shadow is cut off it as detected)."
    } else {
        "# Measured by `vorl teach`: a shadow beside the taught part is not part of it."
    };
    let line = format!("polarity = \"{}\"", value(wanted));
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    match lines.iter().position(|l| is_key(l)) {
        Some(i) => lines[i] = line.clone(),
        None => {
            if lines.is_empty() {
                lines.push("# Parameters for this set (keys of `vorl config --defaults`).".into());
            }
            lines.push(why.into());
            lines.push(line.clone());
        }
    }
    std::fs::write(&file, lines.join("\n") + "\n").map_err(|e| format!("{}: cannot write: {e}", file.display()))?;
    println!("{}: {line}", file.display());
    Ok(())
}

/// The part whose centre lies nearest (x, y).
fn nearest(result: &crate::engine::FrameResult, x: f64, y: f64) -> Option<&crate::engine::HostDetection> {
    result.detections.iter().min_by(|a, b| {
        let da = (f64::from(a.core.x) - x).hypot(f64::from(a.core.y) - y);
        let db = (f64::from(b.core.x) - x).hypot(f64::from(b.core.y) - y);
        da.total_cmp(&db)
    })
}

/// `silhouette` turned onto the reference pose of `first` (another example of its class): the
/// angle at which `first`, taught alone, recognises `silhouette` (any scale in 0.5–2), undone
/// about the silhouette's own pixel centroid on a canvas large enough for any turn, thresholded
/// at half level and cropped with a 10 px margin. Returns the turned silhouette and the angle
/// (degrees, counter-clockwise) that was undone.
///
/// # Errors
/// `first` cannot be taught, or does not align on `silhouette` at all (then the two are
/// probably not one class).
pub fn to_reference_pose(
    silhouette: &GrayImage,
    first: &GrayImage,
    params: vorl_core::Params,
) -> Result<(GrayImage, f32), String> {
    let angle = crate::engine::recognise_alone(params, first, silhouette)?
        .filter(|d| d.pose.is_some())
        .ok_or("the new example does not align on the class's first example (another class?)")?
        .angle_deg;
    // A square canvas with the silhouette's pixel centroid at its centre.
    let (mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y, p) in silhouette.enumerate_pixels() {
        if p.0[0] > 127 {
            sx += x as f64;
            sy += y as f64;
            n += 1.0;
        }
    }
    let (cx, cy) = (sx / n.max(1.0), sy / n.max(1.0));
    let diag = ((silhouette.width().pow(2) + silhouette.height().pow(2)) as f64).sqrt();
    let side = 2 * (diag.ceil() as u32) + 4;
    let mut canvas = GrayImage::new(side, side);
    let (ox, oy) = (side as f64 / 2.0 - cx, side as f64 / 2.0 - cy);
    for (x, y, p) in silhouette.enumerate_pixels() {
        let (tx, ty) = ((x as f64 + ox).round() as u32, (y as f64 + oy).round() as u32);
        if tx < side && ty < side {
            canvas.put_pixel(tx, ty, *p);
        }
    }
    // imageproc turns clockwise on screen: by the part's counter-clockwise angle, to undo it.
    let turned = imageproc::geometric_transformations::rotate(
        &canvas,
        (
            (side as f64 / 2.0 - ox.fract()) as f32,
            (side as f64 / 2.0 - oy.fract()) as f32,
        ),
        angle.to_radians(),
        imageproc::geometric_transformations::Interpolation::Bilinear,
        imageproc::geometric_transformations::Border::Constant(Luma([0u8])),
    );
    let labels: Vec<u8> = turned.as_raw().iter().map(|&v| (v > 127) as u8).collect();
    // The largest component only (a turn may leave a stray pixel at the edge).
    let turned = largest_component(&labels, side as usize, side as usize).ok_or("the turned example holds no part")?;
    Ok((turned, angle))
}

/// The largest 8-connected component of a 0/1 plane, cropped as [`component`] crops; `None`
/// when the plane is empty.
fn largest_component(labels: &[u8], w: usize, h: usize) -> Option<GrayImage> {
    let seed = labels.iter().position(|&l| l != 0)?;
    let mut best = (0usize, seed);
    let mut seen = vec![false; w * h];
    for i in 0..w * h {
        if labels[i] != 0 && !seen[i] {
            let pixels = component_pixels(labels, w, h, i % w, i / w);
            for &j in &pixels {
                seen[j] = true;
            }
            if pixels.len() > best.0 {
                best = (pixels.len(), i);
            }
        }
    }
    Some(component(labels, w, h, best.1 % w, best.1 / w))
}

/// Where `--add` writes the next example of a class, `folder/<k>.png` for the first free `k`
/// from 1, and the move of an existing single template `single` into the folder before it (to
/// the first free name, so the new example takes the next).
fn example_paths(folder: &std::path::Path, single: &std::path::Path) -> (PathBuf, Option<(PathBuf, PathBuf)>) {
    let mut free = (1..).map(|k| folder.join(format!("{k}.png"))).filter(|p| !p.exists());
    let mut next = || free.next().unwrap_or_else(|| folder.join("1.png"));
    if single.is_file() {
        let first = next();
        (next(), Some((single.to_path_buf(), first)))
    } else {
        (next(), None)
    }
}

/// `--list`: the numbered parts, and the overlay with their numbers.
fn list(args: &TeachArgs, image: &GrayImage, result: &crate::engine::FrameResult) -> Result<ExitCode, String> {
    println!("{}: {} part(s)", args.frame.display(), result.detections.len());
    for (i, d) in result.detections.iter().enumerate() {
        let class = d.class.as_deref().unwrap_or("unknown");
        println!(
            "  {:>3}  x {:8.2}  y {:8.2}  area {:8.0} px²  {class}{}",
            i + 1,
            d.core.x,
            d.core.y,
            d.core.area,
            if d.core.touches_edge { "  [touches edge]" } else { "" }
        );
    }
    let target = match &args.overlay {
        Some(p) => p.clone(),
        None => {
            let stem = args
                .frame
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            PathBuf::from(format!("{stem}_parts.png"))
        }
    };
    let mut pic = crate::overlay::draw(image, result);
    for (i, d) in result.detections.iter().enumerate() {
        crate::overlay::draw_number(&mut pic, d.core.x, d.core.y, i + 1);
    }
    pic.save(&target)
        .map_err(|e| format!("{}: cannot write overlay: {e}", target.display()))?;
    println!("numbered overlay: {}", target.display());
    Ok(ExitCode::SUCCESS)
}

/// `X,Y` as two numbers.
fn parse_point(text: &str) -> Result<(f64, f64), String> {
    let bad = || format!("--at {text}: expected X,Y in pixels (for example --at 312,140)");
    let (x, y) = text.split_once(',').ok_or_else(bad)?;
    let (x, y): (f64, f64) = (
        x.trim().parse().map_err(|_| bad())?,
        y.trim().parse().map_err(|_| bad())?,
    );
    if !(x.is_finite() && y.is_finite()) {
        return Err(bad());
    }
    Ok((x, y))
}

/// The part whose silhouette holds pixel (x, y), or whose outer border encloses it or passes
/// within 3 px of it, or whose centre (as `--list` prints it) lies within 3 px of it: the centre
/// of an open part, an e-clip or a C, lies off its silhouette.
fn part_at<'a>(
    result: &'a crate::engine::FrameResult,
    labels: &[u8],
    w: usize,
    h: usize,
    x: f64,
    y: f64,
) -> Option<&'a crate::engine::HostDetection> {
    let (px, py) = (x.round(), y.round());
    if px >= 0.0 && py >= 0.0 && (px as usize) < w && (py as usize) < h && labels[py as usize * w + px as usize] != 0 {
        // The component holding the pixel: the part whose border's first point lies in it.
        let comp = component_pixels(labels, w, h, px as usize, py as usize);
        if let Some(d) = result.detections.iter().find(|d| {
            d.border
                .first()
                .is_some_and(|&(bx, by)| comp.binary_search(&(by as usize * w + bx as usize)).is_ok())
        }) {
            return Some(d);
        }
    }
    // Inside a part's outer border (a washer's hole too).
    if let Some(d) = result.detections.iter().find(|d| inside(&d.border, x, y)) {
        return Some(d);
    }
    result
        .detections
        .iter()
        .map(|d| {
            let dist = d
                .border
                .iter()
                .map(|&(bx, by)| (bx as f64 - x).hypot(by as f64 - y))
                .fold(f64::INFINITY, f64::min);
            (d, dist)
        })
        .filter(|(_, dist)| *dist <= 3.0)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(d, _)| d)
        .or_else(|| nearest(result, x, y).filter(|d| (f64::from(d.core.x) - x).hypot(f64::from(d.core.y) - y) <= 3.0))
}

/// Whether (x, y) lies inside the closed polygon through the border's pixel centres (even-odd).
fn inside(border: &[(u16, u16)], x: f64, y: f64) -> bool {
    let mut odd = false;
    let n = border.len();
    for i in 0..n {
        let (a, b) = (border[i], border[(i + 1) % n]);
        let (ax, ay, bx, by) = (a.0 as f64, a.1 as f64, b.0 as f64, b.1 as f64);
        if (ay > y) != (by > y) && x < ax + (y - ay) * (bx - ax) / (by - ay) {
            odd = !odd;
        }
    }
    odd
}

/// The sorted pixel indices of the 8-connected foreground component holding (sx, sy).
fn component_pixels(labels: &[u8], w: usize, h: usize, sx: usize, sy: usize) -> Vec<usize> {
    let mut seen = vec![false; w * h];
    let mut queue = VecDeque::from([(sx, sy)]);
    let mut out = Vec::new();
    seen[sy * w + sx] = true;
    while let Some((x, y)) = queue.pop_front() {
        out.push(y * w + x);
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let i = ny as usize * w + nx as usize;
                if !seen[i] && labels[i] != 0 {
                    seen[i] = true;
                    queue.push_back((nx as usize, ny as usize));
                }
            }
        }
    }
    out.sort_unstable();
    out
}

/// The 8-connected foreground component containing `(sx, sy)`, cropped with a 10 px margin,
/// part 255 and the rest 0.
pub fn component(labels: &[u8], w: usize, h: usize, sx: usize, sy: usize) -> GrayImage {
    let on = sx < w && sy < h && labels.get(sy * w + sx).is_some_and(|&l| l != 0);
    let pixels: Vec<(usize, usize)> = if on {
        component_pixels(labels, w, h, sx, sy)
            .into_iter()
            .map(|i| (i % w, i / w))
            .collect()
    } else {
        vec![(sx, sy)]
    };
    let x0 = pixels.iter().map(|p| p.0).min().unwrap_or(sx);
    let y0 = pixels.iter().map(|p| p.1).min().unwrap_or(sy);
    let x1 = pixels.iter().map(|p| p.0).max().unwrap_or(sx);
    let y1 = pixels.iter().map(|p| p.1).max().unwrap_or(sy);
    const MARGIN: usize = 10;
    let (cw, ch) = (x1 - x0 + 1 + 2 * MARGIN, y1 - y0 + 1 + 2 * MARGIN);
    let mut out = GrayImage::new(cw as u32, ch as u32);
    if on {
        for (x, y) in pixels {
            out.put_pixel((x - x0 + MARGIN) as u32, (y - y0 + MARGIN) as u32, Luma([255]));
        }
    }
    out
}
