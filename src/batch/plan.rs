//! The batch plan (scenarios × controllers), its fingerprint and deterministic shards.

use anyhow::{Context, bail};
use millcomp_closedloop::ControllerKind;
use serde::{Deserialize, Serialize};

use super::factors::{BASE_SCENARIO_FILE, BASE_SCENARIO_TOML, ScenarioSpec};

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
pub fn parse_controllers(list: &str) -> anyhow::Result<Vec<String>> {
    let mut out: Vec<String> = Vec::new();
    for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let kind: ControllerKind = name.parse().context("--controllers")?;
        if out.iter().any(|c| c == kind.name()) {
            bail!("--controllers: `{name}` is listed twice");
        }
        out.push(kind.name().to_string());
    }
    if out.is_empty() {
        bail!("--controllers: give at least one controller, e.g. pid,mpc");
    }
    Ok(out)
}

impl Plan {
    /// A plan with its fingerprint.
    pub fn new(
        factor_names: Vec<String>,
        scenarios: Vec<ScenarioSpec>,
        controllers: Vec<String>,
    ) -> anyhow::Result<Self> {
        // `threshold` is the 004 thin-wall baseline: refuse it on groove scenarios before anything runs
        if controllers.iter().any(|c| c == "threshold") {
            for sc in &scenarios {
                let thin = matches!(
                    sc.factors.get("stage"),
                    Some(super::factors::FactorValue::Text(t)) if t == "thin_wall"
                );
                if !thin {
                    bail!(
                        "--controllers: `threshold` (the 004 thin-wall baseline) runs only on thin-wall \
                         scenarios, but scenario row {} is a groove (set factor stage = thin_wall)",
                        sc.index + 1
                    );
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

    /// The fingerprint this plan should carry.
    pub fn compute_fingerprint(&self) -> anyhow::Result<String> {
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

    /// The runs of shard `k` of `n` (round robin over the global run index: every shard gets a mix of
    /// scenarios and controllers, so slices take similar time).
    pub fn shard_runs(&self, shard: Shard) -> Vec<RunId> {
        (0..self.n_runs())
            .filter(|i| i % shard.count == shard.index)
            .map(|i| self.run_id(i))
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
    pub fn new(index: usize, count: usize, what: &str) -> anyhow::Result<Self> {
        if count == 0 {
            bail!("{what}: the number of shards must be at least 1");
        }
        if index >= count {
            bail!(
                "{what}: shard index {index} is out of range for {count} shards (allowed 0..={})",
                count - 1
            );
        }
        Ok(Shard { index, count })
    }

    /// Parses `K/N` (0-based K).
    pub fn parse(text: &str) -> anyhow::Result<Self> {
        let (k, n) = text
            .split_once('/')
            .with_context(|| format!("--shard `{text}`: expected K/N, e.g. 0/4"))?;
        let k: usize = k
            .trim()
            .parse()
            .with_context(|| format!("--shard `{text}`: K is not a non-negative integer"))?;
        let n: usize = n
            .trim()
            .parse()
            .with_context(|| format!("--shard `{text}`: N is not a positive integer"))?;
        Self::new(k, n, &format!("--shard {text}"))
    }

    /// The shard from the environment of an array job: Slurm (`SLURM_ARRAY_TASK_ID`, 0-based with
    /// `--array=0-(N-1)`, minus `SLURM_ARRAY_TASK_MIN` when set, and `SLURM_ARRAY_TASK_COUNT`) or a
    /// Kubernetes Indexed Job (`JOB_COMPLETION_INDEX` with the count from `MILLCOMP_SHARD_COUNT`).
    pub fn from_env(get: impl Fn(&str) -> Option<String>) -> anyhow::Result<Option<Self>> {
        let parse = |name: &str| -> anyhow::Result<Option<usize>> {
            match get(name) {
                None => Ok(None),
                Some(v) => Ok(Some(v.trim().parse::<usize>().with_context(|| {
                    format!("environment variable {name}=`{v}` is not a non-negative integer")
                })?)),
            }
        };
        if let Some(id) = parse("SLURM_ARRAY_TASK_ID")? {
            let count = parse("SLURM_ARRAY_TASK_COUNT")?.context(
                "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not (give --shard K/N)",
            )?;
            let min = parse("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let k = id.checked_sub(min).with_context(|| {
                format!("SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}")
            })?;
            return Ok(Some(Self::new(
                k,
                count,
                "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT",
            )?));
        }
        if let Some(k) = parse("JOB_COMPLETION_INDEX")? {
            let count = parse("MILLCOMP_SHARD_COUNT")?.context(
                "JOB_COMPLETION_INDEX is set but MILLCOMP_SHARD_COUNT is not (set it to the Job's completions, or give --shard K/N)",
            )?;
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
    fn shard_errors_are_clear() {
        assert!(format!("{:#}", Shard::parse("4/4").unwrap_err()).contains("out of range"));
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
        assert!(format!("{e:#}").contains("lqr"));
        assert_eq!(parse_controllers("pid, mpc").unwrap(), vec!["pid", "mpc"]);
    }
}
