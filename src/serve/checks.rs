//! What `minos serve` refuses at start-up, before it listens: settings that make no sense
//! (no sessions, images of no pixels, timeouts and rate limits of zero, an empty access
//! token), and scenes whose navigation grids were baked for another body than the agent
//! preset's — found once for the whole server, not when a person's session first loads
//! them.

use std::collections::{BTreeMap, BTreeSet};

use super::{FrameFormat, ServeConfig, ServeError, Shared};
use crate::scene::SceneRef;

/// Largest image side a session may send (pixels).
const MAX_SIDE: u32 = 4096;

/// Scenes named per problem in an error, at most.
const LISTED: usize = 5;

/// Refuses settings that make no sense, naming the first one.
pub fn settings(cfg: &ServeConfig) -> Result<(), ServeError> {
    let bad = |m: String| Err(ServeError::Setting(m));
    if cfg.max_sessions == 0 {
        return bad("max sessions 0: a server needs room for at least one session".into());
    }
    if let Some(token) = &cfg.access_token {
        if token.is_empty() {
            return bad("access token: empty".into());
        }
        if token.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return bad(
                "access token: holds spaces or control characters (it travels in URLs and headers)"
                    .into(),
            );
        }
    }
    let s = &cfg.shared;
    if s.sensors.cameras.is_empty() {
        return bad("sensors: no camera, so the page would show nothing".into());
    }
    for c in &s.sensors.cameras {
        let [w, h] = c.resolution;
        if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
            return bad(format!(
                "camera {}: {w}×{h} pixels: each side must be 1 to {MAX_SIDE}",
                c.name
            ));
        }
    }
    let zero = [
        ("idle timeout", s.idle.is_zero()),
        ("connect timeout", cfg.connect_timeout.is_zero()),
        ("send timeout", cfg.send_timeout.is_zero()),
        (
            "messages per second (rate limit)",
            cfg.rate.messages_per_second == 0,
        ),
        (
            "sessions per minute (rate limit)",
            cfg.rate.sessions_per_minute == 0,
        ),
    ];
    if let Some((name, _)) = zero.iter().find(|(_, z)| *z) {
        return bad(format!("{name}: 0, which would end or refuse everything"));
    }
    if let FrameFormat::Jpeg(q) = s.frames {
        if !(1..=100).contains(&q) {
            return bad(format!("JPEG quality {q}: must be 1 to 100"));
        }
    }
    if cfg
        .allowed_hosts
        .iter()
        .any(|h| h.is_empty() || h.contains(['/', ' ', ':']))
    {
        return bad("allowed host: give host names without scheme, port or path".into());
    }
    Ok(())
}

/// Checks the grids of every scene the server may load, once: the scenes of the episodes
/// must be baked for the agent's body (or the server does not start), and so must every
/// ingested scene that has a grid (those without one are not offered for exploration; on
/// `shared.variant` when it is set). Returns the scenes offered for exploration.
pub fn grids(shared: &Shared) -> Result<Vec<String>, ServeError> {
    let body = shared.agent_config.body;
    let mut problems: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let played: BTreeSet<&str> = shared
        .episodes
        .iter()
        .map(|e| e.scene_id.as_str())
        .collect();
    for id in &played {
        let scene = SceneRef::parse(id);
        let problem = match shared.data.read_grid_params(&scene) {
            Err(e) => Some(format!("not baked: {}", crate::escape::error_line(&e))),
            Ok(p) => body.check_grid(&p.body).err().map(|m| m.to_string()),
        };
        if let Some(p) = problem {
            problems.entry(p).or_default().push(id.to_string());
        }
    }
    let mut explorable = Vec::new();
    let mut unbaked = 0;
    for id in &shared.scenes {
        let scene = SceneRef::base(id.clone()).with_variant(shared.variant.as_deref());
        if !shared.data.grid_path(&scene).is_file() {
            unbaked += 1;
            continue;
        }
        match shared.data.read_grid_params(&scene) {
            Err(e) => problems
                .entry(crate::escape::error_line(&e))
                .or_default()
                .push(scene.to_string()),
            Ok(p) => match body.check_grid(&p.body) {
                Ok(()) => explorable.push(id.clone()),
                Err(m) => problems
                    .entry(m.to_string())
                    .or_default()
                    .push(scene.to_string()),
            },
        }
    }
    if unbaked > 0 {
        tracing::warn!(
            "{unbaked} ingested scenes have no grid and cannot be explored (bake them first)"
        );
    }
    if !problems.is_empty() {
        let listed: Vec<String> = problems
            .iter()
            .map(|(problem, ids)| {
                let mut names = ids[..ids.len().min(LISTED)].join(", ");
                if ids.len() > LISTED {
                    names = format!("{names} and {} more", ids.len() - LISTED);
                }
                format!("{problem} (scenes {names})")
            })
            .collect();
        return Err(ServeError::NotReady(format!(
            "agent preset {}: scenes cannot be served: {}",
            shared.preset.name(),
            listed.join("; ")
        )));
    }
    if shared.episodes.is_empty() && explorable.is_empty() {
        return Err(ServeError::NotReady(
            "nothing to serve: no episode and no baked scene (bake the scenes, or give an episode \
             file)"
                .into(),
        ));
    }
    Ok(explorable)
}
