//! Who plays what: the ledger of a campaign's demonstrations and the assignment rule. A
//! participant plays the tutorial first (once); then each request gets the first episode,
//! in the campaign's order, that the participant has not played (finished or in flight)
//! and whose accepted plus in-flight demonstrations are fewer than K. A flagged
//! demonstration does not count, so its episode goes to someone else. The answer depends
//! only on the ledger, so the same requests in the same order give the same assignments.

use std::collections::{BTreeMap, BTreeSet};

/// What a participant is given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Assignment {
    /// The tutorial episode.
    Tutorial,
    /// This campaign episode (by id).
    Episode(String),
    /// Nothing left for this participant.
    Done,
}

/// Demonstrations of one episode.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Tally {
    /// Finished and accepted.
    pub accepted: u32,
    /// Finished and flagged.
    pub flagged: u32,
    /// Handed out and not finished.
    pub in_flight: u32,
}

/// One participant's record.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct Seat {
    tutorial_done: bool,
    /// Campaign episodes finished (accepted or flagged).
    played: BTreeSet<String>,
    /// The campaign episode handed out and not finished.
    in_flight: Option<String>,
}

/// The demonstrations of a campaign: per episode, per participant.
#[derive(Debug, Clone, PartialEq)]
pub struct Ledger {
    /// Campaign episodes in order.
    order: Vec<String>,
    /// Accepted demonstrations wanted per episode.
    k: u32,
    /// Whether there is a tutorial.
    has_tutorial: bool,
    tallies: BTreeMap<String, Tally>,
    seats: BTreeMap<String, Seat>,
}

impl Ledger {
    /// An empty ledger of the episodes `order` with `k` demonstrations each.
    pub fn new(order: Vec<String>, k: u32, has_tutorial: bool) -> Ledger {
        let tallies = order
            .iter()
            .map(|id| (id.clone(), Tally::default()))
            .collect();
        Ledger {
            order,
            k,
            has_tutorial,
            tallies,
            seats: BTreeMap::new(),
        }
    }

    /// The next thing for `participant` (reserving a campaign episode: it is in flight until
    /// [`Ledger::finished`] or [`Ledger::release`]). A participant with an episode in
    /// flight gets it again.
    pub fn assign(&mut self, participant: &str) -> Assignment {
        let a = self.peek(participant);
        if let Assignment::Episode(id) = &a {
            let seat = self.seats.entry(participant.to_string()).or_default();
            if seat.in_flight.as_ref() != Some(id) {
                seat.in_flight = Some(id.clone());
                if let Some(t) = self.tallies.get_mut(id) {
                    t.in_flight += 1;
                }
            }
        }
        a
    }

    /// What [`Ledger::assign`] would give `participant`, without reserving it.
    pub fn peek(&self, participant: &str) -> Assignment {
        let seat = self.seats.get(participant);
        if self.has_tutorial && !seat.is_some_and(|s| s.tutorial_done) {
            return Assignment::Tutorial;
        }
        if let Some(id) = seat.and_then(|s| s.in_flight.clone()) {
            return Assignment::Episode(id);
        }
        let played = |id: &String| seat.is_some_and(|s| s.played.contains(id));
        self.order
            .iter()
            .find(|id| {
                let t = self.tallies.get(*id).copied().unwrap_or_default();
                !played(id) && t.accepted + t.in_flight < self.k
            })
            .map(|id| Assignment::Episode(id.clone()))
            .unwrap_or(Assignment::Done)
    }

    /// `participant` finished the tutorial.
    pub fn tutorial_done(&mut self, participant: &str) {
        self.seats
            .entry(participant.to_string())
            .or_default()
            .tutorial_done = true;
    }

    /// `participant` finished campaign episode `id`, accepted or flagged (also when it was
    /// not in flight: a demonstration found on disk at start-up).
    pub fn finished(&mut self, participant: &str, id: &str, accepted: bool) {
        let seat = self.seats.entry(participant.to_string()).or_default();
        let was_in_flight = seat.in_flight.as_deref() == Some(id);
        if was_in_flight {
            seat.in_flight = None;
        }
        seat.played.insert(id.to_string());
        if let Some(t) = self.tallies.get_mut(id) {
            if was_in_flight {
                t.in_flight = t.in_flight.saturating_sub(1);
            }
            if accepted {
                t.accepted += 1;
            } else {
                t.flagged += 1;
            }
        }
    }

    /// A finished demonstration of campaign episode `id` changed verdict (an operator's
    /// review): it moves between the accepted and the flagged count.
    pub fn reviewed(&mut self, id: &str, was_accepted: bool, accepted: bool) {
        let Some(t) = self.tallies.get_mut(id) else {
            return;
        };
        match (was_accepted, accepted) {
            (false, true) => {
                t.flagged = t.flagged.saturating_sub(1);
                t.accepted += 1;
            }
            (true, false) => {
                t.accepted = t.accepted.saturating_sub(1);
                t.flagged += 1;
            }
            _ => {}
        }
    }

    /// `participant`'s episode in flight was not finished (the page left, the episode
    /// failed): it goes back to the pool.
    pub fn release(&mut self, participant: &str) {
        if let Some(seat) = self.seats.get_mut(participant) {
            if let Some(id) = seat.in_flight.take() {
                if let Some(t) = self.tallies.get_mut(&id) {
                    t.in_flight = t.in_flight.saturating_sub(1);
                }
            }
        }
    }

    /// Each campaign episode's demonstrations, in campaign order.
    pub fn tallies(&self) -> Vec<(String, Tally)> {
        self.order
            .iter()
            .map(|id| {
                (
                    id.clone(),
                    self.tallies.get(id).copied().unwrap_or_default(),
                )
            })
            .collect()
    }

    /// Accepted demonstrations wanted per episode.
    pub fn k(&self) -> u32 {
        self.k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ep(id: &str) -> Assignment {
        Assignment::Episode(id.into())
    }

    #[test]
    fn every_episode_gets_k_demonstrations_counting_those_in_flight() {
        let mut l = Ledger::new(vec!["a".into(), "b".into()], 2, false);
        // Two participants take "a" (K = 2), the third gets "b".
        assert_eq!(l.assign("p1"), ep("a"));
        assert_eq!(l.assign("p2"), ep("a"));
        assert_eq!(l.assign("p3"), ep("b"));
        // Asking again gives the same episode (in flight).
        assert_eq!(l.assign("p1"), ep("a"));
        l.finished("p1", "a", true);
        // p1 has played "a": it gets "b" (one more wanted).
        assert_eq!(l.assign("p1"), ep("b"));
        // p2 leaves: "a" is wanted again, p4 gets it.
        l.release("p2");
        assert_eq!(l.assign("p4"), ep("a"));
        l.finished("p4", "a", false);
        // A flagged demo does not count: "a" still needs one; p3 (on "b") finishes and gets it.
        l.finished("p3", "b", true);
        assert_eq!(l.assign("p3"), ep("a"));
        l.finished("p3", "a", true);
        l.finished("p1", "b", true);
        assert_eq!(l.assign("p5"), Assignment::Done);
        assert_eq!(
            l.tallies(),
            vec![
                (
                    "a".to_string(),
                    Tally {
                        accepted: 2,
                        flagged: 1,
                        in_flight: 0
                    }
                ),
                (
                    "b".to_string(),
                    Tally {
                        accepted: 2,
                        flagged: 0,
                        in_flight: 0
                    }
                ),
            ]
        );
    }

    #[test]
    fn a_review_moves_a_demonstration_between_accepted_and_flagged() {
        let mut l = Ledger::new(vec!["a".into()], 1, false);
        assert_eq!(l.assign("p1"), ep("a"));
        l.finished("p1", "a", false);
        // Flagged: "a" still wants its demonstration.
        assert_eq!(l.peek("p2"), ep("a"));
        // The operator accepts p1's: "a" is covered, nothing left for p2.
        l.reviewed("a", false, true);
        assert_eq!(l.peek("p2"), Assignment::Done);
        let tally = |l: &Ledger| l.tallies()[0].1;
        assert_eq!((tally(&l).accepted, tally(&l).flagged), (1, 0));
        // Accepting again changes nothing; flagging it gives "a" back to the pool.
        l.reviewed("a", true, true);
        assert_eq!((tally(&l).accepted, tally(&l).flagged), (1, 0));
        l.reviewed("a", true, false);
        assert_eq!((tally(&l).accepted, tally(&l).flagged), (0, 1));
        assert_eq!(l.peek("p2"), ep("a"));
        // An id outside the campaign is ignored.
        l.reviewed("zzz", false, true);
        assert_eq!(l.tallies().len(), 1);
    }

    #[test]
    fn the_tutorial_comes_first_and_once() {
        let mut l = Ledger::new(vec!["a".into()], 1, true);
        assert_eq!(l.assign("p1"), Assignment::Tutorial);
        assert_eq!(l.assign("p1"), Assignment::Tutorial);
        l.tutorial_done("p1");
        assert_eq!(l.assign("p1"), ep("a"));
        assert_eq!(l.peek("p2"), Assignment::Tutorial);
        l.tutorial_done("p2");
        assert_eq!(l.assign("p2"), Assignment::Done);
    }

    #[test]
    fn the_same_requests_give_the_same_assignments() {
        let order: Vec<String> = (0..7).map(|i| format!("e{i}")).collect();
        let play = || {
            let mut l = Ledger::new(order.clone(), 3, false);
            let mut log = Vec::new();
            for round in 0..12 {
                let p = format!("p{}", round % 5);
                let a = l.assign(&p);
                if let Assignment::Episode(id) = &a {
                    if round % 4 == 3 {
                        l.release(&p);
                    } else {
                        l.finished(&p, id, round % 3 != 0);
                    }
                }
                log.push(a);
            }
            (log, l.tallies())
        };
        assert_eq!(play(), play());
    }
}
