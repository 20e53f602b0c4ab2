//! `minos nav query`: reachability, geodesic and Euclidean distance, rooms and doors passed and
//! the path between two points of a baked scene — or, with `--pairs FILE`, for every pair of a
//! CSV or Parquet table in one process, the scene's query structures built once and shared by
//! all threads, one answer row per pair in the file's order.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context as _};
use glam::Vec3;
use minos::io::pairs::{read_pairs, write_answers, write_csv, write_json_lines, PairAnswer};
use minos::navmesh::geodesic::Geodesic;
use minos::navmesh::route::{route, route_many, Route};
use minos::navmesh::NavGrid;
use minos::scene::SceneRef;
use minos::store::DataDir;
use serde_json::json;

use super::Context;

/// Navigation queries on baked grids.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: NavCommand,
}

#[derive(Debug, clap::Subcommand)]
enum NavCommand {
    /// Shortest path between two points (or every pair of a table): reachability, geodesic and
    /// Euclidean distance, rooms and doors passed, path points.
    Query(QueryArgs),
}

/// Points are x,y,z in world metres with y the floor height under the agent; they snap to the
/// nearest walkable span within 2 m.
///
/// With --pairs FILE (CSV with a header, or .parquet; columns from_x,from_y,from_z,to_x,to_y,to_z)
/// every pair is answered in one process, in parallel (--threads), one row per pair in the
/// file's order: CSV on stdout, JSON lines with --json, or --out FILE.csv|FILE.parquet. A pair
/// with a point far from walkable floor is answered unreachable with an `error`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos nav query --data DATA --scene ID --from 1.0,0,2.5 --to 6.2,0,4.0\n  \
    minos nav query --data DATA --scene ID --from 1,0,2.5 --to 6,3,4 --json | jq .geodesic\n  \
    minos nav query --data DATA --scene ID --pairs pairs.csv --out answers.parquet\n  \
    minos --threads 2 nav query --data DATA --scene ID --pairs pairs.parquet --json > answers.jsonl"
)]
pub struct QueryArgs {
    /// DATA folder with DATA/nav/<scene>.nav (run `minos bake`).
    #[arg(long)]
    data: PathBuf,
    /// Scene id, or `<scene>@<variant>` (a retexture-only variant uses its scene's grid).
    #[arg(long)]
    scene: SceneRef,
    /// Start point x,y,z.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    from: Option<Vec3>,
    /// Goal point x,y,z.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    to: Option<Vec3>,
    /// Answer every pair of this CSV or Parquet file instead of --from/--to.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["from", "to"])]
    pairs: Option<PathBuf>,
    /// With --pairs: write the answers to FILE.csv or FILE.parquet instead of stdout.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Print JSON: one object (reachable, geodesic, euclidean, rooms, doors, path), or with
    /// --pairs one line per pair.
    #[arg(long)]
    json: bool,
}

fn parse_point(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .map_err(|_| format!("`{t}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("`{s}`: expected three finite numbers x,y,z")),
    }
}

/// What is asked: one pair, or every pair of a file.
#[derive(Debug, Clone, PartialEq)]
pub enum Asked {
    /// One pair, answered with its path.
    One {
        /// Start point.
        from: Vec3,
        /// Goal point.
        to: Vec3,
    },
    /// Every pair of a CSV or Parquet file.
    Pairs {
        /// The pairs file.
        file: PathBuf,
        /// Where the answers go (stdout when `None`).
        out: Option<PathBuf>,
    },
}

/// A path query, as the flags ask for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Query {
    /// The DATA folder.
    pub data: DataDir,
    /// The scene (or variant).
    pub scene: SceneRef,
    /// The pair or pairs.
    pub asked: Asked,
    /// Print JSON.
    pub json: bool,
}

/// Flags → the query.
pub fn config(q: &QueryArgs) -> anyhow::Result<Query> {
    let asked = match (&q.pairs, q.from, q.to) {
        (Some(file), _, _) => {
            if let Some(out) = &q.out {
                let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("");
                if !["csv", "parquet"].contains(&ext.to_ascii_lowercase().as_str()) {
                    bail!("--out {}: expected a .csv or .parquet file", out.display());
                }
            }
            Asked::Pairs {
                file: file.clone(),
                out: q.out.clone(),
            }
        }
        (None, _, _) if q.out.is_some() => bail!("--out: only with --pairs FILE"),
        (None, Some(from), Some(to)) => Asked::One { from, to },
        _ => bail!("give --from and --to, or --pairs FILE (see `minos nav query --help`)"),
    };
    Ok(Query {
        data: DataDir::new(&q.data),
        scene: q.scene.clone(),
        asked,
        json: q.json,
    })
}

/// Runs `minos nav`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let NavCommand::Query(q) = args.command;
    let q = config(&q)?;
    let path = q.data.grid_path(&q.scene);
    let grid = q
        .data
        .read_grid(&q.scene)
        .with_context(|| format!("scene {}", q.scene))?;
    match &q.asked {
        Asked::One { from, to } => {
            let r = route(&grid, *from, *to).map_err(|e| {
                anyhow::anyhow!("{}: {}", path.display(), minos::escape::error_line(&e))
            })?;
            print_one(&grid, *from, *to, &r, q.json);
        }
        Asked::Pairs { file, out } => answer_pairs(&grid, file, out.as_deref(), q.json, ctx)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Answers every pair of `file` and writes the rows; reports the rate on stderr (or, with
/// `--out`, on stdout).
fn answer_pairs(
    grid: &NavGrid,
    file: &std::path::Path,
    out: Option<&std::path::Path>,
    json: bool,
    ctx: &Context,
) -> anyhow::Result<()> {
    let pairs = read_pairs(file)?;
    let t0 = Instant::now();
    let geo = Geodesic::new(grid);
    let routes = route_many(&geo, &pairs);
    let answers: Vec<PairAnswer> = pairs
        .iter()
        .zip(routes)
        .map(|(&(from, to), r)| PairAnswer::new(grid, from, to, r))
        .collect();
    let secs = t0.elapsed().as_secs_f64();
    let reachable = answers.iter().filter(|a| a.reachable).count();
    let report = format!(
        "{} pairs ({reachable} reachable) in {secs:.3} s: {:.0} queries/s on {} threads",
        answers.len(),
        answers.len() as f64 / secs.max(1e-9),
        rayon::current_num_threads()
    );
    match out {
        Some(out) => {
            write_answers(out, &answers)?;
            ctx.say(format!("{report} -> {}", out.display()));
        }
        None => {
            let stdout = std::io::stdout();
            let mut w = std::io::BufWriter::new(stdout.lock());
            if json {
                write_json_lines(&mut w, &answers)?;
            } else {
                write_csv(&mut w, &answers)?;
            }
            w.flush()?;
            if !ctx.quiet {
                eprintln!("{report}");
            }
        }
    }
    Ok(())
}

/// Prints the answer to one query, with its path.
fn print_one(grid: &NavGrid, from: Vec3, to: Vec3, r: &Route, json: bool) {
    let euclidean = from.distance(to);
    let rooms = r.room_names(grid);
    let doors = r.door_ids(grid);
    if json {
        let out = json!({
            "reachable": r.reachable,
            "geodesic": r.geodesic,
            "euclidean": euclidean,
            "rooms": rooms.iter().map(|(id, class)| json!({"id": id, "class": class})).collect::<Vec<_>>(),
            "doors": doors,
            "path": r.points.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
        });
        println!("{out}");
    } else {
        println!("reachable: {}", if r.reachable { "yes" } else { "no" });
        match r.geodesic {
            Some(g) => println!("geodesic:  {g:.3} m"),
            None => println!("geodesic:  unreachable"),
        }
        println!("euclidean: {euclidean:.3} m");
        let names: Vec<String> = rooms
            .iter()
            .map(|(id, class)| format!("{id} ({class})"))
            .collect();
        println!("rooms:     {}", names.join(" -> "));
        println!("doors:     {}", doors.join(", "));
        let pts: Vec<String> = r
            .points
            .iter()
            .map(|p| format!("({:.2}, {:.2}, {:.2})", p.x, p.y, p.z))
            .collect();
        println!("path:      {}", pts.join(" "));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    #[test]
    fn points_and_scene_references_parse() {
        let a = parse_flags::<QueryArgs>("--data D --scene h@tex --from 1,0,-2.5 --to 6,3,4")
            .expect("flags parse");
        let q = config(&a).unwrap();
        assert_eq!(q.scene, SceneRef::parse("h@tex"));
        assert_eq!(
            q.asked,
            Asked::One {
                from: Vec3::new(1.0, 0.0, -2.5),
                to: Vec3::new(6.0, 3.0, 4.0)
            }
        );
        assert_eq!(
            q.data.grid_path(&q.scene),
            std::path::Path::new("D/nav/h@tex.nav")
        );
        for bad in ["1,2", "1,2,x", "1,2,inf"] {
            assert!(parse_point(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn pairs_replace_from_and_to_and_out_names_a_table() {
        let base = "--data D --scene h";
        let q = config(&parse_flags::<QueryArgs>(&format!("{base} --pairs p.csv --json")).unwrap())
            .unwrap();
        assert_eq!(
            q.asked,
            Asked::Pairs {
                file: "p.csv".into(),
                out: None
            }
        );
        assert!(q.json);
        let a = parse_flags::<QueryArgs>(&format!("{base} --pairs p.csv --out a.parquet")).unwrap();
        assert_eq!(
            config(&a).unwrap().asked,
            Asked::Pairs {
                file: "p.csv".into(),
                out: Some("a.parquet".into())
            }
        );
        let a = parse_flags::<QueryArgs>(&format!("{base} --pairs p.csv --out a.txt")).unwrap();
        let err = config(&a).unwrap_err().to_string();
        assert!(
            err.starts_with("--out a.txt: expected a .csv or .parquet"),
            "{err}"
        );
        // --pairs excludes --from/--to; --out needs --pairs; one of the two forms is needed.
        assert!(parse_flags::<QueryArgs>(&format!("{base} --pairs p.csv --from 1,0,1")).is_err());
        let a = parse_flags::<QueryArgs>(&format!("{base} --from 1,0,1 --to 2,0,2 --out a.csv"))
            .unwrap();
        assert!(config(&a)
            .unwrap_err()
            .to_string()
            .starts_with("--out: only with --pairs"));
        let a = parse_flags::<QueryArgs>(&format!("{base} --from 1,0,1")).unwrap();
        assert!(config(&a).unwrap_err().to_string().contains("--pairs FILE"));
    }
}
