//! `minos nav query`: reachability, geodesic and Euclidean distance, rooms and doors passed and
//! the path between two points of a baked scene.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use glam::Vec3;
use minos::navmesh::route::{route, Route};
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
    /// Shortest path between two points: reachability, geodesic and Euclidean distance, rooms
    /// and doors passed, path points.
    Query(QueryArgs),
}

/// Points are x,y,z in world metres with y the floor height under the agent; they snap to the
/// nearest walkable span within 2 m.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos nav query --data DATA --scene ID --from 1.0,0,2.5 --to 6.2,0,4.0\n  \
    minos nav query --data DATA --scene ID --from 1,0,2.5 --to 6,3,4 --json | jq .geodesic"
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
    from: Vec3,
    /// Goal point x,y,z.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    to: Vec3,
    /// Print one JSON object: reachable, geodesic, euclidean, rooms, doors, path.
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

/// A path query, as the flags ask for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Query {
    /// The DATA folder.
    pub data: DataDir,
    /// The scene (or variant).
    pub scene: SceneRef,
    /// Start point.
    pub from: Vec3,
    /// Goal point.
    pub to: Vec3,
    /// Print JSON.
    pub json: bool,
}

/// Flags → the query.
pub fn config(q: &QueryArgs) -> Query {
    Query {
        data: DataDir::new(&q.data),
        scene: q.scene.clone(),
        from: q.from,
        to: q.to,
        json: q.json,
    }
}

/// Runs `minos nav`.
pub fn run(args: Args, _ctx: &Context) -> anyhow::Result<ExitCode> {
    let NavCommand::Query(q) = args.command;
    let q = config(&q);
    let path = q.data.grid_path(&q.scene);
    let grid = q
        .data
        .read_grid(&q.scene)
        .with_context(|| format!("scene {}", q.scene))?;
    let r: Route =
        route(&grid, q.from, q.to).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let euclidean = q.from.distance(q.to);
    let rooms: Vec<serde_json::Value> = r
        .rooms
        .iter()
        .map(|&i| {
            let room = &grid.rooms[i as usize];
            json!({"id": room.id, "class": minos::scene::RoomClass::ALL.get(room.class as usize).map(|c| c.name()).unwrap_or("other")})
        })
        .collect();
    let doors: Vec<&str> = r
        .doors
        .iter()
        .map(|&i| grid.objects[i as usize].id.as_str())
        .collect();
    if q.json {
        let out = json!({
            "reachable": r.reachable,
            "geodesic": r.geodesic,
            "euclidean": euclidean,
            "rooms": rooms,
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
            .map(|r| {
                format!(
                    "{} ({})",
                    r["id"].as_str().unwrap_or(""),
                    r["class"].as_str().unwrap_or("")
                )
            })
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
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    #[test]
    fn points_and_scene_references_parse() {
        let a = parse_flags::<QueryArgs>("--data D --scene h@tex --from 1,0,-2.5 --to 6,3,4")
            .expect("flags parse");
        let q = config(&a);
        assert_eq!(q.scene, SceneRef::parse("h@tex"));
        assert_eq!(q.from, Vec3::new(1.0, 0.0, -2.5));
        assert_eq!(
            q.data.grid_path(&q.scene),
            std::path::Path::new("D/nav/h@tex.nav")
        );
        for bad in ["1,2", "1,2,x", "1,2,inf"] {
            assert!(parse_point(bad).is_err(), "{bad}");
        }
    }
}
