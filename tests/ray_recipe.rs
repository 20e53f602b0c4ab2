//! The Ray recipe (`scripts/ray_pipeline.py`) on a local Ray cluster this test starts (a head
//! and a second node on 127.0.0.1): its merged outputs are byte for byte those of the
//! pipeline run in one process, although the test kills, with SIGKILL, the Ray worker
//! running one of the `run` shards (Ray retries the task; the retry resumes the shard).
//!
//! Needs a Python with Ray: `$MINOS_RAY_PYTHON`, else `~/.cache/minos-ci-ray-venv` (which
//! `.ci/run` fills when root), else `python3`; without one the test says it skipped and why.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{minos, tree_bytes, RunOk};

/// A Python that imports ray, or why there is none.
fn ray_python() -> Result<PathBuf, String> {
    let mut candidates = Vec::new();
    if let Some(p) = std::env::var_os("MINOS_RAY_PYTHON") {
        candidates.push(PathBuf::from(p));
    }
    if let Some(home) = std::env::var_os("HOME") {
        candidates.push(Path::new(&home).join(".cache/minos-ci-ray-venv/bin/python"));
    }
    candidates.push(PathBuf::from("python3"));
    for p in &candidates {
        let ok = Command::new(p)
            .args(["-c", "import ray"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Ok(p.clone());
        }
    }
    Err(format!(
        "no Python with ray among {candidates:?} (pip install ray, or set MINOS_RAY_PYTHON)"
    ))
}

/// A local Ray cluster (head + one more node), stopped when dropped.
struct Cluster {
    python: PathBuf,
    address: String,
}

impl Cluster {
    fn ray(python: &Path, args: &[&str]) -> std::process::Output {
        Command::new(python)
            .args([
                "-c",
                "import sys; from ray.scripts.scripts import main; sys.argv[0] = 'ray'; main()",
            ])
            .args(args)
            .env("RAY_USAGE_STATS_ENABLED", "0")
            .output()
            .expect("ray starts")
    }

    fn start(python: &Path) -> Cluster {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let address = format!("127.0.0.1:{port}");
        let cluster = Cluster {
            python: python.to_path_buf(),
            address: address.clone(),
        };
        let port = port.to_string();
        for args in [
            vec![
                "start",
                "--head",
                "--node-ip-address",
                "127.0.0.1",
                "--port",
                &port,
                "--num-cpus",
                "1",
                "--include-dashboard",
                "false",
                "--disable-usage-stats",
            ],
            vec![
                "start",
                "--address",
                &address,
                "--node-ip-address",
                "127.0.0.1",
                "--num-cpus",
                "1",
                "--disable-usage-stats",
            ],
        ] {
            let out = Cluster::ray(python, &args);
            assert!(
                out.status.success(),
                "ray {}: {}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        cluster
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Cluster::ray(&self.python, &["stop", "--force"]);
    }
}

/// The pid of a running `minos run … --shard <shard>` process, if any.
fn minos_run_shard(shard: &str) -> Option<u32> {
    for e in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(cmd) = std::fs::read(e.path().join("cmdline")) else {
            continue;
        };
        let args: Vec<&[u8]> = cmd.split(|b| *b == 0).collect();
        let is = |a: &[u8], s: &str| a == s.as_bytes();
        if args.first().is_some_and(|a| a.ends_with(b"minos"))
            && args.iter().any(|a| is(a, "run"))
            && args
                .windows(2)
                .any(|w| is(w[0], "--shard") && is(w[1], shard))
        {
            return Some(pid);
        }
    }
    None
}

fn parent_of(pid: u32) -> Option<u32> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("PPid:"))
        .and_then(|v| v.trim().parse().ok())
}

/// The stages of the recipe, in one process each, with the recipe's arguments.
fn one_process_pipeline(root: &Path, work: &Path) {
    let data = work.join("DATA");
    minos()
        .args(["-q", "ingest", "--dataset", "suncg", "--root"])
        .arg(root)
        .arg("--out")
        .arg(&data)
        .ok_output();
    minos()
        .args(["-q", "bake", "--no-preview", "--data"])
        .arg(&data)
        .ok_output();
    let eps = work.join("episodes.parquet");
    minos()
        .args(["-q", "episodes", "--data"])
        .arg(&data)
        .args([
            "--task",
            "pointgoal",
            "--per-scene",
            "6",
            "--seed",
            "4",
            "--out",
        ])
        .arg(&eps)
        .ok_output();
    minos()
        .args(["-q", "run", "--data"])
        .arg(&data)
        .arg("--episodes")
        .arg(&eps)
        .args([
            "--agent", "oracle", "--seed", "4", "--size", "84", "--format", "lerobot",
        ])
        .arg("--out")
        .arg(work.join("run"))
        .ok_output();
}

fn manifest_sans_command(dir: &Path) -> serde_json::Value {
    let mut m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    m.as_object_mut().unwrap().remove("command");
    m
}

#[test]
fn the_ray_recipe_gives_the_one_process_bytes_despite_a_killed_worker() {
    let python = match ray_python() {
        Ok(p) => p,
        Err(why) => {
            common::skip(why);
            return;
        }
    };
    let recipe = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/ray_pipeline.py");
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("suncg");
    minos()
        .args([
            "-q", "generate", "--houses", "6", "--seed", "8", "--rooms", "3..5", "--out",
        ])
        .arg(&root)
        .ok_output();
    // The reference, written where the recipe will write (manifests record paths), then
    // moved aside.
    let work = dir.path().join("work");
    one_process_pipeline(&root, &work);
    let reference = dir.path().join("reference");
    std::fs::rename(&work, &reference).unwrap();

    let cluster = Cluster::start(&python);
    // Kill the Ray worker running shard 1/3 of `run` as soon as its minos process is seen.
    let stop = Arc::new(AtomicBool::new(false));
    let killer = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                if let Some(worker) = minos_run_shard("1/3").and_then(parent_of) {
                    std::thread::sleep(Duration::from_millis(300));
                    let killed = Command::new("kill")
                        .args(["-9", &worker.to_string()])
                        .status()
                        .is_ok_and(|s| s.success());
                    return killed;
                }
                std::thread::sleep(Duration::from_millis(2));
            }
            false
        })
    };
    let start = Instant::now();
    let out = Command::new(&python)
        .arg(&recipe)
        .args([
            "--address",
            &cluster.address,
            "--minos",
            env!("CARGO_BIN_EXE_minos"),
        ])
        .arg("--root")
        .arg(&root)
        .arg("--work")
        .arg(&work)
        .args([
            "--shards",
            "3",
            "--per-scene",
            "6",
            "--seed",
            "4",
            "--lerobot",
        ])
        .env("RAY_USAGE_STATS_ENABLED", "0")
        .output()
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    let killed = killer.join().unwrap();
    drop(cluster);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "recipe failed after {:?}:\n{stdout}\n{}",
        start.elapsed(),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        killed,
        "the run shard's worker was never seen, so never killed"
    );
    assert!(stdout.contains("\"done\": true"), "{stdout}");

    // Byte for byte: the grids, the merged episodes and the merged run (its manifest but
    // for the command that wrote it).
    let same = |a: &Path, b: &Path, skip: &[&str]| {
        let (x, y) = (tree_bytes(a), tree_bytes(b));
        let names = |t: &[(PathBuf, Vec<u8>)]| t.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
        assert_eq!(names(&x), names(&y), "{}", a.display());
        for ((p, u), (_, v)) in x.iter().zip(&y) {
            if !skip.iter().any(|s| p == Path::new(s)) {
                assert!(u == v, "{} differs", a.join(p).display());
            }
        }
    };
    same(&work.join("DATA/nav"), &reference.join("DATA/nav"), &[]);
    for f in ["episodes.parquet", "episodes.parquet.stats.json"] {
        assert!(
            std::fs::read(work.join(f)).unwrap() == std::fs::read(reference.join(f)).unwrap(),
            "{f} differs"
        );
    }
    same(
        &work.join("run"),
        &reference.join("run"),
        &["manifest.json"],
    );
    assert_eq!(
        manifest_sans_command(&work.join("run")),
        manifest_sans_command(&reference.join("run"))
    );
}
