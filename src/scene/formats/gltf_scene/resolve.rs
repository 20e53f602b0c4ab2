//! Resolving Habitat configuration templates to files: which dataset configuration applies
//! near a file, the stage/object/semantic configs and assets a template names (with the
//! dataset's path templates and defaults), and the stage a bare GLB becomes.

use super::*;

/// Stage or object configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Kind {
    Stage,
    Object,
}

impl Kind {
    pub(super) fn suffix(self) -> &'static str {
        match self {
            Kind::Stage => STAGE_CONFIG,
            Kind::Object => OBJECT_CONFIG,
        }
    }
    pub(super) fn name(self) -> &'static str {
        match self {
            Kind::Stage => "stage",
            Kind::Object => "object",
        }
    }
}

/// A template resolved to its asset and merged attributes.
#[derive(Debug, Clone)]
pub(super) struct Resolved {
    pub(super) asset: PathBuf,
    pub(super) attributes: Attributes,
    /// The most specific configuration file (for errors about its values).
    pub(super) config: PathBuf,
    pub(super) sources: Vec<PathBuf>,
}

/// Why a template did not resolve.
pub(super) enum ResolveError {
    /// Nothing of that name.
    Missing,
    /// A configuration was found but cannot be used.
    Load(LoadError),
}

impl From<LoadError> for ResolveError {
    fn from(e: LoadError) -> Self {
        ResolveError::Load(e)
    }
}

impl GltfLoader {
    /// The scene dataset configs that apply to a file: those in a folder above it.
    pub(super) fn datasets_for(&self, near: &Path) -> Vec<&DatasetConfig> {
        self.index
            .datasets
            .iter()
            .filter(|d| d.path.parent().is_some_and(|dir| near.starts_with(dir)))
            .collect()
    }

    /// Merged dataset defaults for `kind` near a file (the first dataset config wins).
    pub(super) fn defaults(&self, kind: Kind, near: &Path) -> (Attributes, Vec<PathBuf>) {
        let datasets = self.datasets_for(near);
        let mut attributes = Attributes::default();
        for d in datasets.iter().rev() {
            let layer = match kind {
                Kind::Stage => &d.stage_defaults,
                Kind::Object => &d.object_defaults,
            };
            attributes = attributes.under(layer);
        }
        (
            attributes,
            datasets.iter().map(|d| d.path.clone()).collect(),
        )
    }

    /// Finds a config file of `kind` named `template`: `<template><suffix>` beside `near`, else
    /// one whose path without the suffix ends with `/<template>` (preferring `near`'s folder).
    pub(super) fn find_config(&self, kind: Kind, template: &str, near: &Path) -> Option<PathBuf> {
        let t = template.trim().trim_start_matches("./");
        let t = strip_suffix_ci(t, kind.suffix()).unwrap_or(t);
        let leaf = t.rsplit('/').next().unwrap_or(t);
        let list = self.index.config_names.get(&(kind, leaf.to_string()))?;
        let dir = near.parent().unwrap_or(Path::new("."));
        let direct = normalize(&dir.join(format!("{t}{}", kind.suffix())));
        if list.contains(&direct) {
            return Some(direct);
        }
        let tail = format!("/{t}");
        let matches: Vec<&PathBuf> = list
            .iter()
            .filter(|p| {
                let s = p.to_string_lossy();
                strip_suffix_ci(&s, kind.suffix()).is_some_and(|k| k == t || k.ends_with(&tail))
            })
            .collect();
        matches
            .iter()
            .find(|p| p.parent() == Some(dir))
            .or(matches.first())
            .map(|p| (*p).clone())
    }

    /// Finds an asset file named `template` (a path relative to `near`, or a name with or
    /// without its extension, preferring `near`'s folder).
    pub(super) fn find_asset(&self, template: &str, near: &Path) -> Option<PathBuf> {
        let t = template.trim().trim_start_matches("./");
        let dir = near.parent().unwrap_or(Path::new("."));
        let direct = normalize(&dir.join(t));
        if is_asset(&direct) && direct.is_file() {
            return Some(direct);
        }
        let leaf = t.rsplit('/').next().unwrap_or(t);
        let list = self.index.asset_names.get(leaf)?;
        let tail = format!("/{t}");
        let matches: Vec<&PathBuf> = list
            .iter()
            .filter(|p| {
                let s = p.to_string_lossy();
                let no_ext = p.with_extension("");
                let no_ext = no_ext.to_string_lossy();
                s.ends_with(&tail) || s == t || no_ext.ends_with(&tail) || no_ext == t
            })
            .collect();
        matches
            .iter()
            .find(|p| p.parent() == Some(dir))
            .or(matches.first())
            .map(|p| (*p).clone())
    }

    /// Resolves a template a scene instance (or nothing: `near` is the asset itself) names.
    pub(super) fn resolve(
        &self,
        kind: Kind,
        template: &str,
        near: &Path,
    ) -> Result<Resolved, ResolveError> {
        let (mut attributes, mut sources) = self.defaults(kind, near);
        let datasets = self.datasets_for(near);
        let dataset_template = datasets.iter().find_map(|d| {
            let list = match kind {
                Kind::Stage => &d.stage_templates,
                Kind::Object => &d.object_templates,
            };
            list.iter().find(|t| t.handle == template).map(|t| (d, t))
        });
        let (config, name) = if let Some((d, t)) = dataset_template {
            let mut config = d.path.clone();
            let mut name = short_name(Path::new(&t.handle));
            if let Some(f) = &t.original_file {
                attributes = attributes.under(&read_attributes(f)?);
                sources.push(f.clone());
                config = f.clone();
                name = short_name(f);
            }
            attributes = attributes.under(&t.attributes);
            (config, name)
        } else if let Some(f) = self.find_config(kind, template, near) {
            attributes = attributes.under(&read_attributes(&f)?);
            sources.push(f.clone());
            let name = short_name(&f);
            (f, name)
        } else if let Some(asset) = self.find_asset(template, near) {
            let mut config = asset.clone();
            if kind == Kind::Stage {
                if let Some(f) = self.index.stage_config_of.get(&asset) {
                    attributes = attributes.under(&read_attributes(f)?);
                    sources.push(f.clone());
                    config = f.clone();
                }
            }
            return Ok(Resolved {
                asset,
                attributes,
                config,
                sources,
            });
        } else {
            return Err(ResolveError::Missing);
        };
        let dir = config.parent().unwrap_or(Path::new("."));
        let Some(render) = &attributes.render_asset else {
            return Err(LoadError::parse(
                &config,
                format!(
                    "{} template `{template}` has no `render_asset`",
                    kind.name()
                ),
            )
            .into());
        };
        let asset = render.resolve(base_name(&name), dir);
        if !asset.is_file() {
            return Err(LoadError::parse(
                &config,
                format!(
                    "render_asset `{}` not found (looked for {})",
                    render.text,
                    asset.display()
                ),
            )
            .into());
        }
        Ok(Resolved {
            asset,
            attributes,
            config,
            sources,
        })
    }

    /// The stage attributes of a plain asset: dataset defaults and its stage config.
    pub(super) fn stage_for_asset(&self, asset: &Path) -> Result<Resolved, LoadError> {
        let (mut attributes, mut sources) = self.defaults(Kind::Stage, asset);
        let mut config = asset.to_path_buf();
        if let Some(f) = self.index.stage_config_of.get(asset) {
            attributes = attributes.under(&read_attributes(f)?);
            sources.push(f.clone());
            config = f.clone();
        }
        Ok(Resolved {
            asset: asset.to_path_buf(),
            attributes,
            config,
            sources,
        })
    }

    /// A stage ready to assemble: frame, scale and semantic files; remarks on what is ignored.
    pub(super) fn stage_spec(
        &self,
        r: &Resolved,
        warnings: &mut Vec<String>,
    ) -> Result<StageSpec, LoadError> {
        let a = &r.attributes;
        let rotation = frame_to_world(a.up, a.front).map_err(|m| LoadError::parse(&r.config, m))?;
        if let Some(o) = a.origin.filter(|o| *o != Vec3::ZERO) {
            warnings.push(format!(
                "{}: stage origin {o} not applied (habitat-sim does not apply it either)",
                r.config.display()
            ));
        }
        if let Some(u) = a.units_to_meters.filter(|u| (u - 1.0).abs() > 1e-6) {
            warnings.push(format!(
                "{}: units_to_meters {u} not applied (only `scale` is)",
                r.config.display()
            ));
        }
        let dir = r.asset.parent().unwrap_or(Path::new("."));
        let stem = r
            .asset
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let base = base_name(&stem).to_string();
        let beside = |ext: &str| -> Vec<PathBuf> {
            let mut v = vec![dir.join(format!("{stem}.{ext}"))];
            if base != stem {
                v.push(dir.join(format!("{base}.{ext}")));
            }
            v
        };
        let pick = |explicit: &Option<habitat::AssetRef>, ext: &str| -> Option<PathBuf> {
            match explicit {
                Some(x) => Some(x.resolve(&base, dir)).filter(|p| p.is_file()),
                None => beside(ext).into_iter().find(|p| p.is_file()),
            }
        };
        let semantic_glb = pick(&a.semantic_asset, "semantic.glb").filter(|p| *p != r.asset);
        Ok(StageSpec {
            asset: r.asset.clone(),
            rotation,
            scale: a.scale.unwrap_or(Vec3::ONE),
            semantic_txt: pick(&a.semantic_descriptor, "semantic.txt"),
            semantic_glb,
        })
    }

    /// Categories of a scene-instance object named by `template`.
    pub(super) fn template_categories(&self, template: &str) -> Categories {
        let last = template.rsplit(['/', '\\']).next().unwrap_or(template);
        let last = strip_suffix_ci(last, OBJECT_CONFIG).unwrap_or(last);
        match category_from_name(last, &self.categories) {
            Some(c) => self.categories.categories(&c),
            None => Categories::default(),
        }
    }

    /// The region annotations file of a scene instance, if one is named and found.
    pub(super) fn semantic_config(
        &self,
        si: &Path,
        explicit: Option<&str>,
        warnings: &mut Vec<String>,
    ) -> Option<PathBuf> {
        let scene_name = short_name(si);
        let named = explicit.map(str::to_string).or_else(|| {
            self.datasets_for(si)
                .iter()
                .find_map(|d| d.semantic_scene_default.clone())
        })?;
        let name = named.replace(CONFIG_NAME_TAG, base_name(&scene_name));
        let file = if strip_suffix_ci(&name, SEMANTIC_CONFIG).is_some() {
            name.clone()
        } else {
            format!("{name}{SEMANTIC_CONFIG}")
        };
        let dir = si.parent().unwrap_or(Path::new("."));
        let direct = normalize(&dir.join(&file));
        let leaf = Path::new(&file)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let found = if self.index.semantic_configs.contains(&direct) {
            Some(direct)
        } else {
            self.index
                .semantic_configs
                .iter()
                .find(|p| file_name(p) == leaf)
                .cloned()
        };
        if found.is_none() && explicit.is_some() {
            warnings.push(format!(
                "{}: semantic_scene_instance `{named}` not found under {}; no regions",
                si.display(),
                self.root.display()
            ));
        }
        found
    }
}
