//! The instruction grammar: a [`RouteWalk`] in English, with varied phrasing drawn from a
//! seeded generator, and the list of everything each instruction names ([`Mention`]) so it
//! can be checked against the scene.
//!
//! The rules are in `docs/FORMATS.md` ("VLN instructions"). In short: clauses are made from
//! the walk's events in order — the turn to make first, leaving the start room, doorways
//! (with the turn that leads through them and their rank, "take the second door on your
//! right"), rooms entered, turns, stairs, landmarks passed — and a stop clause ("stop next to
//! the refrigerator in the kitchen"); the detail level of an instruction says which optional
//! clauses are kept; clauses are joined into sentences of one to three clauses. Every word
//! choice is `rng.pick` over a fixed list, so the same seed gives the same text.

use super::walk::{Event, RouteWalk, Turn};
use crate::navmesh::NavGrid;
use crate::scene::RoomClass;
use crate::seed::Rng;

/// How much an instruction says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Detail {
    /// Every event: turns, doorways, rooms, stairs, landmarks.
    Full,
    /// Slight turns left out; each landmark kept with probability ½; doorways said only
    /// with the turn or room they lead to.
    Medium,
    /// Rooms, stairs, turns through doorways and the stop; no landmarks, no plain turns.
    Brief,
}

impl Detail {
    /// The detail of the `k`-th instruction of a route: full, medium, brief, then again.
    pub fn of_instruction(k: usize) -> Detail {
        [Detail::Full, Detail::Medium, Detail::Brief][k % 3]
    }
}

/// Something an instruction names, and where along the path (m).
#[derive(Debug, Clone, PartialEq)]
pub enum Mention {
    /// A room, by index, named where the path is in it (the start room at 0, a room entered
    /// where it is entered, the goal room at the end).
    Room {
        /// Room index.
        room: u32,
        /// Distance along the path (m).
        at: f32,
    },
    /// A landmark object named where the path passes it.
    Landmark {
        /// Object index.
        object: u32,
        /// Distance along the path (m) of the path's closest point.
        at: f32,
    },
    /// The object the stop description names, and the room it names with it.
    Goal {
        /// Object index.
        object: u32,
        /// Room index, when named.
        room: Option<u32>,
    },
}

/// One instruction and what it names.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// The text: sentences starting with a capital letter and ending with a full stop.
    pub text: String,
    /// What it names, in order.
    pub mentions: Vec<Mention>,
}

/// A room class in words: `living_room` → `living room`, `other` → `room`, `outdoor` →
/// `outdoor area`.
pub fn room_words(class: u8) -> &'static str {
    match RoomClass::ALL
        .get(class as usize)
        .copied()
        .unwrap_or(RoomClass::Other)
    {
        RoomClass::Other => "room",
        RoomClass::Bedroom => "bedroom",
        RoomClass::LivingRoom => "living room",
        RoomClass::Bathroom => "bathroom",
        RoomClass::Kitchen => "kitchen",
        RoomClass::DiningRoom => "dining room",
        RoomClass::Office => "office",
        RoomClass::Hallway => "hallway",
        RoomClass::Outdoor => "outdoor area",
    }
}

/// A category as words: `coffee_table` → `coffee table`.
pub fn category_words(category: &str) -> String {
    category
        .replace(['_', '-'], " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_ascii_lowercase()
}

/// Ordinal words for door ranks (1 is never said: "the door on your right").
const ORDINALS: [&str; 5] = ["first", "second", "third", "fourth", "fifth"];

/// A clause and what it names.
struct Clause {
    text: String,
    mentions: Vec<Mention>,
}

/// The clause for a landmark passed, if the detail level keeps it.
fn landmark_clause(
    grid: &NavGrid,
    rng: &mut Rng,
    detail: Detail,
    at: f32,
    object: u32,
    side: super::walk::Side,
) -> Option<Clause> {
    let keep = match detail {
        Detail::Full => true,
        Detail::Medium => rng.chance(0.5),
        Detail::Brief => false,
    };
    if !keep {
        return None;
    }
    let name = category_words(&grid.objects[object as usize].category);
    let text = match rng.below(4) {
        0 => format!("walk past the {name}"),
        1 => format!("pass the {name} on your {}", side.word()),
        2 => format!("go past the {name}"),
        _ => format!("keep the {name} on your {}", side.word()),
    };
    Some(Clause {
        text,
        mentions: vec![Mention::Landmark { object, at }],
    })
}

fn say(clauses: &mut Vec<Clause>, text: String, mentions: Vec<Mention>) {
    clauses.push(Clause { text, mentions });
}

fn pick<'a>(rng: &mut Rng, options: &[&'a str]) -> &'a str {
    rng.pick(options).copied().unwrap_or("")
}

fn turn_words(rng: &mut Rng, turn: Turn) -> String {
    match turn {
        Turn::Around => pick(
            rng,
            &["turn around", "turn back", "turn all the way around"],
        )
        .into(),
        Turn::Full(side) => {
            let w = side.word();
            match rng.below(4) {
                0 => format!("turn {w}"),
                1 => format!("take a {w}"),
                2 => format!("make a {w}"),
                _ => format!("turn to your {w}"),
            }
        }
        Turn::Slight(side) => {
            let w = side.word();
            match rng.below(3) {
                0 => format!("bear {w}"),
                1 => format!("veer slightly {w}"),
                _ => format!("turn slightly {w}"),
            }
        }
    }
}

/// The room's name with an article: "the kitchen", or "the next hallway" when the room
/// before it on the route has the same class.
fn room_phrase(grid: &NavGrid, room: u32, previous: Option<u32>) -> String {
    let class = grid.rooms.get(room as usize).map_or(0, |r| r.class);
    let same = previous
        .and_then(|p| grid.rooms.get(p as usize))
        .is_some_and(|p| p.class == class);
    if same {
        format!("the next {}", room_words(class))
    } else {
        format!("the {}", room_words(class))
    }
}

/// Renders one instruction of `walk` at `detail`, drawing word choices from `rng`.
/// `goal_object` is the object the route ends next to (named by the stop clause).
pub fn render(
    grid: &NavGrid,
    walk: &RouteWalk,
    goal_object: Option<u32>,
    detail: Detail,
    rng: &mut Rng,
) -> Rendered {
    let mut clauses: Vec<Clause> = Vec::new();
    if let Some(turn) = walk.initial_turn {
        clauses.push(Clause {
            text: turn_words(rng, turn),
            mentions: Vec::new(),
        });
    }
    let events = &walk.events;
    let mut used = vec![false; events.len()];
    let mut current_room = walk.start_room;
    let mut left_start = false;
    // The room entered within DOOR_TURN after event k, if any (not yet used).
    let enter_after = |k: usize, used: &[bool]| -> Option<usize> {
        let at = events[k].at();
        events[k + 1..]
            .iter()
            .enumerate()
            .take_while(|(_, e)| e.at() - at <= super::walk::DOOR_TURN)
            .find(|(j, e)| matches!(e, Event::Enter { .. }) && !used[k + 1 + j])
            .map(|(j, _)| k + 1 + j)
    };
    // Events between `from` and `to` that a combined clause jumps over: landmarks are said
    // first (they are passed on the way there), turns are part of the combined clause.
    let flush =
        |from: usize, to: usize, used: &mut [bool], rng: &mut Rng, out: &mut Vec<Clause>| {
            for j in from + 1..to {
                if used[j] {
                    continue;
                }
                match events[j] {
                    Event::Landmark {
                        at, object, side, ..
                    } => {
                        used[j] = true;
                        out.extend(landmark_clause(grid, rng, detail, at, object, side));
                    }
                    Event::Turn { .. } => used[j] = true,
                    _ => {}
                }
            }
        };
    for k in 0..events.len() {
        if used[k] {
            continue;
        }
        used[k] = true;
        match events[k] {
            Event::Turn { at, turn } => {
                // A turn through a doorway right after it is said with the doorway.
                let door = events[k + 1..]
                    .iter()
                    .enumerate()
                    .take_while(|(_, e)| e.at() - at <= super::walk::DOOR_TURN)
                    .find(|(_, e)| {
                        matches!(
                            e,
                            Event::Door {
                                turn_rank: Some(_),
                                ..
                            }
                        )
                    })
                    .map(|(j, _)| k + 1 + j);
                if let Some(d) = door {
                    let Event::Door {
                        arch,
                        turn_rank: Some((side, rank)),
                        ..
                    } = events[d]
                    else {
                        continue;
                    };
                    used[d] = true;
                    flush(k, d, &mut used, rng, &mut clauses);
                    let noun = if arch { "archway" } else { "door" };
                    let ordinal = if rank >= 2 {
                        format!(
                            "{} ",
                            ORDINALS.get(rank as usize - 1).copied().unwrap_or("next")
                        )
                    } else {
                        String::new()
                    };
                    let mut text = match rng.below(3) {
                        0 => format!("take the {ordinal}{noun} on your {}", side.word()),
                        1 if rank >= 2 => {
                            format!("go through the {ordinal}{noun} on your {}", side.word())
                        }
                        _ if rank >= 2 => format!("turn {} at the {ordinal}{noun}", side.word()),
                        _ => format!("turn {} through the {noun}", side.word()),
                    };
                    let mut mentions = Vec::new();
                    if let Some(e) = enter_after(d, &used) {
                        if let Event::Enter { at, room } = events[e] {
                            used[e] = true;
                            flush(d, e, &mut used, rng, &mut clauses);
                            text.push_str(&format!(
                                " into {}",
                                room_phrase(grid, room, current_room)
                            ));
                            if !left_start {
                                left_start = true;
                            }
                            current_room = Some(room);
                            mentions.push(Mention::Room { room, at });
                        }
                    }
                    say(&mut clauses, text, mentions);
                } else if detail == Detail::Full
                    || !matches!(turn, Turn::Slight(_)) && detail == Detail::Medium
                {
                    say(&mut clauses, turn_words(rng, turn), Vec::new());
                }
            }
            Event::Door { arch, .. } => {
                let noun = if arch {
                    pick(rng, &["archway", "arch"])
                } else {
                    pick(rng, &["door", "doorway"])
                };
                match enter_after(k, &used) {
                    Some(e) => {
                        let Event::Enter { at, room } = events[e] else {
                            continue;
                        };
                        used[e] = true;
                        flush(k, e, &mut used, rng, &mut clauses);
                        let into = room_phrase(grid, room, current_room);
                        let mut mentions = Vec::new();
                        let text = match (left_start, walk.start_room) {
                            (false, Some(start)) if detail != Detail::Brief && rng.chance(0.5) => {
                                mentions.push(Mention::Room {
                                    room: start,
                                    at: 0.0,
                                });
                                format!(
                                    "{} {} through the {noun} into {into}",
                                    pick(rng, &["leave", "exit", "walk out of"]),
                                    room_phrase(grid, start, None)
                                )
                            }
                            _ => format!(
                                "{} through the {noun} into {into}",
                                pick(rng, &["go", "walk", "go straight", "continue"])
                            ),
                        };
                        mentions.push(Mention::Room { room, at });
                        left_start = true;
                        current_room = Some(room);
                        say(&mut clauses, text, mentions);
                    }
                    None if detail == Detail::Full => {
                        let verb = pick(
                            rng,
                            &[
                                "go through",
                                "walk through",
                                "pass through",
                                "go straight through",
                            ],
                        );
                        say(&mut clauses, format!("{verb} the {noun}"), Vec::new());
                    }
                    None => {}
                }
            }
            Event::Enter { at, room } => {
                let mut mentions = Vec::new();
                let into = room_phrase(grid, room, current_room);
                let text = match (left_start, walk.start_room) {
                    (false, Some(start)) if rng.chance(0.5) => {
                        mentions.push(Mention::Room {
                            room: start,
                            at: 0.0,
                        });
                        format!(
                            "{} {} and {} {into}",
                            pick(rng, &["leave", "exit", "walk out of"]),
                            room_phrase(grid, start, None),
                            pick(rng, &["enter", "go into", "walk into"])
                        )
                    }
                    _ => format!(
                        "{} {into}",
                        pick(
                            rng,
                            &[
                                "enter",
                                "go into",
                                "walk into",
                                "head into",
                                "continue into"
                            ]
                        )
                    ),
                };
                mentions.push(Mention::Room { room, at });
                left_start = true;
                current_room = Some(room);
                say(&mut clauses, text, mentions);
            }
            Event::Stairs { up, levels, .. } => {
                let way = if up { "up" } else { "down" };
                let text = if levels >= 2 {
                    format!(
                        "{} {way} the stairs {} floors",
                        pick(rng, &["go", "walk"]),
                        ["two", "three", "four"]
                            .get(levels as usize - 2)
                            .copied()
                            .unwrap_or("several")
                    )
                } else {
                    match rng.below(3) {
                        0 => format!("go {way} the stairs"),
                        1 => format!("take the stairs {way}"),
                        _ if up => "climb the stairs".into(),
                        _ => "walk down the stairs".into(),
                    }
                };
                say(&mut clauses, text, Vec::new());
            }
            Event::Landmark {
                at, object, side, ..
            } => {
                if let Some(c) = landmark_clause(grid, rng, detail, at, object, side) {
                    say(&mut clauses, c.text, c.mentions);
                }
            }
        }
    }
    // The stop.
    let goal_room = walk.goal_room;
    let room_named =
        goal_room.filter(|&r| grid.rooms.get(r as usize).is_some_and(|r| r.class != 0));
    let text = match goal_object {
        Some(o) => {
            let name = category_words(&grid.objects[o as usize].category);
            let verb = pick(
                rng,
                &[
                    "stop next to",
                    "stop beside",
                    "wait by",
                    "stop by",
                    "stop near",
                ],
            );
            match room_named {
                Some(r) => format!("{verb} the {name} in {}", room_phrase(grid, r, None)),
                None => format!("{verb} the {name}"),
            }
        }
        None => match room_named {
            Some(r) => format!(
                "{} {}",
                pick(rng, &["stop in", "wait in", "stop once you are in"]),
                room_phrase(grid, r, None)
            ),
            None => pick(rng, &["stop there", "wait there", "stop"]).into(),
        },
    };
    let mut mentions = Vec::new();
    if let Some(o) = goal_object {
        mentions.push(Mention::Goal {
            object: o,
            room: room_named,
        });
    }
    if let Some(r) = room_named {
        mentions.push(Mention::Room {
            room: r,
            at: walk.length,
        });
    }
    say(&mut clauses, text, mentions);
    join(clauses, detail, rng)
}

/// Joins clauses into sentences of one to three clauses.
fn join(clauses: Vec<Clause>, detail: Detail, rng: &mut Rng) -> Rendered {
    let mut text = String::new();
    let mut mentions = Vec::new();
    let mut i = 0;
    while i < clauses.len() {
        let most = if detail == Detail::Brief { 3 } else { 2 };
        let take = rng.range_usize(1, most).min(clauses.len() - i);
        let parts: Vec<&str> = clauses[i..i + take]
            .iter()
            .map(|c| c.text.as_str())
            .collect();
        let sentence = match parts.as_slice() {
            [one] => one.to_string(),
            [a, b] => {
                let glue = pick(rng, &[" and ", ", then ", " and then "]);
                format!("{a}{glue}{b}")
            }
            [head @ .., last] => format!("{} and {last}", head.join(", ")),
            [] => String::new(),
        };
        if !text.is_empty() {
            text.push(' ');
        }
        let mut chars = sentence.chars();
        if let Some(first) = chars.next() {
            text.extend(first.to_uppercase());
            text.push_str(chars.as_str());
        }
        text.push('.');
        for c in &clauses[i..i + take] {
            mentions.extend(c.mentions.iter().cloned());
        }
        i += take;
    }
    Rendered { text, mentions }
}
