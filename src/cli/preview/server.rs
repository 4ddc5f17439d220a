//! The preview's HTTP server: a fixed set of routes and nothing else. No route maps a URL to a
//! file, so neither the scene's folder nor any file the scene references can be downloaded
//! through it: files reach the page only as the rendered image.
//!
//! - `GET /`: the page (embedded in the binary, no build step);
//! - `GET /events`: server-sent events, one `status` event (JSON) per change;
//! - `GET /status`: the same JSON, once;
//! - `GET /frame?kind=image|error`: the latest frame's radiance or per-pixel standard error as
//!   little-endian `f32` RGB triples, row-major, its size in `x-lumo-width`/`x-lumo-height`;
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
use lumo::output::ToneMap;
use lumo_schema::Keyword as _;
use serde::Deserialize;

use super::Shared;

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
}

async fn frame(State(shared): State<Arc<Shared>>, Query(q): Query<FrameQuery>) -> Response {
    let Some(frame) = shared.frame() else {
        return (StatusCode::NOT_FOUND, "no frame yet\n").into_response();
    };
    let image = match q.kind.as_deref() {
        None | Some("image") => &frame.image,
        Some("error") => &frame.std_error,
        Some(_) => return (StatusCode::BAD_REQUEST, "kind is image or error\n").into_response(),
    };
    let mut bytes = Vec::with_capacity(image.pixels.len() * 12);
    for p in &image.pixels {
        for c in p.to_array() {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    let mut headers = HeaderMap::new();
    headers.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/octet-stream"),
    );
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    headers.insert("x-lumo-width", HeaderValue::from(image.width));
    headers.insert("x-lumo-height", HeaderValue::from(image.height));
    (headers, bytes).into_response()
}

#[derive(Deserialize)]
struct SaveQuery {
    tonemap: Option<String>,
    exposure: Option<f32>,
}

/// Writes the latest path-traced frame to the output path (atomically, as `lumo render` does):
/// 8-bit formats get the page's exposure and tone mapping, EXR and HDR stay linear.
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
        lumo::output::write_image(image, &output, tone).map(|()| output)
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
