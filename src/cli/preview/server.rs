//! The preview's HTTP server: a fixed set of routes and nothing else. No route maps a URL to a
//! file, so neither the scene's folder nor any file the scene references can be downloaded
//! through it: files reach the page only as the rendered image.
//!
//! - `GET /`: the page (embedded in the binary, no build step);
//! - `GET /events`: server-sent events, one `status` event (JSON) per change;
//! - `GET /status`: the same JSON, once;
//! - `GET /frame?kind=image|error|denoised`: the latest frame's radiance, per-pixel standard
//!   error, or radiance denoised by Open Image Denoise (computed on first request and cached
//!   per frame; `503` while OIDN is being looked for or when it is missing, `409` for the quick
//!   ray-cast frame), as little-endian `f32` RGB triples;
//! - `GET /frame?kind=pass&name=PASS`: a render pass of the latest frame (`albedo`, `normal`,
//!   `depth`, `position`, `uv`, `object_id`, `material_id`, `std_error`, as `lumo render --aov`
//!   names them), its channels interleaved per pixel: little-endian `f32`, ids as `u32`. `404`
//!   when the preview does not render that pass, `409` for the quick ray-cast frame (which has
//!   none), `400` for an unknown name.
//!
//! Every frame answer is row-major, top row first, and says in its headers what it holds:
//! `x-lumo-width` and `x-lumo-height` (the frame's size), `x-lumo-channels` (the channel names
//! in their order within a pixel: `R,G,B`, `X,Y,Z`, `Z`, `U,V`, `I`), `x-lumo-type` (`f32` or
//! `u32`), and `x-lumo-frame` (the frame's number, [`super::Status`]'s `frame`: several
//! answers belong to one frame when their numbers agree). A denoised answer also carries
//! `x-lumo-denoise-seconds`: how long the request waited for OIDN (about 0 when the frame's
//! denoised beauty was cached).
//! - `POST /save?tonemap=clamp|aces&exposure=STOPS`: writes the latest path-traced frame to the
//!   output path atomically, as `lumo render` would.

use std::convert::Infallible;
use std::net::IpAddr;
use std::sync::Arc;

use axum::extract::{Query, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use futures_util::Stream;
use lumo::aov::{Aov, PassImage, PassPixels};
use lumo::output::ToneMap;
use lumo::render::Image;
use lumo_schema::Keyword as _;
use serde::Deserialize;

use super::{Frame, NotDenoised, Shared};

/// The page, embedded.
const PAGE: &str = include_str!("page.html");

/// Serves until the listener fails.
pub(crate) async fn serve(
    listener: tokio::net::TcpListener,
    shared: Arc<Shared>,
) -> std::io::Result<()> {
    let bound = listener.local_addr()?;
    let app = Router::new()
        .route("/", get(|| async { Html(PAGE) }))
        .route("/events", get(events))
        .route("/status", get(status))
        .route("/frame", get(frame))
        .route("/save", post(save))
        .fallback(|| async { (StatusCode::NOT_FOUND, "not found\n") })
        .layer(axum::middleware::from_fn(move |req, next| {
            only_this_host(bound.ip(), req, next)
        }))
        .with_state(shared);
    axum::serve(listener, app).await
}

/// Refuses requests whose `Host` is not this server's own name (a web page elsewhere reaching
/// the preview through DNS rebinding), unless the server was bound to every interface.
async fn only_this_host(bound: IpAddr, req: Request, next: Next) -> Response {
    if !bound.is_unspecified() {
        let host = req
            .headers()
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        let name = match host.rsplit_once(':') {
            Some((n, port)) if port.bytes().all(|b| b.is_ascii_digit()) => n,
            _ => host,
        };
        let name = name.trim_start_matches('[').trim_end_matches(']');
        let ok = name.eq_ignore_ascii_case("localhost")
            || name
                .parse::<IpAddr>()
                .is_ok_and(|ip| ip == bound || ip.is_loopback());
        if !ok {
            return (
                StatusCode::FORBIDDEN,
                "lumo preview answers requests for this machine's own address only\n",
            )
                .into_response();
        }
    }
    next.run(req).await
}

async fn status(State(shared): State<Arc<Shared>>) -> Response {
    json(StatusCode::OK, shared.status_json())
}

fn json(code: StatusCode, body: String) -> Response {
    (
        code,
        [
            (header::CONTENT_TYPE, "application/json"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        body,
    )
        .into_response()
}

/// One `status` event now and one after every change (changes in between are coalesced: the
/// page needs the latest state, not every state).
async fn events(
    State(shared): State<Arc<Shared>>,
) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let mut rx = shared.changed.subscribe();
    rx.mark_changed();
    let stream = futures_util::stream::unfold((rx, shared), |(mut rx, shared)| async move {
        rx.changed().await.ok()?;
        let event = Event::default().event("status").data(shared.status_json());
        Some((Ok(event), (rx, shared)))
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

#[derive(Deserialize)]
struct FrameQuery {
    kind: Option<String>,
    name: Option<String>,
}

/// Why the quick frame has no passes and no denoised view.
const QUICK: &str = "the quick ray-cast frame has no render passes and no denoised view: they \
                     come with the first path-traced pass\n";

async fn frame(State(shared): State<Arc<Shared>>, Query(q): Query<FrameQuery>) -> Response {
    let Some(frame) = shared.frame() else {
        return (StatusCode::NOT_FOUND, "no frame yet\n").into_response();
    };
    match q.kind.as_deref() {
        None | Some("image") => rgb(&frame, &frame.image, None),
        Some("error") => rgb(&frame, &frame.std_error, None),
        Some("denoised") => denoised(shared, frame).await,
        Some("pass") => pass(&frame, q.name.as_deref()),
        Some(_) => (
            StatusCode::BAD_REQUEST,
            "kind is image, error, denoised, or pass (with name=PASS)\n",
        )
            .into_response(),
    }
}

/// The latest frame's beauty denoised, on a blocking thread (the render is not waited for).
async fn denoised(shared: Arc<Shared>, frame: Arc<Frame>) -> Response {
    let done = tokio::task::spawn_blocking(move || {
        let start = std::time::Instant::now();
        let cached = shared.denoised(&frame);
        (frame, cached, start.elapsed().as_secs_f64())
    })
    .await;
    let (frame, result, seconds) = match done {
        Ok(d) => d,
        Err(e) => {
            return (
                StatusCode::INTERNAL_SERVER_ERROR,
                format!("internal error (a bug in lumo, please report it): {e}\n"),
            )
                .into_response()
        }
    };
    match result {
        Ok(image) => rgb(&frame, &image, Some(seconds)),
        Err(NotDenoised::Quick) => (StatusCode::CONFLICT, QUICK).into_response(),
        Err(NotDenoised::Loading) => (
            StatusCode::SERVICE_UNAVAILABLE,
            "Open Image Denoise is still being looked for; ask again when the status says \
             `ready`\n",
        )
            .into_response(),
        Err(NotDenoised::Missing(why)) => {
            (StatusCode::SERVICE_UNAVAILABLE, format!("{why}\n")).into_response()
        }
        Err(NotDenoised::Failed(why)) => {
            (StatusCode::INTERNAL_SERVER_ERROR, format!("{why}\n")).into_response()
        }
    }
}

/// A render pass of the latest frame.
fn pass(frame: &Frame, name: Option<&str>) -> Response {
    let Some(name) = name else {
        return (
            StatusCode::BAD_REQUEST,
            "kind=pass needs name=PASS (albedo, normal, …)\n",
        )
            .into_response();
    };
    let Some(aov) = Aov::ALL.into_iter().find(|a| a.name() == name) else {
        let choices = Aov::ALL.map(Aov::name).join(", ");
        return (
            StatusCode::BAD_REQUEST,
            format!("unknown render pass (choose from {choices})\n"),
        )
            .into_response();
    };
    if aov == Aov::StdError {
        return rgb(frame, &frame.std_error, None);
    }
    if frame.quick {
        return (StatusCode::CONFLICT, QUICK).into_response();
    }
    let Some(p) = frame.pass(aov) else {
        return (
            StatusCode::NOT_FOUND,
            format!(
                "this preview renders no {name} pass: add it with --aov {name} (or to the \
                 scene's render.aov)\n"
            ),
        )
            .into_response();
    };
    let (bytes, kind) = match &p.pixels {
        PassPixels::Float(v) => (le_bytes(v.iter().map(|x| x.to_le_bytes())), "f32"),
        PassPixels::Id(v) => (le_bytes(v.iter().map(|x| x.to_le_bytes())), "u32"),
    };
    let (w, h) = (frame.image.width, frame.image.height);
    binary(frame, (w, h), &aov.channels().join(","), kind, bytes, None)
}

/// An RGB image of the frame's size as `f32` triples.
fn rgb(frame: &Frame, image: &Image, denoise_seconds: Option<f64>) -> Response {
    let bytes = le_bytes(
        image
            .pixels
            .iter()
            .flat_map(|p| p.to_array())
            .map(f32::to_le_bytes),
    );
    binary(
        frame,
        (image.width, image.height),
        "R,G,B",
        "f32",
        bytes,
        denoise_seconds,
    )
}

fn le_bytes(values: impl Iterator<Item = [u8; 4]>) -> Vec<u8> {
    values.flatten().collect()
}

/// A frame answer: the bytes and the headers that say what they hold.
fn binary(
    frame: &Frame,
    (width, height): (u32, u32),
    channels: &str,
    kind: &'static str,
    bytes: Vec<u8>,
    denoise_seconds: Option<f64>,
) -> Response {
    let mut headers = HeaderMap::new();
    headers.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/octet-stream"),
    );
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    headers.insert("x-lumo-width", HeaderValue::from(width));
    headers.insert("x-lumo-height", HeaderValue::from(height));
    if let Ok(v) = HeaderValue::from_str(channels) {
        headers.insert("x-lumo-channels", v);
    }
    headers.insert("x-lumo-type", HeaderValue::from_static(kind));
    headers.insert("x-lumo-frame", HeaderValue::from(frame.number));
    if let Some(s) = denoise_seconds {
        if let Ok(v) = HeaderValue::from_str(&format!("{s:.4}")) {
            headers.insert("x-lumo-denoise-seconds", v);
        }
    }
    (headers, bytes).into_response()
}

#[derive(Deserialize)]
struct SaveQuery {
    tonemap: Option<String>,
    exposure: Option<f32>,
}

/// Writes the latest path-traced frame to the output path (atomically, as `lumo render` does),
/// with its render passes as `lumo render` writes them: 8-bit formats get the page's exposure
/// and tone mapping, EXR and HDR stay linear.
async fn save(State(shared): State<Arc<Shared>>, Query(q): Query<SaveQuery>) -> Response {
    let tone = match q.tonemap.as_deref() {
        None => ToneMap::Clamp,
        Some(t) => match ToneMap::from_keyword(t) {
            Ok(t) => t,
            Err(e) => return json_error(StatusCode::BAD_REQUEST, &e.to_string()),
        },
    };
    let exposure = q.exposure.unwrap_or(0.0);
    if !exposure.is_finite() || exposure.abs() > 30.0 {
        return json_error(StatusCode::BAD_REQUEST, "exposure is in stops, within ±30");
    }
    let frame = match shared.frame() {
        Some(f) if !f.quick => f,
        _ => {
            return json_error(
                StatusCode::CONFLICT,
                "nothing path traced yet: wait for the first pass",
            )
        }
    };
    let output = shared.output().to_path_buf();
    let written = tokio::task::spawn_blocking(move || {
        let eight_bit = matches!(
            lumo::output::format_of(&output),
            Ok(image::ImageFormat::Png | image::ImageFormat::Bmp)
        );
        let scaled;
        let image = if eight_bit && exposure != 0.0 {
            let k = exposure.exp2();
            scaled = lumo::render::Image {
                width: frame.image.width,
                height: frame.image.height,
                pixels: frame.image.pixels.iter().map(|p| *p * k).collect(),
            };
            &scaled
        } else {
            &frame.image
        };
        // The passes `lumo render` writes with the same `--aov`: beside a PNG, in the EXR.
        let passes: Vec<PassImage> = frame
            .asked
            .iter()
            .filter_map(|aov| match aov {
                Aov::StdError => Some(PassImage::std_error(&frame.std_error)),
                _ => frame.pass(aov).cloned(),
            })
            .collect();
        lumo::job::write_image_with_passes(&output, tone, image, &passes, None).map(|()| output)
    })
    .await;
    match written {
        Ok(Ok(path)) => json(
            StatusCode::OK,
            serde_json::json!({ "saved": path.display().to_string(), "tonemap": tone.keyword() })
                .to_string(),
        ),
        Ok(Err(e)) => json_error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string()),
        Err(e) => json_error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string()),
    }
}

fn json_error(code: StatusCode, message: &str) -> Response {
    json(code, serde_json::json!({ "error": message }).to_string())
}
