//! Sharded commands give the bytes of unsharded ones: `bake` shards writing one DATA folder
//! at once, and `minos merge` of the shards of `episodes` and `run` (for 1, 2, 3 and 7
//! shards, one of them killed and resumed); inputs that are not the shards of one job are
//! refused with a one-line error.

use crate::common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::{cli_ingested, first_difference, minos, tree_bytes, RunOk};

/// A DATA folder of 4 generated houses, ingested and baked with the binary.
fn baked_data(dir: &Path) -> PathBuf {
    let data = cli_ingested(dir, 4, 31);
    minos()
        .args(["-q", "bake", "--no-preview", "--data"])
        .arg(&data)
        .ok_output();
    data
}

fn episodes(data: &Path, out: &Path, shard: &str) {
    minos()
        .args(["-q", "episodes", "--data"])
        .arg(data)
        .args(["--task", "pointgoal", "--per-scene", "3", "--seed", "5"])
        .args(["--shard", shard, "--out"])
        .arg(out)
        .ok_output();
}

fn stats_of(p: &Path) -> PathBuf {
    PathBuf::from(format!("{}.stats.json", p.display()))
}

#[test]
fn merged_episode_shards_are_the_unsharded_file() {
    let dir = tempfile::tempdir().unwrap();
    let data = baked_data(dir.path());
    let full = dir.path().join("full.parquet");
    episodes(&data, &full, "0/1");
    for n in [1usize, 2, 3, 7] {
        let parts: Vec<PathBuf> = (0..n)
            .map(|i| {
                let p = dir.path().join(format!("s{n}/part{i}.parquet"));
                episodes(&data, &p, &format!("{i}/{n}"));
                p
            })
            .collect();
        let merged = dir.path().join(format!("merged{n}.parquet"));
        // Shards in reverse order: the order they are given does not matter.
        minos()
            .args(["-q", "merge", "--out"])
            .arg(&merged)
            .args(parts.iter().rev())
            .ok_output();
        // The episode file and its statistics; a failure says what differs (`minos diff`).
        for (x, y) in [
            (merged.clone(), full.clone()),
            (stats_of(&merged), stats_of(&full)),
        ] {
            let what = first_difference(&x, &y);
            assert!(what == "identical", "{n} shards: {}: {what}", x.display());
        }
    }
    // Not the shards of one job: one line naming the problem, nothing written.
    let s3 = |i: usize| dir.path().join(format!("s3/part{i}.parquet"));
    let refused = |shards: &[PathBuf], why: &str| {
        let out = dir.path().join("refused.parquet");
        let o = minos()
            .args(["merge", "--out"])
            .arg(&out)
            .args(shards)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(why), "{why}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!out.exists());
    };
    refused(&[s3(0), s3(2)], "shard 1/3 missing");
    refused(&[s3(0), s3(1), s3(1), s3(2)], "is given twice");
    refused(
        &[s3(0), s3(1), dir.path().join("s2/part1.parquet")],
        "shards of different splits",
    );
    refused(
        &[s3(0), dir.path().join("nothing.parquet")],
        "no such shard",
    );
}

/// `minos run` of the test's episodes into `out` (shard `shard`, recording to `rrd`).
fn run_cmd(data: &Path, eps: &Path, out: &Path, rrd: &Path, shard: &str) -> std::process::Command {
    let mut c = minos();
    c.args(["-q", "run", "--data"])
        .arg(data)
        .arg("--episodes")
        .arg(eps)
        .args(["--agent", "random", "--seed", "9", "--max-steps", "12"])
        .args([
            "--format",
            "lerobot",
            "--rerun-episodes",
            "3",
            "--shard",
            shard,
        ])
        .arg("--out")
        .arg(out)
        .arg("--rerun")
        .arg(rrd);
    c
}

/// Every message of a recording (the bytes of rerun's footer change between any two runs).
fn messages(rrd: &Path) -> Vec<rerun::log::LogMsg> {
    let reader = std::io::BufReader::new(std::fs::File::open(rrd).unwrap());
    re_log_encoding::DecoderApp::decode_eager(reader)
        .unwrap()
        .map(|m| m.unwrap())
        .collect()
}

/// A manifest without the command that made it.
fn manifest_sans_command(dir: &Path) -> serde_json::Value {
    let mut m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    m.as_object_mut().unwrap().remove("command");
    m
}

/// Kills `minos run` once it has finished an episode (and before it finishes all), then
/// resumes it. Returns whether the kill interrupted it.
fn killed_and_resumed(
    mut cmd: std::process::Command,
    resume: std::process::Command,
    out: &Path,
) -> bool {
    let mut child = cmd.spawn().unwrap();
    let parts = out.join(".parts");
    let start = Instant::now();
    let done_one = || {
        std::fs::read_dir(&parts)
            .map(|d| {
                d.flatten()
                    .any(|e| e.path().extension().is_some_and(|x| x == "json"))
            })
            .unwrap_or(false)
    };
    while !done_one()
        && child.try_wait().unwrap().is_none()
        && start.elapsed() < Duration::from_secs(60)
    {
        std::thread::sleep(Duration::from_millis(2));
    }
    let interrupted = child.try_wait().unwrap().is_none();
    let _ = child.kill();
    let _ = child.wait();
    let mut resume = resume;
    resume.arg("--resume").ok_output();
    interrupted
}

#[test]
fn merged_run_shards_are_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    let data = baked_data(dir.path());
    let eps = dir.path().join("eps.parquet");
    episodes(&data, &eps, "0/1");
    let (full, full_rrd) = (dir.path().join("full"), dir.path().join("full.rrd"));
    run_cmd(&data, &eps, &full, &full_rrd, "0/1").ok_output();
    // The reference moves aside: the merges write where the unsharded run wrote, so the
    // paths the manifests record are the same.
    let (reference, reference_rrd) = (dir.path().join("ref"), dir.path().join("ref.rrd"));
    std::fs::rename(&full, &reference).unwrap();
    std::fs::rename(&full_rrd, &reference_rrd).unwrap();
    let expected = tree_bytes(&reference);
    assert!(expected.iter().any(|(p, _)| p.starts_with("lerobot")));
    let expected_messages = messages(&reference_rrd);
    let mut interrupted = false;
    for n in [1usize, 2, 3, 7] {
        let mut shards = Vec::new();
        for i in 0..n {
            let out = dir.path().join(format!("r{n}/{i}"));
            let rrd = dir.path().join(format!("r{n}/{i}.rrd"));
            let shard = format!("{i}/{n}");
            if n == 3 && i == 1 {
                interrupted |= killed_and_resumed(
                    run_cmd(&data, &eps, &out, &rrd, &shard),
                    run_cmd(&data, &eps, &out, &rrd, &shard),
                    &out,
                );
            } else {
                run_cmd(&data, &eps, &out, &rrd, &shard).ok_output();
            }
            shards.push(out);
        }
        minos()
            .args(["-q", "merge", "--out"])
            .arg(&full)
            .arg("--rerun")
            .arg(&full_rrd)
            .args(&shards)
            .ok_output();
        let got = tree_bytes(&full);
        let names = |t: &[(PathBuf, Vec<u8>)]| t.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
        assert_eq!(names(&got), names(&expected), "{n} shards: files differ");
        for ((p, a), (_, b)) in got.iter().zip(&expected) {
            if p == Path::new("manifest.json") {
                continue;
            }
            assert!(
                a == b,
                "{n} shards: {}: {}",
                p.display(),
                first_difference(&full.join(p), &reference.join(p))
            );
        }
        assert_eq!(
            manifest_sans_command(&full),
            manifest_sans_command(&reference),
            "{n} shards: manifest"
        );
        assert!(
            messages(&full_rrd) == expected_messages,
            "{n} shards: the recording's messages differ"
        );
        std::fs::remove_dir_all(&full).unwrap();
        std::fs::remove_file(&full_rrd).unwrap();
    }
    assert!(interrupted, "the kill came too late to interrupt shard 1/3");

    // Shards of different runs are refused, naming the manifest key that differs.
    let other = dir.path().join("other/0");
    let other_rrd = dir.path().join("other/0.rrd");
    let mut c = run_cmd(&data, &eps, &other, &other_rrd, "0/2");
    c.args(["--reward", "geodesic"]).ok_output();
    // A refused merge of `shards` with a recording: its stderr.
    let refused = |shards: [&Path; 2]| {
        let o = minos()
            .args(["merge", "--out"])
            .arg(&full)
            .arg("--rerun")
            .arg(&full_rrd)
            .args(shards)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{shards:?} merged");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let err = refused([&other, &dir.path().join("r2/1")]);
    assert!(
        err.contains("`reward` differs") && err.contains("not shards of one run"),
        "{err}"
    );
    // So are shards whose LeRobot copies encode the cameras otherwise (the merged copy is
    // encoded once, as the first shard's).
    let video = dir.path().join("video/1");
    let mut c = run_cmd(&data, &eps, &video, &dir.path().join("video/1.rrd"), "1/2");
    c.args(["--video", "--video-qp", "30"]).ok_output();
    let err = refused([&dir.path().join("r2/0"), &video]);
    assert!(
        err.contains("video at quantiser 30")
            && err.contains("images, not video")
            && err.contains("not shards of one run"),
        "{err}"
    );
    // A recording run needs --rerun for the merged recording.
    let o = minos()
        .args(["merge", "--out"])
        .arg(&full)
        .arg(dir.path().join("r2/0"))
        .arg(dir.path().join("r2/1"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--rerun"), "{err}");
    // An unfinished shard (no manifest) is named.
    std::fs::remove_file(dir.path().join("r2/1/manifest.json")).unwrap();
    let err = refused([&dir.path().join("r2/0"), &dir.path().join("r2/1")]);
    assert!(
        err.contains("r2/1/manifest.json") && err.contains("--resume"),
        "{err}"
    );
}

#[test]
fn bake_shards_running_at_once_write_the_unsharded_grids() {
    let dir = tempfile::tempdir().unwrap();
    let data = cli_ingested(dir.path(), 5, 13);
    let copy = dir.path().join("DATA-sharded");
    std::fs::create_dir_all(&copy).unwrap();
    for (p, bytes) in tree_bytes(&data) {
        let to = copy.join(&p);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::write(to, bytes).unwrap();
    }
    minos()
        .args(["-q", "bake", "--data"])
        .arg(&data)
        .ok_output();
    // Three shards at once on one folder (the shared lock admits them all), one of them
    // given its shard by a Slurm array's environment.
    let children: Vec<_> = (0..3)
        .map(|i| {
            let mut c = minos();
            c.args(["-q", "bake", "--data"]).arg(&copy);
            if i == 2 {
                c.args(["--shard", "auto"])
                    .env("SLURM_ARRAY_TASK_ID", "3")
                    .env("SLURM_ARRAY_TASK_MIN", "1")
                    .env("SLURM_ARRAY_TASK_COUNT", "3");
            } else {
                c.args(["--shard", &format!("{i}/3")]);
            }
            c.spawn().unwrap()
        })
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let grids = |d: &Path| tree_bytes(&d.join("nav"));
    let (a, b) = (grids(&data), grids(&copy));
    assert!(a.len() >= 5, "{} files", a.len());
    assert_eq!(
        a.iter().map(|(p, _)| p).collect::<Vec<_>>(),
        b.iter().map(|(p, _)| p).collect::<Vec<_>>()
    );
    for ((p, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs", p.display());
    }
}

#[test]
fn ingest_shards_then_one_unsharded_ingest_give_the_one_process_folder() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("suncg");
    minos()
        .args([
            "-q", "generate", "--houses", "7", "--seed", "21", "--rooms", "2..4", "--out",
        ])
        .arg(&root)
        .ok_output();
    let ingest = |data: &Path, shard: Option<&str>| {
        let mut c = minos();
        c.args(["-q", "ingest", "--dataset", "suncg", "--root"])
            .arg(&root)
            .arg("--out")
            .arg(data);
        if let Some(s) = shard {
            c.args(["--shard", s]);
        }
        c
    };
    let one = dir.path().join("DATA-one");
    ingest(&one, None).ok_output();
    let sharded = dir.path().join("DATA-sharded");
    // Three shards at once (the shared lock admits them), then the manifest pass.
    let children: Vec<_> = ["0/3", "1/3", "2/3"]
        .iter()
        .map(|s| ingest(&sharded, Some(s)).spawn().unwrap())
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    assert!(
        !sharded.join("houses.parquet").exists(),
        "a shard writes no manifest"
    );
    let mut last = minos();
    last.args(["ingest", "--dataset", "suncg", "--root"])
        .arg(&root)
        .arg("--out")
        .arg(&sharded);
    let out = last.ok_output();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("0 compiled, 7 up to date, 0 failed"),
        "{said}"
    );
    let (a, b) = (tree_bytes(&one), tree_bytes(&sharded));
    assert_eq!(
        a.iter().map(|(p, _)| p).collect::<Vec<_>>(),
        b.iter().map(|(p, _)| p).collect::<Vec<_>>()
    );
    assert!(a.len() >= 8, "{} files", a.len());
    for ((p, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs", p.display());
    }
}
