//! `vorl soak`: a long stream of generated frames of every variant through one recognizer,
//! resident memory sampled, every frame held against a fresh recognizer ([`crate::soak`]).

use std::process::ExitCode;

use crate::soak::{run as soak_run, SoakOptions};

/// Arguments of `vorl soak`.
#[derive(Debug, Clone, clap::Args)]
#[command(
    after_help = "Examples:\n  vorl soak --frames 100000                           (the long run of docs/reliability.md)\n  \
    vorl soak --frames 280 --distinct 28 --reuse 10 --seed 11   (the test suite's short run)"
)]
pub struct SoakArgs {
    /// Frames through the one long-lived recognizer.
    #[arg(long, default_value_t = 100_000)]
    pub frames: usize,
    /// New frames rendered (in memory) per chunk, cycling over the sources.
    #[arg(long, default_value_t = 112)]
    pub distinct: usize,
    /// Times each rendered frame goes through the long-lived recognizer (shuffled).
    #[arg(long, default_value_t = 8)]
    pub reuse: usize,
    /// Seed of the generated sets.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Frame width, px.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Frame height, px.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Frames between two memory samples.
    #[arg(long, default_value_t = 1000)]
    pub sample_every: usize,
}

/// Runs `vorl soak`; exit code 1 when a frame differs from a fresh recognizer or fails.
///
/// # Errors
/// Options out of range.
pub fn run(args: SoakArgs) -> Result<ExitCode, String> {
    let opts = SoakOptions {
        frames: args.frames,
        distinct: args.distinct,
        reuse: args.reuse,
        seed: args.seed,
        width: args.width,
        height: args.height,
        sample_every: args.sample_every,
    };
    let r = soak_run(&opts, |line| eprintln!("{line}"))?;
    println!(
        "soak: {} frames through one recognizer ({} rendered in memory, {} sources: {}; {} templates) in {:.1} s ({:.1} s in the core)",
        r.frames,
        r.rendered,
        r.sources.len(),
        r.sources.join(", "),
        r.templates,
        r.seconds,
        r.core_seconds
    );
    println!(
        "detections {} ({} known); every frame against a fresh recognizer: {} mismatches, {} errors",
        r.detections, r.known, r.mismatches, r.errors
    );
    println!(
        "resident memory: first sample {} KiB (after {} frames), peak sampled {} KiB, final {} KiB; VmHWM {} KiB",
        r.first_rss_kib(),
        r.memory.first().map_or(0, |m| m.frames),
        r.peak_rss_kib(),
        r.final_rss_kib(),
        r.hwm_kib()
    );
    if let Some(p) = &r.first_problem {
        println!("first problem: {p}");
    }
    Ok(if r.mismatches == 0 && r.errors == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
