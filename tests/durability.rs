//! Durability of the writing commands, as a user meets them: `kill -9` at varied points of
//! `ingest`, `bake`, `episodes` and `run`, then the same command again, leaves exactly the
//! files an uninterrupted run leaves, byte for byte (no stale temporary file, no missing
//! preview); two writers of one folder never run at once; a full disk fails with one line
//! naming the file and the next run completes.
#![cfg(unix)]

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::{cli_ingested, first_difference, minos, tree_bytes, RunOk};
use minos::progress::NoProgress;
use minos::seed::Rng;

/// One step of the pipeline, with the folder it works in (always the same path, so stored
/// paths are the same in every copy).
struct Step {
    name: &'static str,
    args: Vec<String>,
}

fn steps(root: &Path, work: &Path) -> Vec<Step> {
    let s = |p: PathBuf| p.display().to_string();
    let data = s(work.join("DATA"));
    let eps = s(work.join("eps").join("point.parquet"));
    let step = |name, args: &[&str]| Step {
        name,
        args: args.iter().map(|a| a.to_string()).collect(),
    };
    vec![
        step(
            "ingest",
            &[
                "-q",
                "ingest",
                "--dataset",
                "suncg",
                "--root",
                &s(root.to_path_buf()),
                "--out",
                &data,
            ],
        ),
        step(
            "split",
            &[
                "-q", "split", "--name", "all", "--ratios", "1,0,0", "--data", &data,
            ],
        ),
        step("bake", &["-q", "bake", "--data", &data]),
        step(
            "episodes",
            &[
                "-q",
                "episodes",
                "--task",
                "pointgoal",
                "--split",
                "all",
                "--per-scene",
                "3",
                "--seed",
                "5",
                "--data",
                &data,
                "--out",
                &eps,
            ],
        ),
        step(
            "run",
            &[
                "-q",
                "run",
                "--agent",
                "forward",
                "--max-steps",
                "12",
                "--size",
                "16",
                "--format",
                "lerobot",
                "--data",
                &data,
                "--episodes",
                &eps,
                "--out",
                &s(work.join("OUT")),
            ],
        ),
    ]
}

/// `cp -a from to` (times kept: freshness checks compare them), `to` replaced.
fn copy_tree(from: &Path, to: &Path) {
    if to.exists() {
        std::fs::remove_dir_all(to).unwrap();
    }
    let ok = Command::new("cp")
        .arg("-a")
        .arg(from)
        .arg(to)
        .status()
        .unwrap();
    assert!(ok.success(), "cp -a {} {}", from.display(), to.display());
}

fn run_step(step: &Step) {
    minos().args(&step.args).ok_output();
}

/// Names of the files under `dir` that look temporary (`.<name>.tmp-<pid>`, `.old-`).
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    tree_bytes(dir)
        .into_iter()
        .map(|(p, _)| p)
        .filter(|p| {
            p.components()
                .any(|c| minos::atomic::temp_owner(&c.as_os_str().to_string_lossy()).is_some())
        })
        .collect()
}

#[test]
fn kill_9_at_varied_points_then_rerun_leaves_the_uninterrupted_bytes() {
    let base = tempfile::tempdir().unwrap();
    let (root, work) = (base.path().join("suncg"), base.path().join("work"));
    minos()
        .args([
            "-q", "generate", "--houses", "3", "--seed", "8", "--rooms", "3..5", "--out",
        ])
        .arg(&root)
        .ok_output();
    std::fs::create_dir_all(&work).unwrap();
    // The uninterrupted pipeline, with the work folder saved before and after each step.
    let steps = steps(&root, &work);
    let snap = |i: usize| base.path().join(format!("snap{i}"));
    copy_tree(&work, &snap(0));
    let mut took = Vec::new();
    for (i, step) in steps.iter().enumerate() {
        let start = Instant::now();
        run_step(step);
        took.push(start.elapsed());
        copy_tree(&work, &snap(i + 1));
    }
    // A deterministic list of kill points per command, as fractions of its uninterrupted
    // time: some early, some late, some after it finished.
    let mut rng = Rng::new(0x6b69_6c6c);
    let mut killed_early = 0;
    for (i, step) in steps.iter().enumerate() {
        if step.name == "split" {
            continue;
        }
        let expected = tree_bytes(&snap(i + 1));
        for _ in 0..3 {
            let fraction = rng.range_f64(0.05, 1.15);
            let delay = took[i].mul_f64(fraction);
            copy_tree(&snap(i), &work);
            let mut child = minos().args(&step.args).spawn().unwrap();
            std::thread::sleep(delay);
            let finished = child.try_wait().unwrap().is_some();
            let _ = child.kill(); // SIGKILL
            let status = child.wait().unwrap();
            killed_early += usize::from(!finished && !status.success());
            eprintln!(
                "{} killed at {:.0}%: {}, {} temporaries left",
                step.name,
                fraction * 100.0,
                if finished {
                    "had finished"
                } else {
                    "interrupted"
                },
                temporaries(&work).len()
            );
            let label = format!(
                "{} killed at {:.0}% ({delay:?})",
                step.name,
                fraction * 100.0
            );
            // The LeRobot copy appears whole or not at all: whatever a kill left checks clean.
            let copy = work.join("OUT/lerobot");
            if copy.exists() {
                let report = minos::verify::verify(&copy, &Default::default(), &NoProgress)
                    .unwrap_or_else(|e| panic!("{label}: {e}"));
                assert!(report.is_clean(), "{label}: {:#?}", report.problems);
            }
            run_step(step);
            let got = tree_bytes(&work);
            assert_eq!(temporaries(&work), Vec::<PathBuf>::new(), "{label}");
            let names =
                |t: &[(PathBuf, Vec<u8>)]| t.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
            assert_eq!(names(&got), names(&expected), "{label}: files differ");
            for ((p, a), (_, b)) in got.iter().zip(&expected) {
                assert!(
                    a == b,
                    "{label}: {}: {}",
                    p.display(),
                    first_difference(&work.join(p), &snap(i + 1).join(p))
                );
            }
        }
    }
    // The kills must have interrupted something, or the test proves nothing.
    assert!(
        killed_early >= 4,
        "only {killed_early} kills interrupted a command"
    );

    // What a kill can leave, planted where each command writes: temporaries of a dead
    // process (files and a LeRobot-style folder) and a grid without its preview. Running the
    // pipeline again removes and rewrites them.
    let done = snap(steps.len());
    copy_tree(&done, &work);
    let dead = 4_194_305 + 99; // above Linux's largest pid
    let data = work.join("DATA");
    let planted = [
        data.join(format!(".houses.parquet.tmp-{dead}")),
        data.join("scenes").join(format!(".x.mscene.tmp-{dead}")),
        data.join("nav").join(format!(".x.nav.tmp-{dead}")),
        work.join("eps").join(format!(".point.parquet.tmp-{dead}")),
        work.join("OUT")
            .join(format!(".trajectories.parquet.tmp-{dead}")),
        work.join("OUT")
            .join(format!(".lerobot.tmp-{dead}"))
            .join("info.json"),
    ];
    for p in &planted {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, b"partial").unwrap();
    }
    let preview = std::fs::read_dir(data.join("nav"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "png"))
        .expect("bake wrote previews");
    std::fs::remove_file(&preview).unwrap();
    for step in &steps {
        run_step(step);
    }
    assert_eq!(temporaries(&work), Vec::<PathBuf>::new());
    assert!(preview.is_file(), "{} not rewritten", preview.display());
    assert!(
        tree_bytes(&work) == tree_bytes(&done),
        "planted leftovers change the outputs"
    );
}

/// A DATA folder with two ingested houses, in `dir/DATA`.
fn ingested(dir: &Path) -> PathBuf {
    cli_ingested(dir, 2, 3)
}

#[test]
fn a_second_writer_fails_naming_the_holder_or_waits_and_readers_are_never_blocked() {
    let dir = tempfile::tempdir().unwrap();
    let data = ingested(dir.path());
    // This test process is the first writer.
    let held = minos::store::DataDir::new(&data)
        .lock("test", minos::lock::LockMode::Fail)
        .unwrap();
    let me = std::process::id();
    for args in [
        vec!["bake", "--data"],
        vec!["split", "--name", "all", "--ratios", "1,0,0", "--data"],
        vec!["ingest", "--dataset", "suncg", "--root", "suncg", "--out"],
    ] {
        let out = minos()
            .current_dir(dir.path())
            .args(&args)
            .arg(&data)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} ran beside the holder");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains(&format!("in use by pid {me} (minos test)")),
            "{err}"
        );
        assert!(err.contains(&data.display().to_string()), "{err}");
        // The library says what is wrong; the command line adds its flag.
        assert!(
            err.trim_end().ends_with("(or pass --wait to wait for it)"),
            "{err}"
        );
    }
    assert!(
        !data.join("nav").exists() && !data.join("splits").exists(),
        "nothing written"
    );
    // Readers go on.
    minos()
        .args(["-q", "stats", "--data"])
        .arg(&data)
        .ok_output();
    // A waiting writer blocks until the holder lets go, then runs.
    let mut waiter = minos()
        .args([
            "-q", "--wait", "split", "--name", "all", "--ratios", "1,0,0", "--data",
        ])
        .arg(&data)
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(700));
    assert!(waiter.try_wait().unwrap().is_none(), "--wait did not wait");
    assert!(!data.join("splits").exists());
    drop(held);
    assert!(waiter.wait().unwrap().success());
    assert!(data.join("splits/all/train.txt").is_file());
    // Two real processes: a run holds its output folder while it runs.
    assert_eq!(
        std::fs::read(data.join(".minos.lock")).unwrap(),
        b"",
        "released lock is empty"
    );
}

/// A small tmpfs mounted on a folder, unmounted when dropped.
struct Tmpfs(PathBuf);

impl Tmpfs {
    /// Mounts one of `size` bytes on `dir`, or says why it cannot.
    fn mount(dir: &Path, size: u64) -> Result<Tmpfs, String> {
        let uid = Command::new("id")
            .arg("-u")
            .output()
            .map_err(|e| e.to_string())?;
        if String::from_utf8_lossy(&uid.stdout).trim() != "0" {
            return Err("not root: cannot mount a tmpfs".into());
        }
        std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir)
            .output()
            .map_err(|e| format!("mount: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "mount: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Ok(Tmpfs(dir.to_path_buf()))
    }

    /// Resizes it to `size` bytes.
    fn resize(&self, size: u64) {
        let ok = Command::new("mount")
            .args(["-o", &format!("remount,size={size}")])
            .arg(&self.0)
            .status()
            .unwrap();
        assert!(ok.success(), "remount {}", self.0.display());
    }

    /// Remounts it `ro` or `rw`.
    fn remount(&self, how: &str) {
        let ok = Command::new("mount")
            .args(["-o", &format!("remount,{how}")])
            .arg(&self.0)
            .status()
            .unwrap();
        assert!(ok.success(), "remount {how} {}", self.0.display());
    }

    /// Bytes in use.
    fn used(&self) -> u64 {
        let out = Command::new("df")
            .args(["-B1", "--output=used"])
            .arg(&self.0)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        text.lines()
            .last()
            .and_then(|l| l.trim().parse().ok())
            .expect("df output")
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// Runs `args` expecting failure on a full disk: one line naming a file under `under`.
fn fails_naming_a_file(args: &[&str], extra: &[&Path], under: &Path) {
    let mut cmd = minos();
    cmd.args(args);
    for p in extra {
        cmd.arg(p);
    }
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    eprint!("full disk, {}: {err}", args[1]);
    assert!(!out.status.success(), "{args:?} succeeded on a full disk");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    assert!(err.contains(&under.display().to_string()), "{err}");
}

#[test]
fn a_full_disk_fails_with_one_line_naming_the_file_and_the_next_run_completes() {
    let dir = tempfile::tempdir().unwrap();
    // The same commands on a roomy disk, for the expected bytes.
    let reference = ingested(dir.path());
    let root = dir.path().join("suncg");
    minos()
        .args([
            "-q", "split", "--name", "all", "--ratios", "1,0,0", "--data",
        ])
        .arg(&reference)
        .ok_output();
    let ingest_only = tree_bytes(&reference);
    minos()
        .args(["-q", "bake", "--data"])
        .arg(&reference)
        .ok_output();
    let baked = tree_bytes(&reference);
    let scenes_bytes: u64 = tree_bytes(&reference.join("scenes"))
        .iter()
        .map(|(_, b)| b.len() as u64)
        .sum();

    let mnt = dir.path().join("small");
    let fs = match Tmpfs::mount(&mnt, scenes_bytes / 2) {
        Ok(fs) => fs,
        Err(why) => {
            common::skip(why);
            return;
        }
    };
    let data = mnt.join("DATA");
    let ingest = ["-q", "ingest", "--dataset", "suncg", "--root"];
    fails_naming_a_file(&ingest, &[&root, Path::new("--out"), &data], &data);
    // Nothing under a final name but whole files: no manifest, no temporaries, and every
    // compiled scene there is the complete one.
    assert!(!data.join("houses.parquet").exists());
    assert_eq!(temporaries(&data), Vec::<PathBuf>::new());
    let whole: std::collections::BTreeMap<_, _> = ingest_only.iter().cloned().collect();
    for (p, bytes) in tree_bytes(&data) {
        if p.as_os_str() != ".minos.lock" {
            assert!(
                whole.get(&p) == Some(&bytes),
                "{} is not whole",
                p.display()
            );
        }
    }
    // Space freed: the same command completes.
    fs.resize(64 << 20);
    minos()
        .args(ingest)
        .arg(&root)
        .arg("--out")
        .arg(&data)
        .ok_output();
    minos()
        .args([
            "-q", "split", "--name", "all", "--ratios", "1,0,0", "--data",
        ])
        .arg(&data)
        .ok_output();
    assert!(
        tree_bytes(&data) == ingest_only,
        "ingest after a full disk differs"
    );

    // Bake with a few kilobytes left: grids do not fit.
    fs.resize(fs.used() + (16 << 10));
    fails_naming_a_file(&["-q", "bake", "--data"], &[&data], &data.join("nav"));
    assert_eq!(temporaries(&data), Vec::<PathBuf>::new());
    fs.resize(64 << 20);
    minos()
        .args(["-q", "bake", "--data"])
        .arg(&data)
        .ok_output();
    assert!(tree_bytes(&data) == baked, "bake after a full disk differs");

    // A read-only folder: one line naming it, nothing changed.
    fs.remount("ro");
    let out = minos()
        .args(["-q", "bake", "--force", "--data"])
        .arg(&data)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    eprint!("read-only, bake: {err}");
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("Read-only file system") && err.contains(&data.display().to_string()),
        "{err}"
    );
    fs.remount("rw");
    assert!(tree_bytes(&data) == baked, "a refused bake changed DATA");

    // A run whose output folder fills up: its reference first, in the same place.
    let eps = dir.path().join("point.parquet");
    minos()
        .args([
            "-q",
            "episodes",
            "--task",
            "pointgoal",
            "--split",
            "all",
            "--per-scene",
            "3",
        ])
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&eps)
        .ok_output();
    let out = mnt.join("OUT");
    let run = || {
        let mut cmd = minos();
        cmd.args([
            "-q",
            "run",
            "--agent",
            "forward",
            "--max-steps",
            "12",
            "--size",
            "32",
        ])
        .arg("--data")
        .arg(&data)
        .arg("--episodes")
        .arg(&eps)
        .arg("--out")
        .arg(&out);
        cmd
    };
    run().ok_output();
    let ran = tree_bytes(&out);
    std::fs::remove_dir_all(&out).unwrap();
    fs.resize(fs.used() + (24 << 10));
    let failed = run().output().unwrap();
    let err = String::from_utf8_lossy(&failed.stderr);
    eprint!("full disk, run: {err}");
    assert!(!failed.status.success(), "run succeeded on a full disk");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    assert!(err.contains(&out.display().to_string()), "{err}");
    for table in [
        "trajectories.parquet",
        "observations.parquet",
        "metrics.json",
    ] {
        assert!(!out.join(table).exists(), "{table} written on a full disk");
    }
    fs.resize(64 << 20);
    run().ok_output();
    assert!(tree_bytes(&out) == ran, "run after a full disk differs");
}

#[test]
fn two_runs_on_one_output_folder_the_second_names_the_first_and_a_killed_holder_frees_it() {
    let dir = tempfile::tempdir().unwrap();
    let data = ingested(dir.path());
    let eps = dir.path().join("point.parquet");
    for args in [
        vec![
            "-q", "split", "--name", "all", "--ratios", "1,0,0", "--data",
        ],
        vec!["-q", "bake", "--no-preview", "--data"],
    ] {
        minos().args(&args).arg(&data).ok_output();
    }
    minos()
        .args([
            "-q",
            "episodes",
            "--task",
            "pointgoal",
            "--split",
            "all",
            "--per-scene",
            "2",
        ])
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&eps)
        .ok_output();
    let out = dir.path().join("OUT");
    let run = |agent: &str| {
        let mut cmd = minos();
        cmd.args([
            "-q",
            "run",
            "--max-steps",
            "5",
            "--size",
            "16",
            "--agent",
            agent,
        ])
        .arg("--data")
        .arg(&data)
        .arg("--episodes")
        .arg(&eps)
        .arg("--out")
        .arg(&out);
        cmd
    };
    // The first run's policy never answers (it reads until minos goes away), so the first
    // run holds OUT until it is killed.
    let mut first = run("external:cat > /dev/null").spawn().unwrap();
    let holder = format!("{} run\n", first.id());
    let lock = out.join(".minos.lock");
    let start = Instant::now();
    while std::fs::read_to_string(&lock).unwrap_or_default() != holder {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the first run never took the lock"
        );
        assert!(
            first.try_wait().unwrap().is_none(),
            "the first run ended early"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let second = run("forward").output().unwrap();
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "two runs wrote one folder");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(&format!("in use by pid {} (minos run)", first.id())),
        "{err}"
    );
    // The run only reads DATA: a DATA writer goes on beside it.
    minos()
        .args(["-q", "split", "--name", "b", "--ratios", "1,0,0", "--data"])
        .arg(&data)
        .ok_output();
    // Killed, the holder lets go: no stale lock.
    first.kill().unwrap();
    first.wait().unwrap();
    run("forward").ok_output();
    assert!(out.join("trajectories.parquet").is_file());
    assert_eq!(temporaries(&out), Vec::<PathBuf>::new());
    assert_eq!(std::fs::read(&lock).unwrap(), b"");
}
