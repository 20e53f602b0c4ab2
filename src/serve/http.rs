//! The HTTP side of `minos serve`: the page, the server's description, creating sessions,
//! and the guard every request passes (access token, same origin).

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

/// Refuses a request without the access token (when the server has one) and one sent by a
/// page of another origin (its `Origin` is not the `Host` it was sent to).
async fn guard(State(app): State<Arc<App>>, req: Request, next: Next) -> Response {
    if let Some(expected) = &app.access_token {
        let from_header = req
            .headers()
            .get("x-minos-access")
            .and_then(|v| v.to_str().ok())
            .map(str::to_string);
        let from_query = Query::<HashMap<String, String>>::try_from_uri(req.uri())
            .ok()
            .and_then(|q| q.0.get("access").cloned());
        let given = from_header.or(from_query).unwrap_or_default();
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
    let set = |h: &mut HeaderMap, k: header::HeaderName, v: &'static str| {
        h.insert(k, HeaderValue::from_static(v));
    };
    set(h, header::CONTENT_TYPE, "text/html; charset=utf-8");
    set(h, header::CACHE_CONTROL, "no-store");
    set(h, header::REFERRER_POLICY, "no-referrer");
    set(h, header::X_CONTENT_TYPE_OPTIONS, "nosniff");
    set(
        h,
        header::CONTENT_SECURITY_POLICY,
        "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
         img-src 'self' blob: data:; connect-src 'self'",
    );
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
        "actions": Shared::actions(),
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

/// Creates a session: its token (the only way to its socket) and its name (its folder).
async fn create(State(app): State<Arc<App>>, body: axum::body::Bytes) -> Response {
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
        tracing::warn!("{e}");
        return error(StatusCode::FORBIDDEN, e);
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
