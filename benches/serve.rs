//! Responsiveness of `minos serve`: `cargo bench --bench serve`.
//!
//! One generated furnished house (default configuration), PointGoal episodes, the Habitat
//! agent and MINOS's RGB-D-semantic sensors at 256² on the CPU renderer, observations written
//! raw to Parquet, the server in this process, clients over real WebSockets on localhost.
//!
//! Every session asks for all three views (colour, depth, semantic), sent as the server's
//! frame format (`MINOS_BENCH_FRAMES`: `jpeg`, the default of `minos serve`; `png`, its
//! `--lossless-frames`; `webp`, its `--lossless-frames webp`; or `raw`); a key press's frame
//! is its last view's message.
//!
//! 1. Latency: one session; the time from sending a key press (an action) to receiving the
//!    new frames, over many steps (median, 90th and 99th percentile).
//! 2. Load: N sessions (`MINOS_BENCH_SESSIONS`, default 12), each pressing a key every
//!    100 ms (a person holding a key at 10 presses/s; as on the page, one action in flight,
//!    so a late frame delays the next press and later ones catch up), the sessions' schedules
//!    spread over the period (`MINOS_BENCH_LOCKSTEP=1`: all at once); the frames per second
//!    each session gets and the latencies of all (p50, p90, p99), also without the frames
//!    that wait for an episode's end, and in each quarter of the run (the sessions' start
//!    against their steady state).
//! 3. Frame encodings: a 256² view's message as raw RGB, JPEG, PNG and WebP (time and bytes).
//!
//! `MINOS_BENCH_STEPS` (default 200) sets the steps of the latency run, `MINOS_BENCH_SECONDS`
//! (default 20) the length of the load run, `MINOS_BENCH_RATE` (default 10) its key presses
//! per second and session, `MINOS_BENCH_CLIENT_THREADS` (default 2) the scripted clients'
//! threads.

mod support;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use minos::body::{AgentPreset, BodyRule};
use minos::episode::sample::SampleConfig;
use minos::episode::Task;
use minos::io::image_codec::ImageEncoding;
use minos::pipeline::episodes::sample_scenes;
use minos::progress::NoProgress;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::serve::frames::FrameFormat;
use minos::serve::rate::RateLimits;
use minos::serve::session::Shared;
use minos::serve::{start, ServeConfig};
use minos::shard::Shard;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;
use tokio_tungstenite::tungstenite::Message;

type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

fn env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A session's token from `POST /api/sessions` (a minimal HTTP/1.1 request).
fn create(addr: SocketAddr) -> String {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    let body = "{}";
    write!(
        s,
        "POST /api/sessions HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let json = out.split_once("\r\n\r\n").expect("a body").1;
    let v: serde_json::Value = serde_json::from_str(json).expect("JSON");
    v["token"].as_str().expect("a token").to_string()
}

/// Actions of a wandering person: mostly forward, some turns; blocked by a wall, they turn
/// away ([`Walker`]) instead of pressing on into it (which would leave the camera facing the
/// wall, a cheap frame to render, and the figures too good).
const WALK: [&str; 8] = [
    "forward",
    "forward",
    "turn_left",
    "forward",
    "forward",
    "turn_right",
    "forward",
    "turn_right",
];

/// A wandering person's next actions: [`WALK`] in turn, and after a step that collided, a
/// turn of 30–90° away from the wall (the direction and size vary with the press count).
struct Walker {
    presses: usize,
    turning: usize,
    turn: &'static str,
}

impl Walker {
    fn new(start: usize) -> Self {
        Walker {
            presses: start,
            turning: 0,
            turn: "turn_left",
        }
    }

    /// The action after a step that `collided` (or not).
    fn next(&mut self, collided: bool) -> &'static str {
        let i = self.presses;
        self.presses += 1;
        if collided && self.turning == 0 {
            self.turning = 3 + i % 7;
            self.turn = if (i / 7).is_multiple_of(2) {
                "turn_left"
            } else {
                "turn_right"
            };
        }
        if self.turning > 0 {
            self.turning -= 1;
            return self.turn;
        }
        WALK[i % WALK.len()]
    }
}

/// What arrived for a step: its last view's message, whether an episode ended on the way
/// (the frame is then the next episode's first), and whether the step collided.
struct Arrived {
    frame: Vec<u8>,
    ended: bool,
    collided: bool,
}

/// Waits for the frames of step `want` of the session (counting every step message since it
/// began; answering an episode's end with "next").
async fn frame(ws: &mut Ws, steps: &mut u64, want: u64) -> Option<Arrived> {
    let (mut ended, mut collided) = (false, false);
    while let Some(Ok(m)) = ws.next().await {
        match m {
            Message::Binary(b) if b[0] == 1 && b[1] == 2 && *steps >= want => {
                return Some(Arrived {
                    frame: b.to_vec(),
                    ended,
                    collided,
                })
            }
            Message::Text(t) if t.as_str().contains("\"type\":\"step\"") => {
                *steps += 1;
                collided = t.as_str().contains("\"collision\":true");
            }
            Message::Text(t) if t.as_str().contains("\"type\":\"done\"") => {
                ended = true;
                ws.send(Message::Text(r#"{"next":null}"#.into()))
                    .await
                    .unwrap();
            }
            _ => {}
        }
    }
    None
}

/// A key press's latency (ms), whether an episode ended before its frame, and when the key
/// was pressed.
type Latency = (f64, bool, Instant);

/// One session: actions at most every `period`, for `duration` or `steps`; the latencies
/// and the last frame.
async fn session(
    addr: SocketAddr,
    period: Duration,
    phase: Duration,
    duration: Duration,
    steps: usize,
    mut walker: Walker,
) -> (Vec<Latency>, Vec<u8>) {
    let token = tokio::task::spawn_blocking(move || create(addr))
        .await
        .unwrap();
    let url = format!("ws://{addr}/api/sessions/{token}/ws");
    let (mut ws, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    ws.send(Message::Text(r#"{"views":["depth","semantic"]}"#.into()))
        .await
        .unwrap();
    // The first step's frames may go out before the views are asked for: the next ones
    // carry all three.
    ws.send(Message::Text(r#"{"action":"turn_left"}"#.into()))
        .await
        .unwrap();
    let mut seen = 0;
    let mut want = 2;
    let last = frame(&mut ws, &mut seen, want).await.expect("first frames");
    let mut collided = last.collided;
    let mut last = last.frame;
    let mut latencies = Vec::new();
    let begin = Instant::now();
    // Key presses on a fixed schedule, every `period` (like a key held down), one in flight
    // as the page does: a late frame delays the next press, later presses catch up.
    let mut due = tokio::time::Instant::now() + phase;
    while begin.elapsed() < duration && latencies.len() < steps {
        tokio::time::sleep_until(due).await;
        due += period;
        let sent = Instant::now();
        let action = format!(r#"{{"action":"{}"}}"#, walker.next(collided));
        ws.send(Message::Text(action.into())).await.unwrap();
        want += 1;
        match frame(&mut ws, &mut seen, want).await {
            Some(a) => {
                latencies.push((sent.elapsed().as_secs_f64() * 1e3, a.ended, sent));
                (last, collided) = (a.frame, a.collided);
            }
            None => break,
        }
    }
    let _ = ws.send(Message::Text(r#"{"end":true}"#.into())).await;
    (latencies, last)
}

/// The RGB pixels of a camera message, whatever its format.
fn decoded(message: &[u8]) -> Vec<u8> {
    if message[6] == 0 {
        return message[8..].to_vec();
    }
    image::load_from_memory(&message[8..])
        .expect("a decodable frame")
        .to_rgb8()
        .into_raw()
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn percentiles(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    format!(
        "median {:.1} ms, p90 {:.1} ms, p99 {:.1} ms, max {:.1} ms ({} frames)",
        percentile(&v, 0.5),
        percentile(&v, 0.9),
        percentile(&v, 0.99),
        v.last().copied().unwrap_or(f64::NAN),
        v.len()
    )
}

/// The latencies' percentiles in four windows of the load run (from `start`, `seconds`
/// long): whether the tail is the sessions' start or their steady state.
fn by_window(v: Vec<Latency>, start: Instant, seconds: u64) -> String {
    let quarter = seconds as f64 / 4.0;
    let mut windows = vec![Vec::new(); 4];
    for (ms, _, at) in v {
        let i = (at.saturating_duration_since(start).as_secs_f64() / quarter) as usize;
        windows[i.min(3)].push(ms);
    }
    let parts: Vec<String> = windows
        .into_iter()
        .enumerate()
        .map(|(i, w)| {
            format!(
                "{:.0}–{:.0} s: {}",
                i as f64 * quarter,
                (i + 1) as f64 * quarter,
                percentiles(w)
            )
        })
        .collect();
    format!("by window of the load run: {}", parts.join("; "))
}

/// The latencies' percentiles, all of them and those within episodes (the others wait for
/// an episode's end and the next one's start: its parts written, its goal field computed).
fn summary(v: Vec<Latency>) -> String {
    let within: Vec<f64> = v.iter().filter(|l| !l.1).map(|l| l.0).collect();
    format!(
        "{}; within episodes {}",
        percentiles(v.into_iter().map(|l| l.0).collect()),
        percentiles(within)
    )
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let body = AgentConfig::habitat();
    let (data, ids) = support::baked_houses(dir.path(), 1, 1, body.body);
    let data = DataDir::new(&data);
    let episodes = sample_scenes(
        &data,
        &[(ids[0].clone(), "val".into())],
        &SampleConfig {
            task: Task::PointGoal,
            per_scene: 40,
            seed: 1,
            ..Default::default()
        },
        BodyRule::strict(body.body),
        Shard::ALL,
        &NoProgress,
    )
    .episodes;
    let size = env("MINOS_BENCH_SIZE", 256) as u32;
    let sessions = env("MINOS_BENCH_SESSIONS", 12) as usize;
    let frames = match std::env::var("MINOS_BENCH_FRAMES").as_deref() {
        Ok("raw") => FrameFormat::Raw,
        Ok("png") => FrameFormat::Png,
        Ok("webp") => FrameFormat::WebP,
        _ => FrameFormat::default(),
    };
    let running = start(
        ServeConfig {
            shared: Shared {
                data: data.clone(),
                episodes,
                episodes_file: None,
                scenes: ids.clone(),
                out: dir.path().join("demos"),
                preset: AgentPreset::Habitat,
                agent_config: body,
                sensors: SensorSuite::minos(size),
                renderer: RendererChoice::Cpu,
                reward: Reward::DistTime,
                encoding: ImageEncoding::Raw,
                seed: 0,
                idle: Duration::from_secs(60),
                command: Vec::new(),
                variant: None,
                frames,
            },
            access_token: None,
            max_sessions: sessions.max(1) + 1,
            connect_timeout: Duration::from_secs(30),
            send_timeout: Duration::from_secs(10),
            allowed_hosts: Vec::new(),
            // A scripted client back to back sends more than a person's 50 messages a
            // second: one ignored action would stall the run until the idle timeout.
            rate: RateLimits {
                messages_per_second: 100_000,
                ..RateLimits::default()
            },
        },
        "127.0.0.1:0".parse().unwrap(),
    )
    .expect("server");
    let addr = running.addr;
    // The scripted clients' own threads (MINOS_BENCH_CLIENT_THREADS, default 2): with the
    // server's threads busy, too few of them delay reading the frames and count as latency.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(env("MINOS_BENCH_CLIENT_THREADS", 2).max(1) as usize)
        .enable_all()
        .build()
        .unwrap();
    println!(
        "serve: 1 house ({}), RGB-D-semantic {size}² on the CPU renderer, raw Parquet, \
         frames as {}, {} cores",
        ids[0],
        frames.name(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    let steps = env("MINOS_BENCH_STEPS", 200) as usize;
    let (one, pixels) = rt.block_on(session(
        addr,
        Duration::ZERO,
        Duration::ZERO,
        Duration::from_secs(600),
        steps,
        Walker::new(0),
    ));
    println!(
        "key press -> frames, 1 session, back to back: {}",
        summary(one)
    );
    let seconds = env("MINOS_BENCH_SECONDS", 20);
    // Key presses per second and session (a person holding a key: 10).
    let rate = env("MINOS_BENCH_RATE", 10).max(1);
    let period = Duration::from_millis(1000 / rate);
    let t = Instant::now();
    // People do not press their keys in step: each session's schedule starts at its own
    // phase of the period (spread evenly), unless MINOS_BENCH_LOCKSTEP=1 (every session at
    // once, the worst case: 12 steps arrive together on the cores).
    let lockstep = env("MINOS_BENCH_LOCKSTEP", 0) == 1;
    let all: Vec<Vec<Latency>> = rt.block_on(async {
        let tasks: Vec<_> = (0..sessions)
            .map(|k| {
                let phase = if lockstep {
                    Duration::ZERO
                } else {
                    period * k as u32 / sessions as u32
                };
                tokio::spawn(session(
                    addr,
                    period,
                    phase,
                    Duration::from_secs(seconds),
                    usize::MAX,
                    Walker::new(k * 3),
                ))
            })
            .collect();
        let mut out = Vec::new();
        for t in tasks {
            out.push(t.await.unwrap().0);
        }
        out
    });
    let wall = t.elapsed().as_secs_f64();
    let fps: Vec<f64> = all
        .iter()
        .map(|l| l.len() as f64 / seconds as f64)
        .collect();
    let min_fps = fps.iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "{sessions} sessions pressing {rate} keys/s ({}) for {seconds} s ({wall:.1} s with set-up): \
         {:.1} frames/s per session (min {min_fps:.1}), {:.0} frames/s in all; key press -> \
         frames {}",
        if lockstep {
            "in lockstep"
        } else {
            "phases spread"
        },
        fps.iter().sum::<f64>() / fps.len() as f64,
        fps.iter().sum::<f64>(),
        summary(all.iter().flatten().copied().collect())
    );
    println!(
        "{}",
        by_window(all.into_iter().flatten().collect(), t, seconds)
    );
    // Frame encodings of the last semantic view seen and of a synthetic colour-like view.
    let semantic = decoded(&pixels);
    let colour: Vec<u8> = (0..size * size)
        .flat_map(|i| {
            let (x, y) = (i % size, i / size);
            [
                (x * 255 / size) as u8,
                (y * 255 / size) as u8,
                ((x ^ y) & 0xff) as u8,
            ]
        })
        .collect();
    for (what, rgb) in [
        ("semantic view", &semantic),
        ("gradient test image", &colour),
    ] {
        let mut line = format!("a {size}² {what}:");
        for format in [
            FrameFormat::Raw,
            FrameFormat::default(),
            FrameFormat::Png,
            FrameFormat::WebP,
        ] {
            let n = 200;
            let t = Instant::now();
            let mut bytes = 0;
            for _ in 0..n {
                bytes = minos::serve::frames::camera_message(format, 0, size, size, rgb)
                    .unwrap()
                    .len();
            }
            let ms = t.elapsed().as_secs_f64() / n as f64 * 1e3;
            line += &format!(" {} {ms:.3} ms ({bytes} bytes);", format.name());
        }
        println!("{line}");
    }
    running.stop();
}
