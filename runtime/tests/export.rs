//! The MPC's export: the document a CasADi/do-mpc/acados user rebuilds the problem from holds the
//! model, the configuration and the first cycle's QP, and its first plan is the command the runtime
//! sends in that cycle, bit for bit.

use millcomp_runtime::export::{FORMAT, export_mpc};
use millcomp_runtime::{Controller, ControllerKind, Measurement, Origins, load_bundle};

use crate::common;

#[test]
fn the_export_holds_the_problem_and_the_first_plan() {
    let bundle = load_bundle(&common::data("bundle_s7.toml")).unwrap();
    let p = common::program(ControllerKind::Mpc);
    let doc = export_mpc(&bundle, &p, &Origins::default()).unwrap();
    assert_eq!((doc.format, doc.horizon), (FORMAT, 20));
    let m = &doc.model;
    let n = m.n_plant + m.n_dist;
    assert_eq!(
        (m.a.len(), m.a[0].len(), m.b.len(), m.c[0].len()),
        (n, n, n, n)
    );
    assert!(
        (m.dt_s - 5e-4).abs() < 1e-15,
        "the MPC's period: 10 control periods"
    );
    let f = &doc.first_cycle;
    assert_eq!(f.qp.q.len(), f.qp.n);
    assert_eq!(f.qp.b.len(), f.qp.m);
    assert_eq!(f.plan.len(), 20);
    // the runtime's first command is the plan's first move
    let mut ctl = Controller::from_bundle(&bundle, &p).unwrap();
    let c = ctl.step(&Measurement::NONE);
    assert_eq!(c.voltage_v.to_bits(), f.plan[0].to_bits());
    // one JSON document
    let text = serde_json::to_string(&doc).unwrap();
    let back: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(back["config"]["horizon"], 20);
    assert_eq!(back["first_cycle"]["qp"]["n"], f.qp.n);
}
