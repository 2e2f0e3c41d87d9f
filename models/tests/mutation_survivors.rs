//! Tests written for the mutants of `millcomp-models` cargo-mutants found surviving
//! (docs/reliability-mutants.md): each asserts what the code must do where the mutated line decides.

use std::path::Path;

use millcomp_models::{HysteresisModel, IdentifiedModel, ModelError};

fn hysteresis(w03: &str) -> IdentifiedModel {
    toml::from_str(&format!(
        r#"
status = "converged"
n_obs = 900
dof = 897
rms_residual = 0.05
residual_unit = "um"
[params]
w00_um_per_v = 0.04
w03_um_per_v = {w03}
offset_um = 0.2
[fixed]
r00_v = 0.0
r03_v = 56.25
[std_err]
[covariance]
names = []
values = []
"#
    ))
    .unwrap()
}

/// A play-operator weight below 0 is refused naming its key and value, 0 is accepted. Kills `identified.rs: replace && with || in HysteresisModel::from_identified`
/// (which lets any finite weight through).
#[test]
fn a_negative_hysteresis_weight_is_refused_naming_its_key() {
    let at = Path::new("hysteresis.toml");
    match HysteresisModel::from_identified(&hysteresis("-0.006"), at) {
        Err(ModelError::InvalidValue { key, value, .. }) => {
            assert_eq!(
                (key.as_str(), value.as_str()),
                ("model.params.w03_um_per_v", "-0.006")
            );
        }
        other => panic!("{other:?}"),
    }
    let h = HysteresisModel::from_identified(&hysteresis("0.0"), at).unwrap();
    assert_eq!(h.weights_um_per_v, vec![0.04, 0.0]);
}
