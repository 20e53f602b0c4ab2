//! `minos serve`: flags → [`ServeConfig`] ([`config`]: DATA, episodes, variant, agent,
//! sensors, reward, seed, address, tokens, host names, frames and limits), then
//! [`minos::serve::start`]; prints the page's address and serves until the process ends.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context as _};
use minos::body::AgentPreset;
use minos::episode::format::read_episodes;
use minos::io::image_codec::ImageEncoding;
use minos::pipeline::rollout::episodes_on_variant;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::serve::campaign::CampaignSpec;
use minos::serve::frames::FrameFormat;
use minos::serve::frames::{LosslessFormat, DEFAULT_JPEG_QUALITY};
use minos::serve::rate::RateLimits;
use minos::serve::session::Shared;
use minos::serve::ServeConfig;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

use super::common::{sensor_suite, sensors_help, vocab};

/// The environment variable an access token may come from (out of sight of `ps`).
pub const ACCESS_TOKEN_ENV: &str = "MINOS_ACCESS_TOKEN";
use super::Context;

/// Serve a web page to explore scenes and record human demonstrations.
///
/// Each visitor's session plays episodes of --episodes (or explores a scene) with the
/// keyboard or the buttons, and is recorded into DEMOS/<session>/ exactly like `minos run`
/// output: trajectories.parquet, observations.parquet, episodes.parquet, metrics.json,
/// manifest.json, plus played.parquet, the episodes it finished. `minos run --episodes
/// DEMOS/<session>/played.parquet --agent replay:DEMOS/<session>/trajectories.parquet` (same
/// --preset and --size) reproduces its tables byte for byte; `minos export-dataset` turns it
/// into a LeRobot dataset. People are offered exactly the agent preset's actions (Habitat's:
/// forward, turn left, turn right, stop). Binds to localhost; another address needs an
/// access token (--access-token-file FILE or MINOS_ACCESS_TOKEN; --access-token shows it to
/// every user of `ps`).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos serve --data DATA --episodes eps/point.parquet\n  \
    minos serve --data DATA --out demos --preset minos\n  \
    openssl rand -hex 16 > token.txt; minos serve --data DATA --episodes eps/object.parquet --bind 0.0.0.0:8080 --access-token-file token.txt --allowed-host lab.example.org"
)]
pub struct Args {
    /// DATA folder (ingested and baked).
    #[arg(long)]
    data: PathBuf,
    /// Episode file from `minos episodes` (without it, sessions explore a scene).
    #[arg(long, conflicts_with = "campaign")]
    episodes: Option<PathBuf>,
    /// Campaign file (TOML): episodes, demonstrations per episode, tutorial, instructions,
    /// agent and quality thresholds; sessions are opened only by participants' links
    /// (`minos campaign links`) and recorded in the campaign's state folder.
    #[arg(long, value_name = "FILE")]
    campaign: Option<PathBuf>,
    /// Play every episode on this variant of its scene (scene and episode ids in the outputs
    /// read `<scene>@NAME`, as with `minos run --variant`); explored scenes are loaded on it.
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:8080")]
    bind: SocketAddr,
    /// Output folder: one folder per session.
    #[arg(long, default_value = "demos")]
    out: PathBuf,
    /// Token every request must carry (open the page as http://HOST:PORT/?access=TOKEN);
    /// required to listen on an address other than localhost. Visible to every user of the
    /// machine in `ps`: prefer --access-token-file or the MINOS_ACCESS_TOKEN variable.
    #[arg(long, conflicts_with = "access_token_file")]
    access_token: Option<String>,
    /// File holding the access token (its first line; surrounding white space ignored).
    #[arg(long, value_name = "FILE")]
    access_token_file: Option<PathBuf>,
    /// A host name the page may be reached by besides localhost and addresses (the name in
    /// the link you send; repeatable). Requests for any other name are refused (DNS
    /// rebinding).
    #[arg(long = "allowed-host", value_name = "NAME")]
    allowed_hosts: Vec<String>,
    /// Agent preset (body and motion); the grids must be baked for its body.
    #[arg(long, value_parser = vocab::<AgentPreset>(), default_value = "habitat")]
    preset: AgentPreset,
    #[arg(long, help = sensors_help("MINOS's RGB, depth, semantic at --size (grey, depth and semantic at 90° for --preset minos-paper)."))]
    sensors: Option<PathBuf>,
    /// Image size of the default sensors.
    #[arg(long, default_value_t = 256)]
    size: u32,
    /// Renderer.
    #[arg(long, value_parser = vocab::<RendererChoice>(), default_value = "cpu")]
    renderer: RendererChoice,
    /// Image storage in observations.parquet.
    #[arg(long, value_parser = vocab::<ImageEncoding>(), default_value = "raw")]
    image_encoding: ImageEncoding,
    /// Reward recorded with each step: dist_time (MINOS), path_delta (MINOS) or geodesic
    /// (Habitat), as `minos run --reward`.
    #[arg(long, value_parser = vocab::<Reward>(), default_value = "dist_time")]
    reward: Reward,
    /// Seed of sensor noise (as `minos run --seed`) and of free-exploration episodes.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Send camera images to the page losslessly instead of as JPEG: as PNG (the flag
    /// alone) or as WebP (about half PNG's bytes for twice its time: for pages on slow links).
    #[arg(
        long,
        value_parser = vocab::<LosslessFormat>(),
        num_args = 0..=1,
        default_missing_value = "png",
        conflicts_with = "jpeg_quality",
        value_name = "FORMAT"
    )]
    lossless_frames: Option<LosslessFormat>,
    /// JPEG quality of the camera images sent to the page (1-100).
    #[arg(long, default_value_t = DEFAULT_JPEG_QUALITY)]
    jpeg_quality: u8,
    /// Sessions at once, at most (each holds a simulator).
    #[arg(long, default_value_t = 16)]
    max_sessions: usize,
    /// A session ends after this many seconds without a key press.
    #[arg(long, default_value_t = 600)]
    idle_timeout: u64,
    /// Messages a page may send per second (key presses; twice as many in a burst).
    #[arg(long, default_value_t = RateLimits::default().messages_per_second)]
    max_messages_per_second: u32,
    /// New sessions per minute per access token (as many in a burst).
    #[arg(long, default_value_t = RateLimits::default().sessions_per_minute)]
    max_new_sessions_per_minute: u32,
}

/// The access token: `--access-token`, the first line of `--access-token-file`, or
/// `env` (the value of [`ACCESS_TOKEN_ENV`]), in that order; none of them, none.
fn access_token(args: &Args, env: Option<String>) -> anyhow::Result<Option<String>> {
    if let Some(t) = &args.access_token {
        return Ok(Some(t.clone()));
    }
    if let Some(path) = &args.access_token_file {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("--access-token-file {}", path.display()))?;
        let token = text.lines().next().unwrap_or("").trim();
        if token.is_empty() {
            bail!("--access-token-file {}: empty", path.display());
        }
        return Ok(Some(token.to_string()));
    }
    match env {
        Some(t) if t.trim().is_empty() => bail!("{ACCESS_TOKEN_ENV}: empty"),
        Some(t) => Ok(Some(t.trim().to_string())),
        None => Ok(None),
    }
}

/// Flags → the server's configuration (reads the episode, sensor and token files, the
/// manifest and the variant; `env`: the value of [`ACCESS_TOKEN_ENV`]).
pub fn config(args: &Args, env: Option<String>) -> anyhow::Result<(ServeConfig, SocketAddr)> {
    let access_token = access_token(args, env)?;
    if !args.bind.ip().is_loopback() && access_token.is_none() {
        bail!(
            "--bind {}: listening beyond this machine needs an access token \
             (--access-token-file FILE or {ACCESS_TOKEN_ENV}; visitors open \
             http://HOST:PORT/?access=TOKEN)",
            args.bind
        );
    }
    if args.access_token.as_deref() == Some("") {
        bail!("--access-token: empty");
    }
    if args.size == 0 {
        bail!("--size 0: images need at least one pixel");
    }
    if args.idle_timeout == 0 {
        bail!("--idle-timeout 0: every session would end at once");
    }
    let spec = args
        .campaign
        .as_deref()
        .map(CampaignSpec::read)
        .transpose()?;
    let data = DataDir::new(&args.data);
    let scenes = data
        .ingested_ids()
        .with_context(|| format!("--data {}", args.data.display()))?;
    let episodes_file = match &spec {
        Some(c) => Some(c.episodes.clone()),
        None => args.episodes.clone(),
    };
    let episodes = match &episodes_file {
        Some(path) => read_episodes(path)?,
        None => Vec::new(),
    };
    let episodes = match args.variant.as_deref() {
        Some(name) => episodes_on_variant(&data, Some(name), episodes)
            .with_context(|| format!("--variant {name}"))?,
        None => episodes,
    };
    // A campaign's agent and sensors win over the flags.
    let preset = spec.as_ref().and_then(|c| c.preset).unwrap_or(args.preset);
    let size = spec.as_ref().and_then(|c| c.size).unwrap_or(args.size);
    let sensor_file = spec
        .as_ref()
        .and_then(|c| c.sensors.clone())
        .or_else(|| args.sensors.clone());
    let sensors = sensor_suite(sensor_file.as_deref(), size, || {
        SensorSuite::for_preset(preset, size)
    })?;
    let out = match &spec {
        Some(c) => c.state.join(minos::serve::campaign::DEMOS),
        None => args.out.clone(),
    };
    let shared = Shared {
        data,
        episodes,
        episodes_file,
        scenes,
        out,
        preset,
        agent_config: AgentConfig::preset(preset),
        sensors,
        renderer: args.renderer,
        reward: args.reward,
        encoding: args.image_encoding,
        seed: args.seed,
        idle: Duration::from_secs(args.idle_timeout),
        command: std::env::args().collect(),
        variant: args.variant.clone(),
        frames: args
            .lossless_frames
            .map_or(FrameFormat::Jpeg(args.jpeg_quality), FrameFormat::from),
    };
    Ok((
        ServeConfig {
            shared,
            access_token,
            max_sessions: args.max_sessions,
            connect_timeout: Duration::from_secs(30),
            send_timeout: Duration::from_secs(10),
            allowed_hosts: args.allowed_hosts.clone(),
            rate: RateLimits {
                messages_per_second: args.max_messages_per_second,
                sessions_per_minute: args.max_new_sessions_per_minute,
            },
        },
        args.bind,
    ))
}

/// Runs `minos serve`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let (cfg, bind) = config(&args, std::env::var(ACCESS_TOKEN_ENV).ok())?;
    if let Some(file) = &args.campaign {
        return run_campaign(file, cfg, bind, ctx);
    }
    let has_token = cfg.access_token.is_some();
    let running = minos::serve::start(cfg, bind)?;
    let (episodes, scenes) = running.offered();
    let query = if has_token { "?access=<token>" } else { "" };
    ctx.say(format!(
        "serving {episodes} episodes and {scenes} scenes (preset {}) -> sessions recorded in {}\n\
         open http://{}/{query}   (Ctrl-C stops; finished episodes are already on disk)",
        args.preset.name(),
        args.out.display(),
        running.addr,
    ));
    running.wait();
    Ok(ExitCode::SUCCESS)
}

/// Serves the campaign `file` (its state folder swept and its ledger rebuilt first).
fn run_campaign(
    file: &std::path::Path,
    cfg: ServeConfig,
    bind: SocketAddr,
    ctx: &Context,
) -> anyhow::Result<ExitCode> {
    let spec = CampaignSpec::read(file)?;
    let state = spec.state.clone();
    let campaign = minos::serve::open_campaign(spec, &cfg.shared)?;
    let status = campaign.status();
    let (_, operator_from) = minos::serve::campaign::links::operator_token(&state)?;
    let running = minos::serve::start_campaign(cfg, campaign, bind)?;
    ctx.say(format!(
        "campaign {}: {} of {} episodes covered, {} demonstrations recorded -> {}\n\
         participants open their links (minos campaign links --campaign {} --count N)\n\
         operator page: http://{}/operator?operator=<token from {operator_from}>\n\
         open http://{}/   (Ctrl-C stops; finished episodes are already on disk)",
        file.display(),
        status["episodes_covered"],
        status["episodes_total"],
        status["demos"].as_array().map_or(0, Vec::len),
        state.display(),
        file.display(),
        running.addr,
        running.addr,
    ));
    running.wait();
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    #[test]
    fn remote_binds_need_an_access_token() {
        let a = parse_flags::<Args>("--data /nonexistent --bind 0.0.0.0:8080").expect("flags");
        let e = config(&a, None).unwrap_err().to_string();
        assert!(e.contains("access token"), "{e}");
        // Localhost needs none (it fails later, on the missing DATA folder).
        let a = parse_flags::<Args>("--data /nonexistent").expect("flags");
        assert_eq!(a.bind, "127.0.0.1:8080".parse::<SocketAddr>().unwrap());
        let e = config(&a, None).unwrap_err().to_string();
        assert!(e.contains("/nonexistent"), "{e}");
        assert!(parse_flags::<Args>("--data D --image-encoding jpeg").is_err());
    }

    #[test]
    fn the_access_token_comes_from_a_file_or_the_environment() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("token.txt");
        std::fs::write(&file, "  f1le-t0ken \nsecond line\n").unwrap();
        let remote = "--data /nonexistent --bind 0.0.0.0:8080";
        let a = parse_flags::<Args>(&format!("{remote} --access-token-file {}", file.display()))
            .expect("flags");
        assert_eq!(
            access_token(&a, None).unwrap().as_deref(),
            Some("f1le-t0ken")
        );
        // A remote bind with a token from a file gets past the token check (and fails on
        // the missing DATA folder).
        let e = config(&a, None).unwrap_err().to_string();
        assert!(e.contains("/nonexistent"), "{e}");
        let a = parse_flags::<Args>(remote).expect("flags");
        assert_eq!(
            access_token(&a, Some("env-t0ken\n".into()))
                .unwrap()
                .as_deref(),
            Some("env-t0ken")
        );
        let e = config(&a, Some("env-t0ken".into()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent"), "{e}");
        assert!(access_token(&a, Some(" ".into())).is_err());
        std::fs::write(&file, "\n").unwrap();
        let a = parse_flags::<Args>(&format!("{remote} --access-token-file {}", file.display()))
            .expect("flags");
        assert!(access_token(&a, None)
            .unwrap_err()
            .to_string()
            .contains("empty"));
        let missing = dir.path().join("missing.txt");
        let a = parse_flags::<Args>(&format!(
            "{remote} --access-token-file {}",
            missing.display()
        ))
        .expect("flags");
        assert!(access_token(&a, None)
            .unwrap_err()
            .to_string()
            .contains("missing.txt"));
    }

    #[test]
    fn nonsense_settings_are_refused() {
        for (bad, says) in [
            ("--size 0", "--size 0"),
            ("--idle-timeout 0", "--idle-timeout 0"),
            ("--access-token=", "empty"),
        ] {
            let a = parse_flags::<Args>(&format!("--data /nonexistent {bad}")).expect("flags");
            let e = config(&a, None).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
        // The rest reach the library's checks (tests/serve.rs): here they parse.
        let a = parse_flags::<Args>(
            "--data D --max-sessions 0 --max-messages-per-second 0 --jpeg-quality 0",
        )
        .expect("flags");
        assert_eq!(
            (a.max_sessions, a.max_messages_per_second, a.jpeg_quality),
            (0, 0, 0)
        );
        assert!(parse_flags::<Args>("--data D --lossless-frames --jpeg-quality 50").is_err());
        let lossless = |flags: &str| parse_flags::<Args>(flags).expect("flags").lossless_frames;
        assert_eq!(lossless("--data D"), None);
        assert_eq!(
            lossless("--data D --lossless-frames"),
            Some(LosslessFormat::Png)
        );
        assert_eq!(
            lossless("--lossless-frames webp --data D"),
            Some(LosslessFormat::WebP)
        );
        assert!(parse_flags::<Args>("--data D --lossless-frames gif").is_err());
    }
}
