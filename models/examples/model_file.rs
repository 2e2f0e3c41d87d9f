//! The one model-file format: save an identified spindle model with its provenance (the input file and
//! its SHA-256), read the header to dispatch on the kind, load the typed view a controller consumes, and
//! see a reader of another kind refused with the key named.
//!
//! Run: `cargo run -p millcomp-models --example model_file`.

use std::collections::BTreeMap;

use millcomp_models::{
    FitStatus, ForceModelParams, IdentifiedModel, InputFile, ModelError, ModelFile, NamedMatrix,
    Provenance, SpindleModel, read_header,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    // The measurement the model came from (here a stand-in step response).
    let data = dir.path().join("step.csv");
    std::fs::write(&data, "t_s,u_v,y_um\n0,0,0\n0.001,10,0.31\n")?;

    // The spindle as 000_…txt §5.2.4 reports it: ζ = 0.46 (from 20 % overshoot), ωn = 1302 rad/s;
    // the gain and the covariance are illustrative.
    let names = vec![
        "gain_um_per_v".to_string(),
        "zeta".to_string(),
        "wn_rad_s".to_string(),
    ];
    let params: BTreeMap<String, f64> = names.iter().cloned().zip([0.05, 0.46, 1302.0]).collect();
    let std_err: BTreeMap<String, f64> = names.iter().cloned().zip([0.001, 0.01, 12.0]).collect();
    let covariance = NamedMatrix::from_matrix(
        &names,
        &nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1e-6, 1e-4, 144.0])),
    );
    let model = IdentifiedModel {
        status: FitStatus::Converged,
        n_obs: 2,
        dof: 0,
        rms_residual: 0.004,
        residual_unit: "um".into(),
        warnings: vec![],
        params,
        std_err,
        fixed: BTreeMap::new(),
        derived: BTreeMap::new(),
        covariance,
    };
    let provenance = Provenance::now("millcomp 0.1.0", "model_file example")
        .with_input(InputFile::from_path(&data)?);
    let path = dir.path().join("spindle.toml");
    ModelFile::new("spindle", model, provenance).save(&path)?;
    println!("{}", std::fs::read_to_string(&path)?);

    // Dispatch on the header, then load the typed view.
    let header = read_header(&path)?;
    assert_eq!(
        (header.format.as_str(), header.kind.as_str()),
        ("millcomp-model", "spindle")
    );
    assert_eq!(
        header.provenance.inputs[0].sha256,
        millcomp_models::sha256_hex(&std::fs::read(&data)?)
    );
    let loaded: ModelFile<IdentifiedModel> = ModelFile::load(&path, &SpindleModel::KINDS)?;
    let spindle = SpindleModel::from_identified(&loaded.model, &path)?;
    assert_eq!((spindle.zeta, spindle.wn_rad_s), (0.46, 1302.0));
    assert_eq!(spindle.covariance.get("wn_rad_s", "wn_rad_s"), Some(144.0));
    println!(
        "spindle: ζ = {}, ωn = {} rad/s",
        spindle.zeta, spindle.wn_rad_s
    );

    // A reader of force models is told what the file holds.
    let err = ModelFile::<IdentifiedModel>::load(&path, &ForceModelParams::KINDS).unwrap_err();
    println!("as a force model: {err}");
    assert!(matches!(&err, ModelError::Kind { found, .. } if found == "spindle"));
    Ok(())
}
