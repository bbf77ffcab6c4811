//! `vorl teach`: take the part in a frame as a new template.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::process::ExitCode;

use image::{GrayImage, Luma};

use crate::cli::params::ParamArgs;
use crate::engine::Engine;
use crate::io::load_gray;
use crate::set::load_background_frames;

/// Arguments of `vorl teach`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "The part's silhouette at its pose in FRAME becomes the template's reference pose \
    (angle 0). The frame should hold exactly one part, clear of the frame's edge.\n\n\
    Examples:\n  vorl teach --background set/background.png set/frames/f000.png --name bracket --out set/templates"
)]
pub struct TeachArgs {
    /// The empty platform.
    #[arg(long, value_name = "BG")]
    pub background: PathBuf,
    /// A frame with the part on the platform.
    #[arg(value_name = "FRAME")]
    pub frame: PathBuf,
    /// Class name of the new template (the file name in DIR).
    #[arg(long)]
    pub name: String,
    /// Template folder to write `<name>.png` into (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Overwrite an existing template of that name.
    #[arg(long)]
    pub force: bool,
    /// Pipeline parameters (threshold, α, … used to segment the part).
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Runs `vorl teach`.
///
/// # Errors
/// Unreadable inputs, no part in the frame, or the template cannot be written.
pub fn run(args: TeachArgs) -> Result<ExitCode, String> {
    if args.name.is_empty() || args.name.contains(['/', '\\']) || args.name.starts_with('.') {
        return Err(format!(
            "--name {:?}: a class name must be a plain file name",
            args.name
        ));
    }
    let target = args.out.join(format!("{}.png", args.name));
    if target.exists() && !args.force {
        return Err(format!(
            "{}: template exists already (use --force to replace it)",
            target.display()
        ));
    }
    let mut engine = Engine::new(args.params.params()?)?;
    let bgs = load_background_frames([&args.background]).map_err(|e| e.to_string())?;
    engine.learn_background(&bgs)?;
    let frame = load_gray(&args.frame).map_err(|e| e.to_string())?;
    if let Some(n) = &frame.note {
        eprintln!("note: {}: {n}", args.frame.display());
    }
    if frame.image.dimensions() != bgs[0].dimensions() {
        return Err(format!(
            "{}: frame is {}×{} but the background is {}×{}",
            args.frame.display(),
            frame.image.width(),
            frame.image.height(),
            bgs[0].width(),
            bgs[0].height()
        ));
    }
    let result = engine
        .detect(&frame.image)
        .map_err(|e| format!("{}: {e}", args.frame.display()))?;
    let Some(part) = result
        .detections
        .iter()
        .max_by(|a, b| a.core.area.total_cmp(&b.core.area))
    else {
        return Err(format!(
            "{}: no part found against the background (try a lower --threshold)",
            args.frame.display()
        ));
    };
    if result.detections.len() > 1 {
        eprintln!(
            "warning: {}: {} parts in the frame; teaching the largest (area {:.0} px²)",
            args.frame.display(),
            result.detections.len(),
            part.core.area
        );
    }
    if part.core.touches_edge {
        eprintln!(
            "warning: {}: the part touches the frame's edge; the template may be cut",
            args.frame.display()
        );
    }
    let (w, h) = (frame.image.width() as usize, frame.image.height() as usize);
    let Some(&(sx, sy)) = part.border.first() else {
        return Err("the part has no border".into());
    };
    let silhouette = component(engine.labels(), w, h, sx as usize, sy as usize);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: cannot create folder: {e}", args.out.display()))?;
    silhouette
        .save(&target)
        .map_err(|e| format!("{}: cannot write: {e}", target.display()))?;
    println!(
        "taught {:?} from {} ({}×{} silhouette, area {:.0} px²) → {}",
        args.name,
        args.frame.display(),
        silhouette.width(),
        silhouette.height(),
        part.core.area,
        target.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The 8-connected foreground component containing `(sx, sy)`, cropped with a 10 px margin,
/// part 255 and the rest 0.
pub fn component(labels: &[u8], w: usize, h: usize, sx: usize, sy: usize) -> GrayImage {
    let mut seen = vec![false; w * h];
    let mut queue = VecDeque::from([(sx, sy)]);
    let (mut x0, mut y0, mut x1, mut y1) = (sx, sy, sx, sy);
    let mut pixels = Vec::new();
    if sx < w && sy < h && labels[sy * w + sx] != 0 {
        seen[sy * w + sx] = true;
    } else {
        queue.clear();
    }
    while let Some((x, y)) = queue.pop_front() {
        pixels.push((x, y));
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
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
    const MARGIN: usize = 10;
    let (cw, ch) = (x1 - x0 + 1 + 2 * MARGIN, y1 - y0 + 1 + 2 * MARGIN);
    let mut out = GrayImage::new(cw as u32, ch as u32);
    for (x, y) in pixels {
        out.put_pixel((x - x0 + MARGIN) as u32, (y - y0 + MARGIN) as u32, Luma([255]));
    }
    out
}
