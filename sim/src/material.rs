//! Workpiece materials (`000_…txt` Table 3-1 and Table 4-1; `004_…txt` Table 4; C45 from handbook data).
//!
//! The force model's material parameter is the thesis' "modeled parameter" (Table 4-1, last row), which
//! replaced the Vickers hardness `H` of Arcona's model and correlates with 35 × the area under the
//! stress–strain curve ("volumetric work"). Table 4-1 labels it "Nm/m³", but it is used in place of a
//! hardness in MPa (S7: H = 6710 MPa → W = 6000), so it is stored here as `w_mpa` (N/mm²).

use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_nonneg, check_positive, check_range};

/// A workpiece material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Name, e.g. `S7`.
    pub name: String,
    /// Modeled volumetric-work parameter W (MPa), Table 4-1 last row.
    pub w_mpa: f64,
    /// Elastic modulus E (GPa).
    pub e_gpa: f64,
    /// Rake-face friction coefficient µ.
    pub mu_rake: f64,
    /// Flank-face friction coefficient µf.
    pub mu_flank: f64,
    /// Vickers hardness (MPa), where the seeds give it (Table 3-1); informative only.
    pub hardness_mpa: Option<f64>,
}

/// Names accepted by [`Material::by_name`].
pub const MATERIAL_NAMES: [&str; 5] = ["S7", "1018", "6061", "H59", "C45"];

impl Material {
    /// S7 hardened tool steel: W = 6000, E = 210 GPa, µ = µf = 0.5 (`000_…txt` Table 4-1), H = 6710 MPa
    /// (Table 3-1).
    pub fn s7() -> Self {
        Self {
            name: "S7".into(),
            w_mpa: 6000.0,
            e_gpa: 210.0,
            mu_rake: 0.5,
            mu_flank: 0.5,
            hardness_mpa: Some(6710.0),
        }
    }

    /// 1018 low-carbon steel: W = 4500, E = 210 GPa (`000_…txt` Table 4-1), H = 1760 MPa (Table 3-1).
    pub fn aisi1018() -> Self {
        Self {
            name: "1018".into(),
            w_mpa: 4500.0,
            e_gpa: 210.0,
            mu_rake: 0.5,
            mu_flank: 0.5,
            hardness_mpa: Some(1760.0),
        }
    }

    /// 6061 aluminium: W = 2500, E = 70 GPa (`000_…txt` Table 4-1), H = 1090 MPa (Table 3-1).
    pub fn al6061() -> Self {
        Self {
            name: "6061".into(),
            w_mpa: 2500.0,
            e_gpa: 70.0,
            mu_rake: 0.5,
            mu_flank: 0.5,
            hardness_mpa: Some(1090.0),
        }
    }

    /// H59 brass: E = 100 GPa (`004_…txt` Table 4: 100 000 N/mm²).
    ///
    /// W is *derived*, not published: following `000_…txt` §4.1 (W ≈ 35 × area under the stress–strain
    /// curve, linear approximation of Fig. 4-4), with handbook values for CuZn40 (yield ≈ 200 MPa,
    /// UTS ≈ 390 MPa, elongation ≈ 40 %): area ≈ (200 + 390)/2 · 0.40 ≈ 118 MPa → W ≈ 35 · 118 ≈ 4100.
    /// µ = µf = 0.5 as for the Table 4-1 materials.
    pub fn h59_brass() -> Self {
        Self {
            name: "H59".into(),
            w_mpa: 4100.0,
            e_gpa: 100.0,
            mu_rake: 0.5,
            mu_flank: 0.5,
            hardness_mpa: None,
        }
    }

    /// C45 carbon steel (`003_…txt` workpiece). The seed gives no material data; E = 210 GPa and W derived
    /// as for H59 from handbook values (yield ≈ 430 MPa, UTS ≈ 700 MPa, elongation ≈ 16 %):
    /// area ≈ (430 + 700)/2 · 0.16 ≈ 90 MPa → W ≈ 35 · 90 ≈ 3200.
    pub fn c45() -> Self {
        Self {
            name: "C45".into(),
            w_mpa: 3200.0,
            e_gpa: 210.0,
            mu_rake: 0.5,
            mu_flank: 0.5,
            hardness_mpa: None,
        }
    }

    /// Look a material up by name (case-insensitive; `AISI1018`, `Al6061`, `brass` accepted as aliases).
    ///
    /// # Errors
    /// [`SimError::Session`] with key `material.name` for a name that is neither one of
    /// [`MATERIAL_NAMES`] nor an alias; the message lists the allowed names.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::SimError;
    /// use millcomp_sim::material::Material;
    /// // 000 Table 4-1: modeled parameter W and elastic modulus E of 6061
    /// let al = Material::by_name("al6061").unwrap();
    /// assert_eq!((al.name.as_str(), al.w_mpa, al.e_gpa), ("6061", 2500.0, 70.0));
    /// // flow stress σs = W/3 (Arcona's assumption, 000 §2.1): S7's W = 6000 → 2000 MPa
    /// assert_eq!(Material::by_name(" s7 ").unwrap().flow_stress_mpa(), 2000.0);
    /// let e = Material::by_name("unobtainium").unwrap_err();
    /// assert!(matches!(&e, SimError::Session { key, .. } if key == "material.name"));
    /// ```
    pub fn by_name(name: &str) -> Result<Self, SimError> {
        match name.trim().to_ascii_uppercase().as_str() {
            "S7" => Ok(Self::s7()),
            "1018" | "AISI1018" | "C1018" => Ok(Self::aisi1018()),
            "6061" | "AL6061" | "6061-T6" => Ok(Self::al6061()),
            "H59" | "BRASS" | "H59_BRASS" => Ok(Self::h59_brass()),
            "C45" => Ok(Self::c45()),
            _ => Err(SimError::Session {
                key: "material.name".into(),
                message: format!("unknown material `{name}`; allowed {MATERIAL_NAMES:?}"),
            }),
        }
    }

    /// Validate all parameters.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `w_mpa` or `e_gpa` (not a finite positive number),
    /// `mu_rake` or `mu_flank` (outside `[0, 2]`), or `hardness_mpa` (negative or not finite).
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("w_mpa", self.w_mpa)?;
        check_positive("e_gpa", self.e_gpa)?;
        check_range("mu_rake", self.mu_rake, 0.0, 2.0, "0 <= mu_rake <= 2")?;
        check_range("mu_flank", self.mu_flank, 0.0, 2.0, "0 <= mu_flank <= 2")?;
        if let Some(h) = self.hardness_mpa {
            check_nonneg("hardness_mpa", h)?;
        }
        Ok(())
    }

    /// Flow stress σs = W/3 (MPa): Arcona's assumption 2 (`000_…txt` §2.1) with W in place of H.
    pub fn flow_stress_mpa(&self) -> f64 {
        self.w_mpa / 3.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_4_1_values() {
        // 000 Table 4-1, last row (modeled parameter) and modulus row
        assert_eq!(Material::s7().w_mpa, 6000.0);
        assert_eq!(Material::aisi1018().w_mpa, 4500.0);
        assert_eq!(Material::al6061().w_mpa, 2500.0);
        assert_eq!(Material::al6061().e_gpa, 70.0);
        // 004 Table 4: E = 100 000 N/mm²
        assert_eq!(Material::h59_brass().e_gpa, 100.0);
        assert_eq!(Material::by_name("al6061").unwrap().name, "6061");
        assert!(Material::by_name("unobtainium").is_err());
    }

    #[test]
    fn rejects_negative_modulus() {
        let mut m = Material::s7();
        m.e_gpa = -1.0;
        assert!(matches!(
            m.validate(),
            Err(SimError::InvalidParameter { name: "e_gpa", .. })
        ));
    }
}
