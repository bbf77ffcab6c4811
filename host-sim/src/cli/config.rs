//! `vorl config`: the parameters, their defaults and meaning.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::config::Config;

/// Arguments of `vorl config`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  vorl config --defaults > vorl.toml\n  vorl config --check vorl.toml")]
pub struct ConfigArgs {
    /// Print every parameter with its default and meaning (a TOML file to start from).
    #[arg(long)]
    pub defaults: bool,
    /// Check a config file and print the parameters it gives.
    #[arg(long, value_name = "FILE")]
    pub check: Option<PathBuf>,
}

/// Runs `vorl config`.
///
/// # Errors
/// A config file that does not parse or has values out of range.
pub fn run(args: ConfigArgs) -> Result<ExitCode, String> {
    if let Some(path) = args.check {
        let c = Config::load(&path)?;
        c.to_params().map_err(|e| format!("{}: {e}", path.display()))?;
        print!("{}", toml::to_string(&c).map_err(|e| e.to_string())?);
        return Ok(ExitCode::SUCCESS);
    }
    print!("{}", Config::defaults_toml());
    Ok(ExitCode::SUCCESS)
}
