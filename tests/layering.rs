//! The layering of `docs/ARCHITECTURE.md`, enforced: every module of the library imports only
//! from the floors below it. The test reads the sources, so an import that runs back up the
//! layers fails here, whatever compiles.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Ground: utilities every floor may use.
const GROUND: &[&str] = &[
    "atomic",
    "body",
    "escape",
    "file_error",
    "invalid",
    "lock",
    "parquet_io",
    "prefetch",
    "provenance",
    "progress",
    "seed",
    "vocab",
    "shard",
];

/// Each top-level module of the library and the modules (beyond the ground) it may import.
/// Read top to bottom, this is the floor plan of `docs/ARCHITECTURE.md`.
const FLOORS: &[(&str, &[&str])] = &[
    ("atomic", &[]),
    ("body", &[]),
    ("escape", &[]),
    ("file_error", &[]),
    ("invalid", &[]),
    ("lock", &[]),
    ("parquet_io", &[]),
    ("prefetch", &[]),
    ("provenance", &[]),
    ("progress", &[]),
    ("seed", &[]),
    ("vocab", &[]),
    ("shard", &[]),
    // The canonical model.
    ("scene", &[]),
    // Algorithms, in the direction data flows.
    ("generate", &["scene"]),
    ("navmesh", &["scene"]),
    ("episode", &["scene", "navmesh"]),
    ("render", &["scene"]),
    ("sim", &["scene", "navmesh", "episode", "render"]),
    ("run", &["scene", "navmesh", "episode", "render", "sim"]),
    // Storage (the DATA folder) and outputs, side by side.
    ("store", &["scene", "navmesh"]),
    (
        "io",
        &["scene", "navmesh", "episode", "render", "sim", "run"],
    ),
    // What works on a DATA folder as a whole.
    ("split", &["scene", "store"]),
    ("stats", &["scene", "store", "split"]),
    (
        "pipeline",
        &[
            "scene", "generate", "navmesh", "episode", "render", "sim", "run", "store", "io",
            "split", "stats",
        ],
    ),
    // Checking and comparing outputs: `minos verify` reads every kind of output (the DATA
    // folder through store, datasets through io); `minos diff` compares files alone.
    (
        "verify",
        &["scene", "navmesh", "episode", "render", "store", "io"],
    ),
    ("diff", &[]),
    // Front doors: the web server drives the pipeline (`minos serve`).
    (
        "serve",
        &[
            "scene", "navmesh", "episode", "render", "sim", "run", "store", "io", "pipeline",
        ],
    ),
];

fn allowed(module: &str) -> Option<BTreeSet<&'static str>> {
    let (_, deps) = FLOORS.iter().find(|(m, _)| *m == module)?;
    Some(deps.iter().chain(GROUND).copied().collect())
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable source folder") {
        let path = entry.expect("readable entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a file below `src/` (`src/a/b/mod.rs` → `[a, b]`, `src/a/c.rs` →
/// `[a, c]`).
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The code of a line: without its `//` comment (doc comments included) and without the
/// contents of string literals on it (good enough for this crate's sources).
fn code_of(line: &str) -> String {
    let mut out = String::new();
    let mut in_str = false;
    let mut prev = ' ';
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if !in_str && c == '/' && chars.get(i + 1) == Some(&'/') {
            break;
        }
        if c == '"' && prev != '\\' && !(prev == '\'' && chars.get(i + 1) == Some(&'\'')) {
            in_str = !in_str;
            out.push(c);
        } else if !in_str {
            out.push(c);
        }
        prev = if prev == '\\' && c == '\\' { ' ' } else { c };
        i += 1;
    }
    out
}

fn ident_at(s: &str) -> String {
    s.chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect()
}

/// The top-level modules `code` (one file, comments removed) refers to, for a file whose
/// module path is `here`.
fn references(code: &str, here: &[String]) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    // `crate::x` and `crate::{x, y::z}`.
    for (at, _) in code.match_indices("crate::") {
        let before = code[..at].chars().last();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        let rest = &code[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 0;
            let mut item = String::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        found.insert(ident_at(item.trim()));
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                if depth == 0 {
                    item.push(c);
                }
            }
            found.insert(ident_at(item.trim()));
        } else {
            found.insert(ident_at(rest));
        }
    }
    // `super::…` chains that climb to the crate root (only from a top-level file's children
    // or deeper); `here` is the file's module path.
    for (at, _) in code.match_indices("super::") {
        let before = code[..at].chars().last();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let mut rest = &code[at..];
        let mut ups = 0;
        while let Some(r) = rest.strip_prefix("super::") {
            ups += 1;
            rest = r;
        }
        if ups >= here.len() {
            found.insert(ident_at(rest));
        }
    }
    found.retain(|m| !m.is_empty() && m != "self" && m != "crate");
    found
}

fn violations(src: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut out = Vec::new();
    for file in files {
        let rel = file.strip_prefix(src).expect("below src");
        let here = module_path(rel);
        let Some(top) = here.first() else { continue };
        // The binary's command line may use everything.
        if top == "cmd" || top == "main" || top == "lib" {
            continue;
        }
        let Some(ok) = allowed(top) else {
            out.push(format!(
                "{}: module `{top}` has no floor in tests/layering.rs (add it to FLOORS)",
                rel.display()
            ));
            continue;
        };
        let text = std::fs::read_to_string(&file).expect("readable source");
        let code: String = text.lines().map(code_of).collect::<Vec<_>>().join("\n");
        for m in references(&code, &here) {
            if m != *top && !ok.contains(m.as_str()) {
                out.push(format!(
                    "{}: `{top}` imports `{m}`, which is not below it",
                    rel.display()
                ));
            }
        }
    }
    out
}

#[test]
fn every_import_runs_down_the_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let found = violations(&src);
    assert!(
        found.is_empty(),
        "imports that run back up:\n{}",
        found.join("\n")
    );
}

#[test]
fn every_top_level_module_has_a_floor() {
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs"))
        .expect("lib.rs");
    let declared: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| {
            let l = l.trim();
            l.strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("mod "))
        })
        .map(|m| m.trim_end_matches(';').to_string())
        .collect();
    let floors: BTreeSet<String> = FLOORS.iter().map(|(m, _)| m.to_string()).collect();
    assert_eq!(declared, floors, "src/lib.rs modules vs FLOORS");
}

#[test]
fn the_checker_sees_every_form_of_import() {
    let here = |p: &str| -> Vec<String> { p.split('/').map(String::from).collect() };
    let refs = |code: &str, at: &str| references(&code_of(code), &here(at));
    assert_eq!(
        refs("use crate::store::DataDir;", "navmesh/bake"),
        ["store".to_string()].into()
    );
    assert_eq!(
        refs("use crate::{io::rrd, sim::{Simulator, agent}};", "render/x"),
        ["io".to_string(), "sim".to_string()].into()
    );
    assert_eq!(
        refs("let x = crate::io::tables::ROW_GROUP;", "sim/a"),
        ["io".to_string()].into()
    );
    // From src/navmesh/x.rs, `super::super::store` climbs to the root; `super::grid` does not.
    assert_eq!(
        refs("use super::super::store::DataDir;", "navmesh/x"),
        ["store".to_string()].into()
    );
    assert!(refs("use super::grid::NavGrid;", "navmesh/x").is_empty());
    // From a top-level file, `super::` is the crate root.
    assert_eq!(
        refs("use super::io::tables;", "stats"),
        ["io".to_string()].into()
    );
    // Comments and strings do not count.
    assert!(refs("/// see [`crate::io::rrd`] // crate::store", "render/x").is_empty());
    assert!(refs(r#"let s = "crate::store::x";"#, "render/x").is_empty());
    // A planted violation is reported with its file.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("render")).unwrap();
    std::fs::write(
        dir.path().join("render/bad.rs"),
        "use crate::sim::Simulator;\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("render/good.rs"),
        "use crate::scene::Scene;\n",
    )
    .unwrap();
    let found = violations(dir.path());
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].contains("bad.rs") && found[0].contains("`sim`"),
        "{found:?}"
    );
}

#[test]
fn the_floor_plan_has_no_cycle() {
    // Depth-first search over FLOORS (ground included): a module never reaches itself.
    let graph: BTreeMap<&str, Vec<&str>> = FLOORS
        .iter()
        .map(|(m, deps)| {
            (
                *m,
                deps.iter()
                    .chain(GROUND)
                    .copied()
                    .filter(|d| d != m)
                    .collect(),
            )
        })
        .collect();
    fn reaches(
        graph: &BTreeMap<&str, Vec<&str>>,
        from: &str,
        to: &str,
        seen: &mut BTreeSet<String>,
    ) -> bool {
        graph.get(from).is_some_and(|deps| {
            deps.iter()
                .any(|d| *d == to || (seen.insert(d.to_string()) && reaches(graph, d, to, seen)))
        })
    }
    for (m, _) in FLOORS {
        let ground = GROUND.contains(m);
        // Ground modules list no dependencies, so only the upper floors can cycle.
        if !ground {
            assert!(
                !reaches(&graph, m, m, &mut BTreeSet::new()),
                "{m} depends on itself"
            );
        }
    }
}

/// The Python bindings (python/src/, crate `minos-python`) are a front door like the CLI:
/// they stand above every floor: the library never refers to them or to PyO3. (How the
/// front doors reach the library is checked below, for the CLI and the bindings alike.)
#[test]
fn the_python_bindings_stand_above_the_library() {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut lib = Vec::new();
    rust_files(&here.join("src"), &mut lib);
    for file in &lib {
        let text = std::fs::read_to_string(file).expect("readable source");
        let code: String = text.lines().map(code_of).collect::<Vec<_>>().join("\n");
        for word in ["pyo3", "numpy::", "minos_python"] {
            assert!(
                !code.contains(word),
                "{}: the library refers to `{word}`",
                file.display()
            );
        }
    }
    let mut bindings = Vec::new();
    rust_files(&here.join("python/src"), &mut bindings);
    assert!(!bindings.is_empty(), "python/src holds the bindings");
    // How the bindings reach the library: the_front_doors_take_no_lock_and_write_no_file_themselves.
}

/// The top-level names after each `minos::` of `code` (`minos::{a, b::c}` names `a` and `b`).
fn library_names(code: &str) -> Vec<String> {
    let mut names = Vec::new();
    for (at, _) in code.match_indices("minos::") {
        if code[..at]
            .chars()
            .last()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            continue;
        }
        let rest = &code[at + "minos::".len()..];
        match rest.strip_prefix('{') {
            Some(group) => names.extend(
                group
                    .split('}')
                    .next()
                    .unwrap_or("")
                    .split(',')
                    .map(|s| ident_at(s.trim())),
            ),
            None => names.push(ident_at(rest)),
        }
    }
    names.retain(|n| !n.is_empty());
    names
}

/// The repository's files and folders, relative, `/`-separated, folders ending in `/`
/// (build outputs, version control and caches left out).
fn repository_paths(root: &Path, dir: &Path, out: &mut Vec<String>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if matches!(
            name.as_str(),
            "target" | ".git" | "node_modules" | "__pycache__" | ".venv"
        ) {
            continue;
        }
        let rel = path
            .strip_prefix(root)
            .expect("under the root")
            .to_string_lossy()
            .replace('\\', "/");
        if path.is_dir() {
            out.push(format!("{rel}/"));
            repository_paths(root, &path, out);
        } else {
            out.push(rel);
        }
    }
}

/// The `code` spans of a Markdown text that name a file or folder: no spaces or
/// placeholders, ending in `/` or a source, script or document extension.
fn named_paths(doc: &str) -> Vec<String> {
    doc.split('`')
        .skip(1)
        .step_by(2)
        .filter(|t| {
            !t.is_empty()
                && !t.contains(|c: char| c.is_whitespace() || "<>*{}…:$".contains(c))
                && [".rs", ".wgsl", ".py", ".sh", ".md", ".toml", "/"]
                    .iter()
                    .any(|ext| t.ends_with(ext))
        })
        .map(str::to_string)
        .collect()
}

/// `docs/ARCHITECTURE.md` stays true: every file or folder it names exists (in full, as
/// `src/run/`, or relative to the module it describes, as `oracle/continuous.rs`), every
/// top-level module has its entry, and every file or folder directly inside a module's
/// folder is named — a renamed, removed or new file fails here until the code map follows.
#[test]
fn the_architecture_doc_names_what_exists_and_everything_is_named() {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(here.join("docs/ARCHITECTURE.md")).expect("the doc");
    let mut paths = Vec::new();
    repository_paths(here, here, &mut paths);
    let named = named_paths(&doc);
    assert!(named.len() > 100, "the code map names the files");
    // Folders of the data minos reads and writes (a DATA folder, SUNCG, a LeRobot dataset)
    // and the server's root route, which the doc names too.
    let data_folders = ["scenes/", "nav/", "stats/", "meta/", "texture/", "/"];
    let missing: Vec<&String> = named
        .iter()
        .filter(|t| !data_folders.contains(&t.as_str()))
        .filter(|t| {
            !paths
                .iter()
                .any(|p| p == *t || p.ends_with(&format!("/{t}")))
        })
        .collect();
    assert!(
        missing.is_empty(),
        "docs/ARCHITECTURE.md names what does not exist: {missing:?}"
    );
    // Every top-level module, and every file or folder one level inside a module's folder.
    let mentions = |name: &str| {
        named
            .iter()
            .any(|t| format!("/{t}").contains(&format!("/{name}")))
    };
    let mut unnamed = Vec::new();
    for (module, _) in FLOORS {
        let file = format!("src/{module}.rs");
        let folder = format!("src/{module}/");
        if !(named.contains(&file) || named.contains(&folder)) {
            unnamed.push(format!("{file} or {folder}"));
        }
    }
    for p in &paths {
        let Some(rest) = p.strip_prefix("src/") else {
            continue;
        };
        let parts: Vec<&str> = rest.trim_end_matches('/').split('/').collect();
        if parts.len() != 2 || !(p.ends_with(".rs") || p.ends_with('/')) {
            continue;
        }
        let name = if p.ends_with('/') {
            format!("{}/", parts[1])
        } else {
            parts[1].to_string()
        };
        if name != "mod.rs" && !mentions(&name) {
            unnamed.push(p.clone());
        }
    }
    assert!(
        unnamed.is_empty(),
        "docs/ARCHITECTURE.md does not name: {unnamed:?}"
    );
}

/// The front doors' source files: the binary's command line (`src/main.rs`, `src/cmd/`) and
/// the Python bindings (`python/src/`).
fn front_door_files(root: &Path) -> Vec<PathBuf> {
    let mut files = vec![root.join("src/main.rs")];
    rust_files(&root.join("src/cmd"), &mut files);
    rust_files(&root.join("python/src"), &mut files);
    files.sort();
    files
}

/// A source file's code outside its unit tests (`#[cfg(test)] mod tests` and what follows),
/// comments and string contents removed.
fn non_test_code(file: &Path) -> String {
    let text = std::fs::read_to_string(file).expect("readable source");
    let mut lines = Vec::new();
    let mut prev = "";
    for line in text.lines() {
        if prev.trim() == "#[cfg(test)]" && line.trim_start().starts_with("mod tests") {
            lines.pop();
            break;
        }
        lines.push(code_of(line));
        prev = line;
    }
    lines.join("\n")
}

/// What only the library does: take a folder's lock, and create, replace or remove files
/// (through the atomic writers that sweep what a killed writer left). Each as it appears in
/// code once comments and string contents are gone.
const LIBRARY_ONLY: &[(&str, &str)] = &[
    (".lock(\"", "takes a folder's lock"),
    ("lock_shared(", "takes a folder's lock"),
    ("DirLock", "takes a folder's lock"),
    ("fs::write", "writes a file"),
    ("File::create", "writes a file"),
    ("OpenOptions", "writes a file"),
    ("create_dir", "creates a folder"),
    ("fs::rename", "replaces a file"),
    ("fs::copy", "writes a file"),
    ("fs::remove", "removes files"),
    ("sweep_stale", "removes a killed writer's files"),
    ("write_bytes_atomic", "writes a file"),
    ("minos::atomic", "writes files"),
];

/// The front doors only translate (docs/ARCHITECTURE.md, "Front doors"): they reach the
/// library through its public modules, and every lock and every file of the DATA folder and
/// of the outputs is taken or written by a library call. So a lock cannot be skipped by a
/// library caller, and the durability rules (temporary name, rename, sweep) live in one place.
#[test]
fn the_front_doors_take_no_lock_and_write_no_file_themselves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = front_door_files(root);
    assert!(files.len() > 20, "front-door files found: {files:?}");
    let modules: BTreeSet<&str> = FLOORS.iter().map(|(m, _)| *m).collect();
    let mut found = Vec::new();
    for file in &files {
        let rel = file
            .strip_prefix(root)
            .unwrap_or(file)
            .display()
            .to_string();
        let code = non_test_code(file);
        for (word, what) in LIBRARY_ONLY {
            if code.contains(word) {
                found.push(format!(
                    "{rel}: `{word}` {what}: call a library driver instead"
                ));
            }
        }
        for m in library_names(&code) {
            if !modules.contains(m.as_str()) {
                found.push(format!(
                    "{rel}: `minos::{m}` is not a module of the library"
                ));
            }
        }
    }
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_front_door_check_sees_what_it_forbids() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let file = dir.path().join("x.rs");
    std::fs::write(
        &file,
        "fn f(d: &DataDir) {\n    let _l = d.lock(\"split\", mode); // fs::write in a comment\n    \
         let s = \"fs::write in a string\";\n}\n#[cfg(test)]\nmod tests {\n    fn t() { std::fs::write(p, b) }\n}\n",
    )
    .expect("write");
    let code = non_test_code(&file);
    assert!(code.contains(".lock(\""), "{code}");
    assert!(!code.contains("fs::write"), "{code}");
    assert_eq!(
        library_names(
            "use minos::{store::DataDir, pipeline};\nlet x = minos::split::read(); notminos::x"
        ),
        vec!["store", "pipeline", "split"]
    );
}

/// The error types of the `Result`s in `code` whose error is a bare `String` (the last
/// top-level argument of `Result<…>`, generics nested inside it skipped).
fn string_errors(code: &str) -> usize {
    let mut found = 0;
    let mut rest = code;
    while let Some(at) = rest.find("Result<") {
        let args = &rest[at + "Result<".len()..];
        let (mut depth, mut last_comma, mut end) = (0usize, None, None);
        for (i, c) in args.char_indices() {
            match c {
                '<' | '(' | '[' => depth += 1,
                ')' | ']' => depth = depth.saturating_sub(1),
                '>' if depth == 0 => {
                    end = Some(i);
                    break;
                }
                '>' => depth -= 1,
                ',' if depth == 0 => last_comma = Some(i),
                _ => {}
            }
        }
        if let (Some(comma), Some(end)) = (last_comma, end) {
            if args[comma + 1..end].trim() == "String" {
                found += 1;
            }
        }
        rest = args;
    }
    // An error type that is a `String` under another name.
    found + code.matches("Error = String;").count()
}

/// Library errors are typed (`thiserror` enums with their causes as sources): no library
/// code returns `Result<_, String>` (or names `String` an error type), which would lose the
/// cause and force callers to match on text. Unit tests and the front doors (`anyhow` at the edge) are not checked.
#[test]
fn library_errors_are_typed_not_strings() {
    assert_eq!(string_errors("fn f() -> Result<u32, String> {}"), 1);
    assert_eq!(string_errors("pub type TableError = String;"), 1);
    assert_eq!(
        string_errors("fn f() -> Result<BTreeMap<String, String>, E> {}"),
        0
    );
    assert_eq!(
        string_errors("fn f(x: Result<&Vec<(u8, String)>, String>) -> Result<(), Error>"),
        1
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    let front: BTreeSet<PathBuf> = front_door_files(root).into_iter().collect();
    let offenders: Vec<String> = files
        .iter()
        .filter(|f| !front.contains(*f))
        .filter(|f| string_errors(&non_test_code(f)) > 0)
        .map(|f| f.strip_prefix(root).unwrap_or(f).display().to_string())
        .collect();
    assert!(files.len() > 100, "library files found: {}", files.len());
    assert!(
        offenders.is_empty(),
        "library code returning Result<_, String>: {offenders:?}"
    );
}

/// The internal modules that `docs/ARCHITECTURE.md` lists ("API boundaries", "Internal
/// modules": one bullet per module, its path the bullet's first code span), in order.
fn internal_modules_of_the_doc(doc: &str) -> Vec<String> {
    let section = doc
        .split("\n### Internal modules\n")
        .nth(1)
        .expect("docs/ARCHITECTURE.md has an \"Internal modules\" section");
    let section = section.split("\n#").next().unwrap_or(section);
    section
        .lines()
        .filter_map(|l| l.strip_prefix("- `"))
        .filter_map(|l| l.split('`').next())
        .map(str::to_string)
        .collect()
}

/// The modules a source file declares through `internal!` (`internal! { … pub mod x; }`),
/// and those it declares plainly `pub` (`pub mod x;` outside the macro).
fn declared_modules(code: &str) -> (BTreeSet<String>, BTreeSet<String>) {
    let (mut internal, mut plain) = (BTreeSet::new(), BTreeSet::new());
    let mut inside = false;
    for line in code.lines().map(str::trim) {
        if line.starts_with("internal! {") {
            inside = true;
        } else if inside && line == "}" {
            inside = false;
        } else if let Some(rest) = line.strip_prefix("pub mod ") {
            let name = ident_at(rest);
            if inside {
                internal.insert(name);
            } else {
                plain.insert(name);
            }
        }
    }
    (internal, plain)
}

/// The file that declares the child modules of the library module `module` (`a::b` →
/// `src/a/b/mod.rs` or `src/a/b.rs`; `` → `src/lib.rs`).
fn declaring_file(src: &Path, module: &str) -> PathBuf {
    if module.is_empty() {
        return src.join("lib.rs");
    }
    let dir = src.join(module.replace("::", "/"));
    if dir.join("mod.rs").is_file() {
        dir.join("mod.rs")
    } else {
        dir.with_extension("rs")
    }
}

/// Every library path a use tree or a path starting at `code` names, relative to `minos`
/// (`navmesh::{build::build, NavGrid}` → `navmesh::build::build`, `navmesh::NavGrid`), and
/// how many bytes it took.
fn use_tree(code: &str, prefix: &str, out: &mut Vec<String>) -> usize {
    let mut path = prefix.to_string();
    let mut i = 0;
    loop {
        i += code[i..].len() - code[i..].trim_start().len();
        let rest = &code[i..];
        if rest.starts_with('{') {
            i += 1;
            loop {
                i += code[i..].len() - code[i..].trim_start().len();
                if code[i..].starts_with('}') {
                    return i + 1;
                }
                i += use_tree(&code[i..], &path, out);
                i += code[i..].len() - code[i..].trim_start().len();
                if code[i..].starts_with(',') {
                    i += 1;
                } else {
                    return i + usize::from(code[i..].starts_with('}'));
                }
            }
        }
        let name = ident_at(rest);
        if name.is_empty() {
            if !path.is_empty() {
                out.push(path);
            }
            return i;
        }
        path = if path.is_empty() {
            name.clone()
        } else {
            format!("{path}::{name}")
        };
        i += name.len();
        if code[i..].trim_start().starts_with("::") {
            i += code[i..].len() - code[i..].trim_start().len() + 2;
        } else {
            out.push(path);
            return i;
        }
    }
}

/// The internal modules `code` names: through a path or use tree from `minos::`, or through
/// the module's last two segments anywhere (`navmesh::build` after `use minos::navmesh;`).
fn named_internals(code: &str, internals: &[String]) -> BTreeSet<String> {
    let mut paths = Vec::new();
    for (at, _) in code.match_indices("minos::") {
        let before = code[..at].chars().last();
        if !before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            use_tree(&code[at + "minos::".len()..], "", &mut paths);
        }
    }
    let mut found = BTreeSet::new();
    for m in internals {
        if paths
            .iter()
            .any(|p| p == m || p.starts_with(&format!("{m}::")))
        {
            found.insert(m.clone());
        }
        let segments: Vec<&str> = m.split("::").collect();
        let tail = segments[segments.len().saturating_sub(2)..].join("::");
        let bounded = code.match_indices(&tail).any(|(at, _)| {
            let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
            !code[..at].chars().last().is_some_and(ident)
                && !code[at + tail.len()..].chars().next().is_some_and(ident)
        });
        if bounded {
            found.insert(m.clone());
        }
    }
    found
}

/// The API boundary of docs/ARCHITECTURE.md ("API boundaries"), enforced: every internal
/// module the doc lists is declared through `internal!` (so it is `pub` only with the
/// `internals` feature) and never plainly `pub`; every module declared through `internal!` is
/// listed; and the front doors (`src/main.rs`, `src/cmd/`, `python/src/`), which build without
/// the feature, name none of them. (`cargo test` builds the binary with the tests' features,
/// so this test, not the compiler, is what catches a front door reaching an internal module
/// there.) The manifests turn the feature on for the tests, benches and fuzz targets only.
#[test]
fn internal_modules_are_declared_behind_the_feature_and_front_doors_never_name_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("src");
    let doc = std::fs::read_to_string(root.join("docs/ARCHITECTURE.md")).expect("doc");
    let listed = internal_modules_of_the_doc(&doc);
    assert!(listed.len() >= 5, "internal modules listed: {listed:?}");

    let mut problems = Vec::new();
    for m in &listed {
        let (parent, name) = m.rsplit_once("::").unwrap_or(("", m));
        let file = declaring_file(&src, parent);
        let code = std::fs::read_to_string(&file).unwrap_or_default();
        let (internal, plain) = declared_modules(&code);
        if !internal.contains(name) {
            problems.push(format!(
                "{m}: not declared through internal! in {}",
                file.display()
            ));
        }
        if plain.contains(name) {
            problems.push(format!("{m}: declared plainly `pub` in {}", file.display()));
        }
    }
    // Every module declared through `internal!` anywhere is on the doc's list.
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    for file in &files {
        let code = std::fs::read_to_string(file).expect("source");
        let rel = file.strip_prefix(&src).expect("below src");
        // The children of `src/a/b/mod.rs` and of `src/a/b.rs` are `a::b::…`.
        let mut here = module_path(rel);
        if rel == Path::new("lib.rs") || rel == Path::new("main.rs") {
            here.clear();
        }
        for name in declared_modules(&code).0 {
            let mut path = here.clone();
            path.push(name);
            let path = path.join("::");
            if !listed.contains(&path) {
                problems.push(format!(
                    "{path}: declared through internal! but not listed in docs/ARCHITECTURE.md"
                ));
            }
        }
    }
    for file in front_door_files(root) {
        let rel = file
            .strip_prefix(root)
            .unwrap_or(&file)
            .display()
            .to_string();
        for m in named_internals(&non_test_code(&file), &listed) {
            problems.push(format!(
                "{rel}: names the internal module `{m}`: use the API (docs/ARCHITECTURE.md)"
            ));
        }
    }
    // The feature: declared, on for the tests and benches (a dev-dependency of the crate on
    // itself) and the fuzz targets, off for the bindings.
    let manifest = |p: &str| std::fs::read_to_string(root.join(p)).expect(p);
    let (cargo, fuzz, python) = (
        manifest("Cargo.toml"),
        manifest("fuzz/Cargo.toml"),
        manifest("python/Cargo.toml"),
    );
    for (what, ok) in [
        (
            "Cargo.toml declares the feature",
            cargo.contains("\n[features]\n") && cargo.contains("\ninternals = []\n"),
        ),
        (
            "Cargo.toml's tests and benches turn it on",
            cargo.contains("minos = { path = \".\", features = [\"internals\"] }"),
        ),
        (
            "fuzz/Cargo.toml turns it on",
            fuzz.contains("minos = { path = \"..\", features = [\"internals\"] }"),
        ),
        (
            "python/Cargo.toml leaves it off",
            python.contains("minos = { path = \"..\" }\n") && !python.contains("internals"),
        ),
    ] {
        if !ok {
            problems.push(what.to_string());
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_internal_module_check_sees_what_it_forbids() {
    let internals: Vec<String> = ["navmesh::build", "io::rrd", "scene::formats::mp3d"]
        .map(String::from)
        .to_vec();
    let names =
        |code: &str| -> Vec<String> { named_internals(code, &internals).into_iter().collect() };
    assert_eq!(
        names("use minos::navmesh::{NavGrid, build::build};"),
        ["navmesh::build"]
    );
    assert_eq!(names("use minos::{io::{rrd, tables}, seed};"), ["io::rrd"]);
    assert_eq!(
        names("let g = minos::navmesh::build::build(&s, &p);"),
        ["navmesh::build"]
    );
    assert_eq!(
        names("use minos::scene::{formats::{mp3d::Mp3dLoader, LoadError}};"),
        ["scene::formats::mp3d"]
    );
    assert_eq!(
        names("use minos::navmesh;\nlet g = navmesh::build::build(&s, &p);"),
        ["navmesh::build"]
    );
    assert!(names(
        "use minos::navmesh::{NavGrid, builder, route};\nuse minos::io::rrd_x;\n\
         use minos::scene::formats::{LoadError, mp3d_x}; notminos::navmesh::buildx"
    )
    .is_empty());

    let (internal, plain) = declared_modules(
        "internal! {\n    /// Docs.\n    pub mod bvh;\n}\npub mod camera;\nmod image;\n",
    );
    assert_eq!(internal, BTreeSet::from(["bvh".to_string()]));
    assert_eq!(plain, BTreeSet::from(["camera".to_string()]));
    assert_eq!(
        internal_modules_of_the_doc(
            "## API boundaries\n\n### Internal modules\n\nText `x::y`.\n\n- `render::bvh` — the \
             hierarchy;\n- `io::rrd` — the\n  encoder.\n\nAfter.\n\n## Entry points\n\n- `cmd`\n"
        ),
        ["render::bvh", "io::rrd"]
    );
}

/// `file`'s text, strings and comments kept, up to its unit tests (`#[cfg(test)] mod tests`).
fn text_before_tests(file: &Path) -> String {
    let text = std::fs::read_to_string(file).expect("readable source");
    let cut = text.find("#[cfg(test)]\nmod tests").unwrap_or(text.len());
    text[..cut].to_string()
}

/// The `#[error(…)]` attributes in `code` whose message prints a field that is also the
/// error's `source()` (a field named `source`, or marked `#[source]` or `#[from]`) beside
/// words of its own: each such attribute, whitespace folded. `#[error(transparent)]` and a
/// bare wrapper (`#[error("{0}")]` around its source) are fine.
fn printed_sources(code: &str) -> Vec<String> {
    let lines: Vec<&str> = code.lines().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if !lines[i].contains("#[error(") {
            i += 1;
            continue;
        }
        let mut attr = lines[i].to_string();
        while !attr.trim_end().ends_with(")]") && i + 1 < lines.len() {
            i += 1;
            attr.push(' ');
            attr.push_str(lines[i].trim());
        }
        i += 1;
        if attr.contains("transparent") {
            continue;
        }
        // The variant or struct the attribute describes, up to where its fields close.
        let mut decl = String::new();
        let mut depth = 0i32;
        while i < lines.len() {
            let line = lines[i].trim();
            if line.starts_with("#[error(") {
                break;
            }
            decl.push_str(line);
            decl.push('\n');
            i += 1;
            if line.starts_with("//") || (line.starts_with("#[") && depth == 0) {
                continue;
            }
            depth += line.matches(['{', '(']).count() as i32;
            depth -= line.matches(['}', ')']).count() as i32;
            if depth <= 0 && (line.ends_with(',') || line.ends_with('}') || line.ends_with(';')) {
                break;
            }
        }
        let mut sources = Vec::new();
        let mut marked = false;
        for line in decl.lines() {
            let line = line.trim().trim_start_matches("pub ");
            if line == "#[source]" || line == "#[from]" {
                marked = true;
                continue;
            }
            if let Some((name, _)) = line.split_once(':') {
                let name = name.trim();
                if name.chars().all(|c| c.is_alphanumeric() || c == '_') && !name.is_empty() {
                    if marked || name == "source" {
                        sources.push(name.to_string());
                    }
                    marked = false;
                }
            }
        }
        // Tuple fields: `Name(#[from] A, B)`.
        if let (Some(open), Some(close)) = (decl.find('('), decl.rfind(')')) {
            if !decl[..open].contains('{') && open < close {
                let mut depth = 0;
                let mut field = 0;
                let mut start = open + 1;
                for (k, c) in decl[open + 1..close].char_indices() {
                    let at = open + 1 + k;
                    match c {
                        '(' | '<' | '[' => depth += 1,
                        ')' | '>' | ']' => depth -= 1,
                        ',' if depth == 0 => {
                            if decl[start..at].contains("#[source]")
                                || decl[start..at].contains("#[from]")
                            {
                                sources.push(field.to_string());
                            }
                            field += 1;
                            start = at + 1;
                        }
                        _ => {}
                    }
                }
                if decl[start..close].contains("#[source]")
                    || decl[start..close].contains("#[from]")
                {
                    sources.push(field.to_string());
                }
            }
        }
        let prints = |name: &str| {
            attr.contains(&format!("{{{name}}}"))
                || attr.contains(&format!("{{{name}:"))
                || attr.contains(&format!(".{name})"))
                || attr.contains(&format!(".{name}."))
                || attr.contains(&format!(".{name},"))
        };
        // A wrapper that adds nothing says its cause's words as its own and keeps the cause
        // as its source, so typed inspection of the chain (remedies, Python's exception
        // classes) still finds it; `error_line` does not repeat it.
        let wrapper = |name: &str| attr.replace(' ', "") == format!("#[error(\"{{{name}}}\")]");
        if sources.iter().any(|s| prints(s) && !wrapper(s)) {
            found.push(attr.split_whitespace().collect::<Vec<_>>().join(" "));
        }
    }
    found
}

/// An error prints itself and keeps its cause as its `source()`, never both: the one-line
/// text of an error and its causes is `escape::error_line`'s to make, so no message says a
/// cause twice and no caller needs to de-duplicate text.
#[test]
fn library_errors_print_their_cause_once() {
    let printing = [
        "#[error(\"{}: {source}\", path.display())]\nIo {\n    path: PathBuf,\n    source: io::Error,\n},",
        "#[error(\"lerobot: {0}\")]\nLerobot(#[from] LerobotError),",
        "#[error(\"step {step}: {why}\")]\nStep {\n    step: u32,\n    #[source]\n    why: Invalid,\n},",
        "#[error(\"human{}\", .source.as_ref().map(|s| s.to_string()).unwrap_or_default())]\nHuman {\n    source: Option<Box<dyn Error>>,\n},",
        "#[error(\n    \"{}: {cause} (hint)\",\n    path.display()\n)]\nNoStats {\n    path: PathBuf,\n    #[source]\n    cause: io::Error,\n},",
    ];
    for code in printing {
        assert_eq!(printed_sources(code).len(), 1, "{code}");
    }
    let fine = [
        "#[error(\"{}\", path.display())]\nIo {\n    path: PathBuf,\n    source: io::Error,\n},",
        "#[error(transparent)]\nLerobot(#[from] LerobotError),",
        "#[error(\"step {step}: {0}\")]\nStep(String, #[source] Invalid),",
        "#[error(\"{0}\")]\nText(String),",
        "#[error(\"{0}\")]\nGrid(#[from] NavFileError),",
        "#[error(\"{source}\")]\nStore {\n    #[source]\n    source: StoreError,\n},",
        "#[error(\"row {row}: {message}\")]\nRow {\n    row: usize,\n    message: String,\n},",
    ];
    for code in fine {
        assert_eq!(printed_sources(code), Vec::<String>::new(), "{code}");
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    let offenders: Vec<String> = files
        .iter()
        .flat_map(|f| {
            let name = f.strip_prefix(root).unwrap_or(f).display().to_string();
            printed_sources(&text_before_tests(f))
                .into_iter()
                .map(move |a| format!("{name}: {a}"))
        })
        .collect();
    assert!(files.len() > 100, "library files found: {}", files.len());
    assert!(
        offenders.is_empty(),
        "errors that print their source as well as returning it:\n{}",
        offenders.join("\n")
    );
}

/// The library's source files (the binary's `main.rs` and `cmd/` left out), each with the
/// module path its child modules hang under (`src/lib.rs` → none, `src/a/b.rs` → `a::b`).
fn library_files(src: &Path) -> Vec<(PathBuf, Vec<String>)> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files
        .into_iter()
        .filter_map(|file| {
            let rel = file.strip_prefix(src).expect("below src");
            if rel.starts_with("cmd") || rel == Path::new("main.rs") {
                return None;
            }
            let here = if rel == Path::new("lib.rs") {
                Vec::new()
            } else {
                module_path(rel)
            };
            Some((file, here))
        })
        .collect()
}

/// Whether the module at `path` (from the crate root) is reachable from outside the crate
/// in the plain build: every module on the way is declared plainly `pub mod` (not private,
/// not `pub(crate)`, not behind `internal!`).
fn public_module(src: &Path, path: &[String]) -> bool {
    (1..=path.len()).all(|i| {
        let code = std::fs::read_to_string(declaring_file(src, &path[..i - 1].join("::")))
            .unwrap_or_default();
        declared_modules(&code).1.contains(&path[i - 1])
    })
}

/// The re-exports of one library file (its `pub use` trees, unit tests aside) that give a
/// second path to an item whose own module is public: `(re-exported path, the item's own
/// path)`. `here` is the file's module path; paths into other crates are skipped.
fn second_paths(src: &Path, code: &str, here: &[String]) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let children: BTreeSet<String> = code
        .lines()
        .map(str::trim)
        .filter_map(|l| {
            l.strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("mod "))
                .or_else(|| l.strip_prefix("pub(crate) mod "))
        })
        .map(ident_at)
        .collect();
    for (at, _) in code.match_indices("pub use ") {
        if !code[..at].ends_with('\n') && at != 0 {
            continue;
        }
        let mut paths = Vec::new();
        use_tree(&code[at + "pub use ".len()..], "", &mut paths);
        for p in paths {
            let segments: Vec<&str> = p.split("::").collect();
            let first = segments[0];
            if !["crate", "self", "super"].contains(&first) && !children.contains(first) {
                continue; // another crate's item
            }
            let mut module: Vec<String> = here.to_vec();
            for s in &segments[..segments.len() - 1] {
                match *s {
                    "crate" => module.clear(),
                    "self" => {}
                    "super" => {
                        module.pop();
                    }
                    s => module.push(s.to_string()),
                }
            }
            if public_module(src, &module) {
                let item = segments[segments.len() - 1];
                out.push((
                    format!("{}::{item}", here.join("::")),
                    format!("{}::{item}", module.join("::")),
                ));
            }
        }
    }
    out
}

/// One path per type (docs/ARCHITECTURE.md, "API boundaries"): a `pub use` may lift an item
/// out of a private or internal module (`sim::Simulator` from the private `sim::simulator`),
/// never give an item of a public module a second name.
#[test]
fn a_type_has_one_path() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut problems = Vec::new();
    let mut lifted = 0;
    for (file, here) in library_files(&src) {
        let rel = file.strip_prefix(&src).expect("below src");
        let code = non_test_code(&file);
        lifted += code.matches("\npub use ").count();
        for (second, own) in second_paths(&src, &code, &here) {
            problems.push(format!(
                "{}: `{second}` re-exports `{own}`, whose module is public: make the module \
                 private (or internal) or drop the re-export",
                rel.display()
            ));
        }
    }
    assert!(lifted >= 20, "pub use lines seen: {lifted}");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The one-path check tells a lift out of a private module from a second path.
#[test]
fn the_one_path_check_sees_a_second_path() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let here = vec!["sim".to_string()];
    // `sim::simulator` is private, `sim::batch` public; `render::Frame` is already a path of
    // its own (lifted out of the private `render::frame`), so `sim::Frame` would be a second.
    let code = "mod simulator;\npub mod batch;\npub use simulator::Simulator;\n\
                pub use batch::BatchSim;\npub use crate::render::Frame;\n\
                pub use glam::Vec3;\n";
    let found = second_paths(&src, code, &here);
    let pair = |a: &str, b: &str| (a.to_string(), b.to_string());
    assert_eq!(
        found,
        vec![
            pair("sim::BatchSim", "sim::batch::BatchSim"),
            pair("sim::Frame", "render::Frame")
        ],
        "{found:?}"
    );
    let code = "pub use crate::episode::interchange::DEFAULT_MAX_STEPS;\n";
    assert_eq!(
        second_paths(&src, code, &["run".into(), "stepper".into()]).len(),
        1
    );
}

/// Every module path the "API boundaries" section of docs/ARCHITECTURE.md names, its
/// `code` spans read as use trees (`pipeline::{ingest, merge::run}` → `pipeline::ingest`,
/// `pipeline::merge::run`), with every prefix of each (naming an item names its module).
fn api_paths_of_the_doc(doc: &str) -> BTreeSet<String> {
    let section = doc
        .split("\n## API boundaries\n")
        .nth(1)
        .expect("docs/ARCHITECTURE.md has an \"API boundaries\" section");
    let section = section.split("\n### ").next().unwrap_or(section);
    let text = section.replace('\n', " ");
    let mut paths = Vec::new();
    for span in text.split('`').skip(1).step_by(2) {
        use_tree(span, "", &mut paths);
    }
    let mut named = BTreeSet::new();
    for p in paths {
        let segments: Vec<&str> = p.split("::").collect();
        for i in 1..=segments.len() {
            named.insert(segments[..i].join("::"));
        }
    }
    named
}

/// Every module reachable from outside the crate in the plain build (declared plainly `pub`
/// all the way from the crate root), as `a::b` paths.
fn public_modules(src: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for (file, here) in library_files(src) {
        let code = std::fs::read_to_string(file).expect("source");
        for name in declared_modules(&code).1 {
            let mut path = here.clone();
            path.push(name);
            if public_module(src, &path) {
                found.push(path.join("::"));
            }
        }
    }
    found.sort();
    found
}

/// The API is written down (docs/ARCHITECTURE.md, "API boundaries"): every public module is
/// named there, so a new module is a decision — private, internal, or API and named.
#[test]
fn every_public_module_is_named_in_the_api() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/ARCHITECTURE.md")).expect("doc");
    let named = api_paths_of_the_doc(&doc);
    let public = public_modules(&root.join("src"));
    assert!(public.len() >= 80, "public modules found: {public:?}");
    // The reader sees nested trees and items under their modules.
    for p in [
        "pipeline::merge::run",
        "navmesh::geodesic",
        "episode::vln::walk",
        "vocab",
    ] {
        assert!(named.contains(p), "{p} not read from the doc");
    }
    let unnamed: Vec<&String> = public.iter().filter(|m| !named.contains(*m)).collect();
    assert!(
        unnamed.is_empty(),
        "public modules that docs/ARCHITECTURE.md's \"API boundaries\" does not name: \
         {unnamed:?} (make them private, internal!, or name them)"
    );
}
