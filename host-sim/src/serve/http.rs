//! The page and its JSON API (axum).
//!
//! | route | what |
//! |---|---|
//! | `GET /` | the page (one file, no external assets) |
//! | `GET /api/last` | the last frame's result: `frames` in the shape of `vorl detect --json`, `timing` |
//! | `POST /api/trigger` | the next frame's result (starts it in trigger mode), as `/api/last` |
//! | `GET /api/frame.bmp?v=N` | the frame of publication N (while it is the last or the one before, else the last) as the page shows it: 8-bit gray BMP, uncompressed |
//! | `GET /api/overlay.json?v=N` | the shapes of that frame's overlay of `vorl detect --overlay`, which the page draws over the frame ([`super::picture::shapes_json`]) |
//! | `GET /api/overlay.png` | the last frame with the overlay of `vorl detect --overlay`, drawn and encoded on the server (the page does not use it) |
//! | `GET /api/params` | the parameters in force and the classes taught |
//! | `POST /api/params` | `{"key": value, …}`: parameters changed, the frame on screen run again |
//! | `POST /api/teach` | `{"x", "y", "name", "add"}`: the part at (x, y) taught |
//! | `POST /api/save` | templates and `vorl.toml` written to the set |
//! | `POST /api/calibrate` | `{"points": [[u, v, x, y], …]}`: the homography fitted and saved as the set's `cal.json` |
//!
//! The `POST` routes but `/api/trigger` change the set: off loopback they need the token
//! printed at start, as the header `X-Vorl-Token` or the query `?token=`. Errors are JSON
//! `{"error": "…"}` with a 4xx or 5xx status; nothing a request holds can panic the server.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde_json::{json, Value};

use super::{Command, Published, ServeError, Shared};

/// The page: HTML, CSS and script in one file.
pub const PAGE: &str = include_str!("page.html");

/// The page's routes over the shared state.
pub fn router(shared: Arc<Shared>) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/api/last", get(last))
        .route("/api/trigger", post(trigger))
        .route("/api/frame.bmp", get(frame_bmp))
        .route("/api/overlay.json", get(overlay_json))
        .route("/api/overlay.png", get(overlay))
        .route("/api/params", get(params).post(set_params))
        .route("/api/teach", post(teach))
        .route("/api/save", post(save))
        .route("/api/calibrate", post(calibrate))
        .fallback(not_found)
        .with_state(shared)
}

impl IntoResponse for ServeError {
    fn into_response(self) -> Response {
        let status = match &self {
            ServeError::NoFrame | ServeError::Stopping => StatusCode::SERVICE_UNAVAILABLE,
            ServeError::BadRequest(_) => StatusCode::BAD_REQUEST,
            ServeError::Forbidden => StatusCode::FORBIDDEN,
            ServeError::Failed(_) => StatusCode::INTERNAL_SERVER_ERROR,
        };
        (status, no_store(), Json(json!({"error": self.to_string()}))).into_response()
    }
}

fn no_store() -> [(header::HeaderName, &'static str); 1] {
    [(header::CACHE_CONTROL, "no-store")]
}

async fn page() -> Response {
    (no_store(), [(header::CONTENT_TYPE, "text/html; charset=utf-8")], PAGE).into_response()
}

async fn not_found() -> Response {
    (
        StatusCode::NOT_FOUND,
        no_store(),
        Json(json!({"error": "no such route (see the README's vorl serve section)"})),
    )
        .into_response()
}

/// A result as `/api/last` and `/api/trigger` give it.
pub fn result_json(p: &Published, trigger_mode: bool) -> Value {
    let mut frames = serde_json::Map::new();
    frames.insert(p.frame.clone(), json!(p.parts));
    json!({
        "frame": p.frame,
        "seq": p.seq,
        "version": p.version,
        "frames": frames,
        "timing": {"core_ms": p.core_ms, "frame_ms": p.frame_ms, "fps": p.fps},
        "error": p.error,
        "notes": p.notes,
        "trigger": trigger_mode,
    })
}

async fn last(State(shared): State<Arc<Shared>>) -> Result<Response, ServeError> {
    let p = shared.last()?;
    Ok((no_store(), Json(result_json(&p, shared.trigger_mode()))).into_response())
}

async fn trigger(State(shared): State<Arc<Shared>>) -> Result<Response, ServeError> {
    let p = shared.trigger()?.await.map_err(|_| ServeError::Stopping)?;
    Ok((no_store(), Json(result_json(&p, shared.trigger_mode()))).into_response())
}

/// The publication a request names by `?v=N`.
fn version_of(uri: &Uri) -> Option<u64> {
    uri.query()?
        .split('&')
        .find_map(|kv| kv.strip_prefix("v="))?
        .parse()
        .ok()
}

async fn frame_bmp(State(shared): State<Arc<Shared>>, uri: Uri) -> Result<Response, ServeError> {
    let p = shared.published(version_of(&uri))?;
    let bytes = p.frame_bmp().ok_or(ServeError::NoFrame)?;
    Ok((no_store(), [(header::CONTENT_TYPE, "image/bmp")], bytes).into_response())
}

async fn overlay_json(State(shared): State<Arc<Shared>>, uri: Uri) -> Result<Response, ServeError> {
    let p = shared.published(version_of(&uri))?;
    let bytes = p.overlay_json().ok_or(ServeError::NoFrame)?;
    Ok((no_store(), [(header::CONTENT_TYPE, "application/json")], bytes).into_response())
}

async fn overlay(State(shared): State<Arc<Shared>>) -> Result<Response, ServeError> {
    let p = shared.last()?;
    if p.drawn_from.is_none() {
        return Err(ServeError::NoFrame);
    }
    // Drawn and encoded here, off the worker, once per frame the page shows.
    let bytes = tokio::task::spawn_blocking(move || p.overlay_png().map(<[u8]>::to_vec))
        .await
        .map_err(|e| ServeError::Failed(e.to_string()))?
        .ok_or_else(|| ServeError::Failed("the overlay could not be encoded".into()))?;
    Ok((no_store(), [(header::CONTENT_TYPE, "image/png")], bytes).into_response())
}

/// The overlay as PNG (fast compression: a picture for the page, not for keeping); empty
/// when it cannot be encoded.
pub(super) fn encode_png(img: &image::RgbImage) -> Vec<u8> {
    use image::ImageEncoder as _;
    let mut out = Vec::new();
    let enc = image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    );
    match enc.write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgb8) {
        Ok(()) => out,
        Err(_) => Vec::new(),
    }
}

/// The token a request carries: the `X-Vorl-Token` header, or `token=` in the query.
fn token_of<'a>(headers: &'a HeaderMap, uri: &'a Uri) -> Option<&'a str> {
    headers
        .get("x-vorl-token")
        .and_then(|v| v.to_str().ok())
        .or_else(|| uri.query()?.split('&').find_map(|kv| kv.strip_prefix("token=")))
}

/// Hands a command to the worker (after the token check) and waits for its reply.
async fn run_command(
    shared: &Shared,
    headers: &HeaderMap,
    uri: &Uri,
    command: Command,
) -> Result<Response, ServeError> {
    if !shared.allows(token_of(headers, uri)) {
        return Err(ServeError::Forbidden);
    }
    let value = shared.command(command)?.await.map_err(|_| ServeError::Stopping)??;
    Ok((no_store(), Json(value)).into_response())
}

fn body_object(body: &Bytes) -> Result<serde_json::Map<String, Value>, ServeError> {
    match serde_json::from_slice::<Value>(body) {
        Ok(Value::Object(m)) => Ok(m),
        Ok(_) => Err(ServeError::BadRequest("the body must be a JSON object".into())),
        Err(e) => Err(ServeError::BadRequest(format!("the body is not JSON: {e}"))),
    }
}

async fn params(State(shared): State<Arc<Shared>>) -> Result<Response, ServeError> {
    let value = shared
        .command(Command::Params)?
        .await
        .map_err(|_| ServeError::Stopping)??;
    Ok((no_store(), Json(value)).into_response())
}

async fn set_params(
    State(shared): State<Arc<Shared>>,
    headers: HeaderMap,
    uri: Uri,
    body: Bytes,
) -> Result<Response, ServeError> {
    let changes = body_object(&body)?;
    run_command(&shared, &headers, &uri, Command::SetParams(changes)).await
}

async fn teach(
    State(shared): State<Arc<Shared>>,
    headers: HeaderMap,
    uri: Uri,
    body: Bytes,
) -> Result<Response, ServeError> {
    let m = body_object(&body)?;
    let num = |k: &str| {
        m.get(k)
            .and_then(Value::as_f64)
            .ok_or_else(|| ServeError::BadRequest(format!("\"{k}\" must be a number")))
    };
    let name = m
        .get("name")
        .and_then(Value::as_str)
        .ok_or_else(|| ServeError::BadRequest("\"name\" must be a string".into()))?
        .to_string();
    let add = m.get("add").and_then(Value::as_bool).unwrap_or(false);
    let command = Command::Teach {
        x: num("x")?,
        y: num("y")?,
        name,
        add,
    };
    run_command(&shared, &headers, &uri, command).await
}

async fn save(State(shared): State<Arc<Shared>>, headers: HeaderMap, uri: Uri) -> Result<Response, ServeError> {
    run_command(&shared, &headers, &uri, Command::Save).await
}

async fn calibrate(
    State(shared): State<Arc<Shared>>,
    headers: HeaderMap,
    uri: Uri,
    body: Bytes,
) -> Result<Response, ServeError> {
    let m = body_object(&body)?;
    let bad = || ServeError::BadRequest("\"points\" must be a list of [u, v, x, y]".into());
    let points = m
        .get("points")
        .and_then(Value::as_array)
        .ok_or_else(bad)?
        .iter()
        .map(|p| {
            let a = p.as_array().filter(|a| a.len() == 4).ok_or_else(bad)?;
            let mut out = [0.0; 4];
            for (o, v) in out.iter_mut().zip(a) {
                *o = v.as_f64().ok_or_else(bad)?;
            }
            Ok(out)
        })
        .collect::<Result<Vec<_>, ServeError>>()?;
    run_command(&shared, &headers, &uri, Command::Calibrate(points)).await
}
