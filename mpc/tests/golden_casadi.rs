//! Clarabel's per-cycle solution against CasADi 3.8.2 `conic` (qpOASES, DAQP) on the identical recorded QP
//! sequence. Golden: `tests/golden/casadi_qp_first_moves.json`, written by `bench/peers/mpc_goldens.py`
//! (tool versions and the exact call are recorded inside the file).

use crate::common::FIRST_MOVE_REL_RANGE;
use millcomp_mpc::replay::{QpSequence, replay_clarabel};

#[test]
fn clarabel_first_moves_match_casadi_qpoases_and_daqp() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden/casadi_qp_first_moves.json");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    assert_eq!(v["tools"]["casadi"], "3.8.2");
    let seq: QpSequence = serde_json::from_value(v["sequence"].clone()).unwrap();
    assert_eq!(seq.q.len(), 50);
    let r = replay_clarabel(&seq).unwrap();
    assert_eq!(r.failures, 0);
    for peer in ["first_moves_qpoases", "first_moves_daqp"] {
        let fm: Vec<f64> = serde_json::from_value(v[peer].clone()).unwrap();
        assert_eq!(fm.len(), r.first_moves.len());
        let worst = fm
            .iter()
            .zip(&r.first_moves)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            worst <= FIRST_MOVE_REL_RANGE * seq.input_range,
            "{peer}: {worst} V"
        );
    }
}
