//! Splitting a bake over processes: `--part I/N` picks every N-th item (a zarr shard, or a graph
//! file of a batch) starting at item I − 1.
//!
//! The assignment is a pure function of the item's index, I and N: item `s` (shards numbered in
//! C order over the shard grid, z slowest; files in sorted order) belongs to part
//! `s mod N + 1`. Round-robin rather than contiguous blocks, so parts get the same share of a
//! volume whose cost varies along z (detail that grows with height, a region half empty) and of
//! a batch whose large graphs sort together. No item belongs to two parts, every item to one.

/// Part `index` (1-based) of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    pub index: u64,
    pub count: u64,
}

impl Default for Part {
    fn default() -> Self {
        Part::WHOLE
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Environment variables `--part auto` reads.
pub const KUBERNETES_INDEX: &str = "JOB_COMPLETION_INDEX";
pub const SLURM_ID: &str = "SLURM_ARRAY_TASK_ID";
pub const SLURM_MIN: &str = "SLURM_ARRAY_TASK_MIN";
pub const SLURM_COUNT: &str = "SLURM_ARRAY_TASK_COUNT";

impl Part {
    /// The whole bake: part 1 of 1.
    pub const WHOLE: Part = Part { index: 1, count: 1 };

    /// Part `index` of `count`, checked: 1 ≤ index ≤ count.
    pub fn new(index: u64, count: u64) -> Result<Part, String> {
        if count == 0 {
            return Err("a bake is split into at least 1 part (N ≥ 1)".into());
        }
        if index == 0 || index > count {
            return Err(format!(
                "part {index} of {count} does not exist: parts are numbered 1 to {count}"
            ));
        }
        Ok(Part { index, count })
    }

    /// Parses `I/N` (the `auto` form is [`Part::from_env`]).
    pub fn parse(text: &str) -> Result<Part, String> {
        let (i, n) = text
            .split_once('/')
            .ok_or_else(|| format!("expected I/N (part I of N, from 1) or auto, found `{text}`"))?;
        let number = |s: &str| {
            s.trim()
                .parse::<u64>()
                .map_err(|_| format!("expected I/N with whole numbers, found `{text}`"))
        };
        Part::new(number(i)?, number(n)?)
    }

    /// `--part auto`: a Kubernetes Indexed Job's `JOB_COMPLETION_INDEX` (0-based) with `parts`
    /// (`--parts N`, the Job's `completions`), or a Slurm job array's `SLURM_ARRAY_TASK_ID`
    /// (counted from `SLURM_ARRAY_TASK_MIN`, default 0) and `SLURM_ARRAY_TASK_COUNT`.
    pub fn from_env(
        parts: Option<u64>,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<Part, String> {
        let number = |name: &str, value: String| {
            value
                .trim()
                .parse::<u64>()
                .map_err(|_| format!("--part auto: {name}={value:?} is not a whole number"))
        };
        if let Some(index) = env(KUBERNETES_INDEX) {
            let index = number(KUBERNETES_INDEX, index)?;
            let count = parts.ok_or_else(|| {
                format!("--part auto: {KUBERNETES_INDEX} is set (a Kubernetes Indexed Job) but not how many parts there are: pass --parts N (the Job's completions)")
            })?;
            return Part::new(index + 1, count).map_err(|e| {
                format!("--part auto ({KUBERNETES_INDEX}={index}, --parts {count}): {e}")
            });
        }
        if let Some(id) = env(SLURM_ID) {
            let id = number(SLURM_ID, id)?;
            let min = env(SLURM_MIN).map_or(Ok(0), |v| number(SLURM_MIN, v))?;
            let count = match (env(SLURM_COUNT), parts) {
                (Some(v), _) => number(SLURM_COUNT, v)?,
                (None, Some(n)) => n,
                (None, None) => {
                    return Err(format!(
                        "--part auto: {SLURM_ID} is set but not {SLURM_COUNT}; pass --parts N"
                    ))
                }
            };
            let index = id.checked_sub(min).ok_or_else(|| {
                format!("--part auto: {SLURM_ID}={id} is below {SLURM_MIN}={min}")
            })?;
            return Part::new(index + 1, count).map_err(|e| {
                format!(
                    "--part auto ({SLURM_ID}={id}, {SLURM_MIN}={min}, {SLURM_COUNT}={count}): {e}"
                )
            });
        }
        Err(format!("--part auto needs a cluster scheduler's task index: neither {KUBERNETES_INDEX} (Kubernetes Indexed Job, with --parts N) nor {SLURM_ID} (Slurm job array) is set; give the part as --part I/N"))
    }

    /// Whether item `item` (0-based) belongs to this part.
    pub fn owns(&self, item: u64) -> bool {
        item % self.count == self.index - 1
    }

    pub fn is_whole(&self) -> bool {
        self.count == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_belongs_to_exactly_one_part() {
        for count in 1..=7 {
            for item in 0..50 {
                let owners = (1..=count)
                    .filter(|&i| Part::new(i, count).unwrap().owns(item))
                    .count();
                assert_eq!(owners, 1, "item {item} of {count} parts");
            }
        }
    }

    #[test]
    fn parts_parse_and_out_of_range_parts_are_refused() {
        assert_eq!(Part::parse("2/4"), Ok(Part { index: 2, count: 4 }));
        assert_eq!(Part::parse("4/4"), Ok(Part { index: 4, count: 4 }));
        for bad in ["5/4", "0/4", "1/0", "x/4", "3", "-1/4"] {
            assert!(Part::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn auto_reads_kubernetes_and_slurm() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, v)| v.to_string())
            }
        };
        assert_eq!(
            Part::from_env(Some(64), env(&[(KUBERNETES_INDEX, "0")])),
            Ok(Part {
                index: 1,
                count: 64
            })
        );
        assert!(Part::from_env(None, env(&[(KUBERNETES_INDEX, "0")])).is_err());
        assert!(Part::from_env(Some(4), env(&[(KUBERNETES_INDEX, "4")])).is_err());
        assert_eq!(
            Part::from_env(
                None,
                env(&[(SLURM_ID, "5"), (SLURM_MIN, "1"), (SLURM_COUNT, "8")])
            ),
            Ok(Part { index: 5, count: 8 })
        );
        let none = Part::from_env(Some(4), env(&[])).unwrap_err();
        assert!(
            none.contains(KUBERNETES_INDEX) && none.contains(SLURM_ID),
            "{none}"
        );
    }
}
