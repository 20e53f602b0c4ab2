//! `minos serve --campaign`: participants' links open sessions that play the tutorial and
//! then the episodes the ledger hands out until each has its K accepted demonstrations;
//! every finished episode gets its quality record; the operator's status needs its own
//! token; `minos export-dataset --accepted` takes only accepted demonstrations; and a
//! server killed at any moment, restarted with the same campaign, keeps every finished
//! episode byte for byte, discards the interrupted one without litter and lets the
//! participant come back with the same link.

use crate::common;

use std::collections::BTreeSet;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::serve::{connect, http, play, recv, run_config, send, Msg, Ws, SCRIPTED_RATE};
use common::{minos, RunOk};
use minos::body::AgentPreset;
use minos::episode::format::read_episodes;
use minos::episode::Episode;
use minos::io::image_codec::ImageEncoding;
use minos::io::run_dir::PLAYED;
use minos::io::tables::read_replay;
use minos::pipeline::rollout::{rollout, AgentKind};
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::agents::Decision;
use minos::run::metrics::Reward;
use minos::serve::campaign::links::{mint, Participant};
use minos::serve::campaign::record::SessionQc;
use minos::serve::campaign::{Campaign, CampaignSpec};
use minos::serve::frames::FrameFormat;
use minos::serve::session::Shared;
use minos::serve::{start_campaign, Running, ServeConfig};
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;
use serde_json::Value;

/// The tables of a run that a replay reproduces byte for byte.
const TABLES: [&str; 4] = [
    "trajectories.parquet",
    "observations.parquet",
    "episodes.parquet",
    "metrics.json",
];

/// The serve tests' shared house ([`common::serve::oracle_house`]) and a folder for this
/// file's outputs.
struct Fixture {
    dir: tempfile::TempDir,
    data: DataDir,
    /// Tutorial first, then the two campaign episodes.
    episodes: Vec<Episode>,
    episodes_file: PathBuf,
    oracle: &'static std::collections::HashMap<String, Vec<Decision>>,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let house = common::serve::oracle_house();
        Fixture {
            dir: common::shared_tempdir(),
            data: house.data.clone(),
            episodes: house.episodes.clone(),
            episodes_file: house.episodes_file.clone(),
            oracle: &house.oracle,
        }
    })
}

/// A campaign file in `dir`: K = 1, the first episode as the tutorial, `extra` appended.
fn campaign_file(f: &Fixture, dir: &Path, extra: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let file = dir.join("study.toml");
    std::fs::write(
        &file,
        format!(
            "episodes = {:?}\nsplit = \"val\"\ndemos_per_episode = 1\ntutorial = {:?}\n\
             instructions = \"Reach the goal, then press Space.\"\nsize = 32\n{extra}",
            f.episodes_file.display().to_string(),
            f.episodes[0].episode_id
        ),
    )
    .unwrap();
    file
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
}

fn join(addr: SocketAddr, token: &str) -> (u16, Value) {
    let (status, body) = http(
        addr,
        "POST",
        "/api/campaign/join",
        &[],
        Some(&format!(r#"{{"participant":"{token}"}}"#)),
    );
    (status, serde_json::from_str(&body).unwrap_or(Value::Null))
}

/// Joins with `p`'s link and connects the session; returns its socket and name.
async fn open(addr: SocketAddr, p: &Participant) -> (Ws, String) {
    let (status, v) = join(addr, &p.token);
    assert_eq!(status, 201, "{v}");
    let ws = connect(addr, v["token"].as_str().expect("token"), "").await;
    (ws, v["name"].as_str().expect("name").to_string())
}

/// Asks for the next episode and waits for the campaign to say there is none.
async fn expect_campaign_done(ws: &mut Ws) {
    send(ws, r#"{"next":null}"#).await;
    loop {
        match recv(ws).await {
            Some(Msg::Json(v)) if v["type"] == "campaign_done" => return,
            Some(Msg::Json(v)) if v["type"] == "episode" => panic!("another episode: {v}"),
            None => panic!("closed before campaign_done"),
            _ => {}
        }
    }
}

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn status(addr: SocketAddr, operator: &str) -> Value {
    let (code, body) = http(
        addr,
        "GET",
        "/api/operator/status",
        &[("x-minos-operator", operator)],
        None,
    );
    assert_eq!(code, 200, "{body}");
    serde_json::from_str(&body).expect("JSON status")
}

fn start(f: &Fixture, campaign: Campaign) -> Running {
    let shared = Shared {
        data: f.data.clone(),
        episodes: f.episodes.clone(),
        episodes_file: Some(f.episodes_file.clone()),
        scenes: f.data.ingested_ids().expect("ids"),
        out: campaign.demos_dir.clone(),
        preset: AgentPreset::Habitat,
        agent_config: AgentConfig::habitat(),
        sensors: SensorSuite::minos(32),
        renderer: RendererChoice::Cpu,
        reward: Reward::DistTime,
        encoding: ImageEncoding::Raw,
        seed: 0,
        idle: Duration::from_secs(60),
        command: vec!["minos".into(), "serve".into()],
        variant: None,
        frames: FrameFormat::default(),
    };
    start_campaign(
        ServeConfig {
            shared,
            access_token: None,
            max_sessions: 4,
            connect_timeout: Duration::from_secs(5),
            send_timeout: Duration::from_secs(5),
            allowed_hosts: Vec::new(),
            rate: SCRIPTED_RATE,
        },
        campaign,
        "127.0.0.1:0".parse().unwrap(),
    )
    .expect("campaign server starts")
}

/// `minos export-dataset --accepted` of campaign state folder `state` into `out`; the
/// dataset's `meta/info.json`.
fn export_accepted(state: &Path, out: &Path) -> Value {
    minos()
        .args([
            "export-dataset",
            "--fps",
            "10",
            "--accepted",
            "--campaign-state",
        ])
        .arg(state)
        .arg("--out")
        .arg(out)
        .ok_output();
    info(out)
}

/// LeRobot `meta/info.json` of a dataset.
fn info(dataset: &Path) -> Value {
    serde_json::from_slice(&bytes(&dataset.join("meta/info.json"))).expect("info.json")
}

#[test]
fn a_campaign_assigns_k_demos_checks_quality_and_exports_only_the_accepted() {
    let f = fixture();
    let dir = f.dir.path().join("campaign-a");
    let file = campaign_file(f, &dir, "[qc]\nmax_path_ratio = 10.0\n");
    let spec = CampaignSpec::read(&file).expect("campaign file");
    let people = mint(&spec.state, 2).expect("links");
    let (a, b) = (&people[0], &people[1]);
    let operator = std::fs::read_to_string(spec.state.join("operator.token"))
        .expect("operator token made with the links")
        .trim()
        .to_string();
    let campaign = Campaign::open(spec.clone(), &f.episodes).expect("campaign opens");
    let running = start(f, campaign);
    let addr = running.addr;
    let (tutorial, e1, e2) = (&f.episodes[0], &f.episodes[1], &f.episodes[2]);

    // Outside the links nothing opens a session; the operator's status needs its token.
    assert_eq!(http(addr, "POST", "/api/sessions", &[], Some("{}")).0, 403);
    assert_eq!(join(addr, &"0".repeat(64)).0, 403);
    assert_eq!(http(addr, "GET", "/api/operator/status", &[], None).0, 401);
    assert_eq!(
        http(
            addr,
            "GET",
            "/api/operator/status",
            &[("x-minos-operator", &a.token)],
            None
        )
        .0,
        401
    );
    let (code, page) = http(
        addr,
        "GET",
        &format!("/operator?operator={operator}"),
        &[],
        None,
    );
    assert_eq!(code, 200);
    assert!(page.contains("Demonstrations"), "{page}");

    runtime().block_on(async {
        let (mut wa, name_a) = open(addr, a).await;
        assert_eq!(name_a, "p0001-s01");
        // One live session per link.
        assert_eq!(join(addr, &a.token).0, 409);
        // The tutorial first: recorded, never accepted.
        let done = play(&mut wa, &f.oracle[&tutorial.episode_id]).await;
        assert_eq!(done["episode_id"], tutorial.episode_id.as_str());
        assert_eq!(done["qc"]["accepted"], false);
        assert_eq!(done["qc"]["reasons"][0], "tutorial");
        assert_eq!(done["more"], true);
        // Then the first campaign episode, played well: accepted.
        send(&mut wa, r#"{"next":null}"#).await;
        let done = play(&mut wa, &f.oracle[&e1.episode_id]).await;
        assert_eq!(done["episode_id"], e1.episode_id.as_str());
        assert_eq!(done["qc"]["accepted"], true, "{done}");
        // K = 1 and e1 has its demo: A gets e2, and stops at once: flagged.
        send(&mut wa, r#"{"next":null}"#).await;
        let done = play(&mut wa, &[Decision::Stop]).await;
        assert_eq!(done["episode_id"], e2.episode_id.as_str());
        assert_eq!(done["metrics"]["success"], false);
        assert_eq!(done["qc"]["accepted"], false);
        assert_eq!(done["qc"]["reasons"][0], "did not reach the goal");
        // A has played both: nothing left for A, though e2 still wants an accepted demo.
        assert_eq!(done["more"], false);
        expect_campaign_done(&mut wa).await;

        // B: tutorial, then e2 (the one still short), then done.
        let (mut wb, name_b) = open(addr, b).await;
        assert_eq!(name_b, "p0002-s01");
        play(&mut wb, &f.oracle[&tutorial.episode_id]).await;
        send(&mut wb, r#"{"next":null}"#).await;
        let done = play(&mut wb, &f.oracle[&e2.episode_id]).await;
        assert_eq!(done["episode_id"], e2.episode_id.as_str());
        assert_eq!(done["qc"]["accepted"], true, "{done}");
        let m = &done["metrics"];
        // The QC record's path ratio is the metrics' path over the episode's geodesic.
        let qc = SessionQc::load(&spec.state.join("demos").join(&name_b)).expect("qc.json");
        let rec = &qc.demos[1];
        let ratio = m["path_length"].as_f64().unwrap() / f64::from(e2.geodesic_distance);
        let got = f64::from(rec.qc.expect("figures").path_ratio.expect("ratio"));
        assert!((got - ratio).abs() < 1e-4, "{got} vs {ratio}");
        assert_eq!(
            rec.qc.unwrap().actions as usize,
            f.oracle[&e2.episode_id].len()
        );
        expect_campaign_done(&mut wb).await;
    });
    // Both episodes covered, two accepted demos, one flagged.
    let s = status(addr, &operator);
    assert_eq!(s["episodes_total"], 2, "{s}");
    assert_eq!(s["episodes_covered"], 2, "{s}");
    assert_eq!(s["demos_accepted"], 2, "{s}");
    assert_eq!(s["demos_flagged"], 1, "{s}");
    assert_eq!(s["demos"].as_array().unwrap().len(), 5, "{s}");
    running.stop();

    // Only the accepted demonstrations reach the dataset: e1 by A and e2 by B, as many
    // frames as the oracle's steps of the two.
    let lr = dir.join("accepted-lerobot");
    let i = export_accepted(&spec.state, &lr);
    assert_eq!(i["total_episodes"], 2, "{i}");
    let frames = f.oracle[&e1.episode_id].len() + f.oracle[&e2.episode_id].len();
    assert_eq!(i["total_frames"], frames, "{i}");
    // Without --accepted, every session merged: 3 + 2 episodes.
    let all = dir.join("all-lerobot");
    minos()
        .args(["export-dataset", "--fps", "10", "--campaign-state"])
        .arg(&spec.state)
        .arg("--out")
        .arg(&all)
        .ok_output();
    assert_eq!(info(&all)["total_episodes"], 5);
}

/// Starts `minos serve --campaign FILE` as a process; returns it and its address.
fn serve_process(f: &Fixture, file: &Path) -> (std::process::Child, SocketAddr) {
    use std::io::BufRead;
    let mut child = minos()
        .args(["serve", "--bind", "127.0.0.1:0", "--data"])
        .arg(f.data.root())
        .arg("--campaign")
        .arg(file)
        // A scripted client answers each frame at once, faster than a person's keys.
        .args(["--max-messages-per-second", "10000"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("minos serve starts");
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let addr = loop {
        let line = lines.next().expect("a line").expect("text");
        if let Some(rest) = line.trim().strip_prefix("open http://") {
            break rest.split('/').next().unwrap().parse().expect("address");
        }
    };
    (child, addr)
}

/// Every name in `dir` (files and folders).
fn names(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn a_server_killed_at_any_moment_loses_no_finished_episode_and_leaves_no_litter() {
    let f = fixture();
    // Kill points: after n key presses into the first campaign episode (0: as it is shown).
    for (k, presses) in [0usize, 3, 7].into_iter().enumerate() {
        let dir = f.dir.path().join(format!("campaign-kill-{k}"));
        let file = campaign_file(f, &dir, "");
        let state = dir.join("study.state");
        let out = minos()
            .args(["campaign", "links", "--count", "1", "--campaign"])
            .arg(&file)
            .ok_output();
        let line = String::from_utf8(out.stdout).unwrap();
        let (id, link) = line.trim().split_once('\t').expect("id<TAB>link");
        assert_eq!(id, "p0001");
        let token = link
            .split("participant=")
            .nth(1)
            .expect("token")
            .to_string();
        let p = Participant {
            id: id.into(),
            token,
        };
        let (tutorial, e1) = (&f.episodes[0], &f.episodes[1]);
        let (mut child, addr) = serve_process(f, &file);
        runtime().block_on(async {
            let (mut ws, name) = open(addr, &p).await;
            assert_eq!(name, "p0001-s01");
            play(&mut ws, &f.oracle[&tutorial.episode_id]).await;
            send(&mut ws, r#"{"next":null}"#).await;
            let mut sent = 0;
            let mut stepped = false;
            while sent < presses {
                match recv(&mut ws).await.expect("open") {
                    Msg::Json(v) if v["type"] == "step" => stepped = true,
                    Msg::Binary(1, ..) if stepped => {
                        stepped = false;
                        sent += 1;
                        send(&mut ws, r#"{"action":"turn_left"}"#).await;
                    }
                    _ => {}
                }
            }
            child.kill().expect("kill -9");
            child.wait().unwrap();
        });
        let session = state.join("demos/p0001-s01");
        // Restart with the same campaign: the participant's link works again and gets the
        // interrupted episode (handed back), not the tutorial.
        let (mut child, addr) = serve_process(f, &file);
        // No litter: exactly what a finished session holds.
        let expected: BTreeSet<String> = TABLES
            .iter()
            .map(|s| s.to_string())
            .chain(["manifest.json", PLAYED, "qc.json"].map(String::from))
            .collect();
        assert_eq!(names(&session), expected, "kill point {presses}");
        // Exactly the tutorial, byte for byte what its replay writes.
        let played = read_episodes(&session.join(PLAYED)).unwrap();
        assert_eq!(played, vec![tutorial.clone()]);
        let replay_dir = dir.join("replay");
        let steps = read_replay(&session.join("trajectories.parquet")).unwrap();
        rollout(
            &run_config(
                &f.data,
                &replay_dir,
                AgentKind::Replay(steps),
                SensorSuite::minos(32),
            ),
            &played,
            &NoProgress,
        )
        .unwrap();
        for t in TABLES {
            assert!(
                bytes(&session.join(t)) == bytes(&replay_dir.join(t)),
                "{t} (kill point {presses})"
            );
        }
        // …and the same bytes as the uninterrupted oracle's tutorial (oracle presses).
        let qc = SessionQc::load(&session).unwrap();
        assert_eq!(qc.demos.len(), 1);
        assert!(qc.demos[0].tutorial);
        runtime().block_on(async {
            let t = Instant::now();
            let (mut ws, name) = loop {
                // The killed session's seat is free at once (the ledger starts from disk).
                let (code, v) = join(addr, &p.token);
                if code == 201 {
                    let ws = connect(addr, v["token"].as_str().unwrap(), "").await;
                    break (ws, v["name"].as_str().unwrap().to_string());
                }
                assert!(t.elapsed() < Duration::from_secs(10), "{code} {v}");
                tokio::time::sleep(Duration::from_millis(100)).await;
            };
            assert_eq!(name, "p0001-s02");
            let done = play(&mut ws, &f.oracle[&e1.episode_id]).await;
            assert_eq!(done["episode_id"], e1.episode_id.as_str());
            assert_eq!(done["qc"]["accepted"], true);
            send(&mut ws, r#"{"end":true}"#).await;
            while recv(&mut ws).await.is_some() {}
        });
        child.kill().unwrap();
        child.wait().unwrap();
        let again = state.join("demos/p0001-s02");
        assert_eq!(
            read_episodes(&again.join(PLAYED)).unwrap(),
            vec![e1.clone()]
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}

/// `text` percent-encoded for a query string.
fn query_value(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// What an operator's replay sent: the `replay` message, each frame's message, how many
/// camera images came, and the `replay_end` message (or the error).
struct Replayed {
    intro: Value,
    frames: Vec<Value>,
    images: usize,
    end: Result<Value, String>,
}

async fn replay(addr: SocketAddr, operator: &str, session: &str, episode: &str) -> Replayed {
    let url = format!(
        "ws://{addr}/api/operator/replay?session={}&episode={}&operator={}",
        query_value(session),
        query_value(episode),
        query_value(operator)
    );
    let mut ws = tokio_tungstenite::connect_async(url)
        .await
        .expect("replay socket")
        .0;
    let mut r = Replayed {
        intro: Value::Null,
        frames: Vec::new(),
        images: 0,
        end: Err("closed".into()),
    };
    while let Some(m) = recv(&mut ws).await {
        match m {
            Msg::Json(v) if v["type"] == "replay" => r.intro = v,
            Msg::Json(v) if v["type"] == "frame" => r.frames.push(v),
            Msg::Json(v) if v["type"] == "replay_end" => {
                r.end = Ok(v);
                break;
            }
            Msg::Json(v) if v["type"] == "error" => {
                r.end = Err(v["message"].as_str().unwrap_or("").to_string());
                break;
            }
            Msg::Binary(1, ..) => r.images += 1,
            _ => {}
        }
    }
    r
}

fn post(addr: SocketAddr, path: &str, headers: &[(&str, &str)], body: &Value) -> (u16, Value) {
    let (code, text) = http(addr, "POST", path, headers, Some(&body.to_string()));
    (code, serde_json::from_str(&text).unwrap_or(Value::Null))
}

#[test]
fn the_operator_replays_demonstrations_overrides_verdicts_and_reads_feedback() {
    let f = fixture();
    let dir = f.dir.path().join("campaign-review");
    let file = campaign_file(f, &dir, "");
    let spec = CampaignSpec::read(&file).expect("campaign file");
    let people = mint(&spec.state, 1).expect("links");
    let a = &people[0];
    let operator = std::fs::read_to_string(spec.state.join("operator.token"))
        .expect("operator token")
        .trim()
        .to_string();
    let op = [("x-minos-operator", operator.as_str())];
    let running = start(f, Campaign::open(spec.clone(), &f.episodes).expect("opens"));
    let addr = running.addr;
    let (tutorial, e1, e2) = (&f.episodes[0], &f.episodes[1], &f.episodes[2]);
    let oracle_e2 = &f.oracle[&e2.episode_id];
    runtime().block_on(async {
        let (mut ws, name) = open(addr, a).await;
        play(&mut ws, &f.oracle[&tutorial.episode_id]).await;
        // e1: two turns and a stop short of the goal, flagged.
        send(&mut ws, r#"{"next":null}"#).await;
        let done = play(
            &mut ws,
            &[
                Decision::from_name("turn_left").unwrap(),
                Decision::from_name("turn_left").unwrap(),
                Decision::Stop,
            ],
        )
        .await;
        assert_eq!(done["episode_id"], e1.episode_id.as_str());
        assert_eq!(done["qc"]["accepted"], false);

        // The session is live (its episodes are only parts): the replay reads the parts.
        let r = replay(addr, &operator, &name, &e1.episode_id).await;
        let end = r.end.expect("replay ends");
        assert_eq!(r.intro["episode_id"], e1.episode_id.as_str());
        assert_eq!(r.intro["decisions"], 3);
        // The start and one frame per decision, each with its colour image.
        let actions: Vec<Value> = r.frames.iter().map(|v| v["action"].clone()).collect();
        assert_eq!(
            actions,
            vec![
                Value::Null,
                "turn_left".into(),
                "turn_left".into(),
                "stop".into()
            ]
        );
        assert_eq!(r.images, 4);
        assert_eq!(end["frames"], 4);
        assert_eq!(end["metrics"]["success"], false);
        assert_eq!(end["agrees"], true, "{end}");
        // Turning in place: every frame stands at the start.
        for fr in &r.frames {
            let p: Vec<f64> = serde_json::from_value(fr["position"].clone()).unwrap();
            for (got, want) in p.iter().zip(e1.start_position) {
                assert!((got - f64::from(want)).abs() < 1e-4, "{fr}");
            }
        }

        // The operator accepts it anyway: e1 is covered, and the verdict is on disk.
        let (code, entry) = post(
            addr,
            "/api/operator/review",
            &op,
            &serde_json::json!({"session": name, "episode_id": e1.episode_id,
                                "accepted": true, "note": "stopped on purpose"}),
        );
        assert_eq!(code, 200, "{entry}");
        assert_eq!(entry["verdict"]["accepted"], true);
        assert_eq!(entry["review"]["note"], "stopped on purpose");
        assert_eq!(entry["review"]["automatic"]["accepted"], false);
        let s = status(addr, &operator);
        assert_eq!(s["demos_accepted"], 1, "{s}");
        assert_eq!(s["episodes"][0]["accepted"], 1, "{s}");
        assert_eq!(s["episodes"][0]["flagged"], 0, "{s}");
        let qc = SessionQc::load(&spec.state.join("demos").join(&name)).expect("qc.json");
        assert_eq!(qc.accepted(), vec![e1.episode_id.clone()]);

        // Refused: the tutorial, a demonstration that does not exist, a long note, no token.
        for (body, code_wanted) in [
            (
                serde_json::json!({"session": name, "episode_id": tutorial.episode_id, "accepted": true}),
                409,
            ),
            (
                serde_json::json!({"session": "../p0001-s01", "episode_id": e1.episode_id, "accepted": true}),
                404,
            ),
            (
                serde_json::json!({"session": name, "episode_id": e1.episode_id, "accepted": false,
                                    "note": "x".repeat(501)}),
                400,
            ),
        ] {
            let (code, v) = post(addr, "/api/operator/review", &op, &body);
            assert_eq!(code, code_wanted, "{body} → {v}");
        }
        let body = serde_json::json!({"session": name, "episode_id": e1.episode_id, "accepted": false});
        assert_eq!(post(addr, "/api/operator/review", &[], &body).0, 401);
        let (code, _) = post(
            addr,
            "/api/operator/review",
            &[("x-minos-operator", &a.token)],
            &body,
        );
        assert_eq!(code, 401, "a participant's token is not the operator's");

        // e2, played by the oracle, then the session ends: the replay reads its tables.
        send(&mut ws, r#"{"next":null}"#).await;
        let done = play(&mut ws, oracle_e2).await;
        assert_eq!(done["episode_id"], e2.episode_id.as_str());
        send(&mut ws, r#"{"end":true}"#).await;
        while recv(&mut ws).await.is_some() {}
        let session = spec.state.join("demos").join(&name);
        let t = Instant::now();
        while !session.join("trajectories.parquet").exists() {
            assert!(t.elapsed() < Duration::from_secs(20), "session tables");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let r = replay(addr, &operator, &name, &e2.episode_id).await;
        let end = r.end.expect("replay ends");
        assert_eq!(r.frames.len(), oracle_e2.len() + 1);
        let names: Vec<String> = r.frames[1..]
            .iter()
            .map(|v| v["action"].as_str().unwrap().to_string())
            .collect();
        let want: Vec<String> = oracle_e2.iter().map(|d| d.name()).collect();
        assert_eq!(names, want);
        assert_eq!(end["metrics"]["success"], true);
        assert_eq!(end["agrees"], true, "{end}");
        // The last frame is the stop at the goal that ended the episode.
        let last = r.frames.last().unwrap();
        assert_eq!(last["done"], true);
        assert_eq!(last["success"], true);

        // Replays need the operator's token, and a demonstration the books hold.
        let url = format!(
            "ws://{addr}/api/operator/replay?session={name}&episode={}",
            query_value(&e2.episode_id)
        );
        assert!(tokio_tungstenite::connect_async(url).await.is_err());
        let url = format!(
            "ws://{addr}/api/operator/replay?session=p0009-s01&episode={}&operator={operator}",
            query_value(&e2.episode_id)
        );
        assert!(tokio_tungstenite::connect_async(url).await.is_err());
    });

    // Feedback with the participant's link; checked; shown to the operator.
    let fb = |body: Value| post(addr, "/api/campaign/feedback", &[], &body);
    let (code, v) = fb(
        serde_json::json!({"participant": a.token, "rating": 2, "comment": "the turns felt big"}),
    );
    assert_eq!(code, 201, "{v}");
    assert_eq!(
        fb(serde_json::json!({"participant": a.token, "rating": 9})).0,
        400
    );
    assert_eq!(fb(serde_json::json!({"participant": a.token})).0, 400);
    assert_eq!(
        fb(serde_json::json!({"participant": "0".repeat(64), "rating": 1})).0,
        403
    );
    let s = status(addr, &operator);
    assert_eq!(
        s["feedback"],
        serde_json::json!([{"participant": "p0001", "rating": 2, "comment": "the turns felt big"}])
    );
    running.stop();

    // A restart keeps the review and the feedback: the ledger is rebuilt from qc.json.
    let reopened = Campaign::open(spec.clone(), &f.episodes).expect("reopens");
    let s = reopened.status();
    assert_eq!(s["demos_accepted"], 2, "{s}");
    assert_eq!(s["episodes_covered"], 2, "{s}");
    assert_eq!(s["feedback"][0]["rating"], 2, "{s}");
    drop(reopened);
    // The reviewed demonstration reaches the dataset with the accepted ones.
    let lr = dir.join("lerobot");
    let i = export_accepted(&spec.state, &lr);
    assert_eq!(i["total_episodes"], 2, "{i}");
    assert_eq!(i["total_frames"], 3 + oracle_e2.len(), "{i}");
}
