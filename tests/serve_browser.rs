//! `minos serve` in a real browser: headless Chromium (Debian's `chromium`; `.ci/run` installs
//! it when root) loads the page, the test presses keys through the DevTools protocol
//! (`Input.dispatchKeyEvent`, as a person's key presses arrive), reaches the goal of an
//! episode on a generated house and stops there; the page shows success, and the session's
//! recorded tables are the oracle's (whose actions the keys were) and replay byte for byte.
//! Without Chromium the test says it skipped and why. `MINOS_SCREENSHOT=FILE` saves a
//! screenshot of the page at the goal.

mod common;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::baked_houses;
use common::serve::{http, Ws};
use futures_util::{SinkExt, StreamExt};
use minos::body::AgentPreset;
use minos::episode::sample::SampleConfig;
use minos::episode::Task;
use minos::generate::GenerateConfig;
use minos::io::tables::{read_replay, ImageEncoding};
use minos::pipeline::rollout::{run, AgentKind, Provenance, RunConfig, PLAYED};
use minos::progress::NoProgress;
use minos::run::agents::Decision;
use minos::run::metrics::Reward;
use minos::serve::{start, FrameFormat, RateLimits, ServeConfig, Shared};
use minos::shard::Shard;
use minos::sim::{AgentConfig, RendererChoice, SensorSuite};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

/// The Chromium binary: `MINOS_CHROMIUM`, or `chromium` / `chromium-browser` on the PATH.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MINOS_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// Kills the browser when the test ends, however it ends.
struct Browser(Child);

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A DevTools protocol connection to one page.
struct Cdp {
    ws: Ws,
    next: u64,
}

impl Cdp {
    async fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let id = self.next;
        let msg = json!({"id": id, "method": method, "params": params}).to_string();
        self.ws.send(Message::Text(msg.into())).await.expect("send");
        loop {
            let m = tokio::time::timeout(Duration::from_secs(60), self.ws.next())
                .await
                .expect("DevTools answers")
                .expect("open")
                .expect("message");
            if let Message::Text(t) = m {
                let v: Value = serde_json::from_str(t.as_str()).expect("JSON");
                if v["id"] == id {
                    assert!(v.get("error").is_none(), "{method}: {v}");
                    return v["result"].clone();
                }
            }
        }
    }

    /// Evaluates `expr` in the page and returns its value.
    async fn eval(&mut self, expr: &str) -> Value {
        let r = self
            .call(
                "Runtime.evaluate",
                json!({"expression": expr, "returnByValue": true}),
            )
            .await;
        r["result"]["value"].clone()
    }

    /// Polls `expr` until it is true (fails the test after 60 s).
    async fn until(&mut self, expr: &str) {
        let t = Instant::now();
        while self.eval(expr).await != Value::Bool(true) {
            assert!(t.elapsed() < Duration::from_secs(60), "never true: {expr}");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// Presses and releases a key as a keyboard would.
    async fn press(&mut self, key: &str, code: &str, key_code: u32) {
        let text = if key.chars().count() == 1 { key } else { "" };
        for kind in ["keyDown", "keyUp"] {
            self.call(
                "Input.dispatchKeyEvent",
                json!({"type": kind, "key": key, "code": code, "text": if kind == "keyDown" { text } else { "" },
                       "windowsVirtualKeyCode": key_code, "nativeVirtualKeyCode": key_code}),
            )
            .await;
        }
    }
}

/// The key the page maps to a decision.
fn key_of(d: &Decision) -> (&'static str, &'static str, u32) {
    match d.name().as_str() {
        "forward" => ("ArrowUp", "ArrowUp", 38),
        "backward" => ("ArrowDown", "ArrowDown", 40),
        "turn_left" => ("ArrowLeft", "ArrowLeft", 37),
        "turn_right" => ("ArrowRight", "ArrowRight", 39),
        "strafe_left" => ("q", "KeyQ", 81),
        "strafe_right" => ("e", "KeyE", 69),
        "look_up" => ("r", "KeyR", 82),
        "look_down" => ("f", "KeyF", 70),
        "stop" => (" ", "Space", 32),
        other => panic!("no key for {other}"),
    }
}

/// Starts Chromium on `url`; returns it and its DevTools port.
fn launch(browser: &Path, profile: &Path, url: &str) -> (Browser, u16) {
    let mut child = Command::new(browser)
        .args([
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-extensions",
            "--window-size=1280,1000",
            "--remote-debugging-port=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromium starts");
    // Chromium writes its port into the profile's DevToolsActivePort.
    let t = Instant::now();
    let port = loop {
        if let Ok(text) = std::fs::read_to_string(profile.join("DevToolsActivePort")) {
            if let Some(p) = text.lines().next().and_then(|l| l.trim().parse().ok()) {
                break p;
            }
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("chromium exited: {status}");
        }
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "chromium gave no DevTools port"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    (Browser(child), port)
}

#[test]
fn a_person_in_chromium_reaches_the_goal_and_the_demo_replays() {
    let Some(browser) = chromium() else {
        common::skip(
            "no Chromium (install Debian's `chromium` package, as .ci/run does when root, or \
             set MINOS_CHROMIUM)",
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (data, ids) = baked_houses(
        dir.path(),
        &GenerateConfig {
            houses: 1,
            seed: 8,
            rooms: (3, 4),
            levels: (1, 1),
            closed_door_prob: 0.0,
        },
    );
    let body = AgentConfig::habitat();
    let episodes = minos::pipeline::episodes::sample_scenes(
        &data,
        &[(ids[0].clone(), "val".into())],
        &SampleConfig {
            task: Task::ObjectGoal,
            per_scene: 1,
            seed: 4,
            ..Default::default()
        },
        minos::body::BodyRule::strict(body.body),
        Shard::ALL,
        &NoProgress,
    )
    .episodes;
    assert_eq!(episodes.len(), 1);
    let sensors = SensorSuite::minos(128);
    let cfg = |out: PathBuf, agent| RunConfig {
        batch: None,
        data: data.clone(),
        out,
        agent,
        body,
        sensors: sensors.clone(),
        renderer: RendererChoice::Cpu,
        max_steps: None,
        seed: 0,
        shard: Shard::ALL,
        resume: false,
        reward: Reward::DistTime,
        encoding: ImageEncoding::Raw,
        lerobot: false,
        lerobot_video: false,
        rerun: None,
        allow_body_mismatch: false,
        provenance: Provenance::default(),
    };
    // The oracle's actions are the keys to press.
    let oracle_dir = dir.path().join("oracle");
    run(
        &cfg(oracle_dir.clone(), AgentKind::Oracle),
        &episodes,
        &NoProgress,
    )
    .unwrap();
    let decisions = read_replay(&oracle_dir.join("trajectories.parquet")).unwrap()
        [&episodes[0].episode_id]
        .clone();
    assert_eq!(decisions.last(), Some(&Decision::Stop));
    let out = dir.path().join("demos");
    let running = start(
        ServeConfig {
            shared: Shared {
                data: data.clone(),
                episodes: episodes.clone(),
                episodes_file: None,
                scenes: ids.clone(),
                out: out.clone(),
                preset: AgentPreset::Habitat,
                body,
                sensors: sensors.clone(),
                renderer: RendererChoice::Cpu,
                reward: Reward::DistTime,
                encoding: ImageEncoding::Raw,
                seed: 0,
                idle: Duration::from_secs(120),
                command: vec!["minos".into(), "serve".into()],
                variant: None,
                // JPEG frames, as people get them: the page decodes them.
                frames: FrameFormat::default(),
            },
            access_token: Some("browser-test".into()),
            max_sessions: 2,
            connect_timeout: Duration::from_secs(30),
            send_timeout: Duration::from_secs(10),
            allowed_hosts: Vec::new(),
            rate: RateLimits::default(),
        },
        "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
    )
    .unwrap();
    let url = format!(
        "http://{}/?access=browser-test&episode={}&autostart=1&path=1",
        running.addr, episodes[0].episode_id
    );
    let profile = dir.path().join("chromium-profile");
    let (_browser, port) = launch(&browser, &profile, &url);
    let devtools: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let (_, targets) = http(devtools, "GET", "/json/list", &[], None);
    let targets: Value = serde_json::from_str(&targets).expect("DevTools targets");
    let page = targets
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["type"] == "page")
        .expect("a page")["webSocketDebuggerUrl"]
        .as_str()
        .unwrap()
        .to_string();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let name = rt.block_on(async {
        let (ws, _) = tokio_tungstenite::connect_async(page)
            .await
            .expect("DevTools socket");
        let mut cdp = Cdp { ws, next: 0 };
        cdp.until("window.minos && window.minos.step !== null && window.minos.frames > 0")
            .await;
        let text = cdp
            .eval("document.getElementById('instruction').textContent")
            .await;
        assert!(text.as_str().unwrap().starts_with("Find "), "{text}");
        // Depth and semantic views on (keys 1 and 2): they come with the next frames.
        cdp.press("1", "Digit1", 49).await;
        cdp.press("2", "Digit2", 50).await;
        for d in &decisions {
            if *d == Decision::Stop {
                let shown = cdp
                    .eval("document.getElementById('atgoal').textContent")
                    .await;
                assert!(shown.as_str().unwrap().starts_with("yes"), "{shown}");
                if let Some(file) = std::env::var_os("MINOS_SCREENSHOT") {
                    let shot = cdp
                        .call("Page.captureScreenshot", json!({"format": "png"}))
                        .await;
                    use base64::Engine as _;
                    let png = base64::engine::general_purpose::STANDARD
                        .decode(shot["data"].as_str().unwrap())
                        .unwrap();
                    std::fs::write(file, png).unwrap();
                }
            }
            let frames = cdp.eval("window.minos.frames").await.as_u64().unwrap();
            let (key, code, kc) = key_of(d);
            cdp.press(key, code, kc).await;
            if *d == Decision::Stop {
                cdp.until("window.minos.results.length === 1").await;
            } else {
                cdp.until(&format!("window.minos.frames > {frames}")).await;
            }
        }
        let result = cdp.eval("window.minos.results[0].metrics.success").await;
        assert_eq!(result, Value::Bool(true));
        let shown = cdp
            .eval("document.getElementById('result').textContent")
            .await;
        assert!(shown.as_str().unwrap().starts_with("Success!"), "{shown}");
        let latency = cdp.eval("window.minos.latencies.length").await;
        assert_eq!(latency.as_u64(), Some(decisions.len() as u64 - 1));
        let depth_shown = cdp
            .eval("!document.getElementById('fig-depth').classList.contains('off')")
            .await;
        assert_eq!(depth_shown, Value::Bool(true));
        cdp.eval("window.minos.session")
            .await
            .as_str()
            .unwrap()
            .to_string()
    });
    drop(_browser);
    // The browser is gone: its session ends.
    let t = Instant::now();
    while running.sessions() > 0 {
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "the session did not end"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let session = out.join(&name);
    let read = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    for file in [
        "trajectories.parquet",
        "observations.parquet",
        "episodes.parquet",
    ] {
        assert!(
            read(session.join(file)) == read(oracle_dir.join(file)),
            "{file}: the key presses did not record the oracle's episode"
        );
    }
    let played = minos::episode::format::read_episodes(&session.join(PLAYED)).unwrap();
    let steps = read_replay(&session.join("trajectories.parquet")).unwrap();
    let replay_dir = dir.path().join("replay");
    run(
        &cfg(replay_dir.clone(), AgentKind::Replay(steps)),
        &played,
        &NoProgress,
    )
    .unwrap();
    for file in [
        "trajectories.parquet",
        "observations.parquet",
        "episodes.parquet",
        "metrics.json",
    ] {
        assert!(
            read(session.join(file)) == read(replay_dir.join(file)),
            "{file}: replay differs"
        );
    }
    running.stop();
}
