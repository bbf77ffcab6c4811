//! `vorl gen`: a deterministic synthetic fixture set.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::gen::{generate, GenOptions, Variant};

/// Arguments of `vorl gen`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Variants (the ideal camera):\n  \
    default   parts 88–138 px, σ = 2 noise\n  \
    noisy     stronger noise, lighting drift, lower contrast\n  \
    small     parts 35–55 px\n  \
    border    parts cut by the frame's edge, marked partial\n  \
    stereo    left/right pairs, camera.json, depth in truth\n  \
    flipped   as default, about half the chiral parts upside down; truth adds flipped, chiral\n  \
    touching  as default, about 60 % of the parts against or over another (up to 12 % of the\n            \
              smaller one's area), about half the chiral parts upside down; truth adds touching,\n            \
              visible_fraction, flipped, chiral; writes vorl.toml (touching_parts = true)\n\
    Variants (what real cameras do; each also writes variant.json with its parameters):\n  \
    sharp     sharp-cornered parts (rectangular-tooth gear, snail cam, square L bracket, …) under\n            \
              0.7 px blur; crisp templates\n  \
    lens      barrel distortion (frame corners 3–6 px inward); templates undistorted; truth x, y =\n            \
              the distorted centroid, angle_deg = drawn angle + lens_rotation_deg (best-fit turn of\n            \
              the border by the lens), plus x_undistorted, y_undistorted, area_x, area_y\n  \
    thick     close camera over 4–20 mm thick parts: the walls show, parts away from the centre\n            \
              look stretched outward; truth = the top face's pose (scale included), plus\n            \
              thickness_mm, top_scale, bottom_x, bottom_y\n  \
    exposure  gain 0.6–1.4 and offset ±10 per frame, background at gain 1; frames in pairs of one\n            \
              scene (f000/f001, f002/f003, …); truth adds gain, offset, scene\n  \
    paper     fine paper/belt texture on the platform (in the background and every frame)\n  \
    printed   dark print, logo rings and light hole-like patches on parts; truth = the part's own\n            \
              centroid; texture \"print\", print_marks, print_patches\n  \
    backlit   dark parts on a vignetted backlight (250 centre, ~150 corners); no background.png\n            \
              unless --with-background; truth adds level\n  \
    rods      backlit connecting rods: rod_a (one eye) and rod_b (two eyes, thin rims) of the same\n            \
              outline, each rod with its own proportions (shaft ±15 %, heads ±8 %, eyes ±10 %)\n            \
              at 0.9–1.3× the template's size; washers and screws as distractors; no\n            \
              background.png unless --with-background; writes vorl.toml (scale_min 0.8,\n            \
              scale_max 1.4); truth adds level, stretch and the rods' head and eye factors\n  \
    rods-touching  as rods, with the rods against and over one another as in touching; its\n            \
              vorl.toml adds touching_parts = true\n  \
    frontlit  metal parts on a grey textured mat, diffuse light from one side (about the upper\n            \
              left): parts brighter than the mat, shaded, a dark facet near the mat's level and\n            \
              highlights, each with a soft shadow 4–10 px away from the light; background.png is\n            \
              the empty mat; writes teach.json (each class's first whole part); truth adds\n            \
              light_from_deg, shadow_dx, shadow_dy, shadow_sigma, shadow_depth, facet, facet_share\n  \
    lookalike as default, with untaught look-alikes among the distractors: a cam, hex nut,\n            \
              12-tooth gear, washer-sized disc and oval flange drawn without their holes\n  \
    large     one large part per frame (a guitar pick or a standard part scaled to 26–45 % of\n            \
              the frame; the pick and a gear taught, at its scale), dark or bright, and up to two small ones, on\n            \
              white paper printed with text-like lines and ruled lines (print in background.png\n            \
              too); truth adds level. Without background.png (--no-background) the platform\n            \
              is estimated from frames whose large part covers up to half of them\n\
    The same seed and options give byte-identical sets.\n\n\
    Examples:\n  vorl gen out/plant --seed 7 --frames 60\n  vorl gen out/noisy --variant noisy --frames 20\n  \
    vorl gen out/stereo --variant stereo --frames 10\n  vorl gen out/lens --variant lens --frames 20 --no-background")]
pub struct GenArgs {
    /// Folder to write the set into (created if missing).
    #[arg(value_name = "OUT")]
    pub out: PathBuf,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of frames.
    #[arg(long, default_value_t = 60)]
    pub frames: usize,
    /// Kind of set: default, noisy, small, border, stereo, flipped, touching, sharp, lens,
    /// thick, exposure, paper, printed, backlit, rods, rods-touching, frontlit, lookalike or large
    /// (see below).
    #[arg(long, default_value = "default")]
    pub variant: Variant,
    /// Frame width, px.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Frame height, px.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Write no background.png and no backgrounds/ (the platform is then estimated from the
    /// frames); frames and truth are the same as with them.
    #[arg(long, conflicts_with = "with_background")]
    pub no_background: bool,
    /// Write background.png and backgrounds/ even for a variant that leaves them out (backlit,
    /// rods).
    #[arg(long)]
    pub with_background: bool,
}

/// Runs `vorl gen`.
///
/// # Errors
/// Bad options or a file that cannot be written.
pub fn run(args: GenArgs) -> Result<ExitCode, String> {
    let background = if args.no_background {
        Some(false)
    } else if args.with_background {
        Some(true)
    } else {
        None
    };
    let opts = GenOptions {
        seed: args.seed,
        frames: args.frames,
        variant: args.variant,
        width: args.width,
        height: args.height,
        background,
    };
    let t0 = std::time::Instant::now();
    let s = generate(&args.out, &opts).map_err(|e| e.to_string())?;
    println!(
        "wrote {} ({} variant, seed {}{}): {} frames, {} parts ({} known, {} not templates, {} partial), {} classes, in {:.1} s",
        args.out.display(),
        args.variant,
        args.seed,
        if opts.writes_background() { "" } else { ", no background" },
        s.frames,
        s.parts,
        s.known_parts,
        s.unknown_parts,
        s.partial_parts,
        s.classes.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}
