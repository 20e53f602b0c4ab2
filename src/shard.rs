//! Shards of a sorted list: shard `i/n` takes every n-th item starting at the i-th, so the
//! union of all shards is the whole list and each item's shard depends only on its position
//! in sorted order, never on threads or machines.

/// Why a shard could not be parsed or found in the scheduler's environment.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not `i/n`.
    #[error("`{0}`: expected i/n, e.g. 0/4")]
    Syntax(String),
    /// A part of `i/n` is not a whole number.
    #[error("`{given}`: `{part}` is not a whole number")]
    NotANumber {
        /// The shard as given.
        given: String,
        /// The part that is not a number.
        part: String,
    },
    /// `i >= n` or `n == 0`.
    #[error("`{0}`: need 0 <= i < n")]
    OutOfRange(String),
    /// A scheduler variable is not a whole number.
    #[error("shard auto: {name}=`{value}` is not a whole number")]
    Variable {
        /// The variable.
        name: String,
        /// Its value.
        value: String,
    },
    /// `MINOS_SHARD` is not a shard.
    #[error("shard auto: MINOS_SHARD")]
    Explicit(#[source] Box<ShardError>),
    /// The scheduler's numbers make no shard.
    #[error("shard auto: {origin} gives shard {index} of {count}: need 0 <= i < n")]
    Scheduler {
        /// Which scheduler.
        origin: &'static str,
        /// The index it gives.
        index: usize,
        /// The count it gives.
        count: usize,
    },
    /// A Slurm task id off the array's range or step.
    #[error("shard auto: SLURM_ARRAY_TASK_ID {id} {what}")]
    SlurmTask {
        /// The task id.
        id: usize,
        /// What is wrong with it.
        what: String,
    },
    /// A scheduler's variable is set without the one it needs beside it.
    #[error("shard auto: {0}")]
    Incomplete(&'static str),
    /// No scheduler's environment.
    #[error(
        "shard auto: no scheduler environment found (MINOS_SHARD=i/n, Slurm's \
         SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT, or Kubernetes' JOB_COMPLETION_INDEX with \
         MINOS_SHARD_COUNT)"
    )]
    NoScheduler,
}

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
    pub fn parse(s: &str) -> Result<Shard, ShardError> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| ShardError::Syntax(s.to_string()))?;
        let num = |t: &str| {
            t.trim()
                .parse::<usize>()
                .map_err(|_| ShardError::NotANumber {
                    given: s.to_string(),
                    part: t.to_string(),
                })
        };
        let (index, count) = (num(i)?, num(n)?);
        if count == 0 || index >= count {
            return Err(ShardError::OutOfRange(s.to_string()));
        }
        Ok(Shard { index, count })
    }

    /// Whether the item at `position` of the sorted list belongs to this shard.
    pub fn keeps(&self, position: usize) -> bool {
        position % self.count == self.index
    }
}

/// A shard as the command line gives it: explicit `i/n`, or `auto` (from the scheduler's
/// environment, see [`Shard::from_scheduler`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardSpec {
    /// `i/n`.
    Fixed(Shard),
    /// `auto`.
    Auto,
}

impl ShardSpec {
    /// Parses `auto` or `i/n`.
    pub fn parse(s: &str) -> Result<ShardSpec, ShardError> {
        if s.trim() == "auto" {
            Ok(ShardSpec::Auto)
        } else {
            Shard::parse(s).map(ShardSpec::Fixed)
        }
    }

    /// The shard, looking `auto` up with `var` (the process environment, or a map in tests).
    pub fn resolve(self, var: impl Fn(&str) -> Option<String>) -> Result<Shard, ShardError> {
        match self {
            ShardSpec::Fixed(s) => Ok(s),
            ShardSpec::Auto => Shard::from_scheduler(var),
        }
    }
}

impl Shard {
    /// This process's shard from the environment the common schedulers give it, first found
    /// wins:
    ///
    /// 1. `MINOS_SHARD=i/n` (explicit);
    /// 2. a Slurm job array: `SLURM_ARRAY_TASK_ID`, `SLURM_ARRAY_TASK_COUNT`, and
    ///    `SLURM_ARRAY_TASK_MIN` / `SLURM_ARRAY_TASK_STEP` when present (`--array=1-16` or
    ///    `--array=0-30:2` number their tasks 0…n−1 in order);
    /// 3. a Kubernetes Indexed Job: `JOB_COMPLETION_INDEX`, with the count in
    ///    `MINOS_SHARD_COUNT` (set it to the Job's `completions`; Kubernetes does not export
    ///    it).
    pub fn from_scheduler(var: impl Fn(&str) -> Option<String>) -> Result<Shard, ShardError> {
        let number = |name: &str| -> Result<Option<usize>, ShardError> {
            match var(name) {
                None => Ok(None),
                Some(v) => v
                    .trim()
                    .parse::<usize>()
                    .map(Some)
                    .map_err(|_| ShardError::Variable {
                        name: name.to_string(),
                        value: v,
                    }),
            }
        };
        if let Some(s) = var("MINOS_SHARD") {
            return Shard::parse(&s).map_err(|e| ShardError::Explicit(Box::new(e)));
        }
        let checked = |index: usize, count: usize, origin: &'static str| {
            if count == 0 || index >= count {
                Err(ShardError::Scheduler {
                    origin,
                    index,
                    count,
                })
            } else {
                Ok(Shard { index, count })
            }
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let count = number("SLURM_ARRAY_TASK_COUNT")?.ok_or(ShardError::Incomplete(
                "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not",
            ))?;
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let step = number("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
            let offset = id.checked_sub(min).ok_or_else(|| ShardError::SlurmTask {
                id,
                what: format!("is below SLURM_ARRAY_TASK_MIN {min}"),
            })?;
            if offset % step != 0 {
                return Err(ShardError::SlurmTask {
                    id,
                    what: format!("is not on the array's step {step} from {min}"),
                });
            }
            return checked(offset / step, count, "the Slurm array");
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let count = number("MINOS_SHARD_COUNT")?.ok_or(ShardError::Incomplete(
                "JOB_COMPLETION_INDEX is set (a Kubernetes Indexed Job) but MINOS_SHARD_COUNT \
                 is not: set it to the Job's completions",
            ))?;
            return checked(index, count, "the Kubernetes Indexed Job");
        }
        Err(ShardError::NoScheduler)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = ShardError;

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

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: std::collections::HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn auto_shards_come_from_the_schedulers_environment() {
        let auto = |pairs: &[(&str, &str)]| ShardSpec::Auto.resolve(env(pairs));
        // Slurm: --array=0-15 and --array=1-16 give the same 16 shards in order.
        for (id, min) in [("0", "0"), ("15", "0"), ("1", "1"), ("16", "1")] {
            let s = auto(&[
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_COUNT", "16"),
                ("SLURM_ARRAY_TASK_MIN", min),
            ])
            .unwrap();
            let expected = id.parse::<usize>().unwrap() - min.parse::<usize>().unwrap();
            assert_eq!(
                s,
                Shard {
                    index: expected,
                    count: 16
                }
            );
        }
        // --array=0-30:2: task 30 is the 16th of 16.
        let s = auto(&[
            ("SLURM_ARRAY_TASK_ID", "30"),
            ("SLURM_ARRAY_TASK_COUNT", "16"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ]);
        assert_eq!(
            s,
            Ok(Shard {
                index: 15,
                count: 16
            })
        );
        // Kubernetes Indexed Job.
        let s = auto(&[("JOB_COMPLETION_INDEX", "3"), ("MINOS_SHARD_COUNT", "7")]);
        assert_eq!(s, Ok(Shard { index: 3, count: 7 }));
        // Explicit wins over a scheduler.
        let s = auto(&[("MINOS_SHARD", "2/5"), ("JOB_COMPLETION_INDEX", "3")]);
        assert_eq!(s, Ok(Shard { index: 2, count: 5 }));
        // A fixed shard ignores the environment.
        let fixed = ShardSpec::parse("1/2").unwrap();
        assert_eq!(
            fixed.resolve(env(&[("MINOS_SHARD", "0/9")])),
            Ok(Shard { index: 1, count: 2 })
        );
        // Errors say what is missing or wrong.
        for (pairs, needle) in [
            (vec![], "no scheduler environment"),
            (vec![("SLURM_ARRAY_TASK_ID", "3")], "SLURM_ARRAY_TASK_COUNT"),
            (vec![("JOB_COMPLETION_INDEX", "3")], "MINOS_SHARD_COUNT"),
            (
                vec![("JOB_COMPLETION_INDEX", "7"), ("MINOS_SHARD_COUNT", "7")],
                "0 <= i < n",
            ),
            (
                vec![
                    ("SLURM_ARRAY_TASK_ID", "x"),
                    ("SLURM_ARRAY_TASK_COUNT", "2"),
                ],
                "`x`",
            ),
            (vec![("MINOS_SHARD", "3/3")], "MINOS_SHARD"),
        ] {
            let e = auto(&pairs).unwrap_err().to_string();
            assert!(e.contains(needle), "{pairs:?}: {e}");
            assert!(!e.contains("--"), "the library names no flag: {e}");
        }
        assert_eq!(ShardSpec::parse("auto"), Ok(ShardSpec::Auto));
        assert!(ShardSpec::parse("auto/2").is_err());
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
