//! Every vocabulary a user picks names from (presets, renderers, rewards, image encodings,
//! tasks, subsets, selections, stratification, dataset formats, run formats, house formats,
//! export formats, benchmarks, foreign episode formats, frame formats, texture sets, episode
//! exports, ingest outcomes) is
//! declared once on the library's enum: each
//! name and alias parses back to its value, names do not repeat, an unknown name is refused
//! with the known ones listed, and the command line refuses it in the same words.

use crate::common;

use minos::body::AgentPreset;
use minos::episode::import::ForeignFormat;
use minos::episode::sample::Select;
use minos::episode::vln::export::EpisodeExport;
use minos::episode::Task;
use minos::generate::{Furnishing, HouseFormat};
use minos::io::export::ExportFormat;
use minos::io::image_codec::ImageEncoding;
use minos::io::lerobot::DatasetLayout;
use minos::pipeline::bench::BenchKind;
use minos::pipeline::episodes::Stratify;
use minos::pipeline::ingest::{DatasetFormat, Outcome};
use minos::pipeline::rollout::RunFormat;
use minos::render::RendererChoice;
use minos::run::metrics::Reward;
use minos::scene::variants::TextureSet;
use minos::serve::frames::LosslessFormat;
use minos::sim::SuiteName;
use minos::split::Subset;
use minos::vocab::Vocabulary;

fn check<T: Vocabulary + std::fmt::Debug>() -> Vec<&'static str> {
    let mut seen = std::collections::BTreeSet::new();
    for t in T::TERMS {
        assert_eq!(T::parse_name(t.name), Ok(t.value), "{}", t.name);
        assert_eq!(t.value.term_name(), t.name);
        for alias in t.aliases {
            assert_eq!(T::parse_name(alias), Ok(t.value), "{alias}");
        }
        for name in std::iter::once(&t.name).chain(t.aliases) {
            assert!(seen.insert(*name), "{} `{name}` twice", T::WHAT);
            assert!(
                name.bytes().all(|b| b.is_ascii_lowercase()
                    || b.is_ascii_digit()
                    || b == b'-'
                    || b == b'_'),
                "{name}"
            );
        }
        assert!(!t.help.is_empty(), "{}: no help", t.name);
    }
    // Values do not repeat either: each variant has one name.
    for (i, a) in T::TERMS.iter().enumerate() {
        assert!(
            T::TERMS[i + 1..].iter().all(|b| b.value != a.value),
            "{}",
            a.name
        );
    }
    let e = T::parse_name("no-such-name").unwrap_err();
    assert_eq!(e.known, T::names());
    assert!(e
        .to_string()
        .starts_with(&format!("unknown {} `no-such-name` (", T::WHAT)));
    T::names()
}

#[test]
fn every_vocabulary_parses_its_names_and_refuses_others_with_the_list() {
    assert_eq!(
        check::<AgentPreset>(),
        ["habitat", "minos", "minos-gridworld", "minos-paper"]
    );
    assert_eq!(check::<RendererChoice>(), ["auto", "cpu", "wgpu"]);
    assert_eq!(check::<Reward>(), ["dist_time", "path_delta", "geodesic"]);
    assert_eq!(check::<ImageEncoding>(), ["raw", "png"]);
    assert_eq!(
        check::<Task>(),
        ["pointgoal", "objectgoal", "roomgoal", "vln"]
    );
    assert_eq!(check::<Subset>(), ["train", "val", "test"]);
    assert_eq!(check::<Select>(), ["any", "random", "closest"]);
    assert_eq!(check::<Stratify>(), ["auto", "on", "off"]);
    assert_eq!(
        check::<DatasetFormat>(),
        ["suncg", "3dfront", "gltf", "mp3d"]
    );
    assert_eq!(check::<RunFormat>(), ["parquet", "lerobot"]);
    assert_eq!(check::<HouseFormat>(), ["suncg", "mp3d", "mp3d-scan"]);
    assert_eq!(check::<Furnishing>(), ["standard", "dense"]);
    assert_eq!(check::<ExportFormat>(), ["obj", "glb"]);
    assert_eq!(check::<BenchKind>(), ["bake", "episodes", "render", "run"]);
    assert_eq!(check::<ForeignFormat>(), ["habitat", "minos-csv"]);
    assert_eq!(check::<SuiteName>(), ["minos", "minos-paper", "all"]);
    assert_eq!(check::<LosslessFormat>(), ["png", "webp"]);
    assert_eq!(check::<TextureSet>(), ["train", "val", "test"]);
    assert_eq!(check::<DatasetLayout>(), ["lerobot"]);
    assert_eq!(check::<EpisodeExport>(), ["habitat", "vlnce", "r2r"]);
    assert_eq!(check::<Outcome>(), ["compiled", "up_to_date", "failed"]);
    // Each export format is also the extension of its files.
    for f in ExportFormat::ALL {
        assert_eq!(f.extension(), f.term_name());
    }
    assert!(RunFormat::Lerobot.writes_lerobot() && !RunFormat::Parquet.writes_lerobot());
    // The old spelling of MINOS's continuous agent.
    assert_eq!(
        AgentPreset::parse_name("minos-continuous"),
        Ok(AgentPreset::Minos)
    );
    // `auto` stratifies the val and test subsets only.
    assert!(!Stratify::Auto.applies(None) && !Stratify::Auto.applies(Some(Subset::Train)));
    assert!(Stratify::Auto.applies(Some(Subset::Val)) && Stratify::On.applies(None));
    assert!(!Stratify::Off.applies(Some(Subset::Test)));
}

#[test]
fn the_command_line_takes_its_values_from_the_vocabularies() {
    let out = common::minos()
        .args(["run", "--help"])
        .output()
        .expect("minos runs");
    let help = String::from_utf8_lossy(&out.stdout);
    for t in Reward::TERMS {
        // The help line's start (clap wraps the rest to the terminal's width).
        let start: String = t.help.split(' ').take(4).collect::<Vec<_>>().join(" ");
        assert!(
            help.contains(&format!("{}:", t.name)) && help.contains(&start),
            "{}: {help}",
            t.name
        );
    }
    let out = common::minos()
        .args([
            "episodes",
            "--data",
            "D",
            "--task",
            "flygoal",
            "--out",
            "o.parquet",
        ])
        .output()
        .expect("minos runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    for name in Task::names() {
        assert!(err.contains(name), "{err}");
    }
    // The vocabularies that were the command line's own value enums refuse alike.
    for (args, names) in [
        (
            vec!["generate", "--out", "o", "--format", "ply"],
            HouseFormat::names(),
        ),
        (
            vec!["generate", "--out", "o", "--furnishing", "sparse"],
            Furnishing::names(),
        ),
        (vec!["bench", "fly", "--data", "D"], BenchKind::names()),
        (
            vec!["episodes", "import", "--from", "csv", "f.csv"],
            ForeignFormat::names(),
        ),
        (
            vec!["serve", "--data", "D", "--lossless-frames", "gif"],
            LosslessFormat::names(),
        ),
        (
            vec!["variants", "--data", "D", "--texture-set", "green"],
            TextureSet::names(),
        ),
    ] {
        let out = common::minos().args(&args).output().expect("minos runs");
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        for name in names {
            assert!(err.contains(name), "{args:?}: {err}");
        }
    }
}
