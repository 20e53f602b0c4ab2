//! The HTTP side of `minos serve`: the page, the server's description, creating sessions,
//! and the guard every request passes (its `Host` this server's, the access token, same
//! origin; the security headers added to every response).

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use axum::extract::{Path, Query, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use serde_json::json;

use super::security::{add_headers, host_allowed, API_POLICY};
use super::session::{Shared, Start};
use super::token::{looks_like_token, random_hex, same, session_token};
use super::{App, Slot};
use crate::episode::instruction::instruction;

/// The page's parts, compiled in.
const HTML: &str = include_str!("page/index.html");
const STYLE: &str = include_str!("page/style.css");
const SCRIPT: &str = include_str!("page/app.js");

/// The page with its style and script inlined.
pub fn page() -> String {
    HTML.replace("/*STYLE*/", STYLE)
        .replace("/*SCRIPT*/", SCRIPT)
}

/// The content-security policy of [`page`]: its own inline script and style, by hash.
pub fn page_policy() -> String {
    super::security::page_policy(SCRIPT, STYLE)
}

/// Every route, behind the guard.
pub fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(index))
        .route("/api/info", get(info))
        .route("/api/sessions", post(create))
        .route("/api/sessions/{token}/ws", get(socket))
        .merge(super::campaign::http::routes())
        .fallback(not_found)
        .layer(middleware::from_fn_with_state(app.clone(), guard))
        .with_state(app)
}

/// A JSON error.
fn error(status: StatusCode, message: impl Into<String>) -> Response {
    (status, Json(json!({"error": message.into()}))).into_response()
}

async fn not_found() -> Response {
    error(StatusCode::NOT_FOUND, "not found")
}

/// Refuses a request whose `Host` is not this server's (DNS rebinding), one without the
/// access token (when the server has one) and one sent by a page of another origin (its
/// `Origin` is not the `Host` it was sent to); adds the security headers to every response.
async fn guard(State(app): State<Arc<App>>, req: Request, next: Next) -> Response {
    let mut response = checked(&app, req, next).await;
    add_headers(response.headers_mut(), API_POLICY);
    response
}

async fn checked(app: &App, req: Request, next: Next) -> Response {
    let host = req
        .headers()
        .get(header::HOST)
        .and_then(|h| h.to_str().ok());
    if !host_allowed(host, app.addr, &app.allowed_hosts) {
        tracing::warn!(
            "refused a request for host {:?} (not one of this server's allowed host names)",
            host.unwrap_or("")
        );
        return error(
            StatusCode::MISDIRECTED_REQUEST,
            "this server does not answer for that host name",
        );
    }
    if let Some(expected) = &app.access_token {
        let given = credential(req.headers(), req.uri());
        if !same(&given, expected) {
            return error(
                StatusCode::UNAUTHORIZED,
                "this server needs its access token",
            );
        }
    }
    if !same_origin(req.headers()) {
        return error(
            StatusCode::FORBIDDEN,
            "request from a page of another origin",
        );
    }
    next.run(req).await
}

/// No `Origin`, or one whose host and port are the request's `Host`.
fn same_origin(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return true;
    };
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok());
    let origin = origin
        .to_str()
        .ok()
        .and_then(|o| o.split_once("://"))
        .map(|(_, rest)| rest);
    matches!((origin, host), (Some(o), Some(h)) if o == h)
}

async fn index(State(app): State<Arc<App>>) -> Response {
    let mut r = app.page.clone().into_response();
    let h = r.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/html; charset=utf-8"),
    );
    if let Ok(policy) = HeaderValue::from_str(&app.page_policy) {
        h.insert(header::CONTENT_SECURITY_POLICY, policy);
    }
    r
}

/// The server's description: agent, actions, sensors, scenes and episodes.
async fn info(State(app): State<Arc<App>>) -> Response {
    let s: &Shared = &app.shared;
    let episodes: Vec<_> = s
        .episodes
        .iter()
        .map(|e| json!({"id": e.episode_id, "scene": e.scene_id, "task": e.task.name(), "instruction": instruction(e)}))
        .collect();
    let sensors: Vec<_> = s
        .sensors
        .cameras
        .iter()
        .map(|c| json!({"name": c.name, "modality": c.modality, "resolution": c.resolution}))
        .collect();
    Json(json!({
        "preset": s.preset.name(),
        "actions": s.actions(),
        "frames": s.frames.name(),
        "sensors": sensors,
        "scenes": s.scenes,
        "episodes": episodes,
        "episodes_file": s.episodes_file,
        "max_sessions": app.max_sessions,
        "sessions": app.slots().len(),
    }))
    .into_response()
}

/// What a session plays: one of the episodes, or a scene to explore.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct CreateRequest {
    episode: Option<String>,
    scene: Option<String>,
}

/// The access token a request carries (header or query), if any.
fn credential(headers: &HeaderMap, uri: &axum::http::Uri) -> String {
    headers
        .get("x-minos-access")
        .and_then(|v| v.to_str().ok())
        .map(str::to_string)
        .or_else(|| {
            Query::<HashMap<String, String>>::try_from_uri(uri)
                .ok()
                .and_then(|q| q.0.get("access").cloned())
        })
        .unwrap_or_default()
}

/// Creates a session: its token (the only way to its socket) and its name (its folder).
/// Sessions are rate-limited per access token (see [`super::RateLimits`]).
async fn create(
    State(app): State<Arc<App>>,
    headers: HeaderMap,
    uri: axum::http::Uri,
    body: axum::body::Bytes,
) -> Response {
    if !app.new_sessions.take(&credential(&headers, &uri)) {
        return error(
            StatusCode::TOO_MANY_REQUESTS,
            format!(
                "more than {} new sessions a minute: try again shortly",
                app.rate.sessions_per_minute
            ),
        );
    }
    let req: CreateRequest = if body.iter().all(u8::is_ascii_whitespace) {
        CreateRequest::default()
    } else {
        match serde_json::from_slice(&body) {
            Ok(r) => r,
            Err(e) => return error(StatusCode::BAD_REQUEST, format!("request body: {e}")),
        }
    };
    if app.campaign.is_some() {
        return error(
            StatusCode::FORBIDDEN,
            "this server runs a campaign: open your participant link",
        );
    }
    let s = &app.shared;
    let (start, scene) = match (&req.episode, &req.scene) {
        (Some(_), Some(_)) => {
            return error(
                StatusCode::BAD_REQUEST,
                "give an episode or a scene, not both",
            )
        }
        (Some(id), None) => match s.episodes.iter().position(|e| &e.episode_id == id) {
            Some(i) => (Start::Episode(i), s.episodes[i].scene_id.clone()),
            None => return error(StatusCode::NOT_FOUND, "no such episode"),
        },
        (None, Some(scene)) => {
            if !s.scenes.contains(scene) {
                return error(StatusCode::NOT_FOUND, "no such scene");
            }
            (Start::Explore(scene.clone()), scene.clone())
        }
        (None, None) => match s.episodes.first() {
            Some(e) => (Start::Episode(0), e.scene_id.clone()),
            None => return error(StatusCode::BAD_REQUEST, "no episode file: choose a scene"),
        },
    };
    if let Err(e) = app.contained(&scene) {
        let line = crate::escape::error_line(&e);
        tracing::warn!("{line}");
        return error(StatusCode::FORBIDDEN, line);
    }
    let (token, suffix, seed) = match (session_token(), random_hex(4), random_hex(8)) {
        (Ok(t), Ok(s), Ok(seed)) => (t, s, u64::from_str_radix(&seed, 16).unwrap_or(0)),
        _ => {
            return error(
                StatusCode::INTERNAL_SERVER_ERROR,
                "no randomness from the OS",
            )
        }
    };
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let name = format!("session-{secs}-{suffix}");
    {
        let mut slots = app.slots();
        if slots.len() >= app.max_sessions {
            return error(
                StatusCode::SERVICE_UNAVAILABLE,
                format!("{} sessions already: try again later", app.max_sessions),
            );
        }
        slots.insert(
            token.clone(),
            Slot {
                name: name.clone(),
                start: Some(start),
                created: Instant::now(),
                seed,
            },
        );
    }
    tracing::info!("session {name} created");
    (
        StatusCode::CREATED,
        Json(json!({"token": token, "name": name})),
    )
        .into_response()
}

/// The session's WebSocket (once per session).
async fn socket(
    State(app): State<Arc<App>>,
    Path(token): Path<String>,
    ws: axum::extract::ws::WebSocketUpgrade,
) -> Response {
    if !looks_like_token(&token) {
        return not_found().await;
    }
    let taken = {
        let mut slots = app.slots();
        match slots.get_mut(&token) {
            None => None,
            Some(slot) => Some(
                slot.start
                    .take()
                    .map(|start| (slot.name.clone(), start, slot.seed)),
            ),
        }
    };
    match taken {
        None => not_found().await,
        Some(None) => error(StatusCode::CONFLICT, "this session is connected already"),
        Some(Some((name, start, seed))) => ws
            .max_message_size(4096)
            .on_upgrade(move |socket| super::ws::drive(app, token, name, start, seed, socket)),
    }
}
