//! Sensor configuration (TOML or JSON, with MINOS presets) and the images a camera sensor
//! produces from a rendered frame: colour or grey, depth (float metres or quantised, optional
//! Gaussian or Kinect-like noise), normals, semantic class, instance, room.

use serde::{Deserialize, Serialize};

use crate::body::AgentPreset;
use crate::invalid::{Invalid, SettingsCause, TomlError};
use crate::render::{Frame, RenderScene};
use crate::render::{Image, Modality, PixelType};
use crate::scene::Taxonomy;
use crate::seed::Rng;
use crate::vocab::{Term, Vocabulary};

/// The sensor suites minos defines, by name: what `--sensors NAME` and Python's
/// `sensors="NAME"` take besides a sensor file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SuiteName {
    /// [`SensorSuite::minos`].
    Minos,
    /// [`SensorSuite::minos_paper`].
    MinosPaper,
    /// [`SensorSuite::all`].
    All,
}

impl SuiteName {
    /// The suite `spec` names, when it is a suite's name rather than a sensor file
    /// (`--sensors`, `sensors=`, a campaign file's `sensors`).
    pub fn of_spec(spec: &std::path::Path) -> Option<SuiteName> {
        spec.to_str().and_then(|s| Self::parse_name(s).ok())
    }
}

impl Vocabulary for SuiteName {
    const WHAT: &'static str = "sensor suite";
    const TERMS: &'static [Term<Self>] = &[
        Term {
            value: SuiteName::Minos,
            name: "minos",
            aliases: &[],
            help: "MINOS's RGB, depth and semantic cameras and 4 contact sensors",
        },
        Term {
            value: SuiteName::MinosPaper,
            name: "minos-paper",
            aliases: &[],
            help: "the MINOS paper's grey, depth and semantic cameras at 90° and 4 contacts",
        },
        Term {
            value: SuiteName::All,
            name: "all",
            aliases: &[],
            help: "every image modality",
        },
    ];
}

crate::vocab::name_traits!(SuiteName);

/// How depth is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DepthEncoding {
    /// f32 metres (0 = no hit).
    #[default]
    Float,
    /// u8 over `depth_range` (MINOS's byte depth over 0–10 m).
    U8,
    /// u16 over `depth_range`.
    U16,
}

/// Depth noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum DepthNoise {
    /// Additive Gaussian noise of standard deviation `sigma` (m).
    Gaussian {
        /// Standard deviation (m).
        sigma: f32,
    },
    /// Kinect-like: values outside [min, max] become 0, others get noise growing with the
    /// square of the distance (σ = 0.0012 + 0.0019·(d − 0.4)²).
    Kinect {
        /// Closest measurable depth (m).
        min: f32,
        /// Farthest measurable depth (m).
        max: f32,
    },
}

/// One camera sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSensor {
    /// Name (column name in datasets, file name in `minos render`).
    pub name: String,
    /// What it records.
    pub modality: Modality,
    /// Position relative to the agent's base (x right, y up, z back), metres; default: the eye.
    #[serde(default)]
    pub position: Option<[f32; 3]>,
    /// Yaw and tilt relative to the agent (degrees).
    #[serde(default)]
    pub orientation: [f32; 2],
    /// Width and height (pixels).
    pub resolution: [u32; 2],
    /// Vertical field of view (degrees).
    #[serde(default = "default_vfov")]
    pub vfov: f32,
    /// Near plane (m).
    #[serde(default = "default_near")]
    pub near: f32,
    /// Far plane (m).
    #[serde(default = "default_far")]
    pub far: f32,
    /// Semantic taxonomy (semantic modality).
    #[serde(default)]
    pub taxonomy: Taxonomy,
    /// Depth storage (depth modality).
    #[serde(default)]
    pub depth_encoding: DepthEncoding,
    /// Range quantised depth covers (m).
    #[serde(default = "default_depth_range")]
    pub depth_range: [f32; 2],
    /// Depth noise.
    #[serde(default)]
    pub noise: Option<DepthNoise>,
}

fn default_vfov() -> f32 {
    45.0
}
fn default_near() -> f32 {
    0.01
}
fn default_far() -> f32 {
    50.0
}
fn default_depth_range() -> [f32; 2] {
    [0.0, 10.0]
}

/// Contact sensors around the body.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactSensors {
    /// Number of sensors, evenly spaced starting straight ahead (MINOS: 4, cardinal).
    pub count: u32,
    /// Height above the floor (m).
    pub height: f32,
}

/// The sensor suite of an agent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSuite {
    /// Camera sensors.
    #[serde(default, rename = "camera")]
    pub cameras: Vec<CameraSensor>,
    /// Contact sensors (`None`: none).
    #[serde(default)]
    pub contact: Option<ContactSensors>,
}

impl SensorSuite {
    /// MINOS's default suite at `size`²: RGB, depth (float m), semantic (NYU-40), and 4
    /// contact sensors at 0.3 m.
    pub fn minos(size: u32) -> Self {
        let cam = |name: &str, modality| CameraSensor {
            name: name.into(),
            modality,
            position: None,
            orientation: [0.0, 0.0],
            resolution: [size, size],
            vfov: default_vfov(),
            near: default_near(),
            far: default_far(),
            taxonomy: Taxonomy::Nyu40,
            depth_encoding: DepthEncoding::Float,
            depth_range: default_depth_range(),
            noise: None,
        };
        SensorSuite {
            cameras: vec![
                cam("color", Modality::Color),
                cam("depth", Modality::Depth),
                cam("semantic", Modality::Semantic),
            ],
            contact: Some(ContactSensors {
                count: 4,
                height: 0.3,
            }),
        }
    }

    /// The MINOS paper's suite at `size`² (84 in its experiments): a grey camera, depth
    /// (float m) and semantic (NYU-40), all with a 90° vertical field of view, and 4 contact
    /// sensors at 0.3 m.
    pub fn minos_paper(size: u32) -> Self {
        let mut s = Self::minos(size);
        for c in &mut s.cameras {
            c.vfov = 90.0;
            if c.modality == Modality::Color {
                c.name = "gray".into();
                c.modality = Modality::Gray;
            }
        }
        s
    }

    /// The default suite of an agent preset at `size`²: [`SensorSuite::minos_paper`] for
    /// [`AgentPreset::MinosPaper`], else [`SensorSuite::minos`].
    pub fn for_preset(preset: AgentPreset, size: u32) -> Self {
        match preset {
            AgentPreset::MinosPaper => Self::minos_paper(size),
            AgentPreset::Habitat | AgentPreset::Minos | AgentPreset::MinosGridworld => {
                Self::minos(size)
            }
        }
    }

    /// Every image modality at `size`² (for looking at a scene).
    pub fn all(size: u32) -> Self {
        let mut s = Self::minos(size);
        for (name, m) in [
            ("normal", Modality::Normal),
            ("instance", Modality::Instance),
            ("room", Modality::Room),
            ("room_class", Modality::RoomClass),
        ] {
            let mut c = s.cameras[0].clone();
            c.name = name.into();
            c.modality = m;
            s.cameras.push(c);
        }
        s
    }

    /// The suite called `name` at `size`².
    pub fn named(name: SuiteName, size: u32) -> Self {
        match name {
            SuiteName::Minos => Self::minos(size),
            SuiteName::MinosPaper => Self::minos_paper(size),
            SuiteName::All => Self::all(size),
        }
    }

    /// `spec` as `--sensors` and Python's `sensors=` take it: the name of a suite minos
    /// defines ([`SuiteName`], at `size`²), else a sensor file to read ([`SensorSuite::read`]).
    pub fn from_spec(
        spec: &std::path::Path,
        size: u32,
    ) -> Result<Self, crate::invalid::SettingsFileError> {
        match SuiteName::of_spec(spec) {
            Some(name) => Ok(Self::named(name, size)),
            // A bare word that is no file was meant as a suite's name.
            None if spec.extension().is_none() && !spec.exists() => {
                Err(crate::invalid::SettingsFileError::NotNamed {
                    path: spec.to_path_buf(),
                    what: SuiteName::WHAT,
                    names: SuiteName::names(),
                })
            }
            None => Self::read(spec),
        }
    }

    /// Parses a TOML (or, when it starts with `{`, JSON) sensor file; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> Result<Self, crate::invalid::SettingsFileError> {
        Self::parse_text(text).map_err(|cause| crate::invalid::SettingsFileError::Invalid {
            path: source.into(),
            source: cause,
        })
    }

    /// Reads the sensor file `path` (TOML, or JSON when it starts with `{`): the one reader
    /// of `--sensors FILE` and Python's `sensors=FILE`.
    pub fn read(path: &std::path::Path) -> Result<Self, crate::invalid::SettingsFileError> {
        crate::invalid::read_settings(path, |text| {
            if text.trim().is_empty() {
                return Err(
                    "the sensor file is empty (it needs at least one [[cameras]] table)".into(),
                );
            }
            Self::parse_text(text)
        })
    }

    fn parse_text(text: &str) -> Result<Self, SettingsCause> {
        let suite: SensorSuite = if text.trim_start().starts_with('{') {
            serde_json::from_str(text)?
        } else {
            toml::from_str(text).map_err(|e| TomlError::in_text(e, text))?
        };
        suite.validate()?;
        Ok(suite)
    }

    /// Checks names are unique and numbers usable.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut names = std::collections::BTreeSet::new();
        for c in &self.cameras {
            if !names.insert(c.name.as_str()) {
                return Err(format!("camera `{}` is defined twice", c.name).into());
            }
            if c.resolution[0] == 0
                || c.resolution[1] == 0
                || c.resolution[0] > 8192
                || c.resolution[1] > 8192
            {
                return Err(format!(
                    "camera `{}`: resolution {:?} must be 1..=8192",
                    c.name, c.resolution
                )
                .into());
            }
            if !(c.vfov > 0.0 && c.vfov < 180.0) {
                return Err(
                    format!("camera `{}`: vfov {} must be in (0, 180)", c.name, c.vfov).into(),
                );
            }
            if !(c.near > 0.0 && c.far > c.near) {
                return Err(format!("camera `{}`: need 0 < near < far", c.name).into());
            }
            if c.depth_range[1] <= c.depth_range[0] {
                return Err(format!("camera `{}`: depth_range must increase", c.name).into());
            }
        }
        Ok(())
    }
}

impl CameraSensor {
    /// The image this sensor makes of a frame; `rng` drives depth noise.
    pub fn image(
        &self,
        frame: &Frame,
        scene: &RenderScene,
        camera: &crate::render::Camera,
        rng: &mut Rng,
    ) -> Image {
        match self.modality {
            Modality::Color => Image::U8 {
                channels: 3,
                data: frame.color(scene, camera).into_flattened(),
            },
            Modality::Gray => Image::U8 {
                channels: 1,
                data: frame
                    .color(scene, camera)
                    .into_iter()
                    .map(|[r, g, b]| {
                        (0.299 * f32::from(r) + 0.587 * f32::from(g) + 0.114 * f32::from(b)).round()
                            as u8
                    })
                    .collect(),
            },
            Modality::Depth => {
                let mut d = frame.linear_depth(camera);
                if let Some(noise) = self.noise {
                    apply_noise(&mut d, noise, rng);
                }
                let [lo, hi] = self.depth_range;
                let q = |v: f32, max: f32| {
                    if v <= 0.0 {
                        0.0
                    } else {
                        ((v - lo) / (hi - lo)).clamp(0.0, 1.0) * max
                    }
                };
                match self.depth_encoding {
                    DepthEncoding::Float => Image::F32 {
                        channels: 1,
                        data: d,
                    },
                    DepthEncoding::U8 => Image::U8 {
                        channels: 1,
                        data: d.iter().map(|&v| q(v, 255.0).round() as u8).collect(),
                    },
                    DepthEncoding::U16 => {
                        Image::U16(d.iter().map(|&v| q(v, 65535.0).round() as u16).collect())
                    }
                }
            }
            Modality::Normal => Image::F32 {
                channels: 3,
                data: frame.normals(scene).into_flattened(),
            },
            Modality::Semantic => Image::U16(frame.semantic(scene, self.taxonomy)),
            Modality::Instance => Image::U32(frame.instance(scene)),
            Modality::Room => Image::U32(frame.room(scene)),
            Modality::RoomClass => Image::U8 {
                channels: 1,
                data: frame.room_class(scene),
            },
        }
    }
}

/// `(dtype, channels)` of the images a camera sensor produces.
pub fn dtype_of(c: &CameraSensor) -> (PixelType, u32) {
    match c.modality {
        Modality::Color => (PixelType::U8, 3),
        Modality::Gray | Modality::RoomClass => (PixelType::U8, 1),
        Modality::Depth => match c.depth_encoding {
            DepthEncoding::Float => (PixelType::F32, 1),
            DepthEncoding::U8 => (PixelType::U8, 1),
            DepthEncoding::U16 => (PixelType::U16, 1),
        },
        Modality::Normal => (PixelType::F32, 3),
        Modality::Semantic => (PixelType::U16, 1),
        Modality::Instance | Modality::Room => (PixelType::U32, 1),
    }
}

/// A standard normal sample (Box–Muller).
fn gaussian(rng: &mut Rng) -> f32 {
    let u1 = rng.unit_f64().max(1e-12);
    let u2 = rng.unit_f64();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

fn apply_noise(depth: &mut [f32], noise: DepthNoise, rng: &mut Rng) {
    for d in depth.iter_mut().filter(|d| **d > 0.0) {
        match noise {
            DepthNoise::Gaussian { sigma } => *d = (*d + sigma * gaussian(rng)).max(0.0),
            DepthNoise::Kinect { min, max } => {
                if *d < min || *d > max {
                    *d = 0.0;
                } else {
                    let sigma = 0.0012 + 0.0019 * (*d - 0.4).powi(2);
                    *d = (*d + sigma * gaussian(rng)).max(0.0);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_suite_is_named_or_read_from_its_file() {
        let spec = |s: &str| SensorSuite::from_spec(std::path::Path::new(s), 32);
        let paper = spec("minos-paper").unwrap();
        assert_eq!(
            paper.cameras.len(),
            SensorSuite::minos_paper(32).cameras.len()
        );
        assert!(paper
            .cameras
            .iter()
            .all(|c| c.vfov == 90.0 && c.resolution == [32, 32]));
        assert!(paper.cameras.iter().any(|c| c.modality == Modality::Gray));
        assert_eq!(
            spec("all").unwrap().cameras.len(),
            SensorSuite::all(32).cameras.len()
        );
        assert_eq!(
            spec("minos").unwrap().cameras.len(),
            SensorSuite::minos(32).cameras.len()
        );
        // Anything else is a sensor file: a missing one is an error naming it.
        let e = spec("/nonexistent/minos-papr.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/minos-papr.toml"), "{e}");
        // A bare word that is no file is a mistyped suite: the error lists the suites.
        let e = spec("depth").unwrap_err().to_string();
        assert_eq!(
            e,
            "`depth` is neither a sensor suite (minos, minos-paper, all) nor a file"
        );
    }

    #[test]
    fn a_json_field_name_holding_a_newline_gives_a_one_line_error() {
        // Fuzzing regression (target `config_toml`): the unknown field's name was copied
        // into the message with its newline.
        let e = SensorSuite::parse("{\"[a\\\\\\n\"m", "s.json").unwrap_err();
        let line = crate::escape::error_line(&e);
        assert!(
            line.starts_with("s.json: unknown field") && !line.contains('\n'),
            "{line}"
        );
    }

    #[test]
    fn sensor_files_parse_and_bad_ones_say_why() {
        let toml = "[[camera]]\nname = \"rgb\"\nmodality = \"color\"\nresolution = [84, 84]\n\n\
                    [[camera]]\nname = \"d\"\nmodality = \"depth\"\nresolution = [64, 48]\ndepth_encoding = \"u8\"\n\
                    noise = { kind = \"kinect\", min = 0.4, max = 4.0 }\n\n[contact]\ncount = 4\nheight = 0.3\n";
        let s = SensorSuite::parse(toml, "s.toml").unwrap();
        assert_eq!(s.cameras.len(), 2);
        assert_eq!(s.cameras[1].depth_encoding, DepthEncoding::U8);
        assert_eq!(s.contact.unwrap().count, 4);
        let json = r#"{"camera": [{"name": "x", "modality": "semantic", "resolution": [8, 8], "taxonomy": "mpcat40"}]}"#;
        assert_eq!(
            SensorSuite::parse(json, "s.json").unwrap().cameras[0].taxonomy,
            Taxonomy::Mpcat40
        );
        let dup = "[[camera]]\nname = \"a\"\nmodality = \"color\"\nresolution = [8, 8]\n[[camera]]\nname = \"a\"\nmodality = \"depth\"\nresolution = [8, 8]\n";
        assert!(
            crate::escape::error_line(&SensorSuite::parse(dup, "s.toml").unwrap_err())
                .contains("defined twice")
        );
        let e = SensorSuite::parse(
            "[[camera]]\nname = \"a\"\nmodality = \"smell\"\nresolution = [8, 8]\n",
            "s.toml",
        )
        .unwrap_err();
        // The file, the line and the parser's message, on one line; the parser's error kept.
        let line = crate::escape::error_line(&e);
        assert!(
            line.starts_with("s.toml: line 3: unknown variant `smell`"),
            "{line}"
        );
        let Some(crate::invalid::SettingsCause::Toml(t)) =
            std::error::Error::source(&e).and_then(|c| c.downcast_ref())
        else {
            panic!("not a TOML error: {e:?}");
        };
        assert_eq!(t.line, Some((3, "modality = \"smell\"".to_string())));
        assert!(t.error.span().is_some());
    }

    #[test]
    fn kinect_noise_zeroes_out_of_range_depth() {
        let mut d = vec![0.2, 1.0, 6.0, 0.0];
        apply_noise(
            &mut d,
            DepthNoise::Kinect { min: 0.4, max: 4.0 },
            &mut Rng::new(1),
        );
        assert_eq!(d[0], 0.0);
        assert!((d[1] - 1.0).abs() < 0.05);
        assert_eq!(d[2], 0.0);
        assert_eq!(d[3], 0.0);
    }
}
