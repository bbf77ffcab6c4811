//! `import vorl`: the engine the `vorl` program runs ([`vorl_host_sim::engine::Engine`]), over
//! NumPy arrays, for integrators' scripts, notebooks and OpenCV camera loops.
//!
//! The Python package `vorl` (in `vorl/`) re-exports this module, `vorl._vorl`:
//!
//! - [`Recognizer`]: templates, parameters and a platform model; `detect(frame)` gives each part
//!   as a dict with the keys of `vorl detect --json` ([`vorl_host_sim::run::to_json`]).
//! - [`teach`]: the silhouette `vorl teach` would save ([`vorl_host_sim::cli::teach::take_part`]).
//! - [`config_defaults`], [`imread`].
//!
//! Frames are read in place when their layout allows (row-major, no padding: a plain `cv2` or
//! NumPy image, a row slice of one); other strides are copied once. `detect` releases the GIL
//! while the engine runs. Every error is a `vorl.VorlError` (a `ValueError`) with the command
//! line's one-line message; a panic inside the engine would be caught and raised as one too,
//! never unwinding into Python.

#![forbid(unsafe_code)]
#![deny(missing_docs)]

use std::borrow::Cow;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};

use image::GrayImage;
use numpy::{
    PyArray1, PyArray2, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyUserWarning, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use vorl_host_sim::cli::detect::build_engine;
use vorl_host_sim::cli::teach::{segment, take_part, PartChoice};
use vorl_host_sim::config::Config;
use vorl_host_sim::engine::{frame_notes, load_silhouettes, Engine, NamedSilhouette};
use vorl_host_sim::io::{load_gray, MAX_PIXELS, MAX_SIDE};
use vorl_host_sim::set::{load_background_frames, FixtureSet};
use vorl_host_sim::truth::PartJson;

pyo3::create_exception!(
    vorl,
    VorlError,
    PyValueError,
    "An input vorl cannot use: a missing or unreadable file, an array of the wrong type or \
     shape, invalid parameters. The message is the `vorl` program's one-line message."
);

pyo3::create_exception!(
    vorl,
    VorlWarning,
    PyUserWarning,
    "What a frame held that the engine could not take (the `note:` lines of `vorl detect`), \
     and the warnings of `vorl teach`."
);

/// A `VorlError` carrying `message`.
fn err(message: impl Into<String>) -> PyErr {
    VorlError::new_err(message.into())
}

/// Runs `f`, turning a panic into an error (none is expected: the engine is written not to
/// panic on any input; this keeps one from unwinding into Python all the same).
fn guarded<T>(f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(format!("internal error in vorl (please report it): {what}"))
    })
}

/// Issues each line as a `VorlWarning` (at the caller's line).
fn warn_all(py: Python<'_>, lines: &[String]) -> PyResult<()> {
    let category = py.get_type::<VorlWarning>();
    for line in lines {
        let text = std::ffi::CString::new(line.replace('\0', " ")).unwrap_or_default();
        PyErr::warn(py, &category, &text, 1)?;
    }
    Ok(())
}

/// A frame's pixels: the caller's array itself when it is row-major without padding, else a
/// copy in row order.
struct Pixels<'a> {
    data: Cow<'a, [u8]>,
    width: usize,
    height: usize,
}

/// Checks that `obj` is a 2-D 8-bit gray image (`H×W`, or `H×W×1`) and borrows it read-only.
/// `what` names it in messages ("frame", "background", "silhouette"); `allow_bool` also takes a
/// `bool` mask (a silhouette: `True` is part).
fn gray_array<'py>(obj: &Bound<'py, PyAny>, what: &str, allow_bool: bool) -> PyResult<GrayArray<'py>> {
    let py = obj.py();
    let Ok(arr) = obj.cast::<PyUntypedArray>() else {
        let kind = obj.get_type().name().map(|n| n.to_string()).unwrap_or_default();
        return Err(PyTypeError::new_err(format!(
            "{what}: expected a NumPy array (2-D uint8, height × width), got {kind}"
        )));
    };
    let shape = arr.shape().to_vec();
    let (height, width) = match shape.as_slice() {
        [h, w] | [h, w, 1] => (*h, *w),
        [h, w, c @ (3 | 4)] => {
            return Err(err(format!(
                "{what}: a {c}-channel image ({h}×{w}×{c}); vorl takes 8-bit gray: convert it first, \
                 e.g. cv2.cvtColor({what}, cv2.COLOR_BGR2GRAY)"
            )))
        }
        other => {
            let dims: Vec<String> = other.iter().map(|d| d.to_string()).collect();
            return Err(err(format!(
                "{what}: shape ({}) is not an image; expected 2-D (height, width) 8-bit gray",
                dims.join(", ")
            )));
        }
    };
    if width == 0 || height == 0 {
        return Err(err(format!("{what}: empty image ({width}×{height} px)")));
    }
    if width as u64 > u64::from(MAX_SIDE) || height as u64 > u64::from(MAX_SIDE) || (width * height) as u64 > MAX_PIXELS
    {
        return Err(err(format!(
            "{what}: image is {width}×{height} px; vorl reads images of at most {MAX_SIDE} px a side and \
             {MAX_PIXELS} pixels"
        )));
    }
    let dtype = arr.dtype();
    if dtype.is_equiv_to(&numpy::dtype::<u8>(py)) {
        let typed = arr.cast::<PyArrayDyn<u8>>()?;
        let ro = typed
            .try_readonly()
            .map_err(|e| err(format!("{what}: the array cannot be read: {e}")))?;
        Ok(GrayArray::U8 { ro, width, height })
    } else if allow_bool && dtype.is_equiv_to(&numpy::dtype::<bool>(py)) {
        let typed = arr.cast::<PyArrayDyn<bool>>()?;
        let ro = typed
            .try_readonly()
            .map_err(|e| err(format!("{what}: the array cannot be read: {e}")))?;
        let data = ro.as_array().iter().map(|&b| if b { 255 } else { 0 }).collect();
        Ok(GrayArray::Owned { data, width, height })
    } else {
        Err(err(format!(
            "{what}: dtype {dtype}, expected uint8 (8-bit gray); convert with {what}.astype(numpy.uint8) \
             after scaling to 0-255"
        )))
    }
}

/// A checked gray array, borrowed or converted.
enum GrayArray<'py> {
    /// A `uint8` array, borrowed read-only.
    U8 {
        /// The borrow.
        ro: numpy::PyReadonlyArrayDyn<'py, u8>,
        /// Width, px.
        width: usize,
        /// Height, px.
        height: usize,
    },
    /// A `bool` mask turned to 0/255.
    Owned {
        /// Row-major pixels.
        data: Vec<u8>,
        /// Width, px.
        width: usize,
        /// Height, px.
        height: usize,
    },
}

impl GrayArray<'_> {
    /// The pixels, in place when the layout allows.
    fn pixels(&self) -> Pixels<'_> {
        match self {
            GrayArray::U8 { ro, width, height } => {
                // `as_slice` also takes a column-major (Fortran) array, whose bytes are not
                // the rows: only a row-major one is read in place.
                let data = match ro.as_slice() {
                    Ok(s) if ro.is_c_contiguous() => Cow::Borrowed(s),
                    _ => Cow::Owned(copy_rows(ro.as_array())),
                };
                Pixels {
                    data,
                    width: *width,
                    height: *height,
                }
            }
            GrayArray::Owned { data, width, height } => Pixels {
                data: Cow::Borrowed(data),
                width: *width,
                height: *height,
            },
        }
    }

    /// An owned image of the pixels.
    fn to_image(&self, what: &str) -> PyResult<GrayImage> {
        let p = self.pixels();
        GrayImage::from_raw(p.width as u32, p.height as u32, p.data.into_owned())
            .ok_or_else(|| err(format!("{what}: pixels do not fill the image")))
    }
}

/// The pixels of a 2-D (or `H×W×1`) view in row order: row by row, each row one copy where its
/// pixels lie side by side (a window into a larger image, rows in reverse), else pixel by pixel
/// (a column-major array). An element-wise walk of the whole view costs about 20 times more.
fn copy_rows(view: numpy::ndarray::ArrayViewD<'_, u8>) -> Vec<u8> {
    use numpy::ndarray::{Axis, Ix2};
    let plane = if view.ndim() == 3 {
        view.clone().index_axis_move(Axis(2), 0)
    } else {
        view.clone()
    };
    match plane.into_dimensionality::<Ix2>() {
        Ok(rows) => {
            let mut out = Vec::with_capacity(rows.len());
            for row in rows.rows() {
                match row.as_slice() {
                    Some(s) => out.extend_from_slice(s),
                    None => out.extend(row.iter().copied()),
                }
            }
            out
        }
        Err(_) => view.iter().copied().collect(),
    }
}

/// A path from `str` or `os.PathLike`.
fn path_arg(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
        .map_err(|_| PyTypeError::new_err(format!("{what}: expected a path (str or os.PathLike)")))
}

/// A JSON value as Python objects (dicts, lists, floats, ints, str, bool, None).
fn to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        serde_json::Value::Null => py.None().into_bound(py),
        serde_json::Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        serde_json::Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => PyFloat::new(py, n.as_f64().unwrap_or(f64::NAN)).into_any(),
        },
        serde_json::Value::String(s) => PyString::new(py, s).into_any(),
        serde_json::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(to_py(py, item)?)?;
            }
            list.into_any()
        }
        serde_json::Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, item) in map {
                dict.set_item(key(py, k), to_py(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// A dict key: the keys [`vorl_host_sim::run::to_json`] writes beside the fixed fields as
/// strings made once per process (interned, their hash kept), any other made anew.
fn key<'py>(py: Python<'py>, k: &str) -> Bound<'py, PyString> {
    macro_rules! known {
        ($($name:literal),*) => {
            match k {
                $($name => intern!(py, $name).clone(),)*
                _ => PyString::new(py, k),
            }
        };
    }
    known!(
        "angle_paper_deg",
        "angle_dp_deg",
        "polygon_centroid",
        "verify_px",
        "scale",
        "verify_limit",
        "holes",
        "expected",
        "found",
        "best_class",
        "searches",
        "visible_fraction",
        "position"
    )
}

/// One part of `vorl detect --json` as a dict of the same keys and values (what
/// `json.loads` of the program's output gives), built directly: every field of
/// [`PartJson`] is named here, so a field added to it fails the build until it is converted.
fn part_dict(py: Python<'_>, part: PartJson) -> PyResult<Bound<'_, PyDict>> {
    let PartJson {
        class,
        x,
        y,
        angle_deg,
        symmetry,
        score,
        partial,
        flipped,
        touching,
        extra,
    } = part;
    let d = PyDict::new(py);
    d.set_item(intern!(py, "class"), class)?;
    d.set_item(intern!(py, "x"), x)?;
    d.set_item(intern!(py, "y"), y)?;
    d.set_item(intern!(py, "angle_deg"), angle_deg)?;
    // As serialised: each optional field only when present.
    if let Some(v) = symmetry {
        d.set_item(intern!(py, "symmetry"), v)?;
    }
    if let Some(v) = score {
        d.set_item(intern!(py, "score"), v)?;
    }
    if let Some(v) = partial {
        d.set_item(intern!(py, "partial"), v)?;
    }
    if let Some(v) = flipped {
        d.set_item(intern!(py, "flipped"), v)?;
    }
    if let Some(v) = touching {
        d.set_item(intern!(py, "touching"), v)?;
    }
    for (k, v) in &extra {
        d.set_item(key(py, k), to_py(py, v)?)?;
    }
    Ok(d)
}

/// A Python parameter value (a number, str or bool) as a TOML value.
fn toml_value(obj: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(toml::Value::Boolean(b.is_true()));
    }
    if obj.is_instance_of::<PyInt>() {
        if let Ok(i) = obj.extract::<i64>() {
            return Ok(toml::Value::Integer(i));
        }
    }
    if obj.is_instance_of::<PyFloat>() {
        if let Ok(f) = obj.extract::<f64>() {
            return Ok(toml::Value::Float(f));
        }
    }
    if let Ok(s) = obj.extract::<String>() {
        return Ok(toml::Value::String(s));
    }
    Err(err(format!(
        "parameter {key}: {} is not a parameter value (a number, a str or a bool)",
        obj.repr().map(|r| r.to_string()).unwrap_or_default()
    )))
}

/// A config's TOML value as Python objects (numbers, str, bool; `inf` stays a float).
fn toml_to_py<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        // The config's numbers are f32: each as its shortest decimal (0.08, not 0.0799999982).
        toml::Value::Float(f) => PyFloat::new(py, format!("{}", *f as f32).parse().unwrap_or(*f)).into_any(),
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(toml_to_py(py, item)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(t) => {
            let dict = PyDict::new(py);
            for (k, item) in t {
                dict.set_item(k, toml_to_py(py, item)?)?;
            }
            dict.into_any()
        }
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
    })
}

/// A config as a dict (the keys of `vorl config --defaults`).
fn config_dict<'py>(py: Python<'py>, c: &Config) -> PyResult<Bound<'py, PyAny>> {
    let table = toml::Table::try_from(c).map_err(|e| err(e.to_string()))?;
    toml_to_py(py, &toml::Value::Table(table))
}

/// `base` with the keys of `params` on top (the keys of `vorl config --defaults`).
fn overlay_params(base: Config, params: Option<&Bound<'_, PyDict>>) -> PyResult<Config> {
    let Some(params) = params.filter(|p| !p.is_empty()) else {
        return Ok(base);
    };
    // Through TOML, as a config file is read: the same names, values and messages.
    let mut table = toml::Table::try_from(&base).map_err(|e| err(e.to_string()))?;
    for (k, v) in params.iter() {
        let key: String = k
            .extract()
            .map_err(|_| PyTypeError::new_err("parameter names must be str"))?;
        let value = toml_value(&v, &key)?;
        table.insert(key, value);
    }
    table
        .try_into()
        .map_err(|e: toml::de::Error| err(format!("not a valid vorl config: {}", e.message())))
}

/// The config from `config` (a TOML file's path, a dict, or None) over `base`, then `params`.
fn resolve_config(
    base: Option<PathBuf>,
    config: Option<&Bound<'_, PyAny>>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Config> {
    let mut c = match &base {
        Some(b) => Config::load(b).map_err(err)?,
        None => Config::default(),
    };
    if let Some(config) = config.filter(|c| !c.is_none()) {
        if let Ok(d) = config.cast::<PyDict>() {
            c = overlay_params(c, Some(d))?;
        } else {
            let p = path_arg(config, "config")?;
            c = match &base {
                Some(_) => c.overlay(&p).map_err(err)?,
                None => Config::load(&p).map_err(err)?,
            };
        }
    }
    let c = overlay_params(c, params)?;
    c.to_params().map_err(err)?;
    Ok(c)
}

/// The empty shots from `background`: a path, an array, a list of either, `None` or `"auto"`
/// (no empty shot: the platform is estimated from the frames).
fn backgrounds(background: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<GrayImage>> {
    let Some(bg) = background.filter(|b| !b.is_none()) else {
        return Ok(Vec::new());
    };
    if let Ok(s) = bg.extract::<String>() {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Vec::new());
        }
    }
    let items: Vec<Bound<'_, PyAny>> = if bg.is_instance_of::<PyList>() || bg.is_instance_of::<PyTuple>() {
        bg.try_iter()?.collect::<PyResult<_>>()?
    } else {
        vec![bg.clone()]
    };
    let mut paths = Vec::new();
    let mut images = Vec::new();
    for item in &items {
        if item.cast::<PyUntypedArray>().is_ok() {
            images.push(gray_array(item, "background", false)?.to_image("background")?);
        } else {
            paths.push(path_arg(item, "background")?);
        }
    }
    let mut all = load_background_frames(&paths).map_err(|e| err(e.to_string()))?;
    all.extend(images);
    if let Some(first) = all.first() {
        if let Some(other) = all.iter().find(|i| i.dimensions() != first.dimensions()) {
            return Err(err(format!(
                "background is {}×{} but the first background is {}×{}",
                other.width(),
                other.height(),
                first.width(),
                first.height()
            )));
        }
    }
    Ok(all)
}

/// What a [`Recognizer`] holds behind its lock.
struct Inner {
    engine: Engine,
    config: Config,
    /// Every template taught, in order (to re-teach a class that gets another example).
    silhouettes: Vec<NamedSilhouette>,
    /// The empty shots (none: the platform is estimated from the frames).
    shots: Vec<GrayImage>,
}

impl Inner {
    /// The engine `vorl detect` builds from `config`, `shots` and `silhouettes`; returns the
    /// notes of its classes of several examples.
    fn build(
        config: Config,
        shots: Vec<GrayImage>,
        silhouettes: Vec<NamedSilhouette>,
    ) -> Result<(Self, Vec<String>), String> {
        guarded(move || {
            let (engine, notes) = build_engine(&config, &shots, &silhouettes)?;
            Ok((
                Inner {
                    engine,
                    config,
                    silhouettes,
                    shots,
                },
                notes,
            ))
        })
    }
}

/// Recognises taught parts in 8-bit gray frames: which part, where, how far turned.
///
/// `Recognizer(templates=None, config=None, background=None, **params)`; see the stubs
/// (`vorl/_vorl.pyi`) for every argument.
#[pyclass(module = "vorl", frozen)]
pub struct Recognizer {
    inner: Mutex<Inner>,
}

impl Recognizer {
    /// The lock (a poisoned one is taken over: the engine's state is replaced per frame).
    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn from_parts(py: Python<'_>, config: Config, shots: Vec<GrayImage>, templates: Option<PathBuf>) -> PyResult<Self> {
        let silhouettes = match templates {
            Some(dir) => load_silhouettes(&dir).map_err(|e| err(e.to_string()))?,
            None => Vec::new(),
        };
        let conversions: Vec<String> = silhouettes.iter().filter_map(|s| s.note.clone()).collect();
        let (inner, notes) = py.detach(|| Inner::build(config, shots, silhouettes)).map_err(err)?;
        warn_all(py, &conversions)?;
        let _ = notes; // the tolerance of each class of several examples: see `classes`
        Ok(Recognizer {
            inner: Mutex::new(inner),
        })
    }
}

#[pymethods]
impl Recognizer {
    /// A recognizer from a template folder, parameters and an empty shot.
    #[new]
    #[pyo3(signature = (templates=None, config=None, background=None, **params))]
    fn new(
        py: Python<'_>,
        templates: Option<&Bound<'_, PyAny>>,
        config: Option<&Bound<'_, PyAny>>,
        background: Option<&Bound<'_, PyAny>>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let config = resolve_config(None, config, params)?;
        let templates = templates
            .filter(|t| !t.is_none())
            .map(|t| path_arg(t, "templates"))
            .transpose()?;
        let shots = backgrounds(background)?;
        Self::from_parts(py, config, shots, templates)
    }

    /// A recognizer from a fixture set folder, as `vorl detect SET` builds it.
    #[staticmethod]
    #[pyo3(signature = (path, config=None, **params))]
    fn from_set(
        py: Python<'_>,
        path: &Bound<'_, PyAny>,
        config: Option<&Bound<'_, PyAny>>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let root = path_arg(path, "path")?;
        let set = FixtureSet::open(&root).map_err(|e| err(e.to_string()))?;
        let base = set.config().map_err(|e| err(e.to_string()))?;
        let config = resolve_config(base, config, params)?;
        let shots = set.load_backgrounds().map_err(|e| err(e.to_string()))?;
        Self::from_parts(py, config, shots, Some(set.templates))
    }

    /// The parts in one frame, each a dict with the keys of `vorl detect --json`.
    fn detect<'py>(&self, py: Python<'py>, frame: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyList>> {
        let arr = gray_array(frame, "frame", false)?;
        let pixels = arr.pixels();
        let (parts, notes) = py
            .detach(|| {
                guarded(|| {
                    let mut inner = self.lock();
                    let engine = &mut inner.engine;
                    if let Some(bg) = engine.background().filter(|_| !engine.auto_background()) {
                        if (pixels.width, pixels.height) != (bg.width(), bg.height()) {
                            return Err(format!(
                                "frame is {}×{} but the background is {}×{}",
                                pixels.width,
                                pixels.height,
                                bg.width(),
                                bg.height()
                            ));
                        }
                    }
                    let result = engine.detect_pixels(&pixels.data, pixels.width, pixels.height)?;
                    Ok((vorl_host_sim::run::to_json(&result), frame_notes(&result)))
                })
            })
            .map_err(err)?;
        warn_all(py, &notes)?;
        let list = PyList::empty(py);
        for p in parts {
            list.append(part_dict(py, p)?)?;
        }
        Ok(list)
    }

    /// Teaches one more template: `silhouette` (part > 127, or `True`) under the class `name`.
    fn add_template(&self, py: Python<'_>, name: &str, silhouette: &Bound<'_, PyAny>) -> PyResult<()> {
        if name.is_empty() {
            return Err(err("add_template: a class name must not be empty"));
        }
        let image = gray_array(silhouette, "silhouette", true)?.to_image("silhouette")?;
        let named = NamedSilhouette {
            name: name.to_string(),
            path: PathBuf::from(format!("<{name}>")),
            note: None,
            image,
        };
        py.detach(|| {
            guarded(|| {
                let mut inner = self.lock();
                if inner.engine.names().iter().any(|n| n == name) {
                    // Another example of a class: the class's tolerance is measured anew, as
                    // loading a folder of its examples does.
                    let mut all = inner.silhouettes.clone();
                    all.push(named);
                    let (fresh, _) = Inner::build(inner.config.clone(), inner.shots.clone(), all)?;
                    *inner = fresh;
                } else {
                    inner.engine.add_silhouette(name, &named.image)?;
                    inner.silhouettes.push(named);
                }
                Ok(())
            })
        })
        .map_err(err)
    }

    /// The class names taught, in order, each once.
    #[getter]
    fn classes(&self) -> Vec<String> {
        let inner = self.lock();
        let mut out: Vec<String> = Vec::new();
        for n in inner.engine.names() {
            if !out.contains(n) {
                out.push(n.clone());
            }
        }
        out
    }

    /// The parameters in use, as a dict (the keys of `vorl config --defaults`).
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let c = self.lock().config.clone();
        config_dict(py, &c)
    }

    /// Whether the platform is estimated from the frames (no empty shot).
    #[getter]
    fn auto_background(&self) -> bool {
        self.lock().engine.auto_background()
    }

    fn __repr__(&self) -> String {
        let classes = self.classes();
        let inner = self.lock();
        let platform = match inner.engine.background().filter(|_| !inner.engine.auto_background()) {
            Some(bg) => format!("empty shot {}×{}", bg.width(), bg.height()),
            None => "platform estimated from the frames".into(),
        };
        format!(
            "<vorl.Recognizer: {} template(s) of {:?}; {platform}>",
            inner.silhouettes.len(),
            classes
        )
    }
}

/// The silhouette `vorl teach` would save from the part of `frame` at `at` (or part number
/// `part`, or the largest), as a uint8 array (part 255, rest 0, a 10 px margin).
#[pyfunction]
#[pyo3(signature = (frame, at=None, part=None, background=None, config=None, return_info=false, **params))]
#[allow(clippy::too_many_arguments)]
fn teach<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    at: Option<(f64, f64)>,
    part: Option<usize>,
    background: Option<&Bound<'py, PyAny>>,
    config: Option<&Bound<'py, PyAny>>,
    return_info: bool,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let choice = match (at, part) {
        (Some(_), Some(_)) => return Err(err("teach: give at=(x, y) or part=N, not both")),
        (Some((x, y)), None) => PartChoice::At(format!("{x},{y}")),
        (None, Some(n)) => PartChoice::Number(n),
        (None, None) => PartChoice::Largest,
    };
    let params = resolve_config(None, config, params)?.to_params().map_err(err)?;
    let image = gray_array(frame, "frame", false)?.to_image("frame")?;
    let shots = backgrounds(background)?;
    let taken = py
        .detach(|| {
            guarded(|| {
                let shots = (!shots.is_empty()).then_some(shots);
                let segmented = segment(params, &image, shots, "frame")?;
                take_part(segmented, &image, &choice, "frame")
            })
        })
        .map_err(err)?;
    warn_all(py, &taken.warnings)?;
    let (w, h) = (taken.silhouette.width() as usize, taken.silhouette.height() as usize);
    let array =
        numpy::ndarray::Array2::from_shape_vec((h, w), taken.silhouette.into_raw()).map_err(|e| err(e.to_string()))?;
    let array = PyArray2::from_owned_array(py, array).into_any();
    if !return_info {
        return Ok(array);
    }
    let info = PyDict::new(py);
    let polarity = taken
        .evidence
        .as_ref()
        .map(|e| e.polarity)
        .unwrap_or(taken.params.polarity);
    let polarity = serde_json::to_value(vorl_host_sim::config::PolaritySetting::from_core(polarity))
        .map_err(|e| err(e.to_string()))?;
    info.set_item("polarity", to_py(py, &polarity)?)?;
    info.set_item("polarity_note", taken.evidence.as_ref().map(|e| e.describe()))?;
    info.set_item("area", taken.area)?;
    info.set_item("auto_background", taken.auto_background)?;
    info.set_item("warnings", taken.warnings)?;
    Ok(PyTuple::new(py, [array, info.into_any()])?.into_any())
}

/// Every parameter with its default, as a dict (what `vorl config --defaults` writes).
#[pyfunction]
fn config_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    config_dict(py, &Config::default())
}

/// An image file as a 2-D uint8 array, converted to 8-bit gray as the `vorl` program reads it.
#[pyfunction]
fn imread<'py>(py: Python<'py>, path: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let p = path_arg(path, "path")?;
    let loaded = py
        .detach(|| guarded(|| load_gray(&p).map_err(|e| e.to_string())))
        .map_err(err)?;
    if let Some(n) = &loaded.note {
        warn_all(py, &[format!("{}: {n}", p.display())])?;
    }
    let (w, h) = (loaded.image.width() as usize, loaded.image.height() as usize);
    let array =
        numpy::ndarray::Array2::from_shape_vec((h, w), loaded.image.into_raw()).map_err(|e| err(e.to_string()))?;
    Ok(PyArray2::from_owned_array(py, array).into_any())
}

/// Seconds the engine alone takes on `frame` inside Rust (`Engine::detect` on an owned image,
/// as `vorl detect` calls it on a frame just decoded): the reference of `python/bench.py`, not
/// part of the API. With `evict` (a large uint8 array), each of its bytes is incremented
/// between the copy and the call, as the benchmark does before a cold Python call, so that the
/// frame is no longer in the caches.
#[pyfunction]
#[pyo3(signature = (rec, frame, evict=None))]
fn _engine_seconds(
    py: Python<'_>,
    rec: &Recognizer,
    frame: &Bound<'_, PyAny>,
    evict: Option<&Bound<'_, PyArray1<u8>>>,
) -> PyResult<f64> {
    let image = gray_array(frame, "frame", false)?.to_image("frame")?;
    let mut scratch = evict
        .map(|e| e.try_readwrite())
        .transpose()
        .map_err(|e| err(format!("evict: {e}")))?;
    let mut scratch = scratch
        .as_mut()
        .map(|s| s.as_slice_mut())
        .transpose()
        .map_err(|e| err(format!("evict: {e}")))?;
    py.detach(|| {
        guarded(|| {
            let mut inner = rec.lock();
            if let Some(s) = scratch.as_mut() {
                for b in s.iter_mut() {
                    *b = b.wrapping_add(1);
                }
                std::hint::black_box(s);
            }
            let t0 = std::time::Instant::now();
            let result = inner.engine.detect(&image)?;
            let seconds = t0.elapsed().as_secs_f64();
            std::hint::black_box(result);
            Ok(seconds)
        })
    })
    .map_err(err)
}

/// The extension module `vorl._vorl`.
#[pymodule]
fn _vorl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("VorlError", py.get_type::<VorlError>())?;
    m.add("VorlWarning", py.get_type::<VorlWarning>())?;
    m.add_class::<Recognizer>()?;
    m.add_function(wrap_pyfunction!(teach, m)?)?;
    m.add_function(wrap_pyfunction!(config_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(imread, m)?)?;
    m.add_function(wrap_pyfunction!(_engine_seconds, m)?)?;
    Ok(())
}
