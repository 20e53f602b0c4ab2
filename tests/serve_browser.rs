//! `minos serve` in a real browser: headless Chromium (Debian's `chromium`; `.ci/run` installs
//! it when root) loads the page, the test presses keys through the DevTools protocol
//! (`Input.dispatchKeyEvent`, as a person's key presses arrive), reaches the goal of an
//! episode on a generated house and stops there; the page shows success, and the session's
//! recorded tables are the oracle's (whose actions the keys were) and replay byte for byte.
//! Without Chromium the test says it skipped and why. `MINOS_SCREENSHOT=FILE` saves a
//! screenshot of the page at the goal.

use crate::common;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use common::baked_houses;
use common::browser::{chromium, key_of, launch, Cdp};
use minos::body::AgentPreset;
use minos::episode::sample::SampleConfig;
use minos::episode::Task;
use minos::generate::GenerateConfig;
use minos::io::image_codec::ImageEncoding;
use minos::io::run_dir::PLAYED;
use minos::io::tables::read_replay;
use minos::pipeline::rollout::{rollout, AgentKind, Provenance, RunConfig};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::agents::Decision;
use minos::run::metrics::Reward;
use minos::serve::frames::FrameFormat;
use minos::serve::rate::RateLimits;
use minos::serve::session::Shared;
use minos::serve::{start, ServeConfig};
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use serde_json::{json, Value};

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
            ..Default::default()
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
        agent_config: body,
        sensors: sensors.clone(),
        renderer: RendererChoice::Cpu,
        max_steps: None,
        seed: 0,
        shard: Shard::ALL,
        resume: false,
        reward: Reward::DistTime,
        encoding: ImageEncoding::Raw,
        lerobot: false,
        lerobot_video: None,
        rerun: None,
        allow_body_mismatch: false,
        provenance: Provenance::default(),
    };
    // The oracle's actions are the keys to press.
    let oracle_dir = dir.path().join("oracle");
    rollout(
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
                agent_config: body,
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
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let name = rt.block_on(async {
        let mut cdp = Cdp::first_page(port).await;
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
    rollout(
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
