//! `vorl similarity`: the all-pairs f' matrix of the silhouettes in a folder.

use std::path::PathBuf;
use std::process::ExitCode;

use vorl_core::Params;

use crate::cli::params::ParamArgs;
use crate::engine::{load_silhouettes, Engine, NamedSilhouette, HOST_TEMPLATES};
use crate::similarity::similarity;

/// Output format of the matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Comma-separated, a header row of names.
    Csv,
    /// `{"names", "matrix", "epsilon", "too_alike", "mirror_gap"}`.
    Json,
}

/// Arguments of `vorl similarity`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Row i, column j is f' of silhouette i seen as a part against silhouette j as a \
    template. Pairs below ε in either direction are warned about on stderr: the matcher cannot tell \
    them apart at that ε (examples of one class, in a subfolder DIR/<class>/, are named \
    <class>/<file> and not warned about; the tolerance each such class carries is printed).\n\n\
    Examples:\n  vorl similarity examples/plant/templates\n  \
    vorl similarity my_templates --format json --out sim.json --epsilon 0.05"
)]
pub struct SimilarityArgs {
    /// Folder of silhouettes (PNG, GIF or BMP; part bright on dark).
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: Format,
    /// Write to this file instead of standard output.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Pipeline parameters (n, m, k, ω, ε).
    #[command(flatten)]
    pub params: ParamArgs,
}

/// The tolerance of each class of several examples, as detect and export measure it: one line
/// per class ([`Engine::add_silhouettes`]), in the order the classes first appear.
///
/// Each class is taught into an engine of its own, so the folder may hold more silhouettes than
/// one library holds ([`HOST_TEMPLATES`]); the matrix itself needs no library. A class of more
/// examples than that gets a line saying its tolerance is not measured.
///
/// # Errors
/// As [`Engine::add_silhouettes`].
fn class_notes(params: Params, sils: &[NamedSilhouette]) -> Result<Vec<String>, String> {
    let mut notes = Vec::new();
    let mut done: Vec<&str> = Vec::new();
    for s in sils {
        if done.contains(&s.name.as_str()) {
            continue;
        }
        done.push(&s.name);
        let examples: Vec<NamedSilhouette> = sils.iter().filter(|e| e.name == s.name).cloned().collect();
        if examples.len() < 2 {
            continue;
        }
        if examples.len() > HOST_TEMPLATES {
            notes.push(format!(
                "class {}: {} examples, more than one library holds ({HOST_TEMPLATES}); its tolerance is not measured",
                s.name,
                examples.len()
            ));
            continue;
        }
        let mut engine = Engine::new(params)?;
        notes.extend(engine.add_silhouettes(&examples)?);
    }
    Ok(notes)
}

/// Runs `vorl similarity`.
///
/// # Errors
/// Unreadable folder or silhouette, or an output file that cannot be written.
pub fn run(args: SimilarityArgs) -> Result<ExitCode, String> {
    let params = args.params.params()?;
    let sils = load_silhouettes(&args.dir).map_err(|e| e.to_string())?;
    for n in sils.iter().filter_map(|s| s.note.as_ref()) {
        eprintln!("note: {n}");
    }
    let classes = class_notes(params, &sils)?;
    let class_of: Vec<String> = sils.iter().map(|s| s.name.clone()).collect();
    let mut sils = sils;
    for s in sils.iter_mut() {
        if class_of.iter().filter(|c| **c == s.name).count() > 1 {
            s.name = format!("{}/{}", s.name, crate::io::file_name(&s.path));
        }
    }
    let bar = crate::io::progress(sils.len(), "similarity", "rows");
    let sim = similarity(&sils, &params, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let text = match args.format {
        Format::Csv => sim.to_csv(),
        Format::Json => serde_json::to_string_pretty(&sim).map_err(|e| e.to_string())? + "\n",
    };
    match &args.out {
        Some(p) => std::fs::write(p, text).map_err(|e| format!("{}: cannot write: {e}", p.display()))?,
        None => print!("{text}"),
    }
    const SHOWN: usize = 25;
    for c in &classes {
        eprintln!("{c}");
    }
    let too_alike: Vec<_> = sim
        .too_alike
        .iter()
        .filter(|&&(i, j, _)| class_of[i] != class_of[j])
        .collect();
    for &&(i, j, v) in too_alike.iter().take(SHOWN) {
        eprintln!(
            "warning: {} and {} are too alike to tell apart at ε = {}: f' = {v:.4}",
            sim.names[i], sim.names[j], sim.epsilon
        );
    }
    if too_alike.len() > SHOWN {
        eprintln!(
            "warning: … and {} more pairs (all are listed by --format json)",
            too_alike.len() - SHOWN
        );
    }
    let chiral: Vec<String> = sim
        .names
        .iter()
        .zip(&sim.mirror_gap)
        .filter(|(_, g)| **g >= vorl_core::library::template::CHIRAL_GAP)
        .map(|(n, g)| format!("{n} ({g:.3})"))
        .collect();
    if !chiral.is_empty() {
        eprintln!(
            "chiral (upside down another shape; their mirror images are matched too, mirror gap in brackets): {}",
            chiral.join(", ")
        );
    }
    eprintln!(
        "{} silhouettes, {} pair(s) of different classes below ε = {}",
        sim.names.len(),
        too_alike.len(),
        sim.epsilon
    );
    Ok(ExitCode::SUCCESS)
}
