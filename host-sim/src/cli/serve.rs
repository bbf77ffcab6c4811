//! `vorl serve`: the live cell — frames in, a page to watch, teach and tune, results out to
//! the robot ([`crate::serve`]).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use crate::cli::params::ParamArgs;
use crate::serve::{ServeOptions, SourceSpec};

/// Arguments of `vorl serve`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    vorl serve examples/plant                          (page http://127.0.0.1:8080/, robot port 127.0.0.1:9000)\n  \
    vorl serve examples/plant --trigger                (a frame per robot TRG)\n  \
    vorl serve out/demo --source gen                   (scenes drawn live; writes the generator's set to out/demo first)\n  \
    vorl serve examples/plant --record out/rec         (then: vorl eval out/rec)\n  \
    vorl serve examples/plant --http 127.0.0.1:0 --robot 127.0.0.1:0   (free ports, printed at start)\n\n\
    Robot port: ASCII lines; TRG (the next frame's result), LAST (the last frame's), PING.\n\
    Answers: RES <frame> <n>, n lines <class> <x> <y> <angle_deg> <flipped> <score>, END; PONG; ERR <message>.")]
pub struct ServeArgs {
    /// The fixture set: templates, background, vorl.toml (and frames/, in replay).
    #[arg(value_name = "SET")]
    pub set: PathBuf,
    /// Where frames come from: replay (SET/frames in name order, looping), gen (scenes drawn
    /// live by the generator; SET gets the generator's templates when it has none), or camera
    /// (a V4L2/UVC camera, /dev/video0; camera:DEVICE names another; built with --features
    /// camera).
    #[arg(long, default_value = "replay", value_name = "replay|gen|camera[:DEVICE]")]
    pub source: String,
    /// The generator's seed (--source gen).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Frames per second when running free (at most 1000); 0: as fast as the frames are
    /// processed (soaks, benchmarks).
    #[arg(long, default_value_t = 10.0)]
    pub fps: f64,
    /// Wait for a robot's TRG (or POST /api/trigger) before each frame instead of running free.
    #[arg(long)]
    pub trigger: bool,
    /// The page's address.
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "ADDR")]
    pub http: SocketAddr,
    /// The robot port's address.
    #[arg(long, default_value = "127.0.0.1:9000", value_name = "ADDR")]
    pub robot: SocketAddr,
    /// Allow --http and --robot off loopback (actions that change the set then need the token
    /// printed at start).
    #[arg(long)]
    pub listen: bool,
    /// Ask for the token printed at start on loopback too (a machine several people use).
    #[arg(long)]
    pub require_token: bool,
    /// Write every frame and its result as a fixture set into DIR (a new folder).
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// Camera-to-robot calibration (`vorl calibrate`); default: the set's cal.json when there.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// Stop by itself after this many seconds (demos, tests).
    #[arg(long, value_name = "SECONDS")]
    pub stop_after: Option<f64>,
    /// Pipeline parameters (over the set's vorl.toml).
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Runs `vorl serve` until Ctrl-C or SIGTERM.
///
/// # Errors
/// Set-up problems: the set, parameters, an address that cannot be bound.
pub fn run(args: ServeArgs) -> Result<ExitCode, String> {
    let source = match args.source.as_str() {
        "replay" => SourceSpec::Replay,
        "gen" => SourceSpec::Gen { seed: args.seed },
        "camera" => SourceSpec::Camera {
            device: "/dev/video0".into(),
        },
        other => match other.strip_prefix("camera:") {
            Some(device) if !device.is_empty() => SourceSpec::Camera { device: device.into() },
            _ => return Err(format!("--source {other}: expected replay, gen or camera[:DEVICE]")),
        },
    };
    let stop_after = args
        .stop_after
        .map(|s| {
            if s.is_finite() && s > 0.0 {
                Ok(Duration::from_secs_f64(s))
            } else {
                Err(format!("--stop-after {s}: must be a positive number of seconds"))
            }
        })
        .transpose()?;
    crate::serve::run(ServeOptions {
        set: args.set,
        params: args.params,
        source,
        fps: args.fps,
        trigger: args.trigger,
        http: args.http,
        robot: args.robot,
        listen: args.listen,
        require_token: args.require_token,
        record: args.record,
        calibration: args.calibration,
        stop_after,
    })?;
    Ok(ExitCode::SUCCESS)
}
