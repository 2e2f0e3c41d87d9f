//! Candidate effects: which parameters of each sim [`Effect`] `diagnose` fits, within which bounds
//! and from which starting values.
//!
//! Adding a candidate is one new type implementing `millcomp_sim::effects::Effect` plus one
//! [`CandidateSpec`] registered with [`Registry::register`] (the free parameters are named by the
//! effect's own parameter names). The seven DESIGN.md effects are registered by
//! [`Registry::standard`]. Parameters an effect has but the depth data cannot separate are held
//! fixed at the effect's seed defaults and reported under `fixed`:
//!
//! | effect | free | fixed (why) |
//! |---|---|---|
//! | `coolant_thermal_drift` | `amplitude_um`, `time_constant_s` | — |
//! | `spindle_thermal_growth` | `max_growth_um`, `rpm_onset`, `time_constant_s` (as `identify thermal --model speed-dependent`) | `rpm_max` 50 000 (only the slope `max_growth/(rpm_max − rpm_onset)` and the onset are visible), `um_per_c` (no effect on depth) |
//! | `probe_tilt_offset` | `alpha_deg` | `d1_mm` 6, `d2_mm` 1 (Δl = (D1 − D2)/2·tan α is one constant: only the product is visible) |
//! | `tool_wear` | `max_wear_um`, `length_scale_mm` | — |
//! | `slideway_straightness` | `amplitude_um` | `span_mm` 90, `x0_mm` 0 (with them free the bow becomes a general parabola in X that absorbs offsets and linear trends of other effects) |
//! | `machine_compliance` | `stiffness_n_per_um` | `span_n_per_um` 0, `period_mm` 200 (a position-dependent stiffness needs far more X coverage than a groove session has) |
//! | `flute_runout` | `runout_um` | — |
//!
//! Bounds lie inside the ranges sim's `set_params` accepts; starting values are a small grid over
//! the nonlinear parameters (time constants, length scales, stiffness) because their least-squares
//! surfaces have several basins; the best fit over the grid is kept.

use millcomp_sim::effects::{
    CoolantThermalDrift, Effect, FluteRunout, MachineCompliance, ProbeTiltOffset,
    SlidewayStraightness, SpindleThermalGrowth, ToolWear,
};

/// A parameter `diagnose` estimates.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeParam {
    /// The effect's parameter name (as in `Effect::params`).
    pub name: &'static str,
    /// Lower bound (may be `-inf`).
    pub lower: f64,
    /// Upper bound (may be `+inf`).
    pub upper: f64,
    /// Starting values tried (each strictly inside the bounds).
    pub starts: Vec<f64>,
}

impl FreeParam {
    /// A parameter with bounds and starting values.
    pub fn new(name: &'static str, lower: f64, upper: f64, starts: &[f64]) -> Self {
        FreeParam {
            name,
            lower,
            upper,
            starts: starts.to_vec(),
        }
    }
}

/// One candidate: an effect (its current parameter values are the fixed ones) and the parameters
/// to estimate.
#[derive(Debug, Clone)]
pub struct CandidateSpec {
    /// The effect, with the values of its fixed parameters.
    pub effect: Box<dyn Effect>,
    /// Free parameters (a subset of `effect.params()` names).
    pub free: Vec<FreeParam>,
    /// One line on what the effect is and where it comes from (human report).
    pub description: &'static str,
}

impl CandidateSpec {
    /// The effect's name.
    pub fn name(&self) -> &'static str {
        self.effect.name()
    }

    /// Indices of the free parameters in `effect.params()`; `None` names an unknown parameter.
    pub fn free_indices(&self) -> std::result::Result<Vec<usize>, String> {
        let names: Vec<&str> = self.effect.params().iter().map(|(n, _)| *n).collect();
        self.free
            .iter()
            .map(|f| {
                names
                    .iter()
                    .position(|n| *n == f.name)
                    .ok_or_else(|| format!("{} has no parameter `{}`", self.name(), f.name))
            })
            .collect()
    }

    /// Parameters held fixed, with their values.
    pub fn fixed(&self) -> Vec<(&'static str, f64)> {
        self.effect
            .params()
            .into_iter()
            .filter(|(n, _)| !self.free.iter().any(|f| f.name == *n))
            .collect()
    }
}

/// The set of candidate effects `diagnose` tries.
#[derive(Debug, Clone, Default)]
pub struct Registry {
    specs: Vec<CandidateSpec>,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// The seven DESIGN.md effects (table in the module documentation).
    pub fn standard() -> Self {
        let mut r = Registry::new();
        r.register(CandidateSpec {
            effect: Box::new(CoolantThermalDrift::default()),
            free: vec![
                FreeParam::new("amplitude_um", -500.0, 500.0, &[0.0]),
                FreeParam::new("time_constant_s", 10.0, 1e5, &[300.0, 1000.0, 3000.0]),
            ],
            description: "coolant switched on cools the column: first-order drift after the switch (002 §7.1)",
        });
        r.register(CandidateSpec {
            effect: Box::new(SpindleThermalGrowth::default()),
            free: vec![
                FreeParam::new("max_growth_um", -500.0, 500.0, &[0.0]),
                FreeParam::new("rpm_onset", 0.0, 45_000.0, &[16_000.0]),
                FreeParam::new("time_constant_s", 10.0, 1e5, &[150.0, 600.0, 2400.0]),
            ],
            description: "speed-dependent spindle thermal growth, first-order lag (002 §7.6, Tab. 5)",
        });
        r.register(CandidateSpec {
            effect: Box::new(ProbeTiltOffset::default()),
            free: vec![FreeParam::new("alpha_deg", -10.0, 10.0, &[0.0])],
            description: "tool-length probe tip tilt: constant offset (D1 − D2)/2·tan α (002 §7.3)",
        });
        r.register(CandidateSpec {
            effect: Box::new(ToolWear::default()),
            free: vec![
                FreeParam::new("max_wear_um", -500.0, 500.0, &[0.0]),
                FreeParam::new("length_scale_mm", 1.0, 1e6, &[30.0, 100.0, 300.0, 1000.0]),
            ],
            description: "tool shortens with engaged length (002 §7.5)",
        });
        r.register(CandidateSpec {
            effect: Box::new(SlidewayStraightness::default()),
            free: vec![FreeParam::new("amplitude_um", -500.0, 500.0, &[0.0])],
            description: "X slideway bow over 90 mm (002 §7.2)",
        });
        r.register(CandidateSpec {
            effect: Box::new(MachineCompliance::default()),
            free: vec![FreeParam::new(
                "stiffness_n_per_um",
                0.01,
                1e4,
                &[1.0, 10.0, 100.0],
            )],
            description: "machine compliance in series with the tool (003 eqs 1–5)",
        });
        r.register(CandidateSpec {
            effect: Box::new(FluteRunout::default()),
            free: vec![FreeParam::new("runout_um", 0.0, 50.0, &[0.5, 3.0])],
            description: "flute runout: one flute cuts more, larger peak force (000 §4)",
        });
        r
    }

    /// Adds (or replaces, by effect name) a candidate.
    pub fn register(&mut self, spec: CandidateSpec) {
        match self.specs.iter().position(|s| s.name() == spec.name()) {
            Some(i) => self.specs[i] = spec,
            None => self.specs.push(spec),
        }
    }

    /// Registered names, in registration order.
    pub fn names(&self) -> Vec<&'static str> {
        self.specs.iter().map(|s| s.name()).collect()
    }

    /// The candidate of that name.
    pub fn get(&self, name: &str) -> Option<&CandidateSpec> {
        self.specs.iter().find(|s| s.name() == name)
    }

    /// All candidates.
    pub fn specs(&self) -> &[CandidateSpec] {
        &self.specs
    }
}
