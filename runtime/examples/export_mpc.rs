//! The MPC of a program, built from a bundle, as the JSON document of `millcomp_runtime::export`
//! (docs/export-mpc.md): what `bench/peers/mpc_export_casadi.py` rebuilds with CasADi.
//!
//! ```text
//! cargo run -p millcomp-runtime --example export_mpc -- BUNDLE PROGRAM OUT.json
//! ```

use millcomp_runtime::{Origins, Program, export::export_mpc, load_bundle};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [bundle, program, out] = args.as_slice() else {
        return Err("usage: export_mpc BUNDLE PROGRAM OUT.json".into());
    };
    let origins = Origins {
        bundle: bundle.into(),
        program: program.into(),
    };
    let doc = export_mpc(
        &load_bundle(bundle.as_ref())?,
        &Program::load(program.as_ref())?,
        &origins,
    )?;
    std::fs::write(out, serde_json::to_string_pretty(&doc)?)?;
    eprintln!(
        "{out}: horizon {}, QP {} × {}",
        doc.horizon, doc.first_cycle.qp.n, doc.first_cycle.qp.m
    );
    Ok(())
}
