//! The external agent: a process (`external:CMD`, run through `sh -c`) that receives one JSON
//! line per step on its stdin and answers one JSON line on its stdout, so a policy in any
//! language drives minos without bindings. The protocol is in `docs/EXTERNAL_AGENT.md`.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

use base64::Engine as _;
use serde_json::{json, Value};

use crate::episode::Episode;
use crate::sim::{Actions, Observation, Simulator};

use super::agents::{Agent, AgentError, Decision, ExternalFault, ReplyError};

/// A running external policy.
pub struct ExternalAgent {
    command: String,
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    episode: String,
}

impl ExternalAgent {
    /// Starts `command` with `sh -c`.
    pub fn spawn(command: &str) -> Result<Self, AgentError> {
        let fail = |fault| AgentError::External {
            command: command.to_string(),
            fault,
        };
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(command)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| fail(ExternalFault::Spawn(e)))?;
        let stdin = child
            .stdin
            .take()
            .ok_or_else(|| fail(ExternalFault::NoPipe("stdin")))?;
        let stdout = BufReader::new(
            child
                .stdout
                .take()
                .ok_or_else(|| fail(ExternalFault::NoPipe("stdout")))?,
        );
        Ok(ExternalAgent {
            command: command.to_string(),
            child,
            stdin,
            stdout,
            episode: String::new(),
        })
    }

    fn fail(&self, fault: ExternalFault) -> AgentError {
        AgentError::External {
            command: self.command.clone(),
            fault,
        }
    }

    fn send(&mut self, msg: &Value) -> Result<(), AgentError> {
        let line = msg.to_string();
        writeln!(self.stdin, "{line}")
            .and_then(|_| self.stdin.flush())
            .map_err(|e| self.fail(ExternalFault::Write(e)))
    }

    fn receive(&mut self) -> Result<Value, AgentError> {
        let mut line = String::new();
        let n = self
            .stdout
            .read_line(&mut line)
            .map_err(|e| self.fail(ExternalFault::Read(e)))?;
        if n == 0 {
            return Err(AgentError::ExternalClosed(self.command.clone()));
        }
        serde_json::from_str(line.trim()).map_err(|source| {
            self.fail(ExternalFault::NotJson {
                reply: line.trim().to_string(),
                source,
            })
        })
    }
}

impl Drop for ExternalAgent {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Parses a reply: `{"stop": true}`, `{"action": "forward"}` or `{"actions": {"forward": 1.0, …}}`.
pub fn parse_reply(v: &Value) -> Result<Decision, ReplyError> {
    if v.get("stop").and_then(Value::as_bool) == Some(true) {
        return Ok(Decision::Stop);
    }
    if let Some(name) = v.get("action").and_then(Value::as_str) {
        return Decision::from_name(name)
            .ok_or_else(|| ReplyError(format!("unknown action `{name}`")));
    }
    if let Some(map) = v.get("actions").and_then(Value::as_object) {
        let mut a = Actions::IDLE;
        for (k, val) in map {
            let s = val
                .as_f64()
                .ok_or_else(|| ReplyError(format!("actions.{k}: not a number")))?
                as f32;
            *a.strength_mut(k)
                .ok_or_else(|| ReplyError(format!("actions: unknown action `{k}`")))? = s;
        }
        return Ok(Decision::Act(a.clamped()));
    }
    Err(ReplyError(format!(
        "reply `{v}` has none of `stop`, `action`, `actions`"
    )))
}

fn observation_json(episode: &str, obs: &Observation, sim: &Simulator) -> Value {
    let m = &obs.measurements;
    let images: serde_json::Map<String, Value> = obs
        .images
        .iter()
        .zip(sim.sensor_suite().cameras.iter())
        .map(|((name, img), cam)| {
            let (dtype, channels) = img.dtype();
            (
                name.clone(),
                json!({
                    "shape": [cam.resolution[1], cam.resolution[0], channels],
                    "dtype": dtype.name(),
                    "base64": base64::engine::general_purpose::STANDARD.encode(img.to_le_bytes()),
                }),
            )
        })
        .collect();
    json!({
        "type": "step",
        "episode_id": episode,
        "step": m.step,
        "measurements": {
            "position": m.position, "yaw": m.yaw, "tilt": m.tilt, "velocity": m.velocity,
            "time_fraction": m.time_fraction, "collision": m.collision, "contacts": m.contacts,
            "goal_euclidean": m.goal_euclidean, "goal_direction": m.goal_direction,
            "goal_geodesic": m.goal_geodesic, "waypoint_direction": m.waypoint_direction,
        },
        "images": images,
    })
}

impl Agent for ExternalAgent {
    fn reset(&mut self, episode: &Episode, _sim: &Simulator) -> Result<(), AgentError> {
        self.episode = episode.episode_id.clone();
        let msg = json!({
            "type": "reset",
            "episode_id": episode.episode_id,
            "scene_id": episode.scene_id,
            "task": episode.task.name(),
            "success_radius": episode.success_radius,
            "max_steps": episode.max_steps,
        });
        self.send(&msg)
    }

    fn decide(&mut self, obs: &Observation, sim: &Simulator) -> Result<Decision, AgentError> {
        let msg = observation_json(&self.episode, obs, sim);
        self.send(&msg)?;
        let reply = self.receive()?;
        parse_reply(&reply).map_err(|source| {
            self.fail(ExternalFault::Reply {
                step: obs.measurements.step,
                source,
            })
        })
    }

    fn stops(&self) -> bool {
        true
    }
    fn waits_elsewhere(&self) -> bool {
        // On the agent's process.
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replies_parse_and_bad_ones_say_why() {
        assert_eq!(parse_reply(&json!({"stop": true})).unwrap(), Decision::Stop);
        assert_eq!(
            parse_reply(&json!({"action": "turn_left"})).unwrap(),
            Decision::Act(Actions::single("turn_left").unwrap())
        );
        let Decision::Act(a) =
            parse_reply(&json!({"actions": {"forward": 2.0, "turn_right": 0.5}})).unwrap()
        else {
            panic!()
        };
        assert_eq!((a.forward, a.turn_right), (1.0, 0.5));
        assert!(parse_reply(&json!({"action": "fly"}))
            .unwrap_err()
            .0
            .contains("fly"));
        assert!(parse_reply(&json!({"actions": {"jump": 1}}))
            .unwrap_err()
            .0
            .contains("jump"));
        assert!(parse_reply(&json!({})).is_err());
        // Fuzzing regression (target `external_reply`): a name holding a newline was quoted
        // raw, breaking the error across lines.
        for reply in [
            json!({"actions": {"f\ng": 1}}),
            json!({"action": "f\ng"}),
            json!({"actions": {"f\ng": "x"}}),
        ] {
            let e = parse_reply(&reply).unwrap_err().to_string();
            assert!(e.contains("f\\ng") && !e.contains('\n'), "{e}");
        }
    }
}
