//! `vorl serve`: the live cell. One process runs the engine of `vorl detect` over a stream of
//! frames and serves a local web page and a robot port.
//!
//! The data flow:
//!
//! ```text
//! source (replay | gen) ──▶ worker thread: Engine::detect, record ───────────▶ Shared::last
//!                                   ▲  commands (tune, teach, save, calibrate)     │
//!                                   │                                             ▼
//!                 page (axum, `http`) ◀──────────── /api/last, /api/frame.bmp, TRG/LAST (`robot`)
//! ```
//!
//! Nobody draws pixels for the page: for each frame it shows, the page fetches the frame as it
//! is (`/api/frame.bmp`, 8-bit gray, uncompressed: a header and the rows copied) and the shapes
//! of `vorl detect --overlay` (`/api/overlay.json`), which it draws in the browser as an SVG
//! layer. Both are made once per frame shown, on the HTTP threads, so that the page adds next
//! to nothing to a frame. `/api/overlay.png` still draws and encodes the overlay's picture,
//! for whoever asks for it (the page does not).
//!
//! - [`source`]: where frames come from (the set's frames in name order, looping; or scenes
//!   drawn live by the generator).
//! - [`worker`]: the one thread that owns the [`crate::engine::Engine`]: it paces the frames
//!   (`--fps`, or a robot's trigger), publishes each result, answers the triggers waiting for
//!   it, applies the page's commands to the frame on screen, and records.
//! - [`robot`]: the robot port's line protocol (`TRG`, `LAST`, `PING`) over TCP.
//! - [`http`]: the page and its JSON API.
//! - [`picture`]: what the page shows of a frame: the gray BMP and the overlay's shapes.
//! - [`record`]: `--record DIR`, a fixture set of every frame and its result.
//!
//! Threads: the worker is a plain thread (detection is CPU work); the two ports run on a small
//! tokio runtime. They meet in [`Shared`], a mutex and a condition variable; no lock is held
//! across an await or a detection.

pub mod http;
pub mod picture;
pub mod record;
pub mod robot;
pub mod source;
pub mod worker;

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};
use std::time::Duration;

use axum::body::Bytes;
use tokio::sync::{oneshot, watch};

use crate::cli::params::ParamArgs;
use crate::truth::PartJson;

/// Where `vorl serve` takes its frames from.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    /// The set's `frames/*.png` in name order, looping.
    Replay,
    /// Scenes drawn live by the generator (`vorl gen`) with this seed.
    Gen {
        /// The generator's seed.
        seed: u64,
    },
    /// A V4L2/UVC camera (`/dev/video0`, …; needs the `camera` feature).
    Camera {
        /// The device.
        device: String,
    },
}

/// Everything `vorl serve` is asked to do.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// The fixture set: its templates, background, `vorl.toml` (and frames, in replay).
    pub set: PathBuf,
    /// Parameter flags over the set's `vorl.toml`.
    pub params: ParamArgs,
    /// Where frames come from.
    pub source: SourceSpec,
    /// Frames per second when running free; 0: as fast as the frames are processed.
    pub fps: f64,
    /// Wait for a robot's (or the API's) trigger before each frame instead of running free.
    pub trigger: bool,
    /// The page's address.
    pub http: SocketAddr,
    /// The robot port's address.
    pub robot: SocketAddr,
    /// Whether an address off loopback is allowed.
    pub listen: bool,
    /// Ask for the token on loopback too (a machine several people use).
    pub require_token: bool,
    /// Write every frame and its result as a fixture set here.
    pub record: Option<PathBuf>,
    /// A camera-to-robot calibration (`vorl calibrate`); the set's `cal.json` when absent and
    /// present.
    pub calibration: Option<PathBuf>,
    /// Stop by itself after this long (tests, demos).
    pub stop_after: Option<Duration>,
}

/// One processed frame, as the page and the robot see it.
#[derive(Debug)]
pub struct Published {
    /// The frame's sequence number since start (1, 2, …); a re-run of the same frame after a
    /// change of parameters or templates keeps it.
    pub seq: u64,
    /// Increases at every publication, re-runs included (the page reloads its picture on it).
    pub version: u64,
    /// The frame's name: its file name in replay, a sequence name from the generator.
    pub frame: String,
    /// The parts in the shape of `vorl detect --json` (with `"robot"` under a calibration).
    pub parts: Vec<PartJson>,
    /// Time in the core, ms.
    pub core_ms: f64,
    /// Time for the frame in the worker from the captured pixels on (detect, results,
    /// recording; not reading or waiting for the frame, nor the overlay, drawn when the page
    /// asks for it), ms.
    pub frame_ms: f64,
    /// Frames per second over the last frames.
    pub fps: f64,
    /// Why the frame gave no result (unreadable, of the wrong size, …).
    pub error: Option<String>,
    /// Notes on the frame (what the core could not take).
    pub notes: Vec<String>,
    /// The frame and its result (none for a frame that gave no result), from which the overlay
    /// of `vorl detect --overlay` is drawn when the page first asks for it: at the page's rate,
    /// not at every frame.
    pub drawn_from: Option<(Arc<image::GrayImage>, crate::engine::FrameResult)>,
    /// The overlay as PNG, drawn and encoded on first request.
    pub png: OnceLock<Vec<u8>>,
    /// The frame as a gray BMP, made on first request.
    pub bmp: OnceLock<Bytes>,
    /// The overlay's shapes as JSON, made on first request.
    pub shapes: OnceLock<Bytes>,
}

impl Published {
    /// The frame with the overlay of `vorl detect --overlay`, as PNG: drawn and encoded on the
    /// first call, kept for the next ones; `None` for a frame that gave no result or a picture
    /// that could not be encoded.
    pub fn overlay_png(&self) -> Option<&[u8]> {
        let (frame, result) = self.drawn_from.as_ref()?;
        let png = self
            .png
            .get_or_init(|| http::encode_png(&crate::overlay::draw(frame, result)));
        (!png.is_empty()).then_some(png.as_slice())
    }

    /// The frame as the page shows it: 8-bit gray BMP, made on the first call and kept;
    /// `None` for a frame that gave no result.
    pub fn frame_bmp(&self) -> Option<Bytes> {
        let (frame, _) = self.drawn_from.as_ref()?;
        Some(self.bmp.get_or_init(|| picture::gray_bmp(frame).into()).clone())
    }

    /// The shapes of the overlay of `vorl detect --overlay`, as JSON for the page to draw
    /// ([`picture::shapes_json`]): made on the first call and kept; `None` for a frame that
    /// gave no result.
    pub fn overlay_json(&self) -> Option<Bytes> {
        let (frame, result) = self.drawn_from.as_ref()?;
        Some(
            self.shapes
                .get_or_init(|| picture::shapes_json(self.version, &self.frame, frame, result).into())
                .clone(),
        )
    }
}

/// What went wrong with a request from the page or the robot.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum ServeError {
    /// No frame has been processed yet.
    NoFrame,
    /// The server is stopping.
    Stopping,
    /// The request is malformed or names something that does not exist.
    BadRequest(String),
    /// The action changes the set and the token is missing or wrong.
    Forbidden,
    /// The action was valid but failed (a file could not be written, …).
    Failed(String),
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::NoFrame => write!(f, "no frame yet"),
            ServeError::Stopping => write!(f, "stopping"),
            ServeError::BadRequest(m) | ServeError::Failed(m) => write!(f, "{m}"),
            ServeError::Forbidden => write!(f, "this action needs the token printed at start"),
        }
    }
}

impl std::error::Error for ServeError {}

/// A change the page asks of the worker.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// The parameters in force and the classes taught (changes nothing).
    Params,
    /// Parameters to change: keys of `vorl config --defaults` and their new values.
    SetParams(serde_json::Map<String, serde_json::Value>),
    /// Take the part at (x, y) of the frame on screen as a template of class `name` (another
    /// example of it with `add`).
    Teach {
        /// Pixel column.
        x: f64,
        /// Pixel row.
        y: f64,
        /// The class.
        name: String,
        /// Another example of an existing class.
        add: bool,
    },
    /// Write the templates and `vorl.toml` to the set.
    Save,
    /// Fit and save the homography from pixel–robot point pairs `[u, v, x, y]`.
    Calibrate(Vec<[f64; 4]>),
}

/// The reply to a [`Command`]: a JSON object for the page, or what went wrong.
pub type Reply = Result<serde_json::Value, ServeError>;

struct State {
    last: Option<Arc<Published>>,
    /// The one published before `last`: the page, having read `last`'s version, may ask for
    /// its picture just after the next frame came.
    previous: Option<Arc<Published>>,
    waiters: Vec<oneshot::Sender<Arc<Published>>>,
    commands: VecDeque<(Command, oneshot::Sender<Reply>)>,
    stop: bool,
}

/// What the worker and the two ports share.
pub struct Shared {
    state: Mutex<State>,
    wake: Condvar,
    stopped: watch::Sender<bool>,
    /// The token that actions changing the set need (`None` on loopback: no token needed).
    token: Option<String>,
    /// Whether the worker waits for triggers.
    trigger_mode: bool,
}

impl Shared {
    /// A fresh state: no frame yet, nothing waiting.
    pub fn new(token: Option<String>, trigger_mode: bool) -> Arc<Self> {
        Arc::new(Shared {
            state: Mutex::new(State {
                last: None,
                previous: None,
                waiters: Vec::new(),
                commands: VecDeque::new(),
                stop: false,
            }),
            wake: Condvar::new(),
            stopped: watch::channel(false).0,
            token,
            trigger_mode,
        })
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic elsewhere while holding the lock leaves the state consistent enough to serve.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The last frame's result.
    ///
    /// # Errors
    /// [`ServeError::NoFrame`] before the first frame.
    pub fn last(&self) -> Result<Arc<Published>, ServeError> {
        self.lock().last.clone().ok_or(ServeError::NoFrame)
    }

    /// The publication `version` while it is the last or the one before, else the last (the
    /// page asks for a frame's picture and shapes by the version it read).
    ///
    /// # Errors
    /// [`ServeError::NoFrame`] before the first frame.
    pub fn published(&self, version: Option<u64>) -> Result<Arc<Published>, ServeError> {
        let st = self.lock();
        let last = st.last.clone().ok_or(ServeError::NoFrame)?;
        Ok(match (version, &st.previous) {
            (Some(v), Some(p)) if last.version != v && p.version == v => p.clone(),
            _ => last,
        })
    }

    /// Asks for the next frame's result: the receiver gets the result of the first frame
    /// captured after this call (in trigger mode, the frame this call starts).
    ///
    /// # Errors
    /// [`ServeError::Stopping`] once a stop was asked for.
    pub fn trigger(&self) -> Result<oneshot::Receiver<Arc<Published>>, ServeError> {
        let mut st = self.lock();
        if st.stop {
            return Err(ServeError::Stopping);
        }
        let (tx, rx) = oneshot::channel();
        st.waiters.push(tx);
        drop(st);
        self.wake.notify_all();
        Ok(rx)
    }

    /// Hands a command to the worker; the receiver gets its reply.
    ///
    /// # Errors
    /// [`ServeError::Stopping`] once a stop was asked for.
    pub fn command(&self, command: Command) -> Result<oneshot::Receiver<Reply>, ServeError> {
        let mut st = self.lock();
        if st.stop {
            return Err(ServeError::Stopping);
        }
        let (tx, rx) = oneshot::channel();
        st.commands.push_back((command, tx));
        drop(st);
        self.wake.notify_all();
        Ok(rx)
    }

    /// Asks everything to stop: the worker finishes the frame in hand, flushes the recording
    /// and ends; then the ports close.
    pub fn request_stop(&self) {
        self.lock().stop = true;
        self.wake.notify_all();
    }

    /// Whether a stop was asked for.
    pub fn stop_requested(&self) -> bool {
        self.lock().stop
    }

    /// A receiver that turns `true` once the worker has ended.
    pub fn stopped(&self) -> watch::Receiver<bool> {
        self.stopped.subscribe()
    }

    /// Whether the worker waits for triggers.
    pub fn trigger_mode(&self) -> bool {
        self.trigger_mode
    }

    /// Whether `given` opens the actions that change the set.
    pub fn allows(&self, given: Option<&str>) -> bool {
        match &self.token {
            None => true,
            Some(t) => given.is_some_and(|g| constant_time_eq(g.as_bytes(), t.as_bytes())),
        }
    }

    /// Whether a token is needed.
    pub fn needs_token(&self) -> bool {
        self.token.is_some()
    }
}

fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A token of 128 random bits, in hex.
pub fn new_token() -> String {
    let bits: u128 = rand::random();
    format!("{bits:032x}")
}

/// Refuses an address off loopback unless `listen` allows it.
///
/// # Errors
/// The address is not a loopback one and `listen` is false.
pub fn check_address(what: &str, addr: SocketAddr, listen: bool) -> Result<(), String> {
    if addr.ip().is_loopback() || listen {
        Ok(())
    } else {
        Err(format!(
            "--{what} {addr} is not on loopback: add --listen to serve other machines (actions that change the set then need the token printed at start)"
        ))
    }
}

/// Runs `vorl serve` until Ctrl-C, SIGTERM or `stop_after`; prints the page's and the robot
/// port's addresses (and the token, when one is needed) on stdout first.
///
/// # Errors
/// Set-up problems: the set, its templates or background, parameters, an address that cannot
/// be bound or is off loopback without `--listen`.
pub fn run(opts: ServeOptions) -> Result<(), String> {
    check_address("http", opts.http, opts.listen)?;
    check_address("robot", opts.robot, opts.listen)?;
    if !(opts.fps == 0.0 || (opts.fps.is_finite() && opts.fps > 0.0 && opts.fps <= 1000.0)) {
        return Err(format!(
            "--fps {}: must lie in (0, 1000], or be 0 (as fast as the frames are processed)",
            opts.fps
        ));
    }
    let open_to_others = !(opts.http.ip().is_loopback() && opts.robot.ip().is_loopback());
    let token = (open_to_others || opts.require_token).then(new_token);
    let shared = Shared::new(token.clone(), opts.trigger);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the runtime: {e}"))?;
    // Ctrl-C and SIGTERM are caught from here on, before the set-up: one that comes while the
    // set is loaded, or right after "Ctrl-C stops" is printed, still stops cleanly (the
    // worker's scratch folder removed).
    let signals = {
        let _in_runtime = runtime.enter();
        StopSignals::catch()
    };
    let worker = worker::Worker::new(&opts, shared.clone())?;
    runtime.block_on(async move {
        let web = tokio::net::TcpListener::bind(opts.http)
            .await
            .map_err(|e| format!("--http {}: cannot listen: {e}", opts.http))?;
        let port = tokio::net::TcpListener::bind(opts.robot)
            .await
            .map_err(|e| format!("--robot {}: cannot listen: {e}", opts.robot))?;
        let web_addr = web.local_addr().map_err(|e| e.to_string())?;
        let robot_addr = port.local_addr().map_err(|e| e.to_string())?;
        println!("vorl serve {}: {}", opts.set.display(), worker.describe());
        println!("page       http://{web_addr}/");
        println!("robot port {robot_addr}");
        if let Some(t) = &token {
            println!("token      {t}   (open the page as http://{web_addr}/?token={t} to teach, tune and save)");
        }
        println!("Ctrl-C stops");
        use std::io::Write as _;
        let _ = std::io::stdout().flush();
        let thread = std::thread::Builder::new()
            .name("vorl-worker".into())
            .spawn(move || worker.run())
            .map_err(|e| format!("cannot start the worker: {e}"))?;
        let robot_task = tokio::spawn(robot::serve(port, shared.clone()));
        let mut stopped = shared.stopped();
        let app = http::router(shared.clone());
        let web_task = tokio::spawn(async move {
            let _ = axum::serve(web, app)
                .with_graceful_shutdown(async move {
                    let _ = stopped.wait_for(|s| *s).await;
                })
                .await;
        });
        wait_for_stop(&shared, opts.stop_after, signals).await;
        shared.request_stop();
        let mut stopped = shared.stopped();
        let _ = stopped.wait_for(|s| *s).await;
        let outcome = thread.join();
        let _ = robot_task.await;
        // Connections still open (a page's keep-alive) get a moment, then the runtime ends them.
        let _ = tokio::time::timeout(Duration::from_secs(2), web_task).await;
        match outcome {
            Ok(r) => r,
            Err(_) => Err("the worker thread panicked".into()),
        }
    })
}

/// Ctrl-C (SIGINT) and SIGTERM, caught from the moment this is made.
struct StopSignals {
    #[cfg(unix)]
    interrupt: Option<tokio::signal::unix::Signal>,
    #[cfg(unix)]
    terminate: Option<tokio::signal::unix::Signal>,
}

impl StopSignals {
    /// Starts catching the signals (within a tokio runtime).
    fn catch() -> Self {
        #[cfg(unix)]
        {
            use tokio::signal::unix::{signal, SignalKind};
            StopSignals {
                interrupt: signal(SignalKind::interrupt()).ok(),
                terminate: signal(SignalKind::terminate()).ok(),
            }
        }
        #[cfg(not(unix))]
        StopSignals {}
    }
}

/// Waits for Ctrl-C, SIGTERM, `stop_after`, or the worker's own end.
async fn wait_for_stop(shared: &Shared, stop_after: Option<Duration>, signals: StopSignals) {
    let mut stopped = shared.stopped();
    let timer = async {
        match stop_after {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    #[cfg(unix)]
    let (interrupt, term) = {
        let wait = |s: Option<tokio::signal::unix::Signal>| async move {
            match s {
                Some(mut s) => {
                    s.recv().await;
                }
                None => std::future::pending().await,
            }
        };
        (wait(signals.interrupt), wait(signals.terminate))
    };
    #[cfg(not(unix))]
    let (interrupt, term) = {
        let _ = signals;
        (
            async {
                let _ = tokio::signal::ctrl_c().await;
            },
            std::future::pending::<()>(),
        )
    };
    tokio::select! {
        _ = interrupt => eprintln!("stopping (Ctrl-C): finishing the frame in hand"),
        _ = term => eprintln!("stopping (SIGTERM): finishing the frame in hand"),
        _ = timer => eprintln!("stopping (--stop-after)"),
        _ = stopped.wait_for(|s| *s) => {}
    }
}
