//! The batch plan (scenarios × controllers), its fingerprint and deterministic shards.

use millcomp_datasets::Table;
use serde::{Deserialize, Serialize};

use super::factors::{BASE_SCENARIO_FILE, BASE_SCENARIO_TOML, FactorValue, ScenarioSpec};
use crate::error::ClosedLoopError;
use crate::scenario::ControllerKind;

/// Format tag of `plan.json`.
pub const PLAN_FORMAT: &str = "millcomp-batch-plan/1";

/// Every scenario × controller of a batch. Run `i` is scenario `i / n_controllers` with controller
/// `i % n_controllers`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// [`PLAN_FORMAT`].
    pub format: String,
    /// Where unnamed factors come from.
    pub base_scenario: String,
    /// Factor names, in table order.
    pub factor_names: Vec<String>,
    /// Scenarios.
    pub scenarios: Vec<ScenarioSpec>,
    /// Controller names (validated).
    pub controllers: Vec<String>,
    /// FNV-1a 64 hash (hex) of everything above plus the base scenario's text: two slices belong to the
    /// same batch exactly when their fingerprints agree.
    pub fingerprint: String,
}

/// One closed-loop run of a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunId {
    /// Global run index.
    pub index: usize,
    /// Scenario index.
    pub scenario: usize,
    /// Controller index.
    pub controller: usize,
}

/// FNV-1a, 64 bit: a stable hash (the same on every platform and Rust version).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Parses and validates a controller list (`pid,mpc`).
///
/// # Errors
/// [`ClosedLoopError::Controllers`] (caused by the unknown name), [`ClosedLoopError::ControllerListedTwice`],
/// [`ClosedLoopError::NoControllers`].
///
/// ```
/// use millcomp_closedloop::batch::plan::parse_controllers;
/// assert_eq!(parse_controllers("pid, mpc").unwrap(), vec!["pid", "mpc"]);
/// assert!(parse_controllers("pid,pid").is_err());
/// ```
pub fn parse_controllers(list: &str) -> Result<Vec<String>, ClosedLoopError> {
    let mut out: Vec<String> = Vec::new();
    for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let kind: ControllerKind = name.parse().map_err(|e| ClosedLoopError::Controllers {
            source: Box::new(e),
        })?;
        if out.iter().any(|c| c == kind.name()) {
            return Err(ClosedLoopError::ControllerListedTwice {
                name: name.to_string(),
            });
        }
        out.push(kind.name().to_string());
    }
    if out.is_empty() {
        return Err(ClosedLoopError::NoControllers);
    }
    Ok(out)
}

impl Plan {
    /// A plan with its fingerprint.
    ///
    /// # Errors
    /// [`ClosedLoopError::ThresholdOnGroove`] when `threshold` is asked for on a groove scenario.
    pub fn new(
        factor_names: Vec<String>,
        scenarios: Vec<ScenarioSpec>,
        controllers: Vec<String>,
    ) -> Result<Self, ClosedLoopError> {
        // `threshold` is the 004 thin-wall baseline: refuse it on groove scenarios before anything runs
        if controllers.iter().any(|c| c == "threshold") {
            for sc in &scenarios {
                let thin = matches!(
                    sc.factors.get("stage"),
                    Some(FactorValue::Text(t)) if t == "thin_wall"
                );
                if !thin {
                    return Err(ClosedLoopError::ThresholdOnGroove { row: sc.index + 1 });
                }
            }
        }
        let mut p = Plan {
            format: PLAN_FORMAT.to_string(),
            base_scenario: BASE_SCENARIO_FILE.to_string(),
            factor_names,
            scenarios,
            controllers,
            fingerprint: String::new(),
        };
        p.fingerprint = p.compute_fingerprint()?;
        Ok(p)
    }

    /// The plan of a scenario table (a CSV/Parquet file or a generated design: one row per scenario,
    /// one column per factor, see [`super::factors::scenarios_from_table`]) and a validated controller
    /// list ([`parse_controllers`]).
    ///
    /// # Errors
    /// Those of [`super::factors::scenarios_from_table`] and [`Plan::new`].
    ///
    /// ```
    /// use millcomp_closedloop::batch::plan::Plan;
    /// use millcomp_datasets::{Column, ColumnData, Table};
    /// let t = Table::from_columns(
    ///     "example",
    ///     vec![Column { name: "tilt_deg".into(), data: ColumnData::Float(vec![20.0, 40.0]) }],
    /// )
    /// .unwrap();
    /// let plan = Plan::from_table(&t, vec!["pid".into(), "mpc".into()]).unwrap();
    /// // 2 scenarios × 2 controllers; run 3 is scenario 1 with `mpc`
    /// assert_eq!(plan.n_runs(), 4);
    /// assert_eq!((plan.run_id(3).scenario, plan.run_id(3).controller), (1, 1));
    /// assert_eq!(plan.fingerprint.len(), 16);
    /// ```
    pub fn from_table(table: &Table, controllers: Vec<String>) -> Result<Self, ClosedLoopError> {
        let (names, specs) = super::factors::scenarios_from_table(table)?;
        Self::new(names, specs, controllers)
    }

    /// The fingerprint this plan should carry.
    ///
    /// # Errors
    /// [`ClosedLoopError::Json`] if the plan cannot be serialised (it always can).
    pub fn compute_fingerprint(&self) -> Result<String, ClosedLoopError> {
        let mut copy = self.clone();
        copy.fingerprint.clear();
        let mut bytes = serde_json::to_vec(&copy)?;
        bytes.extend_from_slice(BASE_SCENARIO_TOML.as_bytes());
        Ok(format!("{:016x}", fnv1a64(&bytes)))
    }

    /// Number of runs (scenarios × controllers).
    pub fn n_runs(&self) -> usize {
        self.scenarios.len() * self.controllers.len()
    }

    /// The run with global index `i`.
    pub fn run_id(&self, index: usize) -> RunId {
        let n = self.controllers.len().max(1);
        RunId {
            index,
            scenario: index / n,
            controller: index % n,
        }
    }

    /// The runs of shard `k` of `n`, in global order: whole scenarios, scenario `s` with every
    /// controller in shard `s mod n` — every shard holds every controller on 1/n of the scenarios, so
    /// slices take similar time, and a scenario is prepared (commissioned, previewed) in one slice only.
    pub fn shard_runs(&self, shard: Shard) -> Vec<RunId> {
        (0..self.n_runs())
            .map(|i| self.run_id(i))
            .filter(|r| r.scenario % shard.count == shard.index)
            .collect()
    }
}

/// A slice `index` of `count` (0-based index).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 0-based slice index.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl Shard {
    /// The whole batch.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Checks `index < count`, `count >= 1`; `what` names where the numbers came from.
    ///
    /// # Errors
    /// [`ClosedLoopError::NoShards`], [`ClosedLoopError::ShardOutOfRange`].
    pub fn new(index: usize, count: usize, what: &str) -> Result<Self, ClosedLoopError> {
        if count == 0 {
            return Err(ClosedLoopError::NoShards {
                what: what.to_string(),
            });
        }
        if index >= count {
            return Err(ClosedLoopError::ShardOutOfRange {
                what: what.to_string(),
                index,
                count,
            });
        }
        Ok(Shard { index, count })
    }

    /// Parses `K/N` (0-based K).
    ///
    /// # Errors
    /// [`ClosedLoopError::ShardSyntax`], [`ClosedLoopError::ShardNumber`] and those of [`Shard::new`].
    ///
    /// ```
    /// use millcomp_closedloop::batch::plan::Shard;
    /// assert_eq!(Shard::parse("1/4").unwrap(), Shard { index: 1, count: 4 });
    /// assert!(Shard::parse("4/4").unwrap_err().to_string().contains("out of range"));
    /// ```
    pub fn parse(text: &str) -> Result<Self, ClosedLoopError> {
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| ClosedLoopError::ShardSyntax {
                text: text.to_string(),
            })?;
        let number = |v: &str, which, kind| {
            v.trim()
                .parse::<usize>()
                .map_err(|source| ClosedLoopError::ShardNumber {
                    text: text.to_string(),
                    which,
                    kind,
                    source,
                })
        };
        let k = number(k, "K", "non-negative")?;
        let n = number(n, "N", "positive")?;
        Self::new(k, n, &format!("--shard {text}"))
    }

    /// The shard from the environment of an array job: Slurm (`SLURM_ARRAY_TASK_ID`, 0-based with
    /// `--array=0-(N-1)`, minus `SLURM_ARRAY_TASK_MIN` when set, and `SLURM_ARRAY_TASK_COUNT`) or a
    /// Kubernetes Indexed Job (`JOB_COMPLETION_INDEX` with the count from `MILLCOMP_SHARD_COUNT`).
    ///
    /// # Errors
    /// [`ClosedLoopError::ShardEnvNumber`], [`ClosedLoopError::ShardEnv`] and those of [`Shard::new`].
    pub fn from_env(get: impl Fn(&str) -> Option<String>) -> Result<Option<Self>, ClosedLoopError> {
        let parse = |name: &str| -> Result<Option<usize>, ClosedLoopError> {
            match get(name) {
                None => Ok(None),
                Some(v) => Ok(Some(v.trim().parse::<usize>().map_err(|source| {
                    ClosedLoopError::ShardEnvNumber {
                        name: name.to_string(),
                        value: v.clone(),
                        source,
                    }
                })?)),
            }
        };
        let env = |message: &str| ClosedLoopError::ShardEnv {
            message: message.to_string(),
        };
        if let Some(id) = parse("SLURM_ARRAY_TASK_ID")? {
            let count = parse("SLURM_ARRAY_TASK_COUNT")?.ok_or_else(|| {
                env("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not (give --shard K/N)")
            })?;
            let min = parse("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let k = id.checked_sub(min).ok_or_else(|| {
                env(&format!(
                    "SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}"
                ))
            })?;
            return Ok(Some(Self::new(
                k,
                count,
                "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT",
            )?));
        }
        if let Some(k) = parse("JOB_COMPLETION_INDEX")? {
            let count = parse("MILLCOMP_SHARD_COUNT")?.ok_or_else(|| {
                env(
                    "JOB_COMPLETION_INDEX is set but MILLCOMP_SHARD_COUNT is not (set it to the Job's completions, or give --shard K/N)",
                )
            })?;
            return Ok(Some(Self::new(
                k,
                count,
                "JOB_COMPLETION_INDEX/MILLCOMP_SHARD_COUNT",
            )?));
        }
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::error_chain;

    #[test]
    fn fnv_matches_reference_vectors() {
        // FNV-1a 64 test vectors from the reference (isthe.com/chongo/tech/comp/fnv): "" and "a".
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn shards_partition_the_runs() {
        let scen = (0..5)
            .map(|index| ScenarioSpec {
                index,
                factors: Default::default(),
            })
            .collect();
        let p = Plan::new(vec![], scen, vec!["pid".into(), "mpc".into()]).unwrap();
        let mut all: Vec<usize> = (0..4)
            .flat_map(|k| p.shard_runs(Shard::new(k, 4, "t").unwrap()))
            .map(|r| r.index)
            .collect();
        all.sort_unstable();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(p.run_id(7).scenario, 3);
        assert_eq!(p.run_id(7).controller, 1);
    }

    #[test]
    fn every_shard_holds_every_controller() {
        // 16 scenarios × 2 controllers in 4 slices (the Slurm self-test's shape): a round robin over the
        // run index would give slices 0 and 2 only the first controller; whole scenarios do not
        let scen = (0..16)
            .map(|index| ScenarioSpec {
                index,
                factors: Default::default(),
            })
            .collect();
        let p = Plan::new(vec![], scen, vec!["pid".into(), "mpc".into()]).unwrap();
        for k in 0..4 {
            let runs = p.shard_runs(Shard::new(k, 4, "t").unwrap());
            assert_eq!(runs.len(), 8);
            for c in 0..2 {
                assert_eq!(
                    runs.iter().filter(|r| r.controller == c).count(),
                    4,
                    "slice {k}"
                );
            }
        }
    }

    #[test]
    fn shard_errors_are_clear() {
        assert!(error_chain(&Shard::parse("4/4").unwrap_err()).contains("out of range"));
        assert!(Shard::parse("x/4").is_err());
        assert!(Shard::parse("0/0").is_err());
        let env = |k: &str| match k {
            "SLURM_ARRAY_TASK_ID" => Some("3".to_string()),
            "SLURM_ARRAY_TASK_COUNT" => Some("4".to_string()),
            _ => None,
        };
        assert_eq!(
            Shard::from_env(env).unwrap(),
            Some(Shard { index: 3, count: 4 })
        );
        let env = |k: &str| (k == "JOB_COMPLETION_INDEX").then(|| "5".to_string());
        assert!(Shard::from_env(env).is_err());
    }

    #[test]
    fn unknown_controller_is_named() {
        let e = parse_controllers("pid,lqr").unwrap_err();
        assert!(error_chain(&e).contains("lqr"));
        assert_eq!(parse_controllers("pid, mpc").unwrap(), vec!["pid", "mpc"]);
    }
}
