//! `minos serve` without a browser: a session driven over its WebSocket records exactly what
//! `minos run` writes (the oracle's actions sent as key presses give the oracle's tables, and
//! replaying the session gives the session's), sessions are isolated, tokens and the access
//! token are enforced, no request reaches a file outside DATA and the output folder, a
//! vanished or idle page frees its simulator, and a server killed mid-episode leaves the
//! finished episodes complete.

use crate::common;

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::serve::{connect, create, http, play, recv, run_config, send, Msg, SCRIPTED_RATE};
use common::{minos, RunOk};
use minos::body::AgentPreset;
use minos::episode::format::read_episodes;
use minos::episode::Episode;
use minos::io::image_codec::ImageEncoding;
use minos::io::run_dir::PLAYED;
use minos::io::tables::read_replay;
use minos::pipeline::rollout::{rollout, AgentKind, RunConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::agents::Decision;
use minos::run::metrics::Reward;
use minos::serve::frames::FrameFormat;
use minos::serve::rate::RateLimits;
use minos::serve::session::Shared;
use minos::serve::{start, Running, ServeConfig, ServeError};
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

/// Files a run writes that must match byte for byte (the manifest names the agent).
const TABLES: [&str; 4] = [
    "trajectories.parquet",
    "observations.parquet",
    "episodes.parquet",
    "metrics.json",
];

/// The shared house ([`common::serve::oracle_house`]) and a folder for this file's outputs.
struct Fixture {
    dir: tempfile::TempDir,
    data: DataDir,
    episodes: Vec<Episode>,
    /// The episodes as an episode file.
    episodes_file: &'static Path,
    /// The oracle's run folder.
    oracle_dir: &'static Path,
    /// The oracle's decisions per episode (from its own run, in `oracle_dir`).
    oracle: &'static HashMap<String, Vec<Decision>>,
}

fn sensors() -> SensorSuite {
    SensorSuite::minos(32)
}

/// One generated house, baked; one episode of each task on it; the oracle run over them
/// (shared with the campaign tests), and this file's output folder.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let house = common::serve::oracle_house();
        Fixture {
            dir: common::shared_tempdir(),
            data: house.data.clone(),
            episodes: house.episodes.clone(),
            episodes_file: &house.episodes_file,
            oracle_dir: &house.oracle_dir,
            oracle: &house.oracle,
        }
    })
}

fn shared(f: &Fixture, out: &Path, idle: Duration) -> Shared {
    Shared {
        data: f.data.clone(),
        episodes: f.episodes.clone(),
        episodes_file: None,
        scenes: f.data.ingested_ids().expect("ids"),
        out: out.to_path_buf(),
        preset: AgentPreset::Habitat,
        agent_config: AgentConfig::habitat(),
        sensors: sensors(),
        renderer: RendererChoice::Cpu,
        reward: Reward::DistTime,
        encoding: ImageEncoding::Raw,
        seed: 0,
        idle,
        command: vec!["minos".into(), "serve".into()],
        variant: None,
        frames: FrameFormat::default(),
    }
}

fn serve_config(f: &Fixture, out: &Path, access: Option<&str>, idle: Duration) -> ServeConfig {
    ServeConfig {
        shared: shared(f, out, idle),
        access_token: access.map(str::to_string),
        max_sessions: 4,
        connect_timeout: Duration::from_millis(800),
        send_timeout: Duration::from_secs(5),
        allowed_hosts: Vec::new(),
        rate: SCRIPTED_RATE,
    }
}

fn server(f: &Fixture, out: &Path, access: Option<&str>, idle: Duration) -> Running {
    start(
        serve_config(f, out, access, idle),
        "127.0.0.1:0".parse().unwrap(),
    )
    .expect("server starts")
}

/// A raw HTTP/1.1 request with `host` as its `Host`; the status and the response's head
/// (status line and headers, lowercase).
fn head(addr: SocketAddr, target: &str, host: &str) -> (u16, String) {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    write!(
        s,
        "GET {target} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).to_string();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let head = text.split("\r\n\r\n").next().unwrap_or("").to_lowercase();
    (status, head)
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
}

/// Waits up to 20 s for `running` to hold `n` sessions.
fn sessions_become(running: &Running, n: usize) {
    let t = Instant::now();
    while running.sessions() != n {
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "{} sessions, not {n}",
            running.sessions()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn a_session_records_what_minos_run_writes_and_replays_byte_for_byte() {
    let f = fixture();
    let out = f.dir.path().join("demos-replay");
    let running = server(f, &out, None, Duration::from_secs(60));
    let addr = running.addr;
    let (token, name) = create(addr, r#"{"episode":null}"#, &[]);
    // A second session at the same time: its own simulator and counters.
    let (other, other_name) = create(
        addr,
        &format!(r#"{{"episode":"{}"}}"#, f.episodes[0].episode_id),
        &[],
    );
    assert_ne!(name, other_name);
    runtime().block_on(async {
        let mut ws = connect(addr, &token, "").await;
        let mut bystander = connect(addr, &other, "").await;
        send(&mut bystander, r#"{"action":"turn_left"}"#).await;
        // Every episode of the file, in file order, with the oracle's actions as key presses.
        for (i, ep) in f.episodes.iter().enumerate() {
            if i > 0 {
                send(&mut ws, r#"{"next":null}"#).await;
            }
            let done = play(&mut ws, &f.oracle[&ep.episode_id]).await;
            assert_eq!(done["episode_id"], ep.episode_id.as_str());
            assert_eq!(done["metrics"]["success"], true, "{done}");
            assert_eq!(done["played"], i + 1);
        }
        // The bystander's first step is still step 0 plus its one turn: untouched.
        let mut steps = Vec::new();
        while steps.len() < 2 {
            if let Some(Msg::Json(v)) = recv(&mut bystander).await {
                if v["type"] == "step" {
                    steps.push(v["step"].as_u64().expect("step"));
                }
            }
        }
        assert_eq!(steps, vec![0, 1]);
        send(&mut ws, r#"{"end":true}"#).await;
        send(&mut bystander, r#"{"end":true}"#).await;
        while recv(&mut ws).await.is_some() {}
    });
    sessions_become(&running, 0);
    let session = out.join(&name);
    // The oracle's key presses gave the oracle's tables.
    for file in TABLES {
        assert!(
            bytes(&session.join(file)) == bytes(&f.oracle_dir.join(file)),
            "{file} differs from the oracle run's"
        );
    }
    let manifest: serde_json::Value =
        serde_json::from_slice(&bytes(&session.join("manifest.json"))).expect("manifest");
    assert_eq!(manifest["agent"], format!("human:{name}").as_str());
    assert!(
        !session.join(".parts").exists(),
        "parts are removed at the end"
    );
    // The bystander ended mid-episode: nothing finished, nothing written as a table.
    assert!(!out.join(&other_name).join("trajectories.parquet").exists());
    // `minos run --agent replay:` over the session's played episodes gives the same bytes.
    let played = read_episodes(&session.join(PLAYED)).expect("played episodes");
    assert_eq!(played, f.episodes);
    let replay_dir = f.dir.path().join("replay");
    let steps = read_replay(&session.join("trajectories.parquet")).expect("session steps");
    rollout(
        &run_config(&f.data, &replay_dir, AgentKind::Replay(steps), sensors()),
        &played,
        &NoProgress,
    )
    .expect("replay run");
    for file in TABLES {
        assert!(
            bytes(&session.join(file)) == bytes(&replay_dir.join(file)),
            "{file}: replay differs"
        );
    }
    // And the LeRobot export takes it as it is.
    minos::io::lerobot::write_dataset(
        &minos::io::lerobot::source::RunTables::in_dir(&session),
        &f.dir.path().join("lerobot"),
        &minos::io::lerobot::DatasetOptions {
            fps: 10,
            robot_type: "human".into(),
            run: None,
            video: None,
        },
        &NoProgress,
    )
    .expect("LeRobot export of a session");
    running.stop();
}

#[test]
fn tokens_access_and_origins_are_enforced() {
    let f = fixture();
    let out = f.dir.path().join("demos-tokens");
    let running = server(f, &out, Some("s3cret"), Duration::from_secs(60));
    let a = running.addr;
    let host = a.to_string();
    assert_eq!(http(a, "GET", "/", &[], None).0, 401);
    assert_eq!(http(a, "GET", "/?access=s3cre", &[], None).0, 401);
    assert_eq!(
        http(a, "GET", "/api/info", &[("x-minos-access", "nope")], None).0,
        401
    );
    let (status, page) = http(a, "GET", "/?access=s3cret", &[], None);
    assert_eq!(status, 200);
    assert!(
        page.contains("<canvas") && page.contains("api/sessions"),
        "the page, inlined"
    );
    assert!(
        !page.contains("http://") && !page.contains("https://"),
        "nothing from elsewhere"
    );
    let auth = [("x-minos-access", "s3cret")];
    let (status, info) = http(a, "GET", "/api/info", &auth, None);
    assert_eq!(status, 200);
    let info: serde_json::Value = serde_json::from_str(&info).unwrap();
    assert_eq!(info["episodes"].as_array().unwrap().len(), 3);
    assert_eq!(info["preset"], "habitat");
    assert_eq!(info["frames"], "jpeg");
    // Another origin cannot create sessions.
    let evil = [
        ("x-minos-access", "s3cret"),
        ("Origin", "http://evil.example"),
    ];
    assert_eq!(http(a, "POST", "/api/sessions", &evil, Some("{}")).0, 403);
    let same = format!("http://{host}");
    let ok = [("x-minos-access", "s3cret"), ("Origin", same.as_str())];
    let (token, _) = create(a, "{}", &ok);
    assert_eq!(token.len(), 64);
    runtime().block_on(async {
        // Without the access token, the socket is refused; a made-up token is unknown.
        let url = format!("ws://{a}/api/sessions/{token}/ws");
        assert!(tokio_tungstenite::connect_async(url).await.is_err());
        let fake = "0".repeat(64);
        let url = format!("ws://{a}/api/sessions/{fake}/ws?access=s3cret");
        assert!(tokio_tungstenite::connect_async(url).await.is_err());
        let mut ws = connect(a, &token, "?access=s3cret").await;
        match recv(&mut ws).await {
            Some(Msg::Json(v)) => assert_eq!(v["type"], "episode"),
            other => panic!("{other:?}"),
        }
        // One socket per session.
        let url = format!("ws://{a}/api/sessions/{token}/ws?access=s3cret");
        assert!(tokio_tungstenite::connect_async(url).await.is_err());
        send(&mut ws, r#"{"action":"fly"}"#).await;
        loop {
            if let Some(Msg::Json(v)) = recv(&mut ws).await {
                if v["type"] == "error" {
                    assert!(v["message"].as_str().unwrap().contains("fly"), "{v}");
                    break;
                }
            }
        }
        // Too many sessions: the fifth is refused (4 at most; this one is live).
        for _ in 0..3 {
            create(a, "{}", &auth);
        }
        assert_eq!(http(a, "POST", "/api/sessions", &auth, Some("{}")).0, 503);
        // Sessions whose socket never connects are dropped; this one goes on.
        sessions_become(&running, 1);
    });
    // Its socket closed with the runtime: it ends too.
    sessions_become(&running, 0);
    running.stop();
}

#[test]
fn no_request_reaches_outside_data_and_the_output_folder() {
    let f = fixture();
    let root = tempfile::tempdir().unwrap();
    // A copy of the DATA folder whose one scene file is a link to a file outside it.
    let data = root.path().join("DATA");
    copy_tree(f.data.root(), &data);
    let id = f.data.ingested_ids().unwrap()[0].clone();
    let scene_file = DataDir::new(&data).scene_path(&id);
    let outside = root.path().join("outside.mscene");
    std::fs::rename(&scene_file, &outside).unwrap();
    std::os::unix::fs::symlink(&outside, &scene_file).unwrap();
    let secret = root.path().join("secret.txt");
    std::fs::write(&secret, "TOP-SECRET").unwrap();
    let out = root.path().join("demos");
    let mut s = shared(f, &out, Duration::from_secs(60));
    s.data = DataDir::new(&data);
    let running = start(
        ServeConfig {
            shared: s,
            access_token: None,
            max_sessions: 4,
            connect_timeout: Duration::from_secs(5),
            send_timeout: Duration::from_secs(5),
            allowed_hosts: Vec::new(),
            rate: SCRIPTED_RATE,
        },
        "127.0.0.1:0".parse().unwrap(),
    )
    .unwrap();
    let a = running.addr;
    let secret_s = secret.display().to_string();
    let enc = secret_s.replace('/', "%2f");
    let targets = [
        "/../secret.txt".to_string(),
        "/../../../../../../etc/passwd".into(),
        "/%2e%2e/%2e%2e/etc/passwd".into(),
        "/..%2f..%2f..%2fetc%2fpasswd".into(),
        format!("/{enc}"),
        format!("/{secret_s}"),
        "//etc/passwd".into(),
        "/api/../../etc/passwd".into(),
        "/api/sessions/..%2f..%2fetc%2fpasswd/ws".into(),
        "/api/sessions/../../../etc/passwd/ws".into(),
        "/api/info/../../secret.txt".into(),
        "/%252e%252e/secret.txt".into(),
    ];
    for t in &targets {
        let (status, body) = http(a, "GET", t, &[], None);
        assert!(status == 404 || status == 400, "{t}: {status}");
        assert!(
            !body.contains("TOP-SECRET") && !body.contains("root:"),
            "{t}"
        );
    }
    for body in [
        r#"{"scene":"../../secret"}"#.to_string(),
        r#"{"scene":"/etc/passwd"}"#.into(),
        format!(r#"{{"scene":"{}"}}"#, secret_s),
        r#"{"scene":"..%2f..%2fsecret"}"#.into(),
        r#"{"episode":"../../secret"}"#.into(),
        r#"{"out":"/tmp/x"}"#.into(),
    ] {
        let (status, reply) = http(a, "POST", "/api/sessions", &[], Some(&body));
        assert!(
            status == 404 || status == 400 || status == 422,
            "{body}: {status} {reply}"
        );
    }
    // The scene whose file links out of DATA is refused, naming the file.
    let (status, reply) = http(
        a,
        "POST",
        "/api/sessions",
        &[],
        Some(&format!(r#"{{"scene":"{id}"}}"#)),
    );
    assert_eq!(status, 403, "{reply}");
    assert!(reply.contains("outside the DATA folder"), "{reply}");
    running.stop();
    // Nothing was written beside DATA and the output folder.
    let mut names: Vec<String> = std::fs::read_dir(root.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    names.sort();
    assert_eq!(names, ["DATA", "demos", "outside.mscene", "secret.txt"]);
    assert_eq!(
        std::fs::read_dir(&out).unwrap().count(),
        0,
        "no session folder"
    );
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// The session's `end` message, read until the server closes the socket (`None` without one).
async fn end_message(ws: &mut common::serve::Ws) -> Option<serde_json::Value> {
    let mut end = None;
    while let Some(m) = recv(ws).await {
        if let Msg::Json(v) = m {
            if v["type"] == "end" {
                end = Some(v);
            }
        }
    }
    end
}

#[test]
fn a_vanished_or_idle_page_frees_its_simulator() {
    let f = fixture();
    let out = f.dir.path().join("demos-vanish");
    let running = server(f, &out, None, Duration::from_secs(1));
    let a = running.addr;
    // Vanished: the socket's connection is dropped without a close.
    let (token, _) = create(a, "{}", &[]);
    runtime().block_on(async {
        let mut ws = connect(a, &token, "").await;
        while !matches!(recv(&mut ws).await, Some(Msg::Binary(1, ..))) {}
        drop(ws);
    });
    sessions_become(&running, 0);
    // Idle: connected, never presses a key; the session ends and says so.
    let (token, name) = create(a, "{}", &[]);
    let t = Instant::now();
    runtime().block_on(async {
        let mut ws = connect(a, &token, "").await;
        let end = end_message(&mut ws)
            .await
            .expect("the page hears that the session ended");
        assert!(
            end["episodes"] == 0 && end["session"] == name.as_str(),
            "{end}"
        );
    });
    assert!(t.elapsed() < Duration::from_secs(15));
    sessions_become(&running, 0);
    // Never connected: dropped after the connect timeout.
    create(a, "{}", &[]);
    assert_eq!(running.sessions(), 1);
    sessions_become(&running, 0);
    running.stop();
}

#[test]
fn a_page_that_says_end_frees_its_session_at_once_even_with_its_socket_open() {
    let f = fixture();
    let out = f.dir.path().join("demos-end");
    // An idle time far beyond the test's wait: only `end` can end the session in time.
    let running = server(f, &out, None, Duration::from_secs(120));
    let a = running.addr;
    let (token, name) = create(a, "{}", &[]);
    let t = runtime().block_on(async {
        let mut ws = connect(a, &token, "").await;
        while !matches!(recv(&mut ws).await, Some(Msg::Binary(1, ..))) {}
        let t = Instant::now();
        send(&mut ws, r#"{"end":true}"#).await;
        // The socket stays open on this side; the server says the session ended and closes.
        let end = end_message(&mut ws)
            .await
            .expect("the page hears that the session ended");
        assert_eq!(end["session"], name.as_str(), "{end}");
        t
    });
    sessions_become(&running, 0);
    assert!(
        t.elapsed() < Duration::from_secs(10),
        "the session ended {:?} after `end` (idle time 120 s)",
        t.elapsed()
    );
    running.stop();
}

#[test]
fn a_server_killed_mid_episode_leaves_the_finished_episodes_whole() {
    use std::io::BufRead;
    let f = fixture();
    let out = f.dir.path().join("demos-killed");
    let episodes = f.episodes_file;
    let mut child = minos()
        .args(["serve", "--bind", "127.0.0.1:0", "--size", "32", "--data"])
        .arg(f.data.root())
        .arg("--episodes")
        .arg(episodes)
        .arg("--out")
        .arg(&out)
        .args(["--reward", "geodesic", "--seed", "7"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("minos serve starts");
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let addr: SocketAddr = loop {
        let line = lines.next().expect("a line").expect("text");
        if let Some(rest) = line.trim().strip_prefix("open http://") {
            break rest.split('/').next().unwrap().parse().expect("address");
        }
    };
    let (token, name) = create(addr, "{}", &[]);
    let first = &f.episodes[0];
    runtime().block_on(async {
        let mut ws = connect(addr, &token, "").await;
        let done = play(&mut ws, &f.oracle[&first.episode_id]).await;
        assert_eq!(done["metrics"]["success"], true);
        send(&mut ws, r#"{"next":null}"#).await;
        // A few steps into the second episode, then the server dies.
        let mut steps = 0;
        while steps < 3 {
            if let Some(Msg::Binary(1, ..)) = recv(&mut ws).await {
                steps += 1;
                send(&mut ws, r#"{"action":"turn_left"}"#).await;
            }
        }
        child.kill().expect("kill -9");
        child.wait().unwrap();
    });
    let session = out.join(&name);
    // Killed: the finished episode is in its parts, and no table looks complete.
    assert!(session.join(".parts").is_dir());
    assert!(!session.join("trajectories.parquet").exists());
    // The next start on the same output folder writes the session's outputs from the
    // finished episode (before it listens) and removes the parts.
    let mut again = minos()
        .args(["serve", "--bind", "127.0.0.1:0", "--size", "32", "--data"])
        .arg(f.data.root())
        .arg("--episodes")
        .arg(episodes)
        .arg("--out")
        .arg(&out)
        .args(["--reward", "geodesic", "--seed", "7"])
        // A setting that changes no table: the command line differs from the first start's.
        .args(["--max-sessions", "3"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("minos serve starts again");
    let mut lines = std::io::BufReader::new(again.stdout.take().unwrap()).lines();
    while !lines
        .next()
        .expect("a line")
        .expect("text")
        .contains("open http://")
    {}
    again.kill().expect("stop");
    again.wait().unwrap();
    assert!(!session.join(".parts").exists(), "parts removed");
    assert_eq!(
        std::fs::read(session.join(minos::lock::LOCK_FILE)).unwrap(),
        b"",
        "the lock is released"
    );
    // Exactly the finished episode, in whole files.
    let steps = read_replay(&session.join("trajectories.parquet")).expect("readable table");
    assert_eq!(steps.keys().collect::<Vec<_>>(), vec![&first.episode_id]);
    assert_eq!(
        read_episodes(&session.join(PLAYED)).unwrap(),
        vec![first.clone()]
    );
    for file in TABLES {
        assert!(session.join(file).is_file(), "{file}");
    }
    let stray: Vec<String> = std::fs::read_dir(&session)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
    // The manifest names the command that played the episode, not the restart's.
    let manifest: serde_json::Value =
        serde_json::from_slice(&bytes(&session.join("manifest.json"))).expect("manifest");
    let command: Vec<&str> = manifest["command"]
        .as_array()
        .expect("command list")
        .iter()
        .filter_map(|a| a.as_str())
        .collect();
    assert!(
        command.contains(&"--seed") && !command.contains(&"--max-sessions"),
        "{command:?}"
    );
    // Its replay, with the server's --reward and --seed, gives the same tables.
    let replay_dir = f.dir.path().join("replay-killed");
    rollout(
        &RunConfig {
            reward: Reward::Geodesic,
            seed: 7,
            ..run_config(&f.data, &replay_dir, AgentKind::Replay(steps), sensors())
        },
        std::slice::from_ref(first),
        &NoProgress,
    )
    .unwrap();
    for file in TABLES {
        assert!(
            bytes(&session.join(file)) == bytes(&replay_dir.join(file)),
            "{file}"
        );
    }
}

#[test]
fn people_are_offered_exactly_the_presets_actions() {
    let f = fixture();
    let out = f.dir.path().join("demos-actions");
    let running = server(f, &out, None, Duration::from_secs(60));
    let a = running.addr;
    let (status, info) = http(a, "GET", "/api/info", &[], None);
    assert_eq!(status, 200);
    let info: serde_json::Value = serde_json::from_str(&info).unwrap();
    // Habitat's agent: what NavEnv's Discrete(4) and Habitat express.
    assert_eq!(
        info["actions"],
        serde_json::json!(["forward", "turn_left", "turn_right", "stop"])
    );
    let (token, _) = create(a, "{}", &[]);
    runtime().block_on(async {
        let mut ws = connect(a, &token, "").await;
        // Refused, one by one, naming the action and the preset; no step is taken.
        for name in [
            "backward",
            "strafe_left",
            "strafe_right",
            "look_up",
            "look_down",
        ] {
            send(&mut ws, &format!(r#"{{"action":"{name}"}}"#)).await;
        }
        send(&mut ws, r#"{"action":"turn_left"}"#).await;
        let mut errors = Vec::new();
        let mut steps = Vec::new();
        while steps.len() < 2 {
            if let Some(Msg::Json(v)) = recv(&mut ws).await {
                match v["type"].as_str() {
                    Some("error") => errors.push(v["message"].as_str().unwrap().to_string()),
                    Some("step") => steps.push(v["step"].as_u64().unwrap()),
                    _ => {}
                }
            }
        }
        // The turn is the first step taken after step 0: the five before did nothing.
        assert_eq!(steps, vec![0, 1]);
        assert_eq!(errors.len(), 5, "{errors:?}");
        for (e, name) in errors.iter().zip([
            "backward",
            "strafe_left",
            "strafe_right",
            "look_up",
            "look_down",
        ]) {
            assert!(e.contains(name) && e.contains("habitat"), "{e}");
        }
    });
    running.stop();
}

#[test]
fn grids_baked_for_another_body_are_refused_at_start_up() {
    let f = fixture();
    let out = f.dir.path().join("demos-mismatch");
    // The fixture's grids are baked for Habitat's body; MINOS's agent is another body.
    let mut cfg = serve_config(f, &out, None, Duration::from_secs(60));
    cfg.shared.preset = AgentPreset::Minos;
    cfg.shared.agent_config = AgentConfig::preset(AgentPreset::Minos);
    let e = start(cfg, "127.0.0.1:0".parse().unwrap())
        .err()
        .expect("refused");
    assert!(matches!(e, ServeError::NotReady(_)), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("agent preset minos")
            && text.contains("baked for body")
            && !text.contains('\n'),
        "{text}"
    );
    // Only for exploration (no episode file): refused all the same.
    let mut cfg = serve_config(f, &out, None, Duration::from_secs(60));
    cfg.shared.episodes.clear();
    cfg.shared.preset = AgentPreset::MinosGridworld;
    cfg.shared.agent_config = AgentConfig::preset(AgentPreset::MinosGridworld);
    assert!(start(cfg, "127.0.0.1:0".parse().unwrap()).is_err());
    assert!(!out.exists() || std::fs::read_dir(&out).unwrap().count() == 0);
}

#[test]
fn nonsense_settings_are_refused_at_start_up() {
    let f = fixture();
    let out = f.dir.path().join("demos-nonsense");
    let base = || serve_config(f, &out, None, Duration::from_secs(60));
    let cases: Vec<(&str, ServeConfig)> = vec![
        (
            "max sessions 0",
            ServeConfig {
                max_sessions: 0,
                ..base()
            },
        ),
        ("idle timeout", {
            let mut c = base();
            c.shared.idle = Duration::ZERO;
            c
        }),
        ("0×0 pixels", {
            let mut c = base();
            c.shared.sensors = SensorSuite::minos(0);
            c
        }),
        (
            "messages per second",
            ServeConfig {
                rate: RateLimits {
                    messages_per_second: 0,
                    ..RateLimits::default()
                },
                ..base()
            },
        ),
        (
            "sessions per minute",
            ServeConfig {
                rate: RateLimits {
                    sessions_per_minute: 0,
                    ..RateLimits::default()
                },
                ..base()
            },
        ),
        (
            "connect timeout",
            ServeConfig {
                connect_timeout: Duration::ZERO,
                ..base()
            },
        ),
        (
            "access token: empty",
            ServeConfig {
                access_token: Some(String::new()),
                ..base()
            },
        ),
        ("JPEG quality 0", {
            let mut c = base();
            c.shared.frames = FrameFormat::Jpeg(0);
            c
        }),
    ];
    for (says, cfg) in cases {
        let e = start(cfg, "127.0.0.1:0".parse().unwrap())
            .err()
            .unwrap_or_else(|| panic!("{says}: accepted"));
        assert!(matches!(e, ServeError::Setting(_)), "{says}: {e}");
        assert!(e.to_string().contains(says), "{says}: {e}");
    }
}

#[test]
fn only_this_servers_host_names_are_answered() {
    let f = fixture();
    let out = f.dir.path().join("demos-hosts");
    let mut cfg = serve_config(f, &out, None, Duration::from_secs(60));
    cfg.allowed_hosts = vec!["Lab.Example.org".into()];
    let running = start(cfg, "127.0.0.1:0".parse().unwrap()).unwrap();
    let a = running.addr;
    let port = a.port();
    for host in [
        a.to_string(),
        format!("localhost:{port}"),
        format!("lab.example.org:{port}"),
    ] {
        assert_eq!(head(a, "/api/info", &host).0, 200, "{host}");
    }
    // DNS rebinding: the attacker's name resolved to this machine; the browser says so.
    for host in [
        format!("evil.example:{port}"),
        format!("127.0.0.1.evil.example:{port}"),
        String::new(),
    ] {
        let (status, _) = head(a, "/api/info", &host);
        assert_eq!(status, 421, "{host:?}");
    }
    let (status, _) = head(a, "/", &format!("evil.example:{port}"));
    assert_eq!(status, 421);
    running.stop();
}

#[test]
fn pages_and_answers_carry_a_content_security_policy() {
    let f = fixture();
    let out = f.dir.path().join("demos-headers");
    let running = server(f, &out, None, Duration::from_secs(60));
    let a = running.addr;
    let (status, page) = head(a, "/", &a.to_string());
    assert_eq!(status, 200);
    let csp = page
        .lines()
        .find_map(|l| l.strip_prefix("content-security-policy: "))
        .expect("a policy")
        .to_string();
    // The page runs its own script and style, by hash, and nothing else.
    assert!(
        csp.contains("default-src 'none'") && csp.contains("script-src 'sha256-"),
        "{csp}"
    );
    assert!(
        !csp.contains("unsafe-inline") && csp.contains("frame-ancestors 'none'"),
        "{csp}"
    );
    let (_, body) = http(a, "GET", "/", &[], None);
    let script = body
        .split("<script>")
        .nth(1)
        .and_then(|s| s.split("</script>").next())
        .expect("the inline script");
    use base64::Engine as _;
    use sha2::Digest as _;
    let hash = base64::engine::general_purpose::STANDARD.encode(sha2::Sha256::digest(script));
    // (`head` lowercases the response head.)
    let expected = format!("'sha256-{hash}'").to_lowercase();
    assert!(csp.contains(&expected), "the hash is the page's script's");
    for target in ["/", "/api/info", "/nothing-here"] {
        let (_, h) = head(a, target, &a.to_string());
        for expected in [
            "x-content-type-options: nosniff",
            "x-frame-options: deny",
            "referrer-policy: no-referrer",
            "cross-origin-opener-policy: same-origin",
            "content-security-policy: default-src 'none'",
        ] {
            assert!(h.contains(expected), "{target}: {expected}\n{h}");
        }
    }
    running.stop();
}

#[test]
fn new_sessions_and_messages_are_rate_limited_per_token() {
    let f = fixture();
    let out = f.dir.path().join("demos-rate");
    let mut cfg = serve_config(f, &out, Some("s3cret"), Duration::from_secs(60));
    cfg.rate = RateLimits {
        messages_per_second: 5,
        sessions_per_minute: 2,
    };
    let running = start(cfg, "127.0.0.1:0".parse().unwrap()).unwrap();
    let a = running.addr;
    let auth = [("x-minos-access", "s3cret")];
    let (token, _) = create(a, "{}", &auth);
    create(a, "{}", &auth);
    let (status, reply) = http(a, "POST", "/api/sessions", &auth, Some("{}"));
    assert_eq!(status, 429, "{reply}");
    assert!(reply.contains("2 new sessions a minute"), "{reply}");
    runtime().block_on(async {
        let mut ws = connect(a, &token, "?access=s3cret").await;
        // A burst of 2 × 5 messages goes through; the rest of 30 at once are refused.
        for _ in 0..30 {
            send(&mut ws, r#"{"views":[]}"#).await;
        }
        let mut refused = 0;
        while refused < 15 {
            if let Some(Msg::Json(v)) = recv(&mut ws).await {
                if v["type"] == "error" {
                    assert!(
                        v["message"].as_str().unwrap().contains("too many messages"),
                        "{v}"
                    );
                    refused += 1;
                }
            }
        }
        send(&mut ws, r#"{"end":true}"#).await;
    });
    running.stop();
}

/// Plays `episode` on `running` with `decisions`, asking for the semantic view too; returns
/// the label colours the semantic frames showed, the `done` message and the session's name.
fn semantic_colours(
    running: &Running,
    decisions: &[Decision],
) -> (
    std::collections::BTreeSet<[u8; 3]>,
    serde_json::Value,
    String,
) {
    use futures_util::{SinkExt, StreamExt};
    use tokio_tungstenite::tungstenite::Message;
    let (token, name) = create(running.addr, "{}", &[]);
    let mut colours = std::collections::BTreeSet::new();
    let done = runtime().block_on(async {
        let mut ws = connect(running.addr, &token, "").await;
        send(&mut ws, r#"{"views":["semantic"]}"#).await;
        let mut next = 0;
        let mut stepped = false;
        loop {
            let m = tokio::time::timeout(Duration::from_secs(60), ws.next())
                .await
                .expect("a message within 60 s")
                .expect("the session goes on")
                .expect("a message");
            match m {
                Message::Text(t) => {
                    let v: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
                    match v["type"].as_str() {
                        Some("step") => stepped = true,
                        Some("done") => {
                            ws.send(Message::Text(r#"{"end":true}"#.into()))
                                .await
                                .unwrap();
                            while ws.next().await.is_some() {}
                            return v;
                        }
                        Some("error") => panic!("{v}"),
                        _ => {}
                    }
                }
                // The semantic camera (index 2): its pixels' colours.
                Message::Binary(b) if b[0] == 1 && b[1] == 2 => {
                    let img = image::load_from_memory(&b[8..]).expect("a PNG").to_rgb8();
                    colours.extend(img.pixels().map(|p| p.0));
                }
                Message::Binary(b) if b[0] == 1 && b[1] == 0 && stepped => {
                    stepped = false;
                    let d = decisions.get(next).copied().unwrap_or(Decision::Stop);
                    next += 1;
                    send(&mut ws, &format!(r#"{{"action":"{}"}}"#, d.name())).await;
                }
                _ => {}
            }
        }
    });
    (colours, done, name)
}

#[test]
fn a_variant_is_what_sessions_play_record_and_replay() {
    let f = fixture();
    // A copy of the DATA folder with an `empty` variant (furniture removed), baked.
    let root = f.dir.path().join("data-variant");
    copy_tree(f.data.root(), &root);
    let spec = f.dir.path().join("variants.toml");
    std::fs::write(&spec, "[empty]\nempty = true\n").unwrap();
    minos()
        .args(["-q", "variants", "--data"])
        .arg(&root)
        .arg("--spec")
        .arg(&spec)
        .ok_output();
    minos()
        .args(["-q", "bake", "--no-preview", "--variant", "empty", "--data"])
        .arg(&root)
        .ok_output();
    let data = DataDir::new(&root);
    let base = f.episodes[0].clone();
    let on_empty = base.clone().on_variant("empty");
    // A full turn where the episode starts, then stop.
    let turn = Decision::from_name("turn_left").unwrap();
    let turns: Vec<Decision> = std::iter::repeat_n(turn, 36)
        .chain([Decision::Stop])
        .collect();
    let serve = |variant: Option<&str>, episode: &Episode, out: &Path| {
        let mut cfg = serve_config(f, out, None, Duration::from_secs(60));
        cfg.shared.data = data.clone();
        cfg.shared.episodes = vec![episode.clone()];
        cfg.shared.variant = variant.map(str::to_string);
        start(cfg, "127.0.0.1:0".parse().unwrap()).expect("server starts")
    };
    let out_base = f.dir.path().join("demos-variant-base");
    let running = serve(None, &base, &out_base);
    let (furnished, _, _) = semantic_colours(&running, &turns);
    running.stop();
    let out = f.dir.path().join("demos-variant");
    let running = serve(Some("empty"), &on_empty, &out);
    let (empty, done, name) = semantic_colours(&running, &turns);
    running.stop();
    assert_eq!(done["episode_id"], on_empty.episode_id.as_str());
    // The variant's views show fewer label colours: the furniture's are gone, nothing new.
    assert!(
        empty.is_subset(&furnished) && empty.len() < furnished.len(),
        "empty {empty:?} furnished {furnished:?}"
    );
    // Recorded on the variant: its scene id, the manifest's variant, and a replay on the
    // variant gives the same tables byte for byte.
    let session = out.join(&name);
    let played = read_episodes(&session.join(PLAYED)).unwrap();
    assert_eq!(played, vec![on_empty.clone()]);
    assert!(
        played[0].scene_id.ends_with("@empty"),
        "{}",
        played[0].scene_id
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&bytes(&session.join("manifest.json"))).unwrap();
    assert_eq!(manifest["variant"], "empty", "{manifest}");
    let steps = read_replay(&session.join("trajectories.parquet")).unwrap();
    let replay_dir = f.dir.path().join("replay-variant");
    rollout(
        &run_config(&data, &replay_dir, AgentKind::Replay(steps), sensors()),
        &played,
        &NoProgress,
    )
    .unwrap();
    for file in TABLES {
        assert!(
            bytes(&session.join(file)) == bytes(&replay_dir.join(file)),
            "{file}"
        );
    }
}
