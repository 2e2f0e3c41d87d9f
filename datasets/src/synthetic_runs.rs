//! The synthetic runs shipped in `datasets/synthetic/` and `datasets/runs/` — made by millcomp's own
//! seeded generators, labelled synthetic, each naming what is hidden in it (the READMEs there) — listed
//! beside the published tables and the real records so that nobody mistakes one for another.

/// One synthetic run.
#[derive(Debug, Clone, Copy)]
pub struct SyntheticRun {
    /// Short name.
    pub name: &'static str,
    /// File under `datasets/`.
    pub file: &'static str,
    /// What it is and what is hidden in it.
    pub title: &'static str,
    /// The CSV text.
    pub csv: &'static str,
}

impl SyntheticRun {
    /// Data rows (lines after the header).
    pub fn n_rows(&self) -> usize {
        self.csv
            .lines()
            .filter(|l| !l.trim().is_empty())
            .count()
            .saturating_sub(1)
    }
}

macro_rules! session {
    ($name:literal, $title:literal) => {
        SyntheticRun {
            name: $name,
            file: concat!("synthetic/", $name, ".csv"),
            title: $title,
            csv: include_str!(concat!("../synthetic/", $name, ".csv")),
        }
    };
}

/// Every shipped synthetic run.
pub static SYNTHETIC_RUNS: &[SyntheticRun] = &[
    session!("clean", "groove session, nothing hidden"),
    session!(
        "coolant_thermal_drift",
        "groove session hiding coolant_thermal_drift (8.5 um, tau 900 s)"
    ),
    session!(
        "spindle_thermal_growth",
        "groove session hiding spindle_thermal_growth (20 um at 50 000 rpm)"
    ),
    session!(
        "probe_tilt_offset",
        "groove session hiding probe_tilt_offset (alpha 0.107 deg)"
    ),
    session!(
        "tool_wear",
        "groove session hiding tool_wear (8 um, L0 100 mm)"
    ),
    session!(
        "slideway_straightness",
        "groove session hiding slideway_straightness (5 um over 90 mm)"
    ),
    session!(
        "machine_compliance",
        "groove session hiding machine_compliance (10 N/um)"
    ),
    session!("flute_runout", "groove session hiding flute_runout (3 um)"),
    session!(
        "coolant_thermal_drift+tool_wear",
        "groove session hiding coolant_thermal_drift and tool_wear"
    ),
    session!(
        "robust_spindle_thermal_growth_two_tau",
        "groove session hiding a two-time-constant spindle growth"
    ),
    session!(
        "robust_tool_wear_power_law",
        "groove session hiding a power-law tool wear"
    ),
    session!(
        "robust_slideway_straightness_skewed",
        "groove session hiding a skewed slideway bow"
    ),
    session!(
        "flute_runout_force",
        "groove session hiding flute_runout, with its flute force trace"
    ),
    SyntheticRun {
        name: "spindle_step_synthetic",
        file: "runs/spindle_step_synthetic.csv",
        title: "PZT-spindle step response (the published plant, gauge offset and noise)",
        csv: include_str!("../runs/spindle_step_synthetic.csv"),
    },
    SyntheticRun {
        name: "stiffness_masses_synthetic",
        file: "runs/stiffness_masses_synthetic.csv",
        title: "hanging-mass load-deflection calibration",
        csv: include_str!("../runs/stiffness_masses_synthetic.csv"),
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_run_has_rows_and_a_unique_name() {
        for (i, r) in SYNTHETIC_RUNS.iter().enumerate() {
            assert!(r.n_rows() > 5, "{}", r.name);
            assert!(SYNTHETIC_RUNS[i + 1..].iter().all(|o| o.name != r.name));
            assert!(crate::real::REAL_RECORDS.iter().all(|o| o.name != r.name));
        }
    }
}
