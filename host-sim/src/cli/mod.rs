//! The `vorl` command line: one module per subcommand.

pub mod budget;
pub mod calibrate;
pub mod check;
pub mod config;
pub mod detect;
pub mod eval;
pub mod gen;
pub mod params;
pub mod serve;
pub mod similarity;
pub mod soak;
pub mod stereo;
pub mod teach;
pub mod templates;

use clap::{Parser, Subcommand};

/// vorl: contour matching for smart cameras over a plain platform.
///
/// Teach templates, replay recorded frames through the same core that runs on the camera,
/// and measure it.
#[derive(Debug, Parser)]
#[command(
    name = "vorl",
    version,
    about,
    long_about = None,
    propagate_version = true,
    after_help = "Examples:\n  vorl gen out/plant --seed 7 --frames 20\n  vorl eval out/plant --overlay out/overlays\n  \
        vorl detect out/plant --json > predictions.json\n  vorl check out/plant\n  vorl config --defaults > vorl.toml"
)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Write a deterministic synthetic fixture set (frames, templates, truth).
    Gen(gen::GenArgs),
    /// Find the parts in frames: class (or unknown), position, angle.
    Detect(detect::DetectArgs),
    /// Hold the core against the independent std reference on every frame of a set.
    Check(check::CheckArgs),
    /// Score detect against a set's truth.json.
    Eval(eval::EvalArgs),
    /// The all-pairs f' matrix of silhouettes: which parts will be confused.
    Similarity(similarity::SimilarityArgs),
    /// Take the part in a frame as a new template.
    Teach(teach::TeachArgs),
    /// Write or check the binary template library a camera loads.
    Templates(templates::TemplatesArgs),
    /// The RAM a configuration needs on the camera, buffer by buffer.
    Budget(budget::BudgetArgs),
    /// Print the pipeline parameters.
    Config(config::ConfigArgs),
    /// Fit the camera-to-robot map from point pairs (homography or rigid) and write cal.json.
    Calibrate(calibrate::CalibrateArgs),
    /// A long run of generated frames through one recognizer: memory, errors, fresh-recognizer agreement.
    Soak(soak::SoakArgs),
    /// The live cell: frames in, a page to watch, teach and tune, results out to the robot.
    Serve(serve::ServeArgs),
}

/// Runs the parsed command; the exit code.
pub fn run(cli: Cli) -> std::process::ExitCode {
    let result = match cli.command {
        Command::Gen(a) => gen::run(a),
        Command::Detect(a) => detect::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Check(a) => check::run(a),
        Command::Similarity(a) => similarity::run(a),
        Command::Teach(a) => teach::run(a),
        Command::Templates(a) => templates::run(a),
        Command::Budget(a) => budget::run(a),
        Command::Config(a) => config::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Soak(a) => soak::run(a),
        Command::Serve(a) => serve::run(a),
    };
    match result {
        Ok(code) => code,
        Err(msg) => {
            eprintln!("error: {msg}");
            std::process::ExitCode::from(2)
        }
    }
}
