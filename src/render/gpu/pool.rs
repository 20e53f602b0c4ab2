//! The ray tracer's reusable buffer sets, kept by the room they have: a batch takes the
//! smallest set that holds it, a set comes back to replace a smaller one when the pool is
//! full, and new sets are allocated with room to grow. A batched rollout's batches change
//! size every step (environments end and join), and allocating a batch's buffers on the GPU
//! (hundreds of megabytes, zeroed) costs more than rendering it: the pool must settle on
//! sets that hold the largest batches instead of keeping the first few small ones.

/// What a buffer set has room for (or what a batch needs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Room {
    /// Views.
    pub views: usize,
    /// Output bytes.
    pub bytes: u64,
    /// Dispatches (uniform blocks).
    pub groups: usize,
}

impl Room {
    /// Whether a set with this room holds a batch that needs `need`.
    pub fn holds(&self, need: &Room) -> bool {
        self.views >= need.views && self.bytes >= need.bytes && self.groups >= need.groups
    }

    /// The room to allocate for a batch that needs `self`: views and dispatches rounded up to
    /// a power of two (views at most `max_views`, never below what is needed), the output
    /// bytes grown with the views (a batch's output is proportional to its views).
    pub fn grown(&self, max_views: usize) -> Room {
        let views = self
            .views
            .next_power_of_two()
            .min(max_views)
            .max(self.views);
        let bytes = match self.views {
            0 => self.bytes,
            n => self.bytes / n as u64 * views as u64 + self.bytes % n as u64,
        };
        Room {
            views,
            bytes,
            groups: self.groups.next_power_of_two(),
        }
    }
}

/// Up to `keep` sets, each with its room.
#[derive(Debug)]
pub(super) struct SizedPool<T> {
    keep: usize,
    sets: Vec<(Room, T)>,
}

impl<T> SizedPool<T> {
    /// An empty pool keeping at most `keep` sets.
    pub fn new(keep: usize) -> Self {
        SizedPool {
            keep,
            sets: Vec::new(),
        }
    }

    /// Takes the smallest set (by output bytes) that holds `need`, if any.
    pub fn take(&mut self, need: &Room) -> Option<(Room, T)> {
        let i = (0..self.sets.len())
            .filter(|&i| self.sets[i].0.holds(need))
            .min_by_key(|&i| self.sets[i].0.bytes)?;
        Some(self.sets.swap_remove(i))
    }

    /// Returns a set: kept while there is space, else in place of the smallest set when it is
    /// larger than that one (else dropped).
    pub fn put(&mut self, room: Room, set: T) {
        if self.sets.len() < self.keep {
            self.sets.push((room, set));
            return;
        }
        let smallest = (0..self.sets.len()).min_by_key(|&i| self.sets[i].0.bytes);
        if let Some(i) = smallest.filter(|&i| self.sets[i].0.bytes < room.bytes) {
            self.sets[i] = (room, set);
        }
    }

    /// The rooms of the sets kept.
    #[cfg(test)]
    fn rooms(&self) -> Vec<Room> {
        let mut rooms: Vec<Room> = self.sets.iter().map(|(r, _)| *r).collect();
        rooms.sort_by_key(|r| r.bytes);
        rooms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room(views: usize) -> Room {
        Room {
            views,
            bytes: views as u64 * 100,
            groups: 1,
        }
    }

    #[test]
    fn growing_batches_end_with_the_largest_sets_kept() {
        // A rollout's ramp: batches of 1, 2, … 40 views, then steady batches of 30–40. Each
        // batch takes a set that holds it or allocates one with room to grow.
        let mut pool = SizedPool::new(4);
        let mut allocations = 0;
        let sizes = (1..=40).chain((0..200).map(|i| 30 + i % 11));
        for views in sizes {
            let need = room(views);
            let (r, set) = pool.take(&need).unwrap_or_else(|| {
                allocations += 1;
                (need.grown(1024), ())
            });
            assert!(r.holds(&need));
            pool.put(r, set);
        }
        // Rounded up to powers of two: 1, 2, 4, 8, 16, 32, 64 — and none in the steady part.
        assert_eq!(allocations, 7);
        assert_eq!(
            pool.rooms().iter().map(|r| r.views).collect::<Vec<_>>(),
            vec![8, 16, 32, 64]
        );
    }

    #[test]
    fn a_batch_takes_the_smallest_set_that_holds_it() {
        let mut pool = SizedPool::new(4);
        for (views, tag) in [(64, 'a'), (8, 'b'), (16, 'c')] {
            pool.put(room(views), tag);
        }
        assert_eq!(pool.take(&room(9)).map(|(_, t)| t), Some('c'));
        assert_eq!(pool.take(&room(9)).map(|(_, t)| t), Some('a'));
        assert_eq!(pool.take(&room(9)), None);
        assert_eq!(pool.take(&room(1)).map(|(_, t)| t), Some('b'));
    }

    #[test]
    fn a_full_pool_keeps_the_larger_set() {
        let mut pool = SizedPool::new(2);
        pool.put(room(4), ());
        pool.put(room(8), ());
        pool.put(room(2), ()); // smaller than every kept set: dropped
        assert_eq!(pool.rooms(), vec![room(4), room(8)]);
        pool.put(room(16), ()); // replaces the smallest
        assert_eq!(pool.rooms(), vec![room(8), room(16)]);
    }

    #[test]
    fn grown_room_holds_the_need_and_respects_the_cap() {
        let need = Room {
            views: 600,
            bytes: 600 * 7 + 3,
            groups: 3,
        };
        let g = need.grown(1024);
        assert_eq!((g.views, g.groups), (1024, 4));
        assert_eq!(g.bytes, 1024 * 7 + 3);
        assert!(g.holds(&need));
        // Capped below the power of two, but never below the need.
        assert_eq!(need.grown(700).views, 700);
        assert_eq!(need.grown(100).views, 600);
        assert!(need.grown(100).holds(&need));
    }
}
