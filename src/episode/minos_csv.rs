//! Import of MINOS's presampled episode tables (`episode_states.suncg.csv.bz2`,
//! `episode_states.mp3d.csv.bz2`, plain `.csv` or gzip/bzip2-compressed, told apart by
//! content) into [`Episode`]s.
//!
//! The file is streamed line by line; columns are found by header name, so column order and
//! extra columns do not matter. This module only reads: it does not check episodes against
//! the scenes.
//!
//! # Mapping
//!
//! Required columns: `split`, `sceneId`, `startX`, `startY`, `startZ`, `startAngle`, `goalX`,
//! `goalY`, `goalZ`. Everything else is optional.
//!
//! | MINOS column | episode field |
//! |---|---|
//! | row | `episode_id` = `<sceneId>:minos:<row>` (zero-based data row in the file, 5 digits) |
//! | `sceneId`, `split` | `scene_id`, `split` |
//! | `startX`, `startY`, `startZ` | `start_position`, with `startY` lowered by [`MINOS_AGENT_ORIGIN_HEIGHT`] (and turned into minos's frame for Matterport3D, below) |
//! | `startAngle` | `start_yaw` (turned likewise) |
//! | `goalX`, `goalY`, `goalZ` | the goal point, or the target's position |
//! | `goalObjectId` (empty) | PointGoal |
//! | `goalObjectId` (set) | ObjectGoal `{category: goalObjectType or "object", targets: [{id: goalObjectId, position: goal}]}` |
//! | `task` = `r` / `room_goal` | RoomGoal `{class: goalRoomType, targets: [{id: goalRoomId, position: goal}]}` |
//! | `roomId`, `roomType` | read as RoomGoal ([`import_minos_csv`] with `Some(Task::RoomGoal)`): the goal room, when the row has no `goalRoomId` |
//! | `dist` | `euclidean_distance` (empty or absent: computed from start and goal as given in the file) |
//! | `pathDist` | `geodesic_distance` (empty, absent or negative — MINOS's −1 for "no path found": NaN) |
//! | `pathNumDoors`, `pathNumRooms` | `path_num_doors`, `path_num_rooms` (empty or absent: 0) |
//!
//! Not kept: `level`, `pathDoorIds`, `pathRoomIndices`; `roomId`/`roomType` unless the rows
//! are read as RoomGoal.
//!
//! **Room goals.** The published tables are PointGoal states, and MINOS's RoomGoal
//! configurations (`roomgoal_suncg_sf.py` and the others) read the same tables: the goal room
//! is the row's `roomId` (`RoomSimulator.new_episode`), the room holding the state's goal point
//! (every one of the 100 rows of the Matterport3D house GdvgFV5R1Z5 has its goal, and none its
//! start, inside that region's box). Reading a table as RoomGoal does the same: target id
//! `roomId` (Matterport3D's `R<n>` becomes minos's region id `region<n>`), class `roomType`
//! (a minos room-class name when it is one, [`RoomClass::from_label`]), position the goal
//! point.
//!
//! **Frames.** MINOS's SUNCG coordinates are the house's own, which minos keeps. Its
//! Matterport3D coordinates are SSTK's: (x, y, z) = (y, z, x) of the scan, where minos, as
//! Habitat, uses (x, z, −y) (docs/FORMATS.md). So rows of a Matterport3D scan (an 11-letter
//! alphanumeric scene id, like `17DRP5sb8fy`; SUNCG ids are 32 hex digits) are turned a
//! quarter turn about +Y: minos (x, y, z) = MINOS (z, y, −x), and yaw + π/2 (wrapped to
//! [0, 2π)). Distances are unchanged. On GdvgFV5R1Z5's baked grid, 98 of its 100 rows then
//! have a path from start to goal, of 0.96 × MINOS's `pathDist` (median); as written, 20.
//! `seed` is 0, `difficulty` follows the geodesic distance (below 3 m easy, below 6 m medium,
//! else hard; medium when unknown), `success_radius` is [`MINOS_SUCCESS_RADIUS`] and
//! `max_steps` 500.
//!
//! **Angles.** MINOS hands `startAngle` to its simulator (SSTK), which sets it as the agent's
//! three.js rotation about +Y; the agent looks along −Z. That is minos's yaw exactly
//! (radians, counter-clockwise about +Y, 0 faces −Z), so the value is kept as it is (MINOS
//! samples it in [0, 2π]).
//!
//! **Heights.** MINOS positions the agent by its centre, half its 1.09 m eye height above the
//! floor: in the SUNCG table `startY − goalY` is exactly 0.545 m for 36,192 of 36,400 rows
//! (the goal lies on the floor). minos starts stand on the floor, so `startY` is lowered by
//! 0.545 m. The goal is kept as given. `dist` is MINOS's 3D distance from the agent centre
//! and is kept as given too.
//!
//! The only MINOS tables with object goals use a `task` column and `goalObjectType` (see
//! MINOS's `check_episode_states.js`); the published SUNCG and Matterport3D tables are all
//! PointGoal (`goalObjectId` is always empty). A room class is stored as MINOS's class name
//! when `goalRoomType` is one (`kitchen`, `bedroom`, …), else as written.
//!
//! Blank lines are skipped; CRLF line ends, surrounding whitespace and double-quoted fields
//! are accepted (quoted fields may not span lines). A bad row stops the import with an error
//! naming the file, the line (the header is line 1) and the column.

use crate::file_error::FileError;
use std::borrow::Cow;
use std::collections::HashMap;
use std::io::BufRead;
use std::path::Path;

use super::interchange::{difficulty_for_geodesic, distance, open_text, DEFAULT_MAX_STEPS};
use super::{Episode, Goal, GoalTarget, TargetRoom, Task};
use crate::escape::escape_controls;
use crate::invalid::Invalid;
use crate::scene::RoomClass;
use std::f32::consts::{FRAC_PI_2, TAU};

/// Height (m) of MINOS's agent origin above the floor (half of its 1.09 m eye height), taken
/// off `startY`.
pub const MINOS_AGENT_ORIGIN_HEIGHT: f32 = 0.545;

/// Success radius (m) given to imported episodes: MINOS's `goal_dist_threshold` in its
/// PointGoal environment configurations.
pub const MINOS_SUCCESS_RADIUS: f32 = 0.4;

/// Errors importing a MINOS episode table.
#[derive(Debug, thiserror::Error)]
pub enum MinosCsvError {
    /// File system or decompression error.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The header line lacks required columns (or the file is empty).
    #[error("{path}: line 1: {}", escape_controls(.message))]
    Header {
        /// The table.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A bad row.
    #[error(
        "{path}: line {line}: {}: {}",
        escape_controls(.column),
        escape_controls(.message)
    )]
    Row {
        /// The table.
        path: String,
        /// One-based line number (the header is line 1).
        line: u64,
        /// The column holding the bad value (`(row)` for the row as a whole).
        column: String,
        /// What is wrong.
        message: String,
    },
}

/// Splits one CSV line into fields, trimming surrounding whitespace; double-quoted fields may
/// contain commas and `""` escapes.
fn split_fields(line: &str) -> Result<Vec<Cow<'_, str>>, Invalid> {
    let mut fields = Vec::new();
    let mut rest = line;
    loop {
        let trimmed = rest.trim_start();
        if let Some(quoted) = trimmed.strip_prefix('"') {
            let mut value = String::new();
            let mut chars = quoted.char_indices();
            let end = loop {
                match chars.next() {
                    None => return Err("unterminated quoted field".into()),
                    Some((i, '"')) => {
                        if quoted[i + 1..].starts_with('"') {
                            value.push('"');
                            chars.next();
                        } else {
                            break i + 1;
                        }
                    }
                    Some((_, c)) => value.push(c),
                }
            };
            fields.push(Cow::Owned(value));
            let after = quoted[end..].trim_start();
            match after.strip_prefix(',') {
                Some(r) => rest = r,
                None if after.is_empty() => return Ok(fields),
                None => return Err("text after a closing quote".into()),
            }
        } else {
            match trimmed.split_once(',') {
                Some((field, r)) => {
                    fields.push(Cow::Borrowed(field.trim_end()));
                    rest = r;
                }
                None => {
                    fields.push(Cow::Borrowed(trimmed.trim_end()));
                    return Ok(fields);
                }
            }
        }
    }
}

/// Column indices found in the header.
struct Columns {
    count: usize,
    split: usize,
    scene: usize,
    start: [usize; 3],
    angle: usize,
    goal: [usize; 3],
    task: Option<usize>,
    object_id: Option<usize>,
    object_type: Option<usize>,
    room_id: Option<usize>,
    room_type: Option<usize>,
    state_room_id: Option<usize>,
    state_room_type: Option<usize>,
    dist: Option<usize>,
    path_dist: Option<usize>,
    doors: Option<usize>,
    rooms: Option<usize>,
}

impl Columns {
    fn from_header(fields: &[Cow<'_, str>]) -> Result<(Self, Vec<String>), Invalid> {
        let names: Vec<String> = fields.iter().map(|f| f.to_string()).collect();
        let index: HashMap<&str, usize> = names
            .iter()
            .enumerate()
            .rev() // the first of duplicate names wins
            .map(|(i, n)| (n.as_str(), i))
            .collect();
        let mut missing = Vec::new();
        let mut req = |name: &'static str| {
            index.get(name).copied().unwrap_or_else(|| {
                missing.push(name);
                0
            })
        };
        let split = req("split");
        let scene = req("sceneId");
        let start = [req("startX"), req("startY"), req("startZ")];
        let angle = req("startAngle");
        let goal = [req("goalX"), req("goalY"), req("goalZ")];
        if !missing.is_empty() {
            return Err(format!(
                "missing required column(s) {}",
                missing
                    .iter()
                    .map(|m| format!("`{m}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
            .into());
        }
        let opt = |name: &str| index.get(name).copied();
        let cols = Columns {
            count: names.len(),
            split,
            scene,
            start,
            angle,
            goal,
            task: opt("task"),
            object_id: opt("goalObjectId"),
            object_type: opt("goalObjectType"),
            room_id: opt("goalRoomId"),
            room_type: opt("goalRoomType"),
            state_room_id: opt("roomId"),
            state_room_type: opt("roomType"),
            dist: opt("dist"),
            path_dist: opt("pathDist"),
            doors: opt("pathNumDoors"),
            rooms: opt("pathNumRooms"),
        };
        Ok((cols, names))
    }
}

/// Reads every episode of a MINOS episode table (see the module documentation): as the rows
/// say (`task` column, else PointGoal or ObjectGoal by `goalObjectId`), or every row as
/// `task` when given — RoomGoal as MINOS's RoomGoal configurations read the PointGoal tables.
pub fn import_minos_csv(path: &Path, task: Option<Task>) -> Result<Vec<Episode>, MinosCsvError> {
    let p = path.display().to_string();
    let io = |source| MinosCsvError::Io(FileError::new(p.clone(), source));
    let (mut reader, _) = open_text(path).map_err(io)?;
    let mut buf = Vec::with_capacity(256);
    let mut line_no: u64 = 0;
    let mut header: Option<(Columns, Vec<String>)> = None;
    let mut episodes = Vec::new();
    loop {
        buf.clear();
        if reader.read_until(b'\n', &mut buf).map_err(io)? == 0 {
            break;
        }
        line_no += 1;
        let row_err = |column: &str, message: String| MinosCsvError::Row {
            path: p.clone(),
            line: line_no,
            column: column.to_string(),
            message,
        };
        let text = std::str::from_utf8(&buf)
            .map_err(|e| row_err("(row)", format!("not UTF-8 text: {e}")))?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text).trim();
        if text.is_empty() {
            continue;
        }
        let fields = split_fields(text).map_err(|m| row_err("(row)", m.to_string()))?;
        let Some((cols, names)) = &header else {
            let parsed =
                Columns::from_header(&fields).map_err(|message| MinosCsvError::Header {
                    path: p.clone(),
                    message: message.to_string(),
                })?;
            header = Some(parsed);
            continue;
        };
        if fields.len() != cols.count {
            return Err(row_err(
                "(row)",
                format!(
                    "expected {} fields (as in the header), found {}",
                    cols.count,
                    fields.len()
                ),
            ));
        }
        let row = RowReader {
            fields: &fields,
            names,
            err: &row_err,
        };
        episodes.push(row.episode(cols, episodes.len(), task)?);
    }
    if header.is_none() {
        return Err(MinosCsvError::Header {
            path: p,
            message: "empty file: no header line".into(),
        });
    }
    Ok(episodes)
}

/// The frame a row's coordinates are in (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Frame {
    /// minos's own (SUNCG houses and anything else).
    Same,
    /// SSTK's Matterport3D frame: a quarter turn about +Y from minos's.
    Matterport3d,
}

impl Frame {
    /// Matterport3D for a scan id (11 ASCII letters and digits), else the same frame.
    fn of_scene(scene: &str) -> Frame {
        if scene.len() == 11 && scene.bytes().all(|b| b.is_ascii_alphanumeric()) {
            Frame::Matterport3d
        } else {
            Frame::Same
        }
    }

    /// A position in minos's frame: MINOS (x, y, z) → (z, y, −x) for Matterport3D.
    fn point(self, [x, y, z]: [f32; 3]) -> [f32; 3] {
        match self {
            Frame::Same => [x, y, z],
            Frame::Matterport3d => [z, y, -x],
        }
    }

    /// A yaw in minos's frame: a quarter turn more for Matterport3D, kept in [0, 2π).
    fn yaw(self, yaw: f32) -> f32 {
        match self {
            Frame::Same => yaw,
            Frame::Matterport3d => (yaw + FRAC_PI_2).rem_euclid(TAU),
        }
    }

    /// A room id in minos's terms: Matterport3D's `R<n>` is minos's region `region<n>`.
    fn room_id(self, id: &str) -> String {
        match (self, id.strip_prefix('R')) {
            (Frame::Matterport3d, Some(n))
                if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) =>
            {
                format!("region{n}")
            }
            _ => id.to_string(),
        }
    }
}

/// Typed access to the fields of one data row.
struct RowReader<'a, 'f> {
    fields: &'a [Cow<'f, str>],
    names: &'a [String],
    err: &'a dyn Fn(&str, String) -> MinosCsvError,
}

impl RowReader<'_, '_> {
    fn text(&self, i: usize) -> &str {
        &self.fields[i]
    }

    fn opt_text(&self, i: Option<usize>) -> &str {
        i.map_or("", |i| self.text(i))
    }

    fn fail(&self, i: usize, message: String) -> MinosCsvError {
        (self.err)(&self.names[i], message)
    }

    /// A finite number.
    fn number(&self, i: usize) -> Result<f32, MinosCsvError> {
        let t = self.text(i);
        match t.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.fail(i, format!("`{t}` is not a finite number"))),
            Err(_) => Err(self.fail(i, format!("`{t}` is not a number"))),
        }
    }

    /// A number, or `None` when the column is absent or the field empty.
    fn opt_number(&self, i: Option<usize>) -> Result<Option<f32>, MinosCsvError> {
        match i {
            Some(i) if !self.text(i).is_empty() => self.number(i).map(Some),
            _ => Ok(None),
        }
    }

    /// A count; 0 when the column is absent or the field empty.
    fn count(&self, i: Option<usize>) -> Result<u32, MinosCsvError> {
        match i {
            Some(i) if !self.text(i).is_empty() => {
                let t = self.text(i);
                t.parse::<u32>()
                    .map_err(|_| self.fail(i, format!("`{t}` is not a non-negative integer")))
            }
            _ => Ok(0),
        }
    }

    fn point(&self, idx: [usize; 3]) -> Result<[f32; 3], MinosCsvError> {
        Ok([
            self.number(idx[0])?,
            self.number(idx[1])?,
            self.number(idx[2])?,
        ])
    }

    fn episode(
        &self,
        c: &Columns,
        row: usize,
        read_as: Option<Task>,
    ) -> Result<Episode, MinosCsvError> {
        let scene = self.text(c.scene);
        if scene.is_empty() {
            return Err(self.fail(c.scene, "empty scene id".into()));
        }
        let frame = Frame::of_scene(scene);
        let raw_start = self.point(c.start)?;
        let start_position = frame.point([
            raw_start[0],
            raw_start[1] - MINOS_AGENT_ORIGIN_HEIGHT,
            raw_start[2],
        ]);
        let start_yaw = frame.yaw(self.number(c.angle)?);
        let raw_goal = self.point(c.goal)?;
        let goal_pos = frame.point(raw_goal);
        let object_id = self.opt_text(c.object_id);
        let task = match (read_as, c.task.map(|i| (i, self.text(i)))) {
            (Some(task), _) => task,
            (None, None | Some((_, ""))) => {
                if object_id.is_empty() {
                    Task::PointGoal
                } else {
                    Task::ObjectGoal
                }
            }
            (None, Some((i, t))) => match t {
                "p" | "point_goal" | "pointgoal" => Task::PointGoal,
                "o" | "object_goal" | "objectgoal" => Task::ObjectGoal,
                "r" | "room_goal" | "roomgoal" => Task::RoomGoal,
                other => return Err(self.fail(i, format!("unknown task `{other}`"))),
            },
        };
        let required = |i: Option<usize>, name: &str| -> Result<String, MinosCsvError> {
            let t = self.opt_text(i);
            if t.is_empty() {
                Err((self.err)(
                    name,
                    format!("empty or missing, but the row has a {} goal", task.name()),
                ))
            } else {
                Ok(t.to_string())
            }
        };
        let goal = match task {
            Task::PointGoal | Task::Vln => Goal::Point { position: goal_pos },
            Task::ObjectGoal => {
                let id = required(c.object_id, "goalObjectId")?;
                let category = match self.opt_text(c.object_type) {
                    "" => "object".to_string(),
                    t => t.to_string(),
                };
                Goal::Object {
                    category,
                    targets: vec![GoalTarget {
                        id,
                        position: goal_pos,
                        view_points: Vec::new(),
                        room: None,
                    }],
                }
            }
            Task::RoomGoal => {
                // The table's own room goal, else the state's room (as MINOS's RoomGoal
                // configurations read the PointGoal tables).
                let (id, raw) = if self.opt_text(c.room_id).is_empty() && c.state_room_id.is_some()
                {
                    (
                        frame.room_id(&required(c.state_room_id, "roomId")?),
                        required(c.state_room_type, "roomType")?,
                    )
                } else {
                    (
                        required(c.room_id, "goalRoomId")?,
                        required(c.room_type, "goalRoomType")?,
                    )
                };
                let class = RoomClass::from_label(&raw).map_or(raw, |k| k.name().to_string());
                Goal::Room {
                    targets: vec![GoalTarget {
                        room: Some(TargetRoom {
                            id: id.clone(),
                            class: class.clone(),
                        }),
                        id,
                        position: goal_pos,
                        view_points: Vec::new(),
                    }],
                    class,
                }
            }
        };
        let euclidean_distance = self
            .opt_number(c.dist)?
            .unwrap_or_else(|| distance(raw_start, raw_goal));
        // MINOS writes -1 when its planner found no path: unknown here, as an empty field.
        let geodesic_distance = self
            .opt_number(c.path_dist)?
            .filter(|d| *d >= 0.0)
            .unwrap_or(f32::NAN);
        Ok(Episode {
            episode_id: format!("{scene}:minos:{row:05}"),
            scene_id: scene.to_string(),
            split: self.text(c.split).to_string(),
            task,
            seed: 0,
            start_position,
            start_yaw,
            goal,
            euclidean_distance,
            geodesic_distance,
            path_num_doors: self.count(c.doors)?,
            path_num_rooms: self.count(c.rooms)?,
            difficulty: difficulty_for_geodesic(geodesic_distance),
            success_radius: MINOS_SUCCESS_RADIUS,
            max_steps: DEFAULT_MAX_STEPS,
            levels_crossed: 0,
            route: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Difficulty;
    use std::io::{Read, Write};
    use std::path::PathBuf;

    const SUNCG_HEADER: &str = "split,sceneId,roomId,roomType,startX,startY,startZ,startAngle,\
        goalObjectId,goalX,goalY,goalZ,dist,pathDist,pathNumDoors,pathDoorIds";
    const SUNCG_ROW: &str = "train,0049e2ed9d7b7c49930d92c30fd59ff7,0_0,Living_Room,-37.105,\
        0.595,-42.906,0.700,,-40.083,0.050,-39.258,4.741,5.997,2,0_11:0_4";

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn matterport_rows_turn_into_minos_frame_and_read_as_room_goals() {
        let dir = tempfile::tempdir().unwrap();
        let text = "split,sceneId,level,roomId,roomType,startX,startY,startZ,startAngle,\
                    goalObjectId,goalX,goalY,goalZ,dist,pathDist,pathNumDoors\n\
                    train,GdvgFV5R1Z5,0,R5,dining room,1,0.545,2,5.5,,3,0,4,3.1,-1,0\n\
                    train,0049e2ed9d7b7c49930d92c30fd59ff7,0,0_3,Living_Room,1,0.545,2,5.5,,3,0,4,3.1,4.5,1\n";
        let p = write(dir.path(), "m.csv", text);
        let points = import_minos_csv(&p, None).unwrap();
        let (scan, house) = (&points[0], &points[1]);
        // A scan's row is turned a quarter turn about +Y: (x, y, z) -> (z, y, -x).
        assert_eq!(scan.start_position, [2.0, 0.0, -1.0]);
        assert_eq!(
            scan.goal,
            Goal::Point {
                position: [4.0, 0.0, -3.0]
            }
        );
        // The turned facing is the facing turned: yaw psi faces (-sin psi, -cos psi) in (x, z).
        let face = |yaw: f32| [-yaw.sin(), -yaw.cos()];
        let [fx, fz] = face(5.5);
        let turned = face(scan.start_yaw);
        assert!((turned[0] - fz).abs() < 1e-5 && (turned[1] + fx).abs() < 1e-5);
        assert!((0.0..TAU).contains(&scan.start_yaw));
        // MINOS's -1 ("no path") is an unknown geodesic; a SUNCG house keeps its frame.
        assert!(scan.geodesic_distance.is_nan());
        assert_eq!(house.start_position, [1.0, 0.0, 2.0]);
        assert_eq!((house.start_yaw, house.geodesic_distance), (5.5, 4.5));

        let rooms = import_minos_csv(&p, Some(Task::RoomGoal)).unwrap();
        let target = |e: &Episode| match &e.goal {
            Goal::Room { class, targets } => {
                (class.clone(), targets[0].id.clone(), targets[0].position)
            }
            other => panic!("{other:?}"),
        };
        assert_eq!(rooms[0].task, Task::RoomGoal);
        assert_eq!(
            target(&rooms[0]),
            ("dining_room".into(), "region5".into(), [4.0, 0.0, -3.0])
        );
        assert_eq!(
            target(&rooms[1]),
            ("living_room".into(), "0_3".into(), [3.0, 0.0, 4.0])
        );
    }

    #[test]
    fn suncg_rows_map_to_point_goals() {
        let dir = tempfile::tempdir().unwrap();
        let second = SUNCG_ROW
            .replace("train", "val")
            .replace("5.997", "2.5")
            .replace(",2,0_11", ",0,");
        // CRLF, trailing whitespace, a blank line, and a bzip2 file named .csv.
        let text = format!("{SUNCG_HEADER}\r\n{SUNCG_ROW}  \r\n\r\n{second}\r\n");
        let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
        bz.write_all(text.as_bytes()).unwrap();
        let p = dir.path().join("t.csv");
        std::fs::write(&p, bz.finish().unwrap()).unwrap();
        let eps = import_minos_csv(&p, None).unwrap();
        assert_eq!(eps.len(), 2);
        let e = &eps[0];
        assert_eq!(e.episode_id, "0049e2ed9d7b7c49930d92c30fd59ff7:minos:00000");
        assert_eq!(
            eps[1].episode_id,
            "0049e2ed9d7b7c49930d92c30fd59ff7:minos:00001"
        );
        assert_eq!(e.scene_id, "0049e2ed9d7b7c49930d92c30fd59ff7");
        assert_eq!((e.split.as_str(), eps[1].split.as_str()), ("train", "val"));
        assert_eq!(e.task, Task::PointGoal);
        assert_eq!(
            e.start_position,
            [-37.105, 0.595 - MINOS_AGENT_ORIGIN_HEIGHT, -42.906]
        );
        assert!((e.start_position[1] - 0.05).abs() < 1e-6);
        assert_eq!(e.start_yaw, 0.7);
        assert_eq!(
            e.goal,
            Goal::Point {
                position: [-40.083, 0.05, -39.258]
            }
        );
        assert_eq!((e.euclidean_distance, e.geodesic_distance), (4.741, 5.997));
        assert_eq!((e.path_num_doors, e.path_num_rooms), (2, 0));
        assert_eq!(
            (e.difficulty, eps[1].difficulty),
            (Difficulty::Medium, Difficulty::Easy)
        );
        assert_eq!(eps[1].path_num_doors, 0);
        assert_eq!(e.success_radius, MINOS_SUCCESS_RADIUS);
        assert_eq!(e.max_steps, DEFAULT_MAX_STEPS);
    }

    #[test]
    fn columns_are_found_by_name_and_object_and_room_goals_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let text = "goalZ,goalY,goalX,startAngle,startZ,startY,startX,sceneId,split,task,\
                    goalObjectId,goalObjectType,goalRoomId,goalRoomType,pathDist,pathNumRooms\n\
                    3,0.5,4,1.5,0,0.545,0,s1,test,o,0_5,door,,,7.5,4\n\
                    3,0.05,4,1.5,0,0.545,0,s1,test,r,,,0_2,Kitchen,,\n\
                    \"3\",0.05,4,1.5,0,0.545,0,\"s,2\",test,,,,,,,\n";
        let p = write(dir.path(), "x.csv", text);
        let eps = import_minos_csv(&p, None).unwrap();
        assert_eq!(eps.len(), 3);
        assert_eq!(
            eps[0].goal,
            Goal::Object {
                category: "door".into(),
                targets: vec![GoalTarget {
                    id: "0_5".into(),
                    position: [4.0, 0.5, 3.0],
                    view_points: vec![],
                    room: None,
                }]
            }
        );
        assert_eq!(eps[0].start_position, [0.0, 0.0, 0.0]);
        assert_eq!(
            (eps[0].path_num_rooms, eps[0].difficulty),
            (4, Difficulty::Hard)
        );
        // No `dist` column: computed from the start as written (agent centre) to the goal.
        assert_eq!(
            eps[0].euclidean_distance,
            distance([0.0, 0.545, 0.0], [4.0, 0.5, 3.0])
        );
        match &eps[1].goal {
            Goal::Room { class, targets } => {
                assert_eq!(class, "kitchen");
                assert_eq!(targets[0].id, "0_2");
            }
            g => panic!("expected a room goal, got {g:?}"),
        }
        assert!(eps[1].geodesic_distance.is_nan());
        assert_eq!(eps[1].difficulty, Difficulty::Medium);
        assert_eq!(eps[2].scene_id, "s,2");
        assert_eq!(eps[2].task, Task::PointGoal);
    }

    #[test]
    fn bad_rows_give_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            (
                SUNCG_ROW.replace("-37.105", "abc"),
                "line 17: startX: `abc` is not a number",
            ),
            (
                // Control characters quoted from the file are escaped.
                SUNCG_ROW.replace("-37.105", "ab\u{1}c"),
                "line 17: startX: `ab\\u{1}c` is not a number",
            ),
            (
                SUNCG_ROW.replace(",2,0_11", ",-1,0_11"),
                "line 17: pathNumDoors: `-1` is not a non-negative integer",
            ),
            (
                SUNCG_ROW.replace(",0.700,", ",inf,"),
                "line 17: startAngle: `inf` is not a finite number",
            ),
            (
                SUNCG_ROW.replace(",0_11:0_4", ""),
                "line 17: (row): expected 16 fields (as in the header), found 15",
            ),
            (
                SUNCG_ROW
                    .replace(",,", ",0_7,")
                    .replace("train,", "train,\"x"),
                "line 17: (row): unterminated quoted field",
            ),
        ];
        for (k, (bad, expected)) in cases.iter().enumerate() {
            // Header, 14 good rows and a blank line, so the bad row is line 17.
            let mut text = format!("{SUNCG_HEADER}\n");
            for _ in 0..14 {
                text.push_str(SUNCG_ROW);
                text.push('\n');
            }
            text.push('\n');
            text.push_str(bad);
            text.push('\n');
            let p = write(dir.path(), &format!("episode_states.{k}.csv"), &text);
            let err = import_minos_csv(&p, None).unwrap_err().to_string();
            let want = format!("{}: {expected}", p.display());
            assert_eq!(err, want);
        }
        let p = write(dir.path(), "nohead.csv", "split,sceneId,startX\n");
        let err = import_minos_csv(&p, None).unwrap_err().to_string();
        assert!(
            err.contains("line 1: missing required column(s) `startY`"),
            "{err}"
        );
        let p = write(dir.path(), "empty.csv", "\n");
        assert!(import_minos_csv(&p, None).is_err());
    }

    #[test]
    fn quoted_fields_split_like_csv() {
        let f = split_fields(r#" a , "b,""c""" ,, "" "#).unwrap();
        assert_eq!(f, vec!["a", "b,\"c\"", "", ""]);
        assert!(split_fields(r#""a" b"#).is_err());
    }

    /// Data rows of a (bzip2) CSV, counted without the importer: non-blank lines but the header.
    fn count_rows(path: &Path) -> usize {
        let mut text = String::new();
        bzip2::read::MultiBzDecoder::new(std::fs::File::open(path).unwrap())
            .read_to_string(&mut text)
            .unwrap();
        text.lines().filter(|l| !l.trim().is_empty()).count() - 1
    }

    #[test]
    fn real_minos_tables_import() {
        let Some(root) = std::env::var_os("MINOS_REAL_DATA") else {
            println!("skipped: MINOS_REAL_DATA is not set");
            return;
        };
        let dir = PathBuf::from(root).join("minos");
        let suncg_path = dir.join("episode_states.suncg.csv.bz2");
        let suncg = import_minos_csv(&suncg_path, None).unwrap();
        assert_eq!(suncg.len(), count_rows(&suncg_path));
        assert_eq!(suncg.len(), 36_400);
        let e = &suncg[0];
        assert_eq!(e.episode_id, "0049e2ed9d7b7c49930d92c30fd59ff7:minos:00000");
        assert_eq!(
            e.start_position,
            [-37.105, 0.595 - MINOS_AGENT_ORIGIN_HEIGHT, -42.906]
        );
        assert_eq!((e.geodesic_distance, e.path_num_doors), (5.997, 2));
        assert!(suncg.iter().all(|e| e.task == Task::PointGoal));
        let splits: std::collections::BTreeSet<&str> =
            suncg.iter().map(|e| e.split.as_str()).collect();
        assert_eq!(splits, ["extra", "test", "train", "val"].into());
        assert!(suncg
            .iter()
            .all(|e| (0.0..=std::f32::consts::TAU + 1e-3).contains(&e.start_yaw)));

        let mp3d_path = dir.join("episode_states.mp3d.csv.bz2");
        let mp3d = import_minos_csv(&mp3d_path, None).unwrap();
        assert_eq!(mp3d.len(), count_rows(&mp3d_path));
        assert_eq!(mp3d.len(), 16_744);
        let m = &mp3d[0];
        assert_eq!(m.scene_id, "17DRP5sb8fy");
        // 17DRP5sb8fy is a scan: a quarter turn into minos's frame.
        assert_eq!(m.start_yaw, 4.7 + std::f32::consts::FRAC_PI_2);
        assert_eq!(
            m.start_position,
            [2.664, 0.539 - MINOS_AGENT_ORIGIN_HEIGHT, 0.19]
        );
        // MINOS's -1 ("no path found") rows are unknown geodesics, so the table writes.
        let unknown = mp3d.iter().filter(|e| e.geodesic_distance.is_nan()).count();
        assert_eq!(unknown, 1142);
        let dir = tempfile::tempdir().unwrap();
        crate::episode::format::write_episodes(&dir.path().join("m.parquet"), &mp3d).unwrap();
        assert_eq!((m.euclidean_distance, m.geodesic_distance), (3.451, 3.68));
        assert_eq!((m.path_num_doors, m.path_num_rooms), (0, 3));
        assert_eq!(mp3d[1].path_num_rooms, 5);
    }
}
