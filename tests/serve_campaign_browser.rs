//! A campaign in a real browser: headless Chromium opens a participant's link, the page
//! shows the campaign's instructions, the test presses the oracle's keys through the tutorial
//! and the campaign episode the server hands out, and the page thanks the participant when
//! nothing is left and asks for feedback (typed and sent); then the operator page, opened
//! with its token, lists both demonstrations with their verdicts and the feedback, replays
//! the accepted one in the page and flags it with a note. Without Chromium the test says it
//! skipped and why.

use crate::common;

use std::path::PathBuf;
use std::time::Duration;

use common::browser::{chromium, launch, Cdp};
use minos::body::AgentPreset;
use minos::episode::format::write_episodes;
use minos::io::image_codec::ImageEncoding;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::serve::campaign::links::mint;
use minos::serve::campaign::{Campaign, CampaignSpec};
use minos::serve::frames::FrameFormat;
use minos::serve::rate::RateLimits;
use minos::serve::session::Shared;
use minos::serve::{start_campaign, ServeConfig};
use minos::sim::{AgentConfig, SensorSuite};
use serde_json::Value;

#[test]
fn a_participant_goes_from_tutorial_to_done_and_the_operator_sees_it() {
    let Some(browser) = chromium() else {
        common::skip(
            "no Chromium (install Debian's `chromium` package, as .ci/run does when root, or \
             set MINOS_CHROMIUM)",
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // The serve tests' shared house: a PointGoal tutorial and one ObjectGoal campaign
    // episode of it, with the oracle's decisions (its plan does not depend on the cameras).
    let house = common::serve::oracle_house();
    let (data, oracle) = (&house.data, &house.oracle);
    let ids = data.ingested_ids().unwrap();
    let episodes: Vec<_> = house.episodes[..2].to_vec();
    let body = AgentConfig::habitat();
    let sensors = SensorSuite::minos(64);
    let episodes_file = dir.path().join("episodes.parquet");
    write_episodes(&episodes_file, &episodes).unwrap();
    let file = dir.path().join("study.toml");
    std::fs::write(
        &file,
        format!(
            "episodes = {:?}\ndemos_per_episode = 1\ntutorial = {:?}\n\
             instructions = \"Walk to the goal and press Space there.\"\n",
            episodes_file.display().to_string(),
            episodes[0].episode_id
        ),
    )
    .unwrap();
    let spec = CampaignSpec::read(&file).unwrap();
    let link = mint(&spec.state, 1).unwrap().remove(0);
    let operator = std::fs::read_to_string(spec.state.join("operator.token"))
        .unwrap()
        .trim()
        .to_string();
    let campaign = Campaign::open(spec, &episodes).unwrap();
    let out: PathBuf = campaign.demos_dir.clone();
    let running = start_campaign(
        ServeConfig {
            shared: Shared {
                data: data.clone(),
                episodes: episodes.clone(),
                episodes_file: Some(episodes_file),
                scenes: ids.clone(),
                out,
                preset: AgentPreset::Habitat,
                agent_config: body,
                sensors,
                renderer: RendererChoice::Cpu,
                reward: Reward::DistTime,
                encoding: ImageEncoding::Raw,
                seed: 0,
                idle: Duration::from_secs(120),
                command: vec!["minos".into(), "serve".into()],
                variant: None,
                frames: FrameFormat::default(),
            },
            access_token: None,
            max_sessions: 2,
            connect_timeout: Duration::from_secs(30),
            send_timeout: Duration::from_secs(10),
            allowed_hosts: Vec::new(),
            rate: RateLimits::default(),
        },
        campaign,
        "127.0.0.1:0".parse().unwrap(),
    )
    .unwrap();
    let addr = running.addr;
    let profile = dir.path().join("chromium-profile");
    let url = format!("http://{addr}/?participant={}", link.token);
    let (_browser, port) = launch(&browser, &profile, &url);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let mut cdp = Cdp::first_page(port).await;
        cdp.until("window.minos && window.minos.step !== null && window.minos.frames > 0")
            .await;
        // The participant's page: no episode chooser, the campaign's instructions, the
        // tutorial first.
        let chooser = cdp
            .eval("getComputedStyle(document.getElementById('chooser')).display")
            .await;
        assert_eq!(chooser, "none");
        let header = cdp.eval("document.getElementById('preset').textContent").await;
        assert_eq!(header, "Walk to the goal and press Space there.");
        let id = cdp.eval("window.minos.episode.episode_id").await;
        assert_eq!(id, episodes[0].episode_id.as_str());
        cdp.play(&oracle[&episodes[0].episode_id], 0).await;
        // N: the campaign's episode.
        cdp.press("n", "KeyN", 78).await;
        cdp.until(&format!(
            "window.minos.episode.episode_id === {:?} && window.minos.step !== null",
            episodes[1].episode_id
        ))
        .await;
        cdp.play(&oracle[&episodes[1].episode_id], 1).await;
        let r = cdp.eval("window.minos.results[1]").await;
        assert_eq!(r["metrics"]["success"], true, "{r}");
        assert_eq!(r["qc"]["accepted"], true, "{r}");
        assert_eq!(r["more"], false, "{r}");
        // N again: nothing left, the page says thank you.
        cdp.press("n", "KeyN", 78).await;
        cdp.until("window.minos.campaignDone === true").await;
        let text = cdp
            .eval("document.getElementById('instruction').textContent")
            .await;
        assert!(text.as_str().unwrap().starts_with("Thank you"), "{text}");
        // The last stage: the feedback form, typed into (the page does not take W as
        // "forward" there) and sent.
        cdp.until("!document.getElementById('feedback').hidden").await;
        cdp.eval("document.querySelector('input[name=rating][value=\"4\"]').click(); document.getElementById('comment').focus()")
            .await;
        for (key, code, key_code) in [("w", "KeyW", 87), ("o", "KeyO", 79), ("w", "KeyW", 87)] {
            cdp.call(
                "Input.dispatchKeyEvent",
                serde_json::json!({"type": "keyDown", "key": key, "code": code,
                                   "windowsVirtualKeyCode": key_code, "text": key}),
            )
            .await;
            cdp.call(
                "Input.dispatchKeyEvent",
                serde_json::json!({"type": "keyUp", "key": key, "code": code,
                                   "windowsVirtualKeyCode": key_code}),
            )
            .await;
        }
        cdp.eval("document.getElementById('send-feedback').click()").await;
        cdp.until("window.minos.feedback === 'sent'").await;

        // The operator page with its token: both demonstrations, the episode covered.
        cdp.call(
            "Page.navigate",
            serde_json::json!({"url": format!("http://{addr}/operator?operator={operator}")}),
        )
        .await;
        cdp.until("window.operator && window.operator.status !== null && window.operator.status.demos.length === 2")
            .await;
        let rows = cdp
            .eval("[...document.querySelectorAll('#demos tbody tr')].map(r => r.cells[2].textContent)")
            .await;
        assert_eq!(rows, serde_json::json!(["tutorial", "accepted"]));
        let summary: Value = cdp
            .eval("document.getElementById('summary').textContent")
            .await;
        assert!(
            summary.as_str().unwrap().starts_with("1 of 1 episodes"),
            "{summary}"
        );
        // The operator's page shows the feedback.
        cdp.until("window.operator.status.feedback.length === 1").await;
        let fb = cdp.eval("window.operator.status.feedback[0]").await;
        assert_eq!(
            fb,
            serde_json::json!({"participant": "p0001", "rating": 4, "comment": "wow"})
        );
        // Replay the accepted demonstration in the page: every frame arrives and the replay
        // agrees with the quality record; the slider goes back to the start.
        cdp.eval("[...document.querySelectorAll('#demos tbody tr')][1].querySelector('button').click()")
            .await;
        cdp.until("window.operator.replay && window.operator.replay.ended").await;
        let end = cdp.eval("window.operator.replay.end").await;
        let steps = oracle[&episodes[1].episode_id].len();
        assert_eq!(end["frames"], steps + 1, "{end}");
        assert_eq!(end["agrees"], true, "{end}");
        cdp.until(&format!("window.operator.replay.images.length === {}", steps + 1))
            .await;
        let status = cdp
            .eval("document.getElementById('replay-status').className")
            .await;
        assert_eq!(status, "agrees");
        cdp.eval("const s = document.getElementById('replay-slider'); s.value = '0'; s.dispatchEvent(new Event('input'))")
            .await;
        let at = cdp.eval("document.getElementById('replay-at').textContent").await;
        assert!(at.as_str().unwrap().starts_with("frame 0 · step 0 · start"), "{at}");
        // Flag it with a note: the table says so and the episode is no longer covered.
        cdp.eval("document.getElementById('note').value = 'too fast to be a person'").await;
        cdp.eval("[...document.querySelectorAll('#demos tbody tr')][1].querySelectorAll('button')[2].click()")
            .await;
        cdp.until("window.operator.reviewed !== null && window.operator.status.demos_accepted === 0")
            .await;
        cdp.until("document.querySelectorAll('#demos tbody tr')[1].cells[2].textContent.includes('operator')")
            .await;
        let verdict = cdp
            .eval("document.querySelectorAll('#demos tbody tr')[1].cells[2].textContent")
            .await;
        assert_eq!(
            verdict,
            "flagged by the operator: too fast to be a person (thresholds: accepted)"
        );
        // Without the token the page is refused.
        let (code, _) = common::serve::http(addr, "GET", "/operator", &[], None);
        assert_eq!(code, 401);
    });
    running.stop();
}
