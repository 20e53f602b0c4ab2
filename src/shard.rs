//! Shards of a sorted list: shard `i/n` takes every n-th item starting at the i-th, so the
//! union of all shards is the whole list and each item's shard depends only on its position
//! in sorted order, never on threads or machines.

/// One shard of a scene list: `index` of `count` (`0/1` is everything).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard (0-based).
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Everything.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `i/n` with `0 <= i < n`.
    pub fn parse(s: &str) -> Result<Shard, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}`: expected i/n, e.g. 0/4"))?;
        let num = |t: &str| {
            t.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: `{t}` is not a whole number"))
        };
        let (index, count) = (num(i)?, num(n)?);
        if count == 0 || index >= count {
            return Err(format!("`{s}`: need 0 <= i < n"));
        }
        Ok(Shard { index, count })
    }

    /// Whether the item at `position` of the sorted list belongs to this shard.
    pub fn keeps(&self, position: usize) -> bool {
        position % self.count == self.index
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Shard::parse(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse() {
        assert_eq!(Shard::parse("1/4"), Ok(Shard { index: 1, count: 4 }));
        assert!(Shard::parse("4/4").is_err());
        assert!(Shard::parse("1").is_err());
        assert!(Shard::parse("0/0").is_err());
        assert_eq!(
            "2/7".parse::<Shard>().map(|s| s.to_string()),
            Ok("2/7".to_string())
        );
    }

    #[test]
    fn shards_partition_a_list() {
        for count in 1..8 {
            let mut owners = vec![0; 50];
            for index in 0..count {
                let shard = Shard { index, count };
                for (i, owner) in owners.iter_mut().enumerate() {
                    *owner += usize::from(shard.keeps(i));
                }
            }
            assert!(owners.iter().all(|&n| n == 1), "{count} shards");
        }
    }
}
