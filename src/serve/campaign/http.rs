//! The campaign's routes: `POST /api/campaign/join` (`{"participant": TOKEN}` from the
//! participant's link → a session token, as `POST /api/sessions` gives), `POST
//! /api/campaign/feedback` (`{"participant": TOKEN, "rating": 1-5, "comment": TEXT}`), and
//! behind the operator token (`x-minos-operator` header or `?operator=`): `GET /operator`
//! (the operator page), `GET /api/operator/status` (progress, live sessions, quality
//! records, feedback), `POST /api/operator/review` (`{"session", "episode_id", "accepted",
//! "note"}`: the operator's verdict on a demonstration) and `GET /api/operator/replay`
//! (`?session=&episode=`, a WebSocket: the demonstration replayed by the simulator, frame
//! by frame, then whether the replay agrees with its quality record).

use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Instant;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use serde_json::json;

use super::feedback::{Feedback, FeedbackError};
use super::{Demo, ReviewError, Seat};
use crate::serve::frames::{self, KIND_MAP};
use crate::serve::replay::{recorded_decisions, replay, ReplayFrame};
use crate::serve::session::{camera_messages, episode_intro, Start, Update};
use crate::serve::token::{random_hex, session_token};
use crate::serve::{App, Slot};

/// The operator page's parts, compiled in.
const OPERATOR_HTML: &str = include_str!("operator.html");
const OPERATOR_STYLE: &str = include_str!("operator.css");
const OPERATOR_SCRIPT: &str = include_str!("operator.js");

/// Replays running at once, at most (each holds a simulator).
pub const MAX_REPLAYS: usize = 2;

/// The campaign's routes (answering 404 on a server without a campaign).
pub(in crate::serve) fn routes() -> Router<Arc<App>> {
    Router::new()
        .route("/api/campaign/join", post(join))
        .route("/api/campaign/feedback", post(feedback))
        .route("/operator", get(operator_page))
        .route("/api/operator/status", get(status))
        .route("/api/operator/review", post(review))
        .route("/api/operator/replay", get(replay_socket))
}

fn error(status: StatusCode, message: impl Into<String>) -> Response {
    (status, Json(json!({"error": message.into()}))).into_response()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JoinRequest {
    participant: String,
}

/// The participant whose link carries `token`; otherwise the status and message to answer
/// (403 for an unknown link).
fn participant_of(
    campaign: &super::Campaign,
    token: &str,
) -> Result<String, (StatusCode, &'static str)> {
    match campaign.participant(token) {
        Ok(Some(p)) => Ok(p),
        Ok(None) => Err((StatusCode::FORBIDDEN, "unknown participant link")),
        Err(e) => {
            tracing::error!("{}", crate::escape::error_line(&e));
            Err((
                StatusCode::INTERNAL_SERVER_ERROR,
                "participants file unreadable",
            ))
        }
    }
}

/// A participant's link opens a session (one live session per participant).
async fn join(State(app): State<Arc<App>>, body: axum::body::Bytes) -> Response {
    let Some(campaign) = app.campaign.clone() else {
        return error(StatusCode::NOT_FOUND, "this server runs no campaign");
    };
    let req: JoinRequest = match serde_json::from_slice(&body) {
        Ok(r) => r,
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("request body: {e}")),
    };
    let participant = match participant_of(&campaign, &req.participant) {
        Ok(p) => p,
        Err((status, message)) => return error(status, message),
    };
    let (token, seed) = match (session_token(), random_hex(8)) {
        (Ok(t), Ok(seed)) => (t, u64::from_str_radix(&seed, 16).unwrap_or(0)),
        _ => {
            return error(
                StatusCode::INTERNAL_SERVER_ERROR,
                "no randomness from the OS",
            )
        }
    };
    let more = campaign.more_for(&participant);
    let tutorial = matches!(
        campaign.books().ledger.peek(&participant),
        super::Assignment::Tutorial
    );
    {
        let mut slots = app.slots();
        if slots.len() >= app.max_sessions {
            return error(
                StatusCode::SERVICE_UNAVAILABLE,
                format!("{} sessions already: try again later", app.max_sessions),
            );
        }
        if !more {
            return error(
                StatusCode::GONE,
                "thank you: there is nothing left for you to play",
            );
        }
        let Some(name) = campaign.open_session(&participant) else {
            return error(
                StatusCode::CONFLICT,
                "this link has a session open already (close the other page)",
            );
        };
        slots.insert(
            token.clone(),
            Slot {
                name: name.clone(),
                start: Some(Start::Campaign(Seat {
                    campaign: campaign.clone(),
                    participant: participant.clone(),
                })),
                created: Instant::now(),
                seed,
            },
        );
        tracing::info!("campaign session {name} created");
        (
            StatusCode::CREATED,
            Json(json!({
                "token": token,
                "name": name,
                "participant": participant,
                "instructions": campaign.spec.instructions,
                "tutorial": tutorial,
            })),
        )
            .into_response()
    }
}

/// Whether the request (its `headers` and `uri`) carries the operator token.
fn operator(app: &App, headers: &HeaderMap, uri: &Uri) -> bool {
    let Some(campaign) = &app.campaign else {
        return false;
    };
    let from_header = headers
        .get("x-minos-operator")
        .and_then(|v| v.to_str().ok())
        .map(str::to_string);
    let from_query = Query::<HashMap<String, String>>::try_from_uri(uri)
        .ok()
        .and_then(|q| q.0.get("operator").cloned());
    campaign.is_operator(&from_header.or(from_query).unwrap_or_default())
}

async fn operator_page(State(app): State<Arc<App>>, req: Request) -> Response {
    if !operator(&app, req.headers(), req.uri()) {
        return error(
            StatusCode::UNAUTHORIZED,
            "the operator page needs its token",
        );
    }
    let page = OPERATOR_HTML
        .replace("/*STYLE*/", OPERATOR_STYLE)
        .replace("/*SCRIPT*/", OPERATOR_SCRIPT);
    let mut r = page.into_response();
    let h = r.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/html; charset=utf-8"),
    );
    if let Ok(policy) = HeaderValue::from_str(&crate::serve::security::page_policy(
        OPERATOR_SCRIPT,
        OPERATOR_STYLE,
    )) {
        h.insert(header::CONTENT_SECURITY_POLICY, policy);
    }
    r
}

async fn status(State(app): State<Arc<App>>, req: Request) -> Response {
    if !operator(&app, req.headers(), req.uri()) {
        return error(
            StatusCode::UNAUTHORIZED,
            "the operator status needs its token",
        );
    }
    match &app.campaign {
        Some(c) => {
            let mut r = Json(c.status()).into_response();
            r.headers_mut()
                .insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
            r
        }
        None => error(StatusCode::NOT_FOUND, "this server runs no campaign"),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FeedbackRequest {
    participant: String,
    #[serde(default)]
    rating: Option<u8>,
    #[serde(default)]
    comment: String,
}

/// A participant's feedback, with their link's token.
async fn feedback(State(app): State<Arc<App>>, body: axum::body::Bytes) -> Response {
    let Some(campaign) = app.campaign.clone() else {
        return error(StatusCode::NOT_FOUND, "this server runs no campaign");
    };
    let req: FeedbackRequest = match serde_json::from_slice(&body) {
        Ok(r) => r,
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("request body: {e}")),
    };
    let participant = match participant_of(&campaign, &req.participant) {
        Ok(p) => p,
        Err((status, message)) => return error(status, message),
    };
    let said = Feedback {
        rating: req.rating,
        comment: req.comment,
    };
    match campaign.feedback(&participant, said) {
        Ok(()) => (StatusCode::CREATED, Json(json!({"thanks": true}))).into_response(),
        Err(e @ FeedbackError::TooMany) => error(StatusCode::TOO_MANY_REQUESTS, e.to_string()),
        Err(FeedbackError::Record(e)) => {
            tracing::error!("{}", crate::escape::error_line(&e));
            error(StatusCode::INTERNAL_SERVER_ERROR, "feedback not kept")
        }
        Err(e) => error(StatusCode::BAD_REQUEST, crate::escape::error_line(&e)),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ReviewRequest {
    session: String,
    episode_id: String,
    accepted: bool,
    #[serde(default)]
    note: String,
}

/// The operator's verdict on a demonstration.
async fn review(State(app): State<Arc<App>>, req: Request) -> Response {
    if !operator(&app, req.headers(), req.uri()) {
        return error(
            StatusCode::UNAUTHORIZED,
            "a review needs the operator token",
        );
    }
    let Some(campaign) = app.campaign.clone() else {
        return error(StatusCode::NOT_FOUND, "this server runs no campaign");
    };
    let body = match axum::body::to_bytes(req.into_body(), 64 * 1024).await {
        Ok(b) => b,
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("request body: {e}")),
    };
    let r: ReviewRequest = match serde_json::from_slice(&body) {
        Ok(r) => r,
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("request body: {e}")),
    };
    // The quality file is rewritten: off the async workers.
    let done = tokio::task::spawn_blocking(move || {
        campaign.review(&r.session, &r.episode_id, r.accepted, &r.note)
    })
    .await;
    match done {
        Ok(Ok(entry)) => Json(entry).into_response(),
        Ok(Err(e @ ReviewError::NoDemo { .. })) => error(StatusCode::NOT_FOUND, e.to_string()),
        Ok(Err(e @ ReviewError::Tutorial)) => error(StatusCode::CONFLICT, e.to_string()),
        Ok(Err(e @ ReviewError::NoteTooLong(_))) => error(StatusCode::BAD_REQUEST, e.to_string()),
        Ok(Err(ReviewError::Record(e))) => {
            tracing::error!("{}", crate::escape::error_line(&e));
            error(StatusCode::INTERNAL_SERVER_ERROR, "the review was not kept")
        }
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()),
    }
}

#[derive(Debug, Deserialize)]
struct ReplayQuery {
    session: String,
    episode: String,
}

/// The replay of a demonstration, on a WebSocket (the operator's token by `?operator=`: a
/// browser's socket carries no header of the page's).
async fn replay_socket(
    State(app): State<Arc<App>>,
    headers: HeaderMap,
    uri: Uri,
    ws: WebSocketUpgrade,
) -> Response {
    if !operator(&app, &headers, &uri) {
        return error(
            StatusCode::UNAUTHORIZED,
            "a replay needs the operator token",
        );
    }
    let Some(campaign) = app.campaign.clone() else {
        return error(StatusCode::NOT_FOUND, "this server runs no campaign");
    };
    let q = match Query::<ReplayQuery>::try_from_uri(&uri) {
        Ok(q) => q.0,
        Err(e) => return error(StatusCode::BAD_REQUEST, e.to_string()),
    };
    let Some((demo, index)) = campaign.demo(&q.session, &q.episode) else {
        return error(
            StatusCode::NOT_FOUND,
            format!(
                "no demonstration of episode `{}` in session `{}`",
                q.episode, q.session
            ),
        );
    };
    if app.replays.fetch_add(1, Ordering::AcqRel) >= MAX_REPLAYS {
        app.replays.fetch_sub(1, Ordering::AcqRel);
        return error(
            StatusCode::SERVICE_UNAVAILABLE,
            format!("{MAX_REPLAYS} replays run already: try again when one ends"),
        );
    }
    ws.max_message_size(4096)
        .on_upgrade(move |socket| drive_replay(app, demo, index, socket))
}

/// Runs the replay of `demo` (episode `index` of the episode file) on a thread and forwards
/// its messages to `socket`.
async fn drive_replay(app: Arc<App>, demo: Demo, index: usize, mut socket: WebSocket) {
    let (tx, mut rx) = tokio::sync::mpsc::channel::<Update>(16);
    let thread_app = app.clone();
    let spawned = std::thread::Builder::new()
        .name(format!("replay {}", demo.session))
        .spawn(move || {
            run_replay(&thread_app, &demo, index, &tx);
            thread_app.replays.fetch_sub(1, Ordering::AcqRel);
        });
    if spawned.is_err() {
        app.replays.fetch_sub(1, Ordering::AcqRel);
        return;
    }
    let send_timeout = app.send_timeout;
    loop {
        tokio::select! {
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => break,
                Some(Ok(_)) => {}
            },
            update = rx.recv() => {
                let Some(update) = update else { break };
                if !crate::serve::ws::send_update(&mut socket, update, send_timeout).await {
                    break;
                }
            }
        }
    }
    // The thread sees the viewer gone at its next send.
    drop(rx);
    let _ = tokio::time::timeout(send_timeout, socket.send(Message::Close(None))).await;
}

/// The replay's messages: `replay` (the episode, as a session's `episode` message, with the
/// decisions recorded) and the map, then per frame a `frame` message and the colour view,
/// then `replay_end` (the replay's metrics, the quality record's, whether they agree) — or
/// one `error`.
fn run_replay(app: &App, demo: &Demo, index: usize, tx: &tokio::sync::mpsc::Sender<Update>) {
    let send = |u: Update| tx.blocking_send(u).is_ok();
    let text = |v: serde_json::Value| send(Update::Text(v.to_string()));
    let shared = &app.shared;
    let Some(episode) = shared.episodes.get(index) else {
        text(json!({"type": "error", "message": "the episode is not in the episode file"}));
        return;
    };
    let dir = shared.out.join(&demo.session);
    let decisions = match recorded_decisions(&dir, &episode.episode_id) {
        Ok(d) => d,
        Err(e) => {
            text(json!({"type": "error", "message": crate::escape::error_line(&e)}));
            return;
        }
    };
    let views = shared.default_views();
    let mut frame_index = 0u32;
    let mut visit = |f: ReplayFrame<'_>| -> bool {
        if f.decision.is_none() {
            let (mut intro, map) = match episode_intro(episode, f.sim) {
                Ok(x) => x,
                Err(e) => {
                    text(
                        json!({"type": "error", "message": format!("map: {}", crate::escape::error_line(&e))}),
                    );
                    return false;
                }
            };
            intro["type"] = json!("replay");
            intro["session"] = json!(demo.session);
            intro["participant"] = json!(demo.entry.participant);
            intro["decisions"] = json!(decisions.len());
            intro["verdict"] = json!(demo.entry.verdict);
            let map_msg = frames::message(KIND_MAP, 0, map.size[0], map.size[1], &map.png);
            if !(text(intro) && send(Update::Binary(map_msg))) {
                return false;
            }
        }
        let state = f.sim.state();
        let ok = text(json!({
            "type": "frame",
            "frame": frame_index,
            "step": f.steps,
            "action": f.decision.map(|d| d.name()),
            "position": state.position,
            "yaw": state.yaw,
            "tilt": state.tilt,
            "collision": f.collision,
            "reward": f.reward,
            "done": f.done,
            "success": f.success,
        }));
        frame_index += 1;
        if !ok {
            return false;
        }
        match camera_messages(f.obs, f.sim, views, shared.frames) {
            Ok(messages) => messages.into_iter().all(|m| send(Update::Binary(m))),
            Err(e) => {
                text(json!({"type": "error", "message": crate::escape::error_line(&e)}));
                false
            }
        }
    };
    match replay(shared, &demo.session, episode, &decisions, &mut visit) {
        Ok(m) => {
            let record = demo.entry.qc;
            let agrees = record.is_some_and(|q| {
                q.success == m.success
                    && q.actions == m.steps
                    && q.collisions == m.collisions
                    && (q.path_length - m.path_length).abs() <= 1e-4 * q.path_length.max(1.0)
            });
            text(json!({
                "type": "replay_end",
                "frames": frame_index,
                "metrics": m,
                "record": record,
                "agrees": agrees,
            }));
        }
        Err(e) => {
            text(json!({"type": "error", "message": crate::escape::error_line(&e)}));
        }
    }
}
