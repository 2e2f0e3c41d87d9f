//! The pipeline plan (`millcomp pipeline PLAN.toml`): which measured files supply each stage, and the
//! designs and settings the stages use. One schema, defined here and documented in `docs/pipeline.md`;
//! unknown keys are errors naming the key; paths are relative to the plan file.
//!
//! A stage whose files are not given is skipped with a message saying what it would need — unless the
//! plan names a simulated machine (`[machine] seed = …`), which then measures what the files do not
//! give (that is `millcomp demo`: [`Plan::demo`]).
//!
//! ```
//! use millcomp_pipeline::plan::Plan;
//! let p = Plan::from_toml_str(
//!     r#"
//! name = "bench 3"
//! [measure]
//! spindle_step = "step.csv"
//! [compare]
//! tolerance_pp_um = 3.0
//! "#,
//!     std::path::Path::new("/data/plan.toml"),
//! )
//! .unwrap();
//! assert_eq!(p.measure.spindle_step.unwrap(), std::path::Path::new("/data/step.csv"));
//! assert_eq!(p.compare.tolerance_pp_um, 3.0);
//! assert!(p.machine.is_none());
//! let e = Plan::from_toml_str("[measure]\nforce = \"f.csv\"\n", std::path::Path::new("p.toml"));
//! assert!(e.unwrap_err().to_string().contains("force"));
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{PipelineError, Result};

/// The simulated machine that measures what no file gives (`[machine]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineSpec {
    /// Seed the machine is drawn from (`millcomp_closedloop::machine::SimulatedMachine::new`).
    pub seed: u64,
}

/// `[design]`: the calibration cuts as a design of experiments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DesignSpec {
    /// Factors in `doe design` form: `depth_um=20:80,…`; numeric levels in the units of their names,
    /// `material` a label factor.
    pub factors: String,
    /// Smallest resolution of the two-level fraction (III = 3 …).
    pub resolution: u32,
    /// Revolutions cut per run (synchronously averaged).
    pub revolutions: usize,
    /// Force samples per revolution.
    pub samples_per_rev: usize,
}

impl Default for DesignSpec {
    /// A 2^(5−1) of resolution V over depth 20/80 µm, upfeed 5/15 µm/rev, speed 10 000/20 000 rpm, tilt
    /// 20/40° and the two materials the comparison cuts (S7, 6061): 16 cuts, every main effect and
    /// two-factor interaction clear of each other; 20 revolutions at 72 samples each (the
    /// commissioning's).
    fn default() -> Self {
        Self {
            factors: "depth_um=20:80,upfeed_um=5:15,speed_rpm=10000:20000,tilt_deg=20:40,material=S7:6061"
                .into(),
            resolution: 5,
            revolutions: 20,
            samples_per_rev: 72,
        }
    }
}

/// `[measure]`: the calibration records.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasureSpec {
    /// Force calibration traces (`run, material, depth_um, upfeed_um, speed_rpm, tilt_deg, rot_deg,
    /// fz_n`).
    pub forces: Option<PathBuf>,
    /// Spindle step test in air (`t_s, u_v, y_um`).
    pub spindle_step: Option<PathBuf>,
    /// Quasi-static sweep of the stack in air (`u_v, y_um`).
    pub hysteresis_sweep: Option<PathBuf>,
    /// Load–deflection test (`load_n, deflection_um, direction`).
    pub load_deflection: Option<PathBuf>,
    /// The sensors at rest (`t_s, force_n, gauge_um`).
    pub sensors_at_rest: Option<PathBuf>,
}

/// `[identify]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifySpec {
    /// Force parameters fitted (names of `identify force --free`).
    pub force_free: Vec<String>,
}

impl Default for IdentifySpec {
    /// W, wearland and runout (the commissioning's).
    fn default() -> Self {
        Self {
            force_free: vec!["w_mpa".into(), "wearland_um".into(), "runout_um".into()],
        }
    }
}

/// `[compare]`: the designed comparison of the controllers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompareSpec {
    /// Measured part errors of the controllers over the conditions (`scenario`, the factors,
    /// `controller`, `pp_error_um`, optionally `change_excess_um` and the other metrics of `millcomp
    /// batch`'s results.csv).
    pub results: Option<PathBuf>,
    /// Factors of the design in `doe design` form (batch factor names).
    pub factors: String,
    /// Smallest resolution of the fraction.
    pub resolution: u32,
    /// Groove length of every condition (mm).
    pub length_mm: f64,
    /// Controllers, in the order reported.
    pub controllers: Vec<String>,
    /// The part's tolerance on the peak-to-peak depth error (µm).
    pub tolerance_pp_um: f64,
}

impl Default for CompareSpec {
    /// A 2^(6−1) of resolution VI (32 conditions) over tilt 20/40°, final depth 40/80 µm, the tool's
    /// wearland 8/14 µm (as commissioned / worn), material S7/6061, a feed step at once (0/1) and a
    /// depth step at once (0/1); 10 mm grooves (the changes at 5 mm, their windows 4.5–7 mm); none,
    /// open-loop, the published pid, pid-tuned and mpc; a part tolerance of 4 µm peak to peak
    /// (±2 µm on a 100 µm feature).
    fn default() -> Self {
        Self {
            results: None,
            factors: "tilt_deg=20:40,depth_um=40:80,wearland_um=8:14,material=S7:6061,feed_step=0:1,depth_step=0:1"
                .into(),
            resolution: 6,
            length_mm: 10.0,
            controllers: ["none", "open-loop", "pid", "pid-tuned", "mpc"]
                .map(String::from)
                .to_vec(),
            tolerance_pp_um: 4.0,
        }
    }
}

/// `[diagnose]`: a measured session.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnoseSpec {
    /// Session file (nominal model and plan; `sim/SESSION.md`).
    pub session: Option<PathBuf>,
    /// Measured-groove CSV of that session (DESIGN.md's contract).
    pub measured: Option<PathBuf>,
}

/// `[rerun]`: the controllers with the corrected model, on the comparison's conditions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RerunSpec {
    /// Measured part errors of the corrected controllers (as `[compare] results`; controller names
    /// `mpc+diagnosed`, `open-loop+diagnosed`, …).
    pub results: Option<PathBuf>,
}

/// A pipeline plan (module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// A label for the report.
    #[serde(default)]
    pub name: String,
    /// Seed of the designs' run order and of the simulated machine's noise.
    #[serde(default = "one")]
    pub seed: u64,
    /// Measure what no file gives on this simulated machine.
    #[serde(default)]
    pub machine: Option<MachineSpec>,
    /// The calibration design.
    #[serde(default)]
    pub design: DesignSpec,
    /// The calibration records.
    #[serde(default)]
    pub measure: MeasureSpec,
    /// Identification settings.
    #[serde(default)]
    pub identify: IdentifySpec,
    /// The comparison.
    #[serde(default)]
    pub compare: CompareSpec,
    /// The diagnosis.
    #[serde(default)]
    pub diagnose: DiagnoseSpec,
    /// The rerun with the corrected model.
    #[serde(default)]
    pub rerun: RerunSpec,
}

fn one() -> u64 {
    1
}

impl Plan {
    /// The demo's plan: everything measured on the simulated machine drawn from `machine_seed`.
    pub fn demo(machine_seed: u64) -> Self {
        Self {
            name: "millcomp demo".into(),
            seed: 1,
            machine: Some(MachineSpec { seed: machine_seed }),
            design: DesignSpec::default(),
            measure: MeasureSpec::default(),
            identify: IdentifySpec::default(),
            compare: CompareSpec::default(),
            diagnose: DiagnoseSpec::default(),
            rerun: RerunSpec::default(),
        }
    }

    /// [`Self::demo`] with a smaller comparison: 8 conditions (a 2^(4−1) of resolution IV over tilt,
    /// final depth, material and a depth step at once) on 5 mm grooves — a quicker look, and the tests'.
    pub fn quick_demo(machine_seed: u64) -> Self {
        let mut p = Self::demo(machine_seed);
        p.compare.factors = "tilt_deg=20:40,depth_um=40:80,material=S7:6061,depth_step=0:1".into();
        p.compare.resolution = 4;
        p.compare.length_mm = 5.0;
        p
    }

    /// Reads a plan file; its paths are made relative to its directory.
    ///
    /// # Errors
    /// [`PipelineError::Io`] for an unreadable file; [`PipelineError::Plan`] for bad TOML or an unknown
    /// key (named); [`PipelineError::PlanValue`] for a value out of range.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| PipelineError::io(path, "reading the plan", e))?;
        Self::from_toml_str(&text, path)
    }

    /// Parses a plan; `path` names it in messages and anchors its relative paths.
    ///
    /// # Errors
    /// As [`Self::load`].
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self> {
        let mut p: Plan = toml::from_str(text).map_err(|e| PipelineError::Plan {
            path: path.to_path_buf(),
            message: e.to_string().trim().replace('\n', " "),
        })?;
        let dir = path.parent().unwrap_or(Path::new(""));
        let anchor = |f: &mut Option<PathBuf>| {
            if let Some(p) = f.as_mut()
                && p.is_relative()
            {
                *p = dir.join(&*p);
            }
        };
        let m = &mut p.measure;
        for f in [
            &mut m.forces,
            &mut m.spindle_step,
            &mut m.hysteresis_sweep,
            &mut m.load_deflection,
            &mut m.sensors_at_rest,
            &mut p.compare.results,
            &mut p.diagnose.session,
            &mut p.diagnose.measured,
            &mut p.rerun.results,
        ] {
            anchor(f);
        }
        p.validate(path)?;
        Ok(p)
    }

    fn validate(&self, path: &Path) -> Result<()> {
        let bad = |key: &str, value: String, allowed: &str| PipelineError::PlanValue {
            path: path.to_path_buf(),
            key: key.to_string(),
            value,
            allowed: allowed.to_string(),
        };
        let c = &self.compare;
        if !(c.tolerance_pp_um.is_finite() && c.tolerance_pp_um > 0.0) {
            return Err(bad(
                "compare.tolerance_pp_um",
                c.tolerance_pp_um.to_string(),
                "a finite tolerance > 0 µm",
            ));
        }
        if !(c.length_mm.is_finite() && (3.0..=40.0).contains(&c.length_mm)) {
            return Err(bad(
                "compare.length_mm",
                c.length_mm.to_string(),
                "3 to 40 mm (long enough to hold a change at half-length and its window, 0.5 mm before to 2 mm after)",
            ));
        }
        if c.controllers.is_empty() {
            return Err(bad(
                "compare.controllers",
                "[]".into(),
                "at least one controller",
            ));
        }
        for (k, v) in [
            ("design.resolution", self.design.resolution),
            ("compare.resolution", c.resolution),
        ] {
            if !(3..=8).contains(&v) {
                return Err(bad(k, v.to_string(), "3 to 8 (III to VIII)"));
            }
        }
        if !(1..=200).contains(&self.design.revolutions) {
            return Err(bad(
                "design.revolutions",
                self.design.revolutions.to_string(),
                "1 to 200",
            ));
        }
        if !(8..=720).contains(&self.design.samples_per_rev) {
            return Err(bad(
                "design.samples_per_rev",
                self.design.samples_per_rev.to_string(),
                "8 to 720",
            ));
        }
        if self.identify.force_free.is_empty() {
            return Err(bad(
                "identify.force_free",
                "[]".into(),
                "at least one force parameter (w_mpa, mu_rake, mu_flank, wearland_um, runout_um)",
            ));
        }
        Ok(())
    }
}
