//! `minos serve`: flags → [`ServeConfig`] ([`config`]: DATA, episodes, agent, sensors,
//! address and tokens), then [`minos::serve::start`]; prints the page's address and serves
//! until the process ends.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context as _};
use minos::body::AgentPreset;
use minos::episode::format::read_episodes;
use minos::io::tables::ImageEncoding;
use minos::run::metrics::Reward;
use minos::serve::campaign::{Campaign, CampaignSpec};
use minos::serve::{ServeConfig, Shared};
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

use super::common::{sensor_suite, PresetArg, RendererArg};
use super::Context;

/// Encodings of `--image-encoding`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum EncodingArg {
    /// Raw little-endian pixels.
    Raw,
    /// PNG (lossless but for float depth, 1 mm steps, and normals).
    Png,
}

/// Serve a web page to explore scenes and record human demonstrations.
///
/// Each visitor's session plays episodes of --episodes (or explores a scene) with the
/// keyboard or the buttons, and is recorded into DEMOS/<session>/ exactly like `minos run`
/// output: trajectories.parquet, observations.parquet, episodes.parquet, metrics.json,
/// manifest.json, plus played.parquet, the episodes it finished. `minos run --episodes
/// DEMOS/<session>/played.parquet --agent replay:DEMOS/<session>/trajectories.parquet` (same
/// --preset and --size) reproduces its tables byte for byte; `minos export-dataset` turns it
/// into a LeRobot dataset. Binds to localhost; another address needs --access-token.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos serve --data DATA --episodes eps/point.parquet\n  \
    minos serve --data DATA --out demos --preset minos\n  \
    minos serve --data DATA --episodes eps/object.parquet --bind 0.0.0.0:8080 --access-token \"$(openssl rand -hex 16)\""
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
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:8080")]
    bind: SocketAddr,
    /// Output folder: one folder per session.
    #[arg(long, default_value = "demos")]
    out: PathBuf,
    /// Token every request must carry (open the page as http://HOST:PORT/?access=TOKEN);
    /// required to listen on an address other than localhost.
    #[arg(long)]
    access_token: Option<String>,
    /// Agent preset (body and motion); the grids must be baked for its body.
    #[arg(long, value_enum, default_value_t)]
    preset: PresetArg,
    /// Sensor file (TOML/JSON); default: MINOS's RGB, depth, semantic at --size (grey,
    /// depth and semantic at 90° for --preset minos-paper).
    #[arg(long)]
    sensors: Option<PathBuf>,
    /// Image size of the default sensors.
    #[arg(long, default_value_t = 256)]
    size: u32,
    /// Renderer.
    #[arg(long, value_enum, default_value = "cpu")]
    renderer: RendererArg,
    /// Image storage in observations.parquet.
    #[arg(long, value_enum, default_value = "raw")]
    image_encoding: EncodingArg,
    /// Sessions at once, at most (each holds a simulator).
    #[arg(long, default_value_t = 16)]
    max_sessions: usize,
    /// A session ends after this many seconds without a key press.
    #[arg(long, default_value_t = 600)]
    idle_timeout: u64,
}

/// Flags → the server's configuration (reads the episode and sensor files and the manifest).
pub fn config(args: &Args) -> anyhow::Result<(ServeConfig, SocketAddr)> {
    if !args.bind.ip().is_loopback() && args.access_token.is_none() {
        bail!(
            "--bind {}: listening beyond this machine needs --access-token TOKEN (visitors open \
             http://HOST:PORT/?access=TOKEN)",
            args.bind
        );
    }
    if args.access_token.as_deref() == Some("") {
        bail!("--access-token: empty");
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
    // A campaign's agent and sensors win over the flags.
    let preset = spec
        .as_ref()
        .and_then(|c| c.preset)
        .unwrap_or(AgentPreset::from(args.preset));
    let size = spec.as_ref().and_then(|c| c.size).unwrap_or(args.size);
    let sensor_file = spec
        .as_ref()
        .and_then(|c| c.sensors.clone())
        .or_else(|| args.sensors.clone());
    let sensors = sensor_suite(sensor_file.as_deref(), || {
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
        body: AgentConfig::preset(preset),
        sensors,
        renderer: args.renderer.into(),
        reward: Reward::DistTime,
        encoding: match args.image_encoding {
            EncodingArg::Raw => ImageEncoding::Raw,
            EncodingArg::Png => ImageEncoding::Png,
        },
        seed: 0,
        idle: Duration::from_secs(args.idle_timeout.max(1)),
        command: std::env::args().collect(),
    };
    Ok((
        ServeConfig {
            shared,
            access_token: args.access_token.clone(),
            max_sessions: args.max_sessions,
            connect_timeout: Duration::from_secs(30),
            send_timeout: Duration::from_secs(10),
        },
        args.bind,
    ))
}

/// Runs `minos serve`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let (cfg, bind) = config(&args)?;
    if let Some(file) = &args.campaign {
        return run_campaign(file, cfg, bind, ctx);
    }
    let (episodes, scenes) = (cfg.shared.episodes.len(), cfg.shared.scenes.len());
    let running = minos::serve::start(cfg, bind)?;
    let query = if args.access_token.is_some() {
        "?access=<token>"
    } else {
        ""
    };
    ctx.say(format!(
        "serving {episodes} episodes and {scenes} scenes (preset {}) -> sessions recorded in {}\n\
         open http://{}/{query}   (Ctrl-C stops; finished episodes are already on disk)",
        AgentPreset::from(args.preset).name(),
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
    let campaign = Campaign::open(spec, &cfg.shared.episodes)?;
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
        let e = config(&a).unwrap_err().to_string();
        assert!(e.contains("--access-token"), "{e}");
        // Localhost needs none (it fails later, on the missing DATA folder).
        let a = parse_flags::<Args>("--data /nonexistent").expect("flags");
        assert_eq!(a.bind, "127.0.0.1:8080".parse::<SocketAddr>().unwrap());
        let e = config(&a).unwrap_err().to_string();
        assert!(e.contains("/nonexistent"), "{e}");
        assert!(parse_flags::<Args>("--data D --image-encoding jpeg").is_err());
    }
}
