//! Records the source commit minos is built from (`MINOS_SOURCE_COMMIT`, read by
//! `minos::provenance`): the environment variable of that name when set (a packager's or
//! CI's choice, and a way to keep a fixed value during development: every new commit
//! otherwise rebuilds the crate), else `git rev-parse HEAD` of the checkout, else `unknown`
//! (a source tarball without git). No network is involved.

use std::path::PathBuf;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (!text.is_empty()).then_some(text)
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=MINOS_SOURCE_COMMIT");
    let commit = match std::env::var("MINOS_SOURCE_COMMIT") {
        Ok(c) if !c.is_empty() => c,
        _ => {
            // Rebuild when HEAD moves: HEAD itself (branch switches), the branch's ref file
            // and packed-refs (new commits).
            if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
                println!(
                    "cargo:rerun-if-changed={}",
                    PathBuf::from(&dir).join("HEAD").display()
                );
            }
            if let (Some(common), Some(branch)) = (
                git(&["rev-parse", "--git-common-dir"]),
                git(&["symbolic-ref", "-q", "HEAD"]),
            ) {
                // (Only files that exist: a missing one would rerun this script every build.)
                let common = PathBuf::from(common);
                for file in [common.join(&branch), common.join("packed-refs")] {
                    if file.is_file() {
                        println!("cargo:rerun-if-changed={}", file.display());
                    }
                }
            }
            git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into())
        }
    };
    println!("cargo:rustc-env=MINOS_SOURCE_COMMIT={commit}");
}
