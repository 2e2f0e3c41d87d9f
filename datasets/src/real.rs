//! Records measured on real machines by others (`datasets/real/`, provenance and licences in its
//! README), embedded in the binary and listed apart from the published tables and the synthetic runs.
//!
//! Unlike the published tables they have no schema of millcomp's: they are read as the files are
//! ([`read_any`](crate::read_any)), and a verb maps their columns to its own names with `--columns`
//! ([`crate::mapping`]).
//!
//! ```
//! let r = millcomp_datasets::real::record("fl_thermal_drift").unwrap();
//! assert_eq!(r.path(), "datasets/real/fl_thermal/thermal_drift.csv");
//! let t = r.load().unwrap();
//! // 46.3 h every 15 s (datasets/real/README.md)
//! assert_eq!(t.n_rows(), 11_115);
//! assert_eq!(t.f64s("time_s").unwrap()[11_114], 166_710.0);
//! ```

use crate::error::DatasetError;
use crate::table::{Table, read_any_str};

/// One measured record shipped in `datasets/real/`.
#[derive(Debug, Clone, Copy)]
pub struct RealRecord {
    /// Short name (`millcomp datasets show NAME`).
    pub name: &'static str,
    /// File under `datasets/real/`.
    pub file: &'static str,
    /// One line: what was measured.
    pub title: &'static str,
    /// Where it comes from: repository, commit and path upstream.
    pub source: &'static str,
    /// Licence of the data.
    pub licence: &'static str,
    /// Units of its columns.
    pub units: &'static str,
    /// SHA-256 of the file (as in `datasets/real/README.md`).
    pub sha256: &'static str,
    /// The CSV text.
    pub csv: &'static str,
}

impl RealRecord {
    /// The file's path in the repository.
    pub fn path(&self) -> String {
        format!("datasets/real/{}", self.file)
    }

    /// Reads the embedded copy as the file would be read.
    ///
    /// # Errors
    /// Those of [`read_any_str`] — for a shipped record only if it were
    /// broken, which the test suite rules out.
    pub fn load(&self) -> Result<Table, DatasetError> {
        read_any_str(&self.path(), self.csv)
    }
}

const FL: &str = "GitHub CAIVIAC/FL_THERMAL, commit 9fa40bd4c3d8a67b802c19719ff9b20bbba085d7, data/data.xlsx (sheet 工作表1), converted to CSV, values unchanged";
const FL_LICENCE: &str = "MIT (c) 2024 CAIVIAC, datasets/real/fl_thermal/LICENSE_upstream_MIT.txt";
const PHM_RAW: &str = "PHM Society 2010 data challenge, cutter c1: GitHub WSU-AI-in-ME/ai-in-me-1, commit f7b9b0ad45d59ac9a97d482531978739ed4c5542, data/phm2010/c1_selected_cuts/ (mirrors Kaggle rabahba/phm-data-challenge-2010)";
const PHM_FEAT: &str = "PHM Society 2010 data challenge, cutter c1: GitHub pioneer0413/milling_nasa_ames_etri, commit 5974b9f81f79ff589ed8c092a405455c62ba6a90, datasets/phm2010/";
const PHM_FEAT_C4: &str = "PHM Society 2010 data challenge, cutter c4: GitHub pioneer0413/milling_nasa_ames_etri, commit 5974b9f81f79ff589ed8c092a405455c62ba6a90, datasets/phm2010/";
const PHM_FEAT_C6: &str = "PHM Society 2010 data challenge, cutter c6: GitHub pioneer0413/milling_nasa_ames_etri, commit 5974b9f81f79ff589ed8c092a405455c62ba6a90, datasets/phm2010/";
const CC0: &str = "CC0 1.0 (the Kaggle copy of the PHM 2010 data)";
const CC0_DERIVED: &str = "statistics of the CC0 1.0 PHM 2010 records; the computing repository states no licence of its own (datasets/real/README.md)";

/// Every shipped real record.
pub static REAL_RECORDS: &[RealRecord] = &[
    RealRecord {
        name: "fl_thermal_drift",
        file: "fl_thermal/thermal_drift.csv",
        title: "Machine-tool spindle thermal displacement, 46 h: 5 displacements, 16 temperatures, speed steps to 5000 rpm",
        source: FL,
        licence: FL_LICENCE,
        units: "time_s s, spindle_rpm rpm, disp_ch1_um..disp_ch5_um um, temp_t1_C..temp_t16_C degC",
        sha256: "9de42d688c3b26fe8b64f88456cd15cc315ab4a60a148ab2fa5b514d4439f961",
        csv: include_str!("../real/fl_thermal/thermal_drift.csv"),
    },
    RealRecord {
        name: "phm2010_c1_cut001_raw",
        file: "phm2010_c1/c1_cut001_mid.csv",
        title: "PHM 2010 cutter c1, cut 1 (fresh tool): raw 50 kHz forces, vibration, AE (~2.5 revolutions)",
        source: PHM_RAW,
        licence: CC0,
        units: "force_x_N..force_z_N N, vibration_x_g..vibration_z_g g, ae_rms_V V; 50 kHz",
        sha256: "8d71e10dfb71355e8e1c80502760195c1f76c2ab5f499f5d5ca969070ac9a719",
        csv: include_str!("../real/phm2010_c1/c1_cut001_mid.csv"),
    },
    RealRecord {
        name: "phm2010_c1_cut315_raw",
        file: "phm2010_c1/c1_cut315_mid.csv",
        title: "PHM 2010 cutter c1, cut 315 (worn tool): raw 50 kHz forces, vibration, AE (~2.5 revolutions)",
        source: PHM_RAW,
        licence: CC0,
        units: "force_x_N..force_z_N N, vibration_x_g..vibration_z_g g, ae_rms_V V; 50 kHz",
        sha256: "037a3762e46e076c77d07a0f811060f170074a1404767e1962bca4c79a16c1a4",
        csv: include_str!("../real/phm2010_c1/c1_cut315_mid.csv"),
    },
    RealRecord {
        name: "phm2010_c1_per_cut_forces",
        file: "phm2010_c1/per_cut_force_features_c1.csv",
        title: "PHM 2010 cutter c1: 10 statistics of each full force/vibration/AE record, per cut (315 cuts)",
        source: PHM_FEAT,
        licence: CC0_DERIVED,
        units: "run = cut number; force_* N, vib_* g, ae_rms_* V (no unit suffixes in the names)",
        sha256: "4f1c001f41ccb55336654f03f5134cee935d729f1e5979f91d9f77a5bd0131f3",
        csv: include_str!("../real/phm2010_c1/per_cut_force_features_c1.csv"),
    },
    RealRecord {
        name: "phm2010_c1_per_cut_wear",
        file: "phm2010_c1/per_cut_wear_c1.csv",
        title: "PHM 2010 cutter c1: flank wear VB of each of the 3 flutes after every cut (315 cuts)",
        source: PHM_FEAT,
        licence: CC0_DERIVED,
        units: "run = cut number, VB_flute_1..3 um, time = cut number (not seconds)",
        sha256: "670d6f23675771e4ad7ea64b1437f9c3865f769bc7af4c964a5d8ce6d596e9fe",
        csv: include_str!("../real/phm2010_c1/per_cut_wear_c1.csv"),
    },
    RealRecord {
        name: "phm2010_c4_per_cut_forces",
        file: "phm2010_c4/per_cut_force_features_c4.csv",
        title: "PHM 2010 cutter c4 (a second tool, same machine and conditions): 10 statistics of each full force/vibration/AE record, per cut (315 cuts)",
        source: PHM_FEAT_C4,
        licence: CC0_DERIVED,
        units: "run = cut number, case = cutter (4); force_* N, vib_* g, ae_rms_* V (no unit suffixes in the names)",
        sha256: "25960ba9cda32dc154df842b9f597bf993b83547ed70ccc621fc5dd33de6347c",
        csv: include_str!("../real/phm2010_c4/per_cut_force_features_c4.csv"),
    },
    RealRecord {
        name: "phm2010_c4_per_cut_wear",
        file: "phm2010_c4/per_cut_wear_c4.csv",
        title: "PHM 2010 cutter c4: flank wear VB of each of the 3 flutes after every cut (315 cuts)",
        source: PHM_FEAT_C4,
        licence: CC0_DERIVED,
        units: "run = cut number, case = cutter (4), VB_flute_1..3 um, time = cut number (not seconds)",
        sha256: "54a8d9a1e09f5d5363656dacd3dea82b0c4a019b766588e6a5625d5fa294b253",
        csv: include_str!("../real/phm2010_c4/per_cut_wear_c4.csv"),
    },
    RealRecord {
        name: "phm2010_c6_per_cut_forces",
        file: "phm2010_c6/per_cut_force_features_c6.csv",
        title: "PHM 2010 cutter c6 (a third tool, same machine and conditions): 10 statistics of each full force/vibration/AE record, per cut (315 cuts)",
        source: PHM_FEAT_C6,
        licence: CC0_DERIVED,
        units: "run = cut number, case = cutter (6); force_* N, vib_* g, ae_rms_* V (no unit suffixes in the names)",
        sha256: "77bf22bdf878bdc5402442637d8fe1833b67cc52ad6d2e735b8f7493e1a6b3b1",
        csv: include_str!("../real/phm2010_c6/per_cut_force_features_c6.csv"),
    },
    RealRecord {
        name: "phm2010_c6_per_cut_wear",
        file: "phm2010_c6/per_cut_wear_c6.csv",
        title: "PHM 2010 cutter c6: flank wear VB of each of the 3 flutes after every cut (315 cuts)",
        source: PHM_FEAT_C6,
        licence: CC0_DERIVED,
        units: "run = cut number, case = cutter (6), VB_flute_1..3 um, time = cut number (not seconds)",
        sha256: "12b612f0f80bf6d5876d9741a334a831eca71564d46428eaadf03ec53a182d8f",
        csv: include_str!("../real/phm2010_c6/per_cut_wear_c6.csv"),
    },
];

/// The real record called `name`.
///
/// # Errors
/// [`DatasetError::UnknownDataset`], listing the known names.
pub fn record(name: &str) -> Result<&'static RealRecord, DatasetError> {
    REAL_RECORDS
        .iter()
        .find(|r| r.name == name)
        .ok_or_else(|| DatasetError::UnknownDataset {
            name: name.to_string(),
            known: REAL_RECORDS
                .iter()
                .map(|r| r.name)
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// The shipped real record whose file is `path` (compared by file name under `datasets/real/`, so
/// `../x/datasets/real/fl_thermal/thermal_drift.csv` is found), for outputs that say which real
/// file they used.
///
/// ```
/// let r = millcomp_datasets::real::by_path(std::path::Path::new("./datasets/real/phm2010_c1/c1_cut315_mid.csv"));
/// assert_eq!(r.unwrap().name, "phm2010_c1_cut315_raw");
/// assert!(millcomp_datasets::real::by_path(std::path::Path::new("mine.csv")).is_none());
/// ```
pub fn by_path(path: &std::path::Path) -> Option<&'static RealRecord> {
    let p = path.to_string_lossy().replace('\\', "/");
    REAL_RECORDS
        .iter()
        .find(|r| p.ends_with(&format!("real/{}", r.file)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_record_loads_and_matches_its_hash() {
        for r in REAL_RECORDS {
            let t = r.load().unwrap_or_else(|e| panic!("{}: {e}", r.name));
            assert!(t.n_rows() > 100, "{}", r.name);
            let h = millcomp_models::InputFile::from_bytes(r.file, r.csv.as_bytes());
            assert_eq!(h.sha256, r.sha256, "{}", r.name);
        }
        assert!(
            record("nope")
                .unwrap_err()
                .to_string()
                .contains("fl_thermal_drift")
        );
    }

    #[test]
    fn names_do_not_collide_with_published_tables() {
        for r in REAL_RECORDS {
            assert!(
                crate::DATASETS.iter().all(|d| d.name != r.name),
                "{}",
                r.name
            );
        }
    }
}
