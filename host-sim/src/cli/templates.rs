//! `vorl templates`: the template library a camera loads (`export`) and a check of one (`info`).
//!
//! The library format is defined and read by the core (`vorl_core::library`): the descriptors,
//! resampled points and centroids of the taught silhouettes and the `n`, `m`, `k`, `ω` they were
//! made with, little-endian, versioned and CRC-32 checked.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use vorl_core::library::{encoded_len, write_library, Library, MAX_NAME_LEN};
use vorl_core::Params;

use crate::cli::params::ParamArgs;
use crate::engine::{load_silhouettes, Engine};
use crate::io::io_problem;

/// Arguments of `vorl templates`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    vorl templates export examples/plant/templates --out plant.vtl\n  \
    vorl templates export examples/plant --n 48 --m 72 --out plant-n48.vtl\n  \
    vorl templates info plant.vtl")]
pub struct TemplatesArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: TemplatesAction,
}

/// Subcommands of `vorl templates`.
#[derive(Debug, clap::Subcommand)]
pub enum TemplatesAction {
    /// Teach every silhouette of a folder and write the templates as one binary library file
    /// (what a camera loads: `vorl_core::library`).
    Export(Box<ExportArgs>),
    /// Check a library file (magic, version, size, checksum, counts) and list its templates.
    Info(InfoArgs),
}

/// Arguments of `vorl templates export`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "DIR holds one silhouette per class (<class>.png: part 255, rest 0, at the \
    reference pose); a fixture set folder is accepted too (its templates/ is used). Class names \
    are the file stems, at most 31 bytes; templates are stored in file-name order, so template \
    index i on the camera is the i-th file.\n\n\
    Examples:\n  \
    vorl templates export examples/plant/templates --out plant.vtl\n  \
    vorl templates export firmware-example/fixtures/templates --out firmware-example/fixtures/templates.vtl\n  \
    vorl templates export examples/plant --config camera.toml --out plant.vtl"
)]
pub struct ExportArgs {
    /// Folder of template silhouettes (or a fixture set folder).
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Library file to write.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Pipeline parameters (n, m, k and ω shape the templates and are stored with them).
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Arguments of `vorl templates info`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Exits with status 1 when the file is not a valid library, naming the \
    problem (bad magic, unsupported version, truncated, checksum mismatch, corrupt).\n\n\
    Examples:\n  vorl templates info plant.vtl\n  vorl templates info firmware-example/fixtures/templates.vtl")]
pub struct InfoArgs {
    /// Library file to check.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
}

/// The silhouette folder of `dir`: `dir/templates` for a fixture set, else `dir` itself.
pub fn silhouette_dir(dir: &Path) -> PathBuf {
    let sub = dir.join("templates");
    if sub.is_dir() {
        sub
    } else {
        dir.to_path_buf()
    }
}

/// The library bytes of an engine's templates, with its parameters.
///
/// # Errors
/// A class name longer than 31 bytes, or a template the core cannot store.
pub fn library_bytes(engine: &Engine) -> Result<Vec<u8>, String> {
    let names = engine.names();
    let templates = engine.templates();
    if let Some(long) = names.iter().find(|n| n.len() > MAX_NAME_LEN) {
        return Err(format!(
            "class name {long:?} is {} bytes; a library stores at most {MAX_NAME_LEN}",
            long.len()
        ));
    }
    let mut bytes = vec![0u8; encoded_len(templates.len(), engine.params().m)];
    let written = write_library(
        &mut bytes,
        engine.params(),
        names.iter().map(String::as_str).zip(templates),
    )
    .map_err(|e| format!("cannot write the library: {e}"))?;
    bytes.truncate(written);
    Ok(bytes)
}

/// Teaches every silhouette in `dir` (see [`silhouette_dir`]) with `params` and returns the
/// library bytes and the class names in template order.
///
/// # Errors
/// Unreadable folder or silhouette, a silhouette that is not one part, a name too long.
pub fn export_library(dir: &Path, params: Params) -> Result<(Vec<u8>, Vec<String>), String> {
    let dir = silhouette_dir(dir);
    let mut engine = Engine::new(params)?;
    let silhouettes = load_silhouettes(&dir).map_err(|e| e.to_string())?;
    for n in engine.add_silhouettes(&silhouettes)? {
        eprintln!("note: {n}");
    }
    let bytes = library_bytes(&engine)?;
    Ok((bytes, engine.names().to_vec()))
}

/// Runs `vorl templates`.
///
/// # Errors
/// Set-up problems of `export`; an unreadable file for `info`.
pub fn run(args: TemplatesArgs) -> Result<ExitCode, String> {
    match args.action {
        TemplatesAction::Export(a) => export(*a),
        TemplatesAction::Info(a) => info(a),
    }
}

fn export(args: ExportArgs) -> Result<ExitCode, String> {
    let params = args.params.params()?;
    let (bytes, names) = export_library(&args.dir, params)?;
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| format!("{}: cannot create folder: {e}", parent.display()))?;
    }
    std::fs::write(&args.out, &bytes).map_err(|e| format!("{}: cannot write: {e}", args.out.display()))?;
    let lib = Library::parse(&bytes).map_err(|e| format!("written library does not read back: {e}"))?;
    println!(
        "{}: {} template(s) ({}), n {} m {} k {} ω {}, {} bytes, CRC-32 {:#010x}",
        args.out.display(),
        lib.len(),
        names.join(", "),
        lib.n(),
        lib.m(),
        lib.k(),
        lib.omega(),
        bytes.len(),
        lib.checksum()
    );
    Ok(ExitCode::SUCCESS)
}

fn info(args: InfoArgs) -> Result<ExitCode, String> {
    let bytes = std::fs::read(&args.file).map_err(|e| format!("{}: {}", args.file.display(), io_problem(&e)))?;
    let lib = match Library::parse(&bytes) {
        Ok(lib) => lib,
        Err(e) => {
            eprintln!("error: {}: {e}", args.file.display());
            return Ok(ExitCode::from(1));
        }
    };
    println!(
        "{}: vorl template library v{}, {} bytes, CRC-32 {:#010x}",
        args.file.display(),
        vorl_core::library::VERSION,
        bytes.len(),
        lib.checksum()
    );
    println!(
        "parameters: n {}  m {}  k {}  ω {}",
        lib.n(),
        lib.m(),
        lib.k(),
        lib.omega()
    );
    println!("templates: {}", lib.len());
    for i in 0..lib.len() {
        let t = lib
            .template::<{ crate::engine::HOST_M }>(i)
            .map_err(|e| format!("{}: template {i}: {e}", args.file.display()))?;
        let [ax, ay] = t.area_centroid();
        let tol = t.tolerance();
        let tolerance = if tol == vorl_core::Tolerance::NONE {
            "one example".to_string()
        } else {
            format!(
                "class tolerance: limit ×{:.2}, scale {:.2}–{:.2}",
                tol.verify, tol.scale[0], tol.scale[1]
            )
        };
        println!(
            "  {i:>3}  {:<31}  area {:>9.1} px²  centroid ({ax:.2}, {ay:.2})  holes {}  {}  {tolerance}",
            lib.name(i).unwrap_or("?"),
            t.area(),
            t.holes().len(),
            chirality(&t)
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `chiral (mirror gap 0.123)` or `mirror-symmetric (mirror gap 0.001)`: whether a part of this
/// template lying upside down is another shape ([`vorl_core::Template::is_chiral`]).
pub fn chirality<const M: usize>(t: &vorl_core::Template<M>) -> String {
    let kind = if t.is_chiral() { "chiral" } else { "mirror-symmetric" };
    format!("{kind} (mirror gap {:.3})", t.mirror_gap())
}
