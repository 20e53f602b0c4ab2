//! A client of `minos serve` for the tests: raw HTTP/1.1 requests (so paths reach the server
//! exactly as written) and the session WebSocket.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use minos::run::agents::Decision;
use serde_json::Value;
use tokio_tungstenite::tungstenite::Message;

/// A session socket.
pub type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Sends `method target` with `headers` and `body` on a fresh connection; returns the status
/// and the body.
pub fn http(
    addr: SocketAddr,
    method: &str,
    target: &str,
    headers: &[(&str, &str)],
    body: Option<&str>,
) -> (u16, String) {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let mut req = format!("{method} {target} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    let body = body.unwrap_or("");
    if !body.is_empty() {
        req.push_str(&format!(
            "Content-Type: application/json\r\nContent-Length: {}\r\n",
            body.len()
        ));
    }
    req.push_str("\r\n");
    req.push_str(body);
    s.write_all(req.as_bytes()).expect("send");
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).to_string();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (status, body)
}

/// Creates a session with `body` (JSON); returns its token and name.
pub fn create(addr: SocketAddr, body: &str, headers: &[(&str, &str)]) -> (String, String) {
    let (status, reply) = http(addr, "POST", "/api/sessions", headers, Some(body));
    assert_eq!(status, 201, "{reply}");
    let v: Value = serde_json::from_str(&reply).expect("JSON reply");
    (
        v["token"].as_str().expect("token").to_string(),
        v["name"].as_str().expect("name").to_string(),
    )
}

/// Connects the WebSocket of session `token`.
pub async fn connect(addr: SocketAddr, token: &str, query: &str) -> Ws {
    let url = format!("ws://{addr}/api/sessions/{token}/ws{query}");
    tokio_tungstenite::connect_async(url)
        .await
        .expect("websocket")
        .0
}

/// A message of the server.
#[derive(Debug)]
pub enum Msg {
    /// JSON.
    Json(Value),
    /// A binary message: kind, index, width, height, payload length.
    Binary(u8, u8, u16, u16, usize),
}

/// The next message (`None` when the socket closed); fails the test after 60 s.
pub async fn recv(ws: &mut Ws) -> Option<Msg> {
    loop {
        let m = tokio::time::timeout(Duration::from_secs(60), ws.next())
            .await
            .expect("a message within 60 s");
        match m {
            None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return None,
            Some(Ok(Message::Text(t))) => {
                return Some(Msg::Json(serde_json::from_str(t.as_str()).expect("JSON")))
            }
            Some(Ok(Message::Binary(b))) => {
                let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
                return Some(Msg::Binary(b[0], b[1], u16_at(2), u16_at(4), b.len() - 8));
            }
            Some(Ok(_)) => continue,
        }
    }
}

/// Sends a JSON command.
pub async fn send(ws: &mut Ws, json: &str) {
    ws.send(Message::Text(json.to_string().into()))
        .await
        .expect("send");
}

/// Plays the current episode with `decisions` (one per step, after each step's colour frame)
/// and returns the `done` message.
pub async fn play(ws: &mut Ws, decisions: &[Decision]) -> Value {
    let mut next = 0;
    let mut stepped = false;
    loop {
        match recv(ws).await.expect("the session goes on") {
            Msg::Json(v) => match v["type"].as_str() {
                Some("step") => stepped = true,
                Some("done") => return v,
                Some("error") => panic!("server error: {v}"),
                _ => {}
            },
            Msg::Binary(1, 0, ..) if stepped => {
                stepped = false;
                let d = decisions.get(next).copied().unwrap_or(Decision::Stop);
                next += 1;
                send(ws, &format!(r#"{{"action":"{}"}}"#, d.name())).await;
            }
            Msg::Binary(..) => {}
        }
    }
}

/// The house the serve tests share (`serve`, `serve_campaign`, `serve_campaign_browser`):
/// one generated house, baked, with one episode of each task on it (PointGoal, ObjectGoal,
/// RoomGoal, split `val`), their episode file and the oracle's run over them with
/// [`run_config`] and MINOS's sensors at 32². Read-only, like [`super::SharedHouses`].
pub struct OracleHouse {
    /// The baked DATA folder.
    pub data: minos::store::DataDir,
    /// One episode per task.
    pub episodes: Vec<minos::episode::Episode>,
    /// `episodes` as an episode file.
    pub episodes_file: std::path::PathBuf,
    /// The oracle's run folder.
    pub oracle_dir: std::path::PathBuf,
    /// The oracle's decisions per episode id, read back from its run.
    pub oracle: std::collections::HashMap<String, Vec<Decision>>,
}

/// [`OracleHouse`], built once per test run.
pub fn oracle_house() -> &'static OracleHouse {
    static HOUSE: std::sync::OnceLock<OracleHouse> = std::sync::OnceLock::new();
    HOUSE.get_or_init(|| {
        let houses = super::shared_baked_houses(&minos::generate::GenerateConfig {
            houses: 1,
            seed: 5,
            rooms: (3, 4),
            levels: (1, 1),
            closed_door_prob: 0.0,
            ..Default::default()
        });
        let episodes = super::every_task_episodes(&houses.data, &houses.scenes("val"), 1, 3);
        assert_eq!(episodes.len(), 3, "one episode per task");
        let out = super::shared_tempdir().keep();
        let oracle_dir = out.join("oracle");
        let report = minos::pipeline::rollout::rollout(
            &run_config(
                &houses.data,
                &oracle_dir,
                minos::pipeline::rollout::AgentKind::Oracle,
                minos::sim::SensorSuite::minos(32),
            ),
            &episodes,
            &minos::progress::NoProgress,
        )
        .expect("oracle run");
        assert!(report.failures.is_empty(), "{:?}", report.failures);
        let oracle = minos::io::tables::read_replay(&oracle_dir.join("trajectories.parquet"))
            .expect("oracle steps");
        let episodes_file = out.join("episodes.parquet");
        minos::episode::format::write_episodes(&episodes_file, &episodes).expect("episode file");
        OracleHouse {
            data: houses.data.clone(),
            episodes,
            episodes_file,
            oracle_dir,
            oracle,
        }
    })
}

/// The run a session's recording is compared with: Habitat's body, `sensors`, the CPU
/// renderer, seed 0, MINOS's reward, raw images, plain Parquet (what the serve fixtures'
/// servers record with).
pub fn run_config(
    data: &minos::store::DataDir,
    out: &std::path::Path,
    agent: minos::pipeline::rollout::AgentKind,
    sensors: minos::sim::SensorSuite,
) -> minos::pipeline::rollout::RunConfig {
    minos::pipeline::rollout::RunConfig {
        batch: None,
        data: data.clone(),
        out: out.to_path_buf(),
        agent,
        agent_config: minos::sim::AgentConfig::habitat(),
        sensors,
        renderer: minos::render::RendererChoice::Cpu,
        max_steps: None,
        seed: 0,
        shard: minos::shard::Shard::ALL,
        resume: false,
        reward: minos::run::metrics::Reward::DistTime,
        encoding: minos::io::image_codec::ImageEncoding::Raw,
        lerobot: false,
        lerobot_video: None,
        rerun: None,
        allow_body_mismatch: false,
        provenance: Default::default(),
    }
}

/// Rate limits for scripted clients, which answer each frame at once, faster than a
/// person's keys (the rate-limit tests set their own).
pub const SCRIPTED_RATE: minos::serve::rate::RateLimits = minos::serve::rate::RateLimits {
    messages_per_second: 10_000,
    sessions_per_minute: 10_000,
};
