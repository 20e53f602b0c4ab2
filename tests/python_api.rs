//! The Python API (python/, docs/PYTHON.md), tested from the README's one test command: builds
//! the `minos` Python package into a virtual environment as a user does (`pip install
//! ./python`, maturin, the abi3 extension) and runs its pytest suite (python/tests/), which
//! compares the bindings with this build's `minos` binary.
//!
//! The virtual environment is `$MINOS_PY_VENV`, or `python-venv` in the cargo target folder,
//! kept between runs; the extension is built in the same target folder, so it reuses the
//! compiled dependencies. Without python3, its venv module or a reachable package registry the
//! test says that it skipped and why; once the tools are there, a failing build or test fails.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The cargo target folder this test was built in (`CARGO_TARGET_DIR`, else two levels
/// above the binary: `<target>/release/minos`).
fn target_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("CARGO_TARGET_DIR") {
        let dir = PathBuf::from(dir);
        return if dir.is_absolute() {
            dir
        } else {
            root().join(dir)
        };
    }
    let bin = Path::new(env!("CARGO_BIN_EXE_minos"));
    bin.parent()
        .and_then(Path::parent)
        .map_or_else(|| root().join("target"), Path::to_path_buf)
}

/// Runs `cmd` in the repository root without the variables `cargo test` sets for this test
/// (`CARGO_MANIFEST_DIR`, `CARGO_PKG_*`, …): build scripts of dependencies track some of them,
/// so the extension's cargo build would otherwise see changed inputs and rebuild them.
fn run(cmd: &mut Command) -> std::io::Result<Output> {
    for (name, _) in std::env::vars_os() {
        let name = name.to_string_lossy();
        if (name == "CARGO" || name.starts_with("CARGO_") || name == "OUT_DIR")
            && name != "CARGO_HOME"
            && name != "CARGO_TARGET_DIR"
        {
            cmd.env_remove(name.as_ref());
        }
    }
    cmd.current_dir(root()).output()
}

fn tail(out: &Output) -> String {
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(40)..].join("\n")
}

/// The virtual environment with the build and test tools, or why there is none.
fn venv() -> Result<PathBuf, String> {
    let dir = std::env::var_os("MINOS_PY_VENV")
        .map_or_else(|| target_dir().join("python-venv"), PathBuf::from);
    let python = dir.join("bin/python");
    if !python.is_file() {
        match run(Command::new("python3").args(["-m", "venv"]).arg(&dir)) {
            Err(e) => return Err(format!("python3 not found ({e})")),
            Ok(o) if !o.status.success() => {
                return Err(format!(
                    "`python3 -m venv` failed (install python3-venv): {}",
                    tail(&o).replace('\n', " ")
                ))
            }
            Ok(_) => {}
        }
    }
    let ready = |p: &Path| {
        run(Command::new(p).args([
            "-c",
            "import numpy, gymnasium, pytest, maturin, sys; assert sys.version_info >= (3, 10)",
        ]))
        .is_ok_and(|o| o.status.success())
    };
    if !ready(&python) {
        let o = run(Command::new(&python).args([
            "-m",
            "pip",
            "install",
            "-q",
            "numpy",
            "gymnasium>=1.0",
            "pytest",
            "maturin>=1.9,<2",
        ]))
        .map_err(|e| format!("pip: {e}"))?;
        if !o.status.success() || !ready(&python) {
            return Err(format!(
                "could not install numpy, gymnasium, pytest and maturin into {} (no registry?): {}",
                dir.display(),
                tail(&o).replace('\n', " ")
            ));
        }
    }
    Ok(python)
}

/// `PATH` with the environment's `bin/` first (pip runs the `maturin` found there).
fn path_with(python: &Path) -> std::ffi::OsString {
    let bin = python.parent().map(Path::to_path_buf).unwrap_or_default();
    let rest = std::env::var_os("PATH").unwrap_or_default();
    std::env::join_paths(std::iter::once(bin).chain(std::env::split_paths(&rest))).unwrap_or(rest)
}

#[test]
fn the_python_package_builds_and_its_tests_pass() {
    let python = match venv() {
        Ok(p) => p,
        Err(why) => {
            common::skip(why);
            return;
        }
    };
    // `pip install ./python` with the tools of the environment (no download of maturin per
    // run); cargo builds the extension in this target folder, with the library as the tests
    // built it (feature `internals`), so the library is not compiled a second time. The
    // bindings' own build without the feature is `cargo clippy -p minos-python` (.ci/run),
    // and tests/layering.rs checks they name no internal module.
    let o = run(Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "-q",
            "--no-build-isolation",
            "--no-deps",
            "--force-reinstall",
            "./python",
        ])
        .env("CARGO_TARGET_DIR", target_dir())
        .env("MATURIN_PEP517_ARGS", "--features minos/internals")
        .env("PATH", path_with(&python)))
    .expect("pip runs");
    assert!(
        o.status.success(),
        "pip install ./python failed:\n{}",
        tail(&o)
    );
    let o = run(Command::new(&python)
        .args([
            "-m",
            "pytest",
            "-q",
            "-rs",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .env("MINOS_BIN", env!("CARGO_BIN_EXE_minos"))
        .env("PYTHONDONTWRITEBYTECODE", "1"))
    .expect("pytest runs");
    let report = tail(&o);
    println!("{report}");
    // pytest's `-rs` summary: one `SKIPPED [n] file:line: reason` line per skip reason.
    for line in String::from_utf8_lossy(&o.stdout).lines() {
        if let Some(rest) = line.strip_prefix("SKIPPED ") {
            common::skip(format!("pytest {rest}"));
        }
    }
    assert!(o.status.success(), "pytest failed:\n{report}");
    assert!(report.contains(" passed"), "pytest ran no test:\n{report}");
}

/// The default of a keyword argument in the `#[pyo3(signature = …)]` of `function` in
/// `python/src/<file>` (the text after `name = `, up to the next comma).
fn signature_default(file: &str, function: &str, name: &str) -> String {
    let text = std::fs::read_to_string(root().join("python/src").join(file)).expect("source");
    let at = text
        .find(&format!("pub fn {function}<"))
        .unwrap_or_else(|| panic!("{file}: no function {function}"));
    let signature = text[..at]
        .rfind("#[pyo3(signature = (")
        .map(|s| &text[s..at])
        .unwrap_or_else(|| panic!("{file}: {function} has no signature"));
    let key = format!(" {name} = ");
    let start = signature
        .find(&key)
        .unwrap_or_else(|| panic!("{function}: no default for {name}"))
        + key.len();
    let rest = &signature[start..];
    rest[..rest.find([',', ')']).unwrap_or(rest.len())].to_string()
}

/// pyo3 shows a default that is not a literal as `...` in the signature Python sees (and
/// `python/tests/test_docs.py` compares those with docs/PYTHON.md), so some defaults the
/// library names are spelled as literals there: they must stay the library's values.
#[test]
fn literal_defaults_of_the_bindings_are_the_librarys() {
    assert_eq!(
        signature_default("pipeline.rs", "sample_episodes", "max_steps"),
        minos::episode::interchange::DEFAULT_MAX_STEPS.to_string()
    );
}
