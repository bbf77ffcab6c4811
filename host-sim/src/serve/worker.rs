//! The worker of `vorl serve`: the one thread that owns the engine. It takes frames from the
//! source (at `--fps`, or when a trigger waits), runs them through the engine `vorl detect`
//! builds, publishes each result, answers the triggers waiting for it, applies the page's
//! commands to the frame on screen, and records.

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use image::GrayImage;

use super::record::Recorder;
use super::source::{Captured, FrameSource, Generated, Replay};
use super::{Command, Published, Reply, ServeError, ServeOptions, Shared, SourceSpec};
use crate::cli::calibrate::Calibration;
use crate::cli::detect::build_engine;
use crate::config::Config;
use crate::engine::{frame_notes, Engine, NamedSilhouette};
use crate::set::FixtureSet;

/// The worker and everything it owns.
pub struct Worker {
    shared: Arc<Shared>,
    source: Box<dyn FrameSource>,
    set: PathBuf,
    /// The set's templates copied here; teaching writes here, saving copies back.
    work: WorkDir,
    /// Template files (relative) as copied from the set: those gone from `work` at save time
    /// were moved by teaching (a class's first example into its folder).
    copied: Vec<PathBuf>,
    backgrounds: Vec<GrayImage>,
    background_file: Option<PathBuf>,
    templates: Vec<NamedSilhouette>,
    config: Config,
    engine: Engine,
    calibration: Option<Calibration>,
    recorder: Option<Recorder>,
    period: Duration,
    stop_after: Option<Duration>,
    /// The frame on screen.
    current: Option<(String, Arc<GrayImage>)>,
    seq: u64,
    version: u64,
    last_capture: Option<Instant>,
    fps: f64,
}

impl Worker {
    /// Opens the set (writing the generator's set there first for `--source gen` when it has
    /// no templates), builds the engine and the source, and starts the recording.
    ///
    /// # Errors
    /// The set, its templates, background, parameters or calibration; the recording folder.
    pub fn new(opts: &ServeOptions, shared: Arc<Shared>) -> Result<Self, String> {
        if let SourceSpec::Gen { seed } = opts.source {
            if !opts.set.join("templates").is_dir() {
                crate::gen::generate(&opts.set, &super::source::gen_options(seed)).map_err(|e| e.to_string())?;
                println!("wrote the generator's set (seed {seed}) to {}", opts.set.display());
            }
        }
        let set = FixtureSet::open(&opts.set).map_err(|e| e.to_string())?;
        let base = set.config().map_err(|e| e.to_string())?;
        let config = opts.params.config_over(base.as_deref())?;
        let backgrounds = set.load_backgrounds().map_err(|e| e.to_string())?;
        let work =
            WorkDir(std::env::temp_dir().join(format!("vorl-serve-{}-{}", std::process::id(), super::new_token())));
        let copied = copy_tree(&set.templates, &work.join("templates"))?;
        let templates = crate::engine::load_silhouettes(&work.join("templates")).map_err(|e| e.to_string())?;
        for t in &templates {
            if let Some(n) = &t.note {
                eprintln!("note: {n}");
            }
        }
        let (engine, notes) = build_engine(&config, &backgrounds, &templates)?;
        for n in notes {
            eprintln!("note: {n}");
        }
        let cal_file = opts
            .calibration
            .clone()
            .or_else(|| Some(opts.set.join("cal.json")).filter(|p| p.is_file()));
        let calibration = cal_file.as_deref().map(Calibration::load).transpose()?;
        let source: Box<dyn FrameSource> = match opts.source {
            SourceSpec::Replay => Box::new(Replay::new(set.frames.clone(), &opts.set)?),
            SourceSpec::Gen { seed } => Box::new(Generated::new(seed)?),
            SourceSpec::Camera { ref device } => camera(device)?,
        };
        let recorder = opts
            .record
            .as_deref()
            .map(|dir| Recorder::start(dir, &opts.set))
            .transpose()?;
        Ok(Worker {
            shared,
            source,
            set: opts.set.clone(),
            work,
            copied,
            backgrounds,
            background_file: set.background.clone(),
            templates,
            config,
            engine,
            calibration,
            recorder,
            // --fps 0: no pause between frames.
            period: if opts.fps > 0.0 {
                Duration::from_secs_f64(1.0 / opts.fps)
            } else {
                Duration::ZERO
            },
            stop_after: opts.stop_after,
            current: None,
            seq: 0,
            version: 0,
            last_capture: None,
            fps: 0.0,
        })
    }

    /// What the worker serves, in one line.
    pub fn describe(&self) -> String {
        let pace = if self.shared.trigger_mode() {
            "a frame per trigger".to_string()
        } else if self.period.is_zero() {
            "as fast as the frames are processed".to_string()
        } else {
            format!("{:.1} fps", 1.0 / self.period.as_secs_f64())
        };
        format!(
            "{}, {pace}, {} template(s){}",
            self.source.describe(),
            self.templates.len(),
            if self.calibration.is_some() {
                ", robot coordinates"
            } else {
                ""
            }
        )
    }

    /// Runs until a stop is asked for; then finishes the recording and tells the ports.
    ///
    /// # Errors
    /// The recording could not be finished.
    pub fn run(mut self) -> Result<(), String> {
        let started = Instant::now();
        let mut next = Instant::now();
        loop {
            let waiting = match self.wait(next, started) {
                Some(w) => w,
                None => break,
            };
            let now = Instant::now();
            next = (next + self.period).max(now);
            let captured = self.source.next_frame();
            let published = self.process(captured, true);
            for w in waiting {
                // A waiter that went away (the client disconnected) harms nobody.
                let _ = w.send(published.clone());
            }
        }
        // Triggers still waiting get "stopping" (their senders drop here).
        self.shared.lock().waiters.clear();
        let mut outcome = Ok(());
        if let Some(r) = self.recorder.take() {
            outcome = r.finish(
                &self.work.join("templates"),
                &self.config,
                self.background_file.as_deref(),
            );
            if let Err(e) = &outcome {
                eprintln!("error: {e}");
            }
        }
        self.shared.stopped.send_replace(true);
        outcome
    }

    /// Waits for the next frame's time (or a trigger), applying commands meanwhile; the
    /// triggers this frame answers, or `None` to stop.
    fn wait(&mut self, next: Instant, started: Instant) -> Option<Vec<tokio::sync::oneshot::Sender<Arc<Published>>>> {
        let mut st = self.shared.lock();
        loop {
            if self.stop_after.is_some_and(|d| started.elapsed() >= d) {
                st.stop = true;
            }
            if st.stop {
                return None;
            }
            if let Some((command, reply)) = st.commands.pop_front() {
                drop(st);
                let answer = self.apply(command);
                let _ = reply.send(answer);
                st = self.shared.lock();
                continue;
            }
            let now = Instant::now();
            if self.shared.trigger_mode() {
                if !st.waiters.is_empty() {
                    return Some(std::mem::take(&mut st.waiters));
                }
                st = self
                    .shared
                    .wake
                    .wait_timeout(st, Duration::from_millis(200))
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
            } else {
                if now >= next {
                    return Some(std::mem::take(&mut st.waiters));
                }
                st = self
                    .shared
                    .wake
                    .wait_timeout(st, next - now)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
            }
        }
    }

    /// Runs a captured frame (a new one when `fresh`, else the frame on screen again) and
    /// publishes it.
    fn process(&mut self, captured: Captured, fresh: bool) -> Arc<Published> {
        let t0 = Instant::now();
        if fresh {
            self.seq += 1;
            if let Some(prev) = self.last_capture.replace(t0) {
                let dt = t0.duration_since(prev).as_secs_f64().max(1e-6);
                self.fps = if self.fps == 0.0 {
                    1.0 / dt
                } else {
                    0.8 * self.fps + 0.2 / dt
                };
            }
        }
        self.version += 1;
        let mut notes: Vec<String> = captured.note.into_iter().collect();
        let outcome = captured.image.and_then(|image| {
            check_size(&self.engine, &image, &captured.name)?;
            let result = self
                .engine
                .detect(&image)
                .map_err(|e| format!("{}: {e}", captured.name))?;
            Ok((image, result))
        });
        let published = match outcome {
            Ok((image, result)) => {
                notes.extend(frame_notes(&result));
                let mut parts = crate::run::to_json(&result);
                if let Some(c) = &self.calibration {
                    c.apply_all(&mut parts);
                }
                if fresh {
                    if let Some(r) = self.recorder.as_mut() {
                        if let Err(e) = r.add(&image, &parts) {
                            eprintln!("error: {e}");
                        }
                    }
                }
                let image = Arc::new(image);
                let p = Published {
                    seq: self.seq,
                    version: self.version,
                    frame: captured.name.clone(),
                    parts,
                    core_ms: result.seconds * 1e3,
                    frame_ms: t0.elapsed().as_secs_f64() * 1e3,
                    fps: self.fps,
                    error: None,
                    notes,
                    drawn_from: Some((image.clone(), result)),
                    png: OnceLock::new(),
                    bmp: OnceLock::new(),
                    shapes: OnceLock::new(),
                };
                self.current = Some((captured.name, image));
                p
            }
            Err(e) => {
                eprintln!("error: {e}");
                Published {
                    seq: self.seq,
                    version: self.version,
                    frame: captured.name,
                    parts: Vec::new(),
                    core_ms: 0.0,
                    frame_ms: t0.elapsed().as_secs_f64() * 1e3,
                    fps: self.fps,
                    error: Some(e),
                    notes,
                    drawn_from: None,
                    png: OnceLock::new(),
                    bmp: OnceLock::new(),
                    shapes: OnceLock::new(),
                }
            }
        };
        let published = Arc::new(published);
        let mut st = self.shared.lock();
        st.previous = st.last.replace(published.clone());
        drop(st);
        published
    }

    /// The frame on screen run again (after a change), published under its sequence number.
    fn rerun(&mut self) {
        if let Some((name, image)) = self.current.clone() {
            self.process(
                Captured {
                    name,
                    image: Ok(Arc::unwrap_or_clone(image)),
                    note: None,
                },
                false,
            );
        }
    }

    /// Applies a command from the page.
    fn apply(&mut self, command: Command) -> Reply {
        match command {
            Command::Params => {
                let mut classes: Vec<&str> = self.templates.iter().map(|t| t.name.as_str()).collect();
                classes.dedup();
                Ok(serde_json::json!({
                    "config": self.config,
                    "classes": classes,
                    "calibrated": self.calibration.is_some(),
                    "token_needed": self.shared.needs_token(),
                }))
            }
            Command::SetParams(changes) => {
                let config = changed_config(&self.config, &changes)?;
                let (engine, _) =
                    build_engine(&config, &self.backgrounds, &self.templates).map_err(ServeError::BadRequest)?;
                self.engine = engine;
                self.config = config;
                self.rerun();
                Ok(serde_json::to_value(&self.config).map_err(|e| ServeError::Failed(e.to_string()))?)
            }
            Command::Teach { x, y, name, add } => self.teach(x, y, &name, add),
            Command::Save => self.save(),
            Command::Calibrate(points) => self.calibrate(&points),
        }
    }

    fn teach(&mut self, x: f64, y: f64, name: &str, add: bool) -> Reply {
        check_class_name(name)?;
        if !(x.is_finite() && y.is_finite()) {
            return Err(ServeError::BadRequest("x and y must be numbers".into()));
        }
        let Some((frame_name, image)) = self.current.clone() else {
            return Err(ServeError::NoFrame);
        };
        // `vorl teach` itself, on the frame on screen, into the working copy of the templates
        // with the parameters in force (its vorl.toml: a measured polarity is kept there).
        let frame = self.work.join("frame.png");
        image
            .save(&frame)
            .map_err(|e| ServeError::Failed(format!("{}: cannot write: {e}", frame.display())))?;
        let toml_path = self.work.join("vorl.toml");
        write_config(&toml_path, &self.config).map_err(ServeError::Failed)?;
        let args = crate::cli::teach::TeachArgs {
            background: self.background_file.clone(),
            frame,
            list: false,
            overlay: None,
            part: None,
            at: Some(format!("{x},{y}")),
            name: Some(name.to_string()),
            out: Some(self.work.join("templates")),
            force: false,
            add,
            params: crate::cli::params::ParamArgs {
                config: Some(toml_path.clone()),
                ..Default::default()
            },
        };
        crate::cli::teach::run(args).map_err(ServeError::BadRequest)?;
        let config = Config::load(&toml_path).map_err(ServeError::Failed)?;
        let templates = crate::engine::load_silhouettes(&self.work.join("templates"))
            .map_err(|e| ServeError::Failed(e.to_string()))?;
        let (engine, notes) = build_engine(&config, &self.backgrounds, &templates).map_err(ServeError::BadRequest)?;
        self.engine = engine;
        self.templates = templates;
        self.config = config;
        self.rerun();
        Ok(serde_json::json!({
            "taught": name,
            "frame": frame_name,
            "added": add,
            "templates": self.templates.len(),
            "polarity": self.config.polarity,
            "notes": notes,
        }))
    }

    fn save(&mut self) -> Reply {
        let from = self.work.join("templates");
        let to = self.set.join("templates");
        let now = copy_tree(&from, &to).map_err(ServeError::Failed)?;
        let mut removed = Vec::new();
        for rel in &self.copied {
            if !from.join(rel).exists() {
                let gone = to.join(rel);
                std::fs::remove_file(&gone)
                    .map_err(|e| ServeError::Failed(format!("{}: cannot remove: {e}", gone.display())))?;
                removed.push(rel.display().to_string());
            }
        }
        self.copied = now;
        let toml_path = self.set.join("vorl.toml");
        write_config(&toml_path, &self.config).map_err(ServeError::Failed)?;
        println!(
            "saved {} template file(s) and {} to {}",
            self.copied.len(),
            toml_path.display(),
            self.set.display()
        );
        Ok(serde_json::json!({
            "templates": self.copied.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "removed": removed,
            "config": toml_path.display().to_string(),
        }))
    }

    fn calibrate(&mut self, points: &[[f64; 4]]) -> Reply {
        if points.len() < 4 {
            return Err(ServeError::BadRequest(format!(
                "{} point(s): a homography needs 4 or more, spread out",
                points.len()
            )));
        }
        if points.iter().flatten().any(|v| !v.is_finite()) {
            return Err(ServeError::BadRequest("every coordinate must be a number".into()));
        }
        let csv = self.work.join("points.csv");
        let mut text = String::from("u,v,x,y\n");
        for p in points {
            text += &format!("{},{},{},{}\n", p[0], p[1], p[2], p[3]);
        }
        std::fs::write(&csv, text).map_err(|e| ServeError::Failed(format!("{}: cannot write: {e}", csv.display())))?;
        let out = self.set.join("cal.json");
        crate::cli::calibrate::run(crate::cli::calibrate::CalibrateArgs {
            points: csv,
            out: out.clone(),
        })
        .map_err(ServeError::BadRequest)?;
        self.calibration = Some(Calibration::load(&out).map_err(ServeError::Failed)?);
        self.rerun();
        Ok(serde_json::json!({"calibration": out.display().to_string(), "points": points.len()}))
    }
}

#[cfg(feature = "camera")]
fn camera(device: &str) -> Result<Box<dyn FrameSource>, String> {
    Ok(Box::new(super::source::Camera::open(device)?))
}

#[cfg(not(feature = "camera"))]
fn camera(device: &str) -> Result<Box<dyn FrameSource>, String> {
    Err(format!(
        "--source camera:{device}: this vorl was built without cameras (cargo build --release --features camera)"
    ))
}

/// The worker's scratch folder, removed when the worker ends (or fails to start).
struct WorkDir(PathBuf);

impl std::ops::Deref for WorkDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for WorkDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A frame of another size than the empty shot's is refused, naming it (as `vorl detect`).
fn check_size(engine: &Engine, image: &GrayImage, name: &str) -> Result<(), String> {
    if let Some(bg) = engine.background().filter(|_| !engine.auto_background()) {
        let (w, h) = (image.width() as usize, image.height() as usize);
        if (w, h) != (bg.width(), bg.height()) {
            return Err(format!(
                "{name}: frame is {w}×{h} but the background is {}×{}",
                bg.width(),
                bg.height()
            ));
        }
    }
    Ok(())
}

/// A class name from the page: it becomes a file name inside the set's `templates/`, so it
/// may hold only letters, digits, `_`, `-` and `.` (not first), 1–64 of them.
///
/// # Errors
/// Anything else ([`ServeError::BadRequest`]).
pub fn check_class_name(name: &str) -> Result<(), ServeError> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(ServeError::BadRequest(format!(
            "class name {name:?}: 1-64 letters, digits, '_', '-' or '.' (not first)"
        )))
    }
}

/// `config` with `changes` (keys of `vorl config --defaults`) on top, checked as the engine
/// checks it.
///
/// # Errors
/// An unknown key, a value of the wrong type, or parameters the core refuses.
pub fn changed_config(
    config: &Config,
    changes: &serde_json::Map<String, serde_json::Value>,
) -> Result<Config, ServeError> {
    let bad = |m: String| ServeError::BadRequest(m);
    let mut table = toml::Table::try_from(config).map_err(|e| ServeError::Failed(e.to_string()))?;
    for (key, value) in changes {
        let old = table
            .get(key)
            .ok_or_else(|| bad(format!("unknown parameter {key:?} (see vorl config --defaults)")))?;
        let new = match (old, value) {
            (toml::Value::Float(_), serde_json::Value::Number(n)) => n.as_f64().map(toml::Value::Float),
            (_, serde_json::Value::Number(n)) => match n.as_i64() {
                Some(i) => Some(toml::Value::Integer(i)),
                None => n.as_f64().map(toml::Value::Float),
            },
            (_, serde_json::Value::String(s)) => Some(toml::Value::String(s.clone())),
            (_, serde_json::Value::Bool(b)) => Some(toml::Value::Boolean(*b)),
            _ => None,
        }
        .ok_or_else(|| bad(format!("{key}: {value} is not a value of this parameter")))?;
        table.insert(key.clone(), new);
    }
    let config: Config = table
        .try_into()
        .map_err(|e: toml::de::Error| bad(format!("not a valid value: {}", e.message())))?;
    config.to_params().map_err(bad)?;
    Ok(config)
}

/// Writes a whole config as `vorl.toml`.
pub(super) fn write_config(path: &Path, config: &Config) -> Result<(), String> {
    let body = toml::to_string(config).map_err(|e| e.to_string())?;
    let text = format!("# Parameters for this set (keys of `vorl config --defaults`), saved by `vorl serve`.\n{body}");
    std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

/// Copies the files under `from` into `to` (folders created, files replaced); the relative
/// paths copied.
pub(super) fn copy_tree(from: &Path, to: &Path) -> Result<Vec<PathBuf>, String> {
    let mut copied = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        let dir = from.join(&rel);
        let target = to.join(&rel);
        std::fs::create_dir_all(&target).map_err(|e| format!("{}: cannot create folder: {e}", target.display()))?;
        let entries =
            std::fs::read_dir(&dir).map_err(|e| format!("{}: {}", dir.display(), crate::io::io_problem(&e)))?;
        for entry in entries.flatten() {
            let r = rel.join(entry.file_name());
            let kind = entry.file_type().map_err(|e| e.to_string())?;
            if kind.is_dir() {
                stack.push(r);
            } else if kind.is_file() {
                std::fs::copy(from.join(&r), to.join(&r))
                    .map_err(|e| format!("{}: cannot copy: {e}", from.join(&r).display()))?;
                copied.push(r);
            }
        }
    }
    copied.sort();
    Ok(copied)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_names_stay_inside_the_templates_folder() {
        for good in ["bracket", "rod_a", "nut-M6", "v1.2"] {
            assert!(check_class_name(good).is_ok(), "{good}");
        }
        for bad in [
            "",
            "..",
            "../x",
            "a/b",
            "a\\b",
            ".hidden",
            "with space",
            "ü",
            &"x".repeat(65),
        ] {
            assert!(check_class_name(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn parameter_changes_are_checked() {
        let c = Config::default();
        let mut m = serde_json::Map::new();
        m.insert("epsilon".into(), serde_json::json!(0.2));
        m.insert("touching_parts".into(), serde_json::json!(true));
        let d = changed_config(&c, &m).expect("valid change");
        assert_eq!(d.epsilon, 0.2);
        assert!(d.touching_parts);
        // A float parameter given as an integer is still a float.
        let mut m = serde_json::Map::new();
        m.insert("scale_max".into(), serde_json::json!(2));
        assert_eq!(changed_config(&c, &m).expect("integer for a float").scale_max, 2.0);
        for (k, v) in [
            ("no_such_key", serde_json::json!(1)),
            ("epsilon", serde_json::json!("high")),
            ("polarity", serde_json::json!("sideways")),
            ("epsilon", serde_json::json!(null)),
            ("alpha", serde_json::json!(7.0)),
        ] {
            let mut m = serde_json::Map::new();
            m.insert(k.into(), v.clone());
            assert!(
                matches!(changed_config(&c, &m), Err(ServeError::BadRequest(_))),
                "{k} = {v}"
            );
        }
    }
}
