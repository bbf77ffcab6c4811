//! `vorl check`: the core against the independent std reference on every frame of a set.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::cli::params::ParamArgs;
use crate::compare::{compare_frame, Comparison, Tolerances};
use crate::io::{file_name, load_gray};
use crate::set::FixtureSet;

/// Arguments of `vorl check`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Compares, per frame: background model and mask (pixel for pixel), kept borders \
    (point for point), resampled points and descriptors (1e-3), DP cost for every part × template \
    (1e-3 relative), the decision f' < ε, both angle estimators (0.1°) and the area centroid (1e-3 px). \
    Exits 1 on any disagreement.\n\n\
    Examples:\n  vorl check examples/plant\n  vorl check my_set --threshold otsu --json"
)]
pub struct CheckArgs {
    /// A fixture set folder.
    #[arg(value_name = "SET")]
    pub set: PathBuf,
    /// Print the comparison as JSON.
    #[arg(long)]
    pub json: bool,
    /// Pipeline parameters.
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Runs `vorl check`.
///
/// # Errors
/// The set cannot be read.
pub fn run(args: CheckArgs) -> Result<ExitCode, String> {
    let params = args.params.params()?;
    let set = FixtureSet::open(&args.set).map_err(|e| e.to_string())?;
    let backgrounds = set.load_backgrounds().map_err(|e| e.to_string())?;
    let templates: Vec<_> = set
        .load_templates()
        .map_err(|e| e.to_string())?
        .into_iter()
        .map(|t| {
            if let Some(n) = &t.note {
                eprintln!("note: {n}");
            }
            t.image
        })
        .collect();
    let tol = Tolerances {
        pixels: if params.alpha < 1.0 { 8 } else { 0 },
        ..Tolerances::default()
    };
    let bar = crate::io::progress(set.frames.len(), "check", "frames");
    let mut out = Comparison::default();
    let mut failed = 0usize;
    for path in &set.frames {
        let name = file_name(path);
        let res = load_gray(path).map_err(|e| e.to_string()).and_then(|img| {
            if let Some(n) = &img.note {
                bar.suspend(|| eprintln!("note: {}: {n}", path.display()));
            }
            compare_frame(&name, &img.image, &backgrounds, &templates, &params, &tol, &mut out)
        });
        if let Err(e) = res {
            bar.suspend(|| eprintln!("error: {}: {e}", path.display()));
            failed += 1;
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
    } else {
        println!(
            "vorl check {}: {} frames, {} borders, {} part×template matches compared",
            args.set.display(),
            out.frames,
            out.borders,
            out.matches
        );
        println!(
            "  largest differences: DP cost {:.2e} (relative), signed angle {:.4}°, paper angle {:.4}°, centroid {:.2e} px, descriptor {:.2e}",
            out.max_cost_rel, out.max_angle_deg, out.max_angle_paper_deg, out.max_centroid_px, out.max_descriptor
        );
        println!("  tolerances: {:?}", tol);
        if out.ties > 0 {
            println!(
                "  {} match(es) with several optimal correspondences (symmetric shapes) compared on the core's",
                out.ties
            );
        }
        for d in &out.disagreements {
            println!("  DISAGREE {} at {}: {}", d.stage, d.at, d.detail);
        }
        println!(
            "{}",
            if out.disagreements.is_empty() && failed == 0 {
                "agreement: yes"
            } else {
                "agreement: NO"
            }
        );
    }
    Ok(if out.disagreements.is_empty() && failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
