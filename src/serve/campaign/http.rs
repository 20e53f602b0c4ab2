//! The campaign's routes: `POST /api/campaign/join` (`{"participant": TOKEN}` from the
//! participant's link → a session token, as `POST /api/sessions` gives), `GET /operator`
//! (the operator page) and `GET /api/operator/status` (progress, live sessions, quality
//! records), both behind the operator token (`x-minos-operator` header or `?operator=`).

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use axum::extract::{Query, Request, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use serde_json::json;

use super::Seat;
use crate::serve::session::Start;
use crate::serve::token::{random_hex, session_token};
use crate::serve::{App, Slot};

/// The operator page, compiled in.
const OPERATOR_PAGE: &str = include_str!("operator.html");

/// The campaign's routes (answering 404 on a server without a campaign).
pub(in crate::serve) fn routes() -> Router<Arc<App>> {
    Router::new()
        .route("/api/campaign/join", post(join))
        .route("/operator", get(operator_page))
        .route("/api/operator/status", get(status))
}

fn error(status: StatusCode, message: impl Into<String>) -> Response {
    (status, Json(json!({"error": message.into()}))).into_response()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JoinRequest {
    participant: String,
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
    let participant = match campaign.participant(&req.participant) {
        Ok(Some(p)) => p,
        Ok(None) => return error(StatusCode::FORBIDDEN, "unknown participant link"),
        Err(e) => {
            tracing::error!("{e}");
            return error(
                StatusCode::INTERNAL_SERVER_ERROR,
                "participants file unreadable",
            );
        }
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

/// Whether the request carries the operator token.
fn operator(app: &App, req: &Request) -> bool {
    let Some(campaign) = &app.campaign else {
        return false;
    };
    let from_header = req
        .headers()
        .get("x-minos-operator")
        .and_then(|v| v.to_str().ok())
        .map(str::to_string);
    let from_query = Query::<HashMap<String, String>>::try_from_uri(req.uri())
        .ok()
        .and_then(|q| q.0.get("operator").cloned());
    campaign.is_operator(&from_header.or(from_query).unwrap_or_default())
}

async fn operator_page(State(app): State<Arc<App>>, req: Request) -> Response {
    if !operator(&app, &req) {
        return error(
            StatusCode::UNAUTHORIZED,
            "the operator page needs its token",
        );
    }
    let mut r = OPERATOR_PAGE.into_response();
    let h = r.headers_mut();
    for (k, v) in [
        (header::CONTENT_TYPE, "text/html; charset=utf-8"),
        (header::CACHE_CONTROL, "no-store"),
        (header::REFERRER_POLICY, "no-referrer"),
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        (
            header::CONTENT_SECURITY_POLICY,
            "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
             connect-src 'self'",
        ),
    ] {
        h.insert(k, HeaderValue::from_static(v));
    }
    r
}

async fn status(State(app): State<Arc<App>>, req: Request) -> Response {
    if !operator(&app, &req) {
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
