//! Discovering scenes under a root: mapping stage configs to their assets, finding scene
//! instances and bare stages, and the bounded walk over the folder tree.

use crate::file_error::FileError;
use super::*;

/// Every file under `root` down to `max_depth` folder levels, sorted, paths normalised.
pub(super) fn walk(root: &Path, max_depth: usize) -> Result<Vec<PathBuf>, LoadError> {
    let mut out = Vec::new();
    let mut stack = vec![(root.to_path_buf(), 0usize)];
    while let Some((dir, depth)) = stack.pop() {
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(source) if depth == 0 => return Err(LoadError::Io(FileError::new(dir, source))),
            Err(_) => continue,
        };
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with('.') {
                continue;
            }
            let Ok(kind) = e.file_type() else { continue };
            let path = e.path();
            if kind.is_dir() {
                if depth < max_depth {
                    stack.push((path, depth + 1));
                }
            } else if kind.is_file() || (kind.is_symlink() && path.is_file()) {
                out.push(normalize(&path));
            }
        }
    }
    out.sort();
    Ok(out)
}

impl GltfLoader {
    /// Maps each stage config's render asset to it (by name when the config cannot be read,
    /// so that loading the asset reports the config's error instead of ignoring it).
    pub(super) fn map_stage_configs(&mut self) {
        let mut map: HashMap<PathBuf, PathBuf> = HashMap::new();
        for cfg in &self.index.stage_configs {
            let dir = cfg.parent().unwrap_or(Path::new("."));
            let name = short_name(cfg);
            let assets: Vec<PathBuf> = match read_attributes(cfg) {
                Ok(a) => a
                    .render_asset
                    .map(|r| r.resolve(base_name(&name), dir))
                    .into_iter()
                    .collect(),
                Err(_) => ["glb", "gltf"]
                    .iter()
                    .map(|e| normalize(&dir.join(format!("{name}.{e}"))))
                    .collect(),
            };
            for a in assets {
                if let Some(first) = map.get(&a) {
                    self.root_warnings.push(format!(
                        "{}: describes {} already described by {}; ignored",
                        cfg.display(),
                        a.display(),
                        first.display()
                    ));
                } else {
                    map.insert(a, cfg.clone());
                }
            }
        }
        self.index.stage_config_of = map;
    }

    /// Scene instances, then assets that are not parts of something else.
    pub(super) fn find_scenes(&mut self) -> Vec<SceneEntry> {
        let mut parts: HashSet<PathBuf> = HashSet::new();
        for cfg in &self.index.object_configs {
            let dir = cfg.parent().unwrap_or(Path::new("."));
            let name = short_name(cfg);
            match read_attributes(cfg) {
                Ok(a) => {
                    for r in [&a.render_asset, &a.collision_asset, &a.semantic_asset]
                        .into_iter()
                        .flatten()
                    {
                        parts.insert(r.resolve(base_name(&name), dir));
                    }
                }
                Err(_) => {
                    for e in ["glb", "gltf"] {
                        parts.insert(normalize(&dir.join(format!("{name}.{e}"))));
                    }
                }
            }
        }
        for cfg in &self.index.stage_configs {
            if let Ok(a) = read_attributes(cfg) {
                let dir = cfg.parent().unwrap_or(Path::new("."));
                let name = short_name(cfg);
                for r in [&a.collision_asset, &a.semantic_asset]
                    .into_iter()
                    .flatten()
                {
                    parts.insert(r.resolve(base_name(&name), dir));
                }
            }
        }
        for si in &self.index.scene_instances {
            let mut ignored = Vec::new();
            let Ok(instance) = read_scene_instance(si, &mut ignored) else {
                continue;
            };
            if let Some(stage) = instance.stage {
                if let Ok(r) = self.resolve(Kind::Stage, &stage.template, si) {
                    parts.insert(r.asset);
                }
            }
        }
        let mut scenes: Vec<SceneEntry> = Vec::new();
        let mut ids: HashMap<String, PathBuf> = HashMap::new();
        let candidates = self
            .index
            .scene_instances
            .iter()
            .map(|p| (short_name(p), p))
            .chain(
                self.index
                    .assets
                    .iter()
                    .filter(|a| !parts.contains(*a))
                    .filter(|a| {
                        let n = file_name(a);
                        strip_suffix_ci(n, ".semantic.glb").is_none()
                            && strip_suffix_ci(n, ".semantic.gltf").is_none()
                    })
                    .map(|p| (short_name(p), p)),
            );
        for (id, path) in candidates {
            if let Some(first) = ids.get(&id) {
                self.root_warnings.push(format!(
                    "{}: scene id `{id}` already taken by {}; skipped",
                    path.display(),
                    first.display()
                ));
                continue;
            }
            ids.insert(id.clone(), path.clone());
            scenes.push(SceneEntry {
                id,
                path: path.clone(),
            });
        }
        scenes.sort();
        scenes
    }
}
