//! A session's WebSocket: starts the session's thread, forwards the page's commands to it
//! and its updates to the page. Commands are JSON: `{"action": NAME}` (one of the agent's
//! actions, [`Shared::actions`], or `stop`; any other is refused), `{"next": null | EPISODE_ID}`, `{"views": [CAMERA, …]}`
//! (the cameras to send besides colour), `{"end": true}`.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use axum::extract::ws::{Message, WebSocket};
use serde_json::{json, Value};

use crate::invalid::Invalid;

use super::rate::Bucket;
use super::session::{self, Command, Link, Shared, Start, Update};
use super::App;

/// What a text message from the page asks.
#[derive(Debug, PartialEq)]
enum Parsed {
    Command(Command),
    Views(u32),
}

/// Parses a message of the page (see the module documentation).
fn parse(text: &str, shared: &Shared) -> Result<Parsed, Invalid> {
    let v: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    if let Some(a) = v.get("action") {
        let name = a.as_str().ok_or("action: not text")?;
        return Ok(Parsed::Command(Command::Act(shared.decision(name)?)));
    }
    if let Some(n) = v.get("next") {
        return Ok(Parsed::Command(Command::Next(
            n.as_str().map(str::to_string),
        )));
    }
    if let Some(list) = v.get("views") {
        let names: Vec<String> = list
            .as_array()
            .ok_or("views: not a list")?
            .iter()
            .filter_map(|n| n.as_str().map(str::to_string))
            .collect();
        return Ok(Parsed::Views(shared.views_of(&names)));
    }
    if v.get("end").is_some() {
        return Ok(Parsed::Command(Command::End));
    }
    Err("unknown message".into())
}

/// Sends `update` to the page; false when it did not take it within `timeout` (or left).
pub(super) async fn send_update(
    socket: &mut WebSocket,
    update: Update,
    timeout: std::time::Duration,
) -> bool {
    let msg = match update {
        Update::Text(t) => Message::Text(t.into()),
        Update::Binary(b) => Message::Binary(b.into()),
    };
    matches!(
        tokio::time::timeout(timeout, socket.send(msg)).await,
        Ok(Ok(()))
    )
}

/// Runs the session behind `socket` until either side ends.
pub async fn drive(
    app: Arc<App>,
    token: String,
    name: String,
    start: Start,
    seed: u64,
    mut socket: WebSocket,
) {
    let (cmd_tx, cmd_rx) = std::sync::mpsc::channel::<Command>();
    let (up_tx, mut up_rx) = tokio::sync::mpsc::channel::<Update>(8);
    let views = Arc::new(AtomicU32::new(app.shared.default_views()));
    let link = Arc::new(Link {
        commands: Mutex::new(cmd_rx),
        updates: up_tx,
        views: views.clone(),
        idle: app.shared.idle,
        ended: Default::default(),
    });
    let shared = app.shared.clone();
    let ending = app.clone();
    let thread_token = token.clone();
    app.session_threads.fetch_add(1, Ordering::AcqRel);
    let spawned = std::thread::Builder::new()
        .name(format!("session {name}"))
        .spawn(move || {
            session::run_session(shared, &name, start, link, seed);
            ending.remove(&thread_token);
            ending.session_threads.fetch_sub(1, Ordering::AcqRel);
            tracing::info!("session {name} ended");
        });
    if spawned.is_err() {
        app.session_threads.fetch_sub(1, Ordering::AcqRel);
        app.remove(&token);
        return;
    }
    let send_timeout = app.send_timeout;
    // The session token's rate limit: a burst of two seconds' worth, then the rate.
    let per_second = f64::from(app.rate.messages_per_second);
    let mut bucket = Bucket::new(per_second, 2.0 * per_second, std::time::Instant::now());
    loop {
        tokio::select! {
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Text(_))) if !bucket.take(std::time::Instant::now()) => {
                    let reply = json!({"type": "error", "fatal": false, "message": format!(
                        "too many messages: at most {} a second; this one was ignored",
                        app.rate.messages_per_second)});
                    let send = socket.send(Message::Text(reply.to_string().into()));
                    if !matches!(tokio::time::timeout(send_timeout, send).await, Ok(Ok(()))) {
                        break;
                    }
                }
                Some(Ok(Message::Text(text))) => match parse(text.as_str(), &app.shared) {
                    Ok(Parsed::Views(mask)) => views.store(mask, Ordering::Relaxed),
                    Ok(Parsed::Command(c)) => {
                        if cmd_tx.send(c).is_err() {
                            break;
                        }
                    }
                    Err(message) => {
                        let reply = json!({"type": "error", "message": message.to_string(), "fatal": false});
                        let send = socket.send(Message::Text(reply.to_string().into()));
                        if !matches!(tokio::time::timeout(send_timeout, send).await, Ok(Ok(()))) {
                            break;
                        }
                    }
                },
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => break,
                Some(Ok(_)) => {}
            },
            update = up_rx.recv() => {
                let Some(update) = update else { break };
                if !send_update(&mut socket, update, send_timeout).await {
                    break;
                }
            }
        }
    }
    // The session's thread sees its page gone at its next wait.
    drop(cmd_tx);
    drop(up_rx);
    let _ = tokio::time::timeout(send_timeout, socket.send(Message::Close(None))).await;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::agents::Decision;

    fn shared() -> Shared {
        Shared {
            data: crate::store::DataDir::new("/nonexistent"),
            episodes: Vec::new(),
            episodes_file: None,
            scenes: Vec::new(),
            out: "/nonexistent".into(),
            preset: crate::body::AgentPreset::Habitat,
            agent_config: crate::sim::AgentConfig::habitat(),
            sensors: crate::sim::SensorSuite::minos(8),
            renderer: crate::render::RendererChoice::Cpu,
            reward: crate::run::metrics::Reward::Geodesic,
            encoding: crate::io::image_codec::ImageEncoding::Raw,
            seed: 0,
            idle: std::time::Duration::from_secs(1),
            command: Vec::new(),
            variant: None,
            frames: Default::default(),
        }
    }

    #[test]
    fn commands_parse_and_bad_ones_are_refused() {
        let s = shared();
        let act = |n: &str| Decision::from_name(n).expect("known action");
        assert_eq!(
            parse(r#"{"action":"turn_left"}"#, &s),
            Ok(Parsed::Command(Command::Act(act("turn_left"))))
        );
        assert_eq!(
            parse(r#"{"action":"stop"}"#, &s),
            Ok(Parsed::Command(Command::Act(Decision::Stop)))
        );
        assert_eq!(
            parse(r#"{"next":null}"#, &s),
            Ok(Parsed::Command(Command::Next(None)))
        );
        assert_eq!(
            parse(r#"{"next":"a:b:1"}"#, &s),
            Ok(Parsed::Command(Command::Next(Some("a:b:1".into()))))
        );
        assert_eq!(
            parse(r#"{"end":true}"#, &s),
            Ok(Parsed::Command(Command::End))
        );
        // colour is camera 0, depth 1, semantic 2.
        assert_eq!(
            parse(r#"{"views":["semantic"]}"#, &s),
            Ok(Parsed::Views(0b101))
        );
        assert_eq!(parse(r#"{"views":["../x"]}"#, &s), Ok(Parsed::Views(0b001)));
        assert!(parse(r#"{"action":"fly"}"#, &s).is_err());
        // Habitat's agent moves forward and turns: nothing else is offered or taken.
        assert_eq!(s.actions(), ["forward", "turn_left", "turn_right", "stop"]);
        for name in [
            "backward",
            "strafe_left",
            "strafe_right",
            "look_up",
            "look_down",
            "idle",
        ] {
            let e = parse(&format!(r#"{{"action":"{name}"}}"#), &s).unwrap_err();
            assert!(
                e.to_string().contains(name)
                    && e.to_string().contains("habitat")
                    && e.to_string().contains("turn_right"),
                "{e}"
            );
        }
        // MINOS's continuous agent also backs and strafes (and does not look up or down).
        let minos = Shared {
            preset: crate::body::AgentPreset::Minos,
            agent_config: crate::sim::AgentConfig::preset(crate::body::AgentPreset::Minos),
            ..shared()
        };
        for name in ["backward", "strafe_left", "strafe_right"] {
            assert!(
                parse(&format!(r#"{{"action":"{name}"}}"#), &minos).is_ok(),
                "{name}"
            );
        }
        assert!(parse(r#"{"action":"look_up"}"#, &minos).is_err());
        assert!(parse("not json", &s).is_err());
        assert!(parse(r#"{"hello":1}"#, &s).is_err());
    }
}
