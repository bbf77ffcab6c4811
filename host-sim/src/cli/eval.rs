//! `vorl eval`: run detect on a fixture set and score it against its truth.json.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::cli::detect::prepare;
use crate::cli::params::ParamArgs;
use crate::eval::{score, EvalReport};
use crate::io::file_name;
use crate::run::{run_frame, to_json};
use crate::set::FixtureSet;
use crate::truth::FramesJson;

/// Arguments of `vorl eval`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    vorl eval examples/plant\n  \
    vorl eval examples/plant --overlay out/overlays\n  \
    vorl eval my_set --epsilon 0.06 --json > scores.json")]
pub struct EvalArgs {
    /// A fixture set folder with truth.json.
    #[arg(value_name = "SET")]
    pub set: PathBuf,
    /// Print the scores as JSON.
    #[arg(long)]
    pub json: bool,
    /// Also write an overlay PNG per frame into this folder.
    #[arg(long, value_name = "DIR")]
    pub overlay: Option<PathBuf>,
    /// Pipeline parameters.
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Runs detect over a set and scores it; per-frame errors are reported and counted.
///
/// # Errors
/// The set, its truth, background or templates cannot be read.
pub fn evaluate(args: &EvalArgs) -> Result<EvalReport, String> {
    if crate::cli::stereo::is_stereo_set(&args.set) {
        return crate::cli::stereo::evaluate(&args.set, &args.params, args.overlay.as_deref());
    }
    let set = FixtureSet::open(&args.set).map_err(|e| e.to_string())?;
    let truth_path = set.truth.clone().ok_or_else(|| {
        format!(
            "{}: no such file (eval needs the set's truth)",
            args.set.join("truth.json").display()
        )
    })?;
    let truth = FramesJson::load(&truth_path)?;
    let mut inputs = prepare(Some(&args.set), None, None, &[], &args.params)?;
    if let Some(dir) = &args.overlay {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    }
    let bar = crate::io::progress(inputs.frames.len(), "eval", "frames");
    let mut pred = FramesJson::default();
    let (mut failed, mut seconds, mut done) = (0usize, 0.0f64, 0usize);
    let (mut estimated, mut kept) = (0usize, 0usize);
    for path in inputs.frames.clone() {
        let name = file_name(&path);
        match run_frame(&mut inputs.engine, &path) {
            Ok((result, image, note)) => {
                if let Some(n) = note {
                    bar.suspend(|| eprintln!("note: {n}"));
                }
                for n in crate::engine::frame_notes(&result) {
                    bar.suspend(|| eprintln!("note: {name}: {n}"));
                }
                if let Some(dir) = &args.overlay {
                    let target = dir.join(&name);
                    if let Err(e) = crate::overlay::draw(&image, &result).save(&target) {
                        bar.suspend(|| eprintln!("error: {}: cannot write overlay: {e}", target.display()));
                        failed += 1;
                    }
                }
                seconds += result.seconds;
                done += 1;
                match (result.platform.is_some(), result.platform_frames_ago) {
                    (true, 0) => estimated += 1,
                    (true, _) => kept += 1,
                    (false, _) => {}
                }
                pred.frames.insert(name, to_json(&result));
            }
            Err(e) => {
                bar.suspend(|| eprintln!("error: {e}"));
                failed += 1;
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Frames that failed are not scored (they are reported above).
    let mut scored_truth = truth.clone();
    scored_truth.frames.retain(|k, _| pred.frames.contains_key(k));
    let missing: Vec<&String> = truth
        .frames
        .keys()
        .filter(|k| !set.frames.iter().any(|p| &file_name(p) == *k))
        .collect();
    if !missing.is_empty() {
        eprintln!(
            "warning: {} frame(s) in truth.json have no file in frames/ (first: {})",
            missing.len(),
            missing[0]
        );
    }
    let scores = score(&scored_truth, &pred);
    Ok(EvalReport {
        set: args.set.display().to_string(),
        failed_frames: failed,
        ms_per_frame: if done > 0 {
            seconds * 1e3 / done as f64
        } else {
            f64::NAN
        },
        recall: scores.recall(),
        precision: scores.precision(),
        classification: scores.classification(),
        unknown_rejection: scores.rejection(),
        scores,
        platform_estimated: estimated,
        platform_kept: kept,
        setup_errors: Vec::new(),
    })
}

/// Runs `vorl eval`.
///
/// # Errors
/// As [`evaluate`].
pub fn run(args: EvalArgs) -> Result<ExitCode, String> {
    let r = evaluate(&args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r).map_err(|e| e.to_string())?);
    } else {
        print_table(&r);
    }
    Ok(if r.failed_frames > 0 || !r.setup_errors.is_empty() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

fn pct(v: f64) -> String {
    if v.is_nan() {
        "n/a".into()
    } else {
        format!("{:.1}%", 100.0 * v)
    }
}

/// The human-readable table.
pub fn print_table(r: &EvalReport) {
    let s = &r.scores;
    println!("vorl eval {}: {} frames, {} parts", r.set, s.frames, s.truth_parts);
    println!(
        "  detection recall        {:>8}   ({}/{})",
        pct(r.recall),
        s.detected,
        s.truth_parts
    );
    println!(
        "  detection precision     {:>8}   ({}/{})",
        pct(r.precision),
        s.true_predictions,
        s.predictions
    );
    if s.unscored > 0 {
        println!(
            "  unscored                {:>8}   (predictions in blobs the truth marks \"don't care\")",
            s.unscored
        );
    }
    println!(
        "  classification          {:>8}   ({}/{} known parts)",
        pct(r.classification),
        s.known_correct,
        s.known
    );
    println!(
        "  unknown rejection       {:>8}   ({}/{} parts not taught)",
        pct(r.unknown_rejection),
        s.unknown_rejected,
        s.unknown
    );
    if s.flipped > 0 {
        println!(
            "  upside down: recall     {:>8}   ({}/{} known parts lying upside down)",
            pct(ratio(s.flipped_detected, s.flipped)),
            s.flipped_detected,
            s.flipped
        );
        println!(
            "  upside down: classified {:>8}   ({}/{})",
            pct(ratio(s.flipped_correct, s.flipped)),
            s.flipped_correct,
            s.flipped
        );
    }
    if s.flip_judged > 0 {
        println!(
            "  side reported right     {:>8}   ({}/{} parts classified right: flipped or not)",
            pct(s.flip_accuracy()),
            s.flip_right,
            s.flip_judged
        );
    }
    for (name, g, what) in [
        ("touching", &s.touching, "parts against or over another"),
        ("apart", &s.apart, "parts touching nothing"),
        (
            "cut ≥ half",
            &s.cut_half,
            "parts the frame's edge cuts, half or more visible",
        ),
    ] {
        if g.is_empty() {
            continue;
        }
        println!(
            "  {name:<10}: recall {:>7} ({}/{} {what}), classified {:>7} ({}/{})",
            pct(g.recall()),
            g.detected,
            g.parts,
            pct(g.classification()),
            g.correct,
            g.known
        );
        println!(
            "  {:<10}  angle median {:.3}°  p95 {:.3}°, position median {:.3} px  p95 {:.3} px",
            "", g.angle.median, g.angle.p95, g.position.median, g.position.p95
        );
    }
    println!(
        "  angle error  (reported) median {:.3}°  p95 {:.3}°  max {:.3}°  ({} parts)",
        s.angle.median, s.angle.p95, s.angle.max, s.angle.count
    );
    println!(
        "  angle error  (paper 6.4) median {:.3}°  p95 {:.3}°  max {:.3}°",
        s.angle_paper.median, s.angle_paper.p95, s.angle_paper.max
    );
    println!(
        "  position error          median {:.3} px  p95 {:.3} px  max {:.3} px",
        s.position.median, s.position.p95, s.position.max
    );
    if !s.disparity_centroid.is_empty() || !s.disparity.is_empty() {
        println!(
            "  stereo disparity error  ({} paired parts)",
            s.disparity.count.max(s.disparity_centroid.count)
        );
        for (name, d) in [
            ("polygon centroid", &s.disparity_polygon),
            ("centroid (paper)", &s.disparity_centroid),
            ("refined", &s.disparity),
        ] {
            if !d.is_empty() {
                println!(
                    "    {name:<21} median {:.4} px  p95 {:.4} px  max {:.4} px",
                    d.median, d.p95, d.max
                );
            }
        }
        if !s.depth_mm.is_empty() {
            println!(
                "  depth error (refined)   median {:.3} mm ({:.4}%)  p95 {:.3} mm ({:.4}%)  max {:.3} mm",
                s.depth_mm.median, s.depth_pct.median, s.depth_mm.p95, s.depth_pct.p95, s.depth_mm.max
            );
        }
        if s.stereo_without_depth > 0 {
            println!("  parts without depth     {}", s.stereo_without_depth);
        }
        if s.right_only > 0 {
            println!("  right image only        {} (not scored)", s.right_only);
        }
    }
    println!(
        "  time                    {:.2} ms/frame (core, this machine)",
        r.ms_per_frame
    );
    if r.platform_estimated + r.platform_kept > 0 {
        println!(
            "  platform                estimated from {} frame(s), kept from an earlier one on {} (no empty shot)",
            r.platform_estimated, r.platform_kept
        );
    }
    if r.failed_frames > 0 {
        println!("  failed frames           {}", r.failed_frames);
    }
    for e in &r.setup_errors {
        println!("  error                   {e}");
    }
    if !s.confusions.is_empty() {
        println!("  confusions (truth → predicted):");
        for (t, p, n) in &s.confusions {
            println!("    {t} → {p}: {n}");
        }
    }
}
