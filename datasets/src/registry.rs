//! The published tables shipped with millcomp, embedded in the binary so the CLI works anywhere.
//!
//! Each dataset has a schema; loading one validates it exactly as a user's file would be, so a
//! typo in a shipped table fails the test suite rather than a user's run.

use crate::error::DatasetError;
use crate::table::{ColumnKind, ColumnSpec, Schema, Table, read_csv_str};

/// One shipped table.
#[derive(Debug, Clone, Copy)]
pub struct Dataset {
    /// Short name used on the command line (`millcomp datasets show NAME`).
    pub name: &'static str,
    /// File name under `datasets/data/`.
    pub file: &'static str,
    /// One line: what the table holds.
    pub title: &'static str,
    /// Seed document the values come from (the per-row `source` column is more precise).
    pub seed: &'static str,
    /// The CSV text.
    pub csv: &'static str,
    columns: &'static [(&'static str, ColumnKind, &'static str)],
}

impl Dataset {
    /// The schema the table is validated against.
    pub fn schema(&self) -> Schema {
        Schema::new(
            self.name,
            self.columns
                .iter()
                .map(|&(name, kind, desc)| ColumnSpec::required(name, kind, desc))
                .collect(),
        )
    }

    /// Loads and validates the table.
    ///
    /// # Errors
    /// Those of [`read_csv_str`] — for a shipped table only if it were broken, which the test suite
    /// rules out.
    pub fn load(&self) -> Result<Table, DatasetError> {
        let origin = format!("datasets/data/{}", self.file);
        read_csv_str(&origin, self.csv, &self.schema())
    }
}

use ColumnKind::{Float as F, Int as I, Text as T};

const S0: &str = "000_367e180efde69d0c.txt (Clayton, Force modeling and deflection compensation of miniature ball end mills)";
const S2: &str = "002_1746cabacde4dcfb.txt (axial depth-of-cut error study, micro milling)";
const S3: &str =
    "003_d95efe3529e650fc.txt (Brecher et al., real-time compensation of tool deflection)";
const S4: &str = "004_13bffb4774552fad.txt (thin-wall micromilling with radial compensation)";

const SRC: (&str, ColumnKind, &str) = ("source", T, "seed file and table/section");
const PARAM: [(&str, ColumnKind, &str); 4] = [
    ("parameter", T, "parameter name (snake_case)"),
    ("value", F, "its value"),
    ("unit", T, "unit of value"),
    SRC,
];

/// Every shipped dataset.
pub static DATASETS: &[Dataset] = &[
    Dataset {
        name: "clayton_doe",
        file: "clayton_doe.csv",
        title: "2^3 DOE in 6061: depth, speed, upfeed and the max X/Y/Z force per trial",
        seed: S0,
        csv: include_str!("../data/clayton_doe.csv"),
        columns: &[
            ("trial", I, "trial number as published"),
            ("depth_um", F, "depth of cut"),
            ("speed_rpm", F, "spindle speed"),
            ("upfeed_um", F, "feed per revolution"),
            (
                "max_fx_n",
                F,
                "largest positive X force per flute, averaged",
            ),
            (
                "max_fy_n",
                F,
                "largest positive Y force per flute, averaged",
            ),
            (
                "max_fz_n",
                F,
                "largest positive Z force per flute, averaged",
            ),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_doe_levels",
        file: "clayton_doe_levels.csv",
        title: "Low and high levels of the 2^3 DOE factors",
        seed: S0,
        csv: include_str!("../data/clayton_doe_levels.csv"),
        columns: &[
            ("factor", T, "factor"),
            ("unit", T, "unit of the levels"),
            ("low", F, "low level"),
            ("high", F, "high level"),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_material_properties",
        file: "clayton_material_properties.csv",
        title: "Hardness, modulus, strength and elongation of S7, 1018 and 6061",
        seed: S0,
        csv: include_str!("../data/clayton_material_properties.csv"),
        columns: &[
            ("material", T, "workpiece material"),
            ("hardness_mpa", F, "Vickers hardness"),
            ("modulus_gpa", F, "elastic modulus"),
            ("yield_strength_mpa", F, "yield strength"),
            ("uts_mpa", F, "ultimate tensile strength"),
            ("elongation_pct", F, "elongation to failure"),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_force_materials",
        file: "clayton_force_materials.csv",
        title: "Force-model material parameters: volumetric work W, modulus, friction, shear angle",
        seed: S0,
        csv: include_str!("../data/clayton_force_materials.csv"),
        columns: &[
            ("material", T, "workpiece material"),
            ("modulus_gpa", F, "elastic modulus"),
            ("mu_rake", F, "rake-face friction coefficient"),
            ("mu_flank", F, "flank-face friction coefficient"),
            ("hardness_mpa", F, "measured hardness"),
            (
                "volumetric_work_nm_per_m3",
                F,
                "area under the stress-strain curve",
            ),
            ("volumetric_work_x35_nm_per_m3", F, "35 x volumetric work"),
            (
                "model_w_nm_per_m3",
                F,
                "the model parameter W used in eqs (9)-(10)",
            ),
            ("shear_angle_deg", F, "shear angle gamma"),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_cut_conditions",
        file: "clayton_cut_conditions.csv",
        title: "Cutting parameters of the force-model validation cuts (S7, 1018, 6061)",
        seed: S0,
        csv: include_str!("../data/clayton_cut_conditions.csv"),
        columns: &[
            ("material", T, "workpiece material"),
            (
                "figure",
                T,
                "figure showing the measured and predicted forces",
            ),
            ("tilt_deg", F, "tool tilt"),
            ("depth_um", F, "depth of cut"),
            ("upfeed_um", F, "feed per revolution"),
            ("speed_rpm", F, "spindle speed"),
            ("chip_area_um2", F, "(max) chip area per revolution"),
            ("wearland_um", F, "measured wearland"),
            ("runout_um", F, "measured tool/spindle runout"),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_stiffness",
        file: "clayton_stiffness.csv",
        title: "Tool, spindle, tilted-tool and PZT stiffness, modelled and measured",
        seed: S0,
        csv: include_str!("../data/clayton_stiffness.csv"),
        columns: &[
            ("quantity", T, "what the stiffness is of"),
            ("tilt_deg", F, "tool tilt (0 where not applicable)"),
            ("kind", T, "modelled or measured"),
            ("stiffness_n_per_um", F, "stiffness"),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_spindle",
        file: "clayton_spindle.csv",
        title: "PZT-actuated spindle: step-response, root-locus and PID figures, sensors, limits",
        seed: S0,
        csv: include_str!("../data/clayton_spindle.csv"),
        columns: &PARAM,
    },
    Dataset {
        name: "clayton_grooves",
        file: "clayton_grooves.csv",
        title: "Groove profile errors: uncompensated, open loop and closed loop at 20/30/40 deg",
        seed: S0,
        csv: include_str!("../data/clayton_grooves.csv"),
        columns: &[
            ("tilt_deg", F, "tool tilt"),
            ("method", T, "uncompensated, open_loop or closed_loop_pid"),
            ("force_measured_on", T, "none, workpiece or spindle"),
            ("pp_error_um", F, "peak-to-peak profile error"),
            (
                "reduction_pct",
                F,
                "error reduction relative to uncompensated",
            ),
            SRC,
        ],
    },
    Dataset {
        name: "clayton_groove_conditions",
        file: "clayton_groove_conditions.csv",
        title: "The groove experiment: 0-80 um ramp over 20 mm in S7 and its published figures",
        seed: S0,
        csv: include_str!("../data/clayton_groove_conditions.csv"),
        columns: &PARAM,
    },
    Dataset {
        name: "depth_error_budget",
        file: "depth_error_budget.csv",
        title: "Axial depth-of-cut error budget: coolant, probe tilt, spindle growth, runout",
        seed: S2,
        csv: include_str!("../data/depth_error_budget.csv"),
        columns: &[
            ("contribution", T, "as named in the seed"),
            (
                "effect",
                T,
                "millcomp effect name (diagnose contract) where one applies",
            ),
            ("value_um", F, "contribution (+ deepens the cut)"),
            ("bound", T, "signed value or plus_minus bound"),
            SRC,
        ],
    },
    Dataset {
        name: "depth_error_contributions",
        file: "depth_error_contributions.csv",
        title: "Estimated X/Y/Z error contributions for a 0.2 mm flat end mill",
        seed: S2,
        csv: include_str!("../data/depth_error_contributions.csv"),
        columns: &[
            ("contribution", T, "influencing factor"),
            ("axis", T, "x, y or z"),
            ("value_um", F, "error"),
            ("qualifier", T, "value or up_to"),
            SRC,
        ],
    },
    Dataset {
        name: "depth_drift_tests",
        file: "depth_drift_tests.csv",
        title: "Drift tests: coolant, 60 brass grooves, probe tilt, spindle growth, wear, steps",
        seed: S2,
        csv: include_str!("../data/depth_drift_tests.csv"),
        columns: &[
            ("test", T, "which test of the seed's chapter 7"),
            ("quantity", T, "what was measured"),
            ("value", F, "its value"),
            ("unit", T, "unit of value"),
            SRC,
        ],
    },
    Dataset {
        name: "nc_feed_step",
        file: "nc_feed_step.csv",
        title: "NC feed-axis compensation: feed-step test, filters and the 74/43 um peaks",
        seed: S3,
        csv: include_str!("../data/nc_feed_step.csv"),
        columns: &PARAM,
    },
    Dataset {
        name: "thin_wall_results",
        file: "thin_wall_results.csv",
        title: "Thin-wall thickness without and with compensation (80/100/120 um walls)",
        seed: S4,
        csv: include_str!("../data/thin_wall_results.csv"),
        columns: &[
            ("wall", I, "wall number"),
            ("nominal_um", F, "nominal thickness"),
            (
                "uncompensated_um",
                F,
                "measured thickness without compensation",
            ),
            (
                "uncompensated_error_pct",
                F,
                "relative error without compensation",
            ),
            ("compensated_um", F, "measured thickness with compensation"),
            (
                "compensated_error_pct",
                F,
                "relative error with compensation",
            ),
            SRC,
        ],
    },
    Dataset {
        name: "thin_wall_conditions",
        file: "thin_wall_conditions.csv",
        title: "Thin-wall cutting parameters, cutter, H59 brass properties and the stage",
        seed: S4,
        csv: include_str!("../data/thin_wall_conditions.csv"),
        columns: &PARAM,
    },
];

/// The dataset called `name`.
///
/// ```
/// let d = millcomp_datasets::dataset("clayton_doe").unwrap();
/// assert_eq!(d.file, "clayton_doe.csv");
/// assert_eq!(d.schema().columns.len(), 8);
/// let e = millcomp_datasets::dataset("clayton").unwrap_err();
/// assert!(e.to_string().contains("known datasets: clayton_doe, clayton_doe_levels"));
/// ```
///
/// # Errors
/// [`DatasetError::UnknownDataset`], listing the known names.
pub fn dataset(name: &str) -> Result<&'static Dataset, DatasetError> {
    DATASETS
        .iter()
        .find(|d| d.name == name)
        .ok_or_else(|| DatasetError::UnknownDataset {
            name: name.to_string(),
            known: DATASETS
                .iter()
                .map(|d| d.name)
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// Loads and validates the dataset called `name`.
///
/// ```
/// let t = millcomp_datasets::load("clayton_stiffness").unwrap();
/// // 000_…txt Table 5-1: the radial tool stiffness, modelled 0.141 N/µm and measured 0.114 N/µm
/// let k = t.f64s("stiffness_n_per_um").unwrap();
/// assert!(k.contains(&0.141) && k.contains(&0.114));
/// ```
///
/// # Errors
/// [`DatasetError::UnknownDataset`], and those of [`Dataset::load`].
pub fn load(name: &str) -> Result<Table, DatasetError> {
    dataset(name)?.load()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shipped_dataset_validates_and_has_provenance() {
        for d in DATASETS {
            let t = d.load().unwrap_or_else(|e| panic!("{}: {e}", d.name));
            assert!(t.n_rows() > 0, "{}", d.name);
            assert!(
                t.ignored_columns.is_empty(),
                "{}: {:?}",
                d.name,
                t.ignored_columns
            );
            let sources = t.strings("source").unwrap();
            let seed_file = d.seed.split(' ').next().unwrap();
            for (i, s) in sources.iter().enumerate() {
                assert!(
                    s.starts_with(seed_file) || s.contains("DESIGN.md"),
                    "{} row {}: source `{s}` does not name the seed",
                    d.name,
                    i + 1
                );
            }
        }
    }

    #[test]
    fn names_are_unique_and_match_files() {
        for (i, d) in DATASETS.iter().enumerate() {
            assert_eq!(format!("{}.csv", d.name), d.file);
            assert!(DATASETS[i + 1..].iter().all(|o| o.name != d.name));
        }
    }

    #[test]
    fn clayton_doe_holds_table_3_3() {
        // 000_…txt Table 3-3, trials 1 and 5.
        let t = load("clayton_doe").unwrap();
        assert_eq!(t.n_rows(), 8);
        let fx = t.f64s("max_fx_n").unwrap();
        assert_eq!(fx[0], 3.34);
        assert_eq!(fx[4], 3.60);
        assert_eq!(t.f64s("max_fz_n").unwrap()[2], 0.59);
    }

    #[test]
    fn unknown_name_lists_the_known_ones() {
        let e = load("nope").unwrap_err().to_string();
        assert!(e.contains("clayton_doe") && e.contains("nope"), "{e}");
    }
}
