#!/usr/bin/env python3
"""Golden for millcomp-mpc: first moves of a recorded spindle-MPC QP sequence solved by CasADi `conic`
with qpOASES and DAQP. The sequence itself is stored in the golden, so the Rust test replays exactly the
same data with Clarabel.

Regenerate:
    cargo run --release -p millcomp-closedloop --example qp_replay -- record 10 50 /tmp/seq.json 7
    python bench/peers/mpc_goldens.py /tmp/seq.json mpc/tests/golden/casadi_qp_first_moves.json
"""
import json
import os
import sys

_real_stdout = os.fdopen(os.dup(1), "w")
os.dup2(2, 1)  # qpOASES prints a banner on stdout

import numpy as np  # noqa: E402
import casadi as ca  # noqa: E402


def csc_dense(d):
    out = np.zeros((d["m"], d["n"]))
    for j in range(d["n"]):
        for k in range(d["colptr"][j], d["colptr"][j + 1]):
            out[d["rowval"][k], j] = d["nzval"][k]
    return out


def main():
    seq_path, out_path = sys.argv[1:3]
    with open(seq_path) as f:
        seq = json.load(f)
    pu = csc_dense(seq["p"])
    h = pu + pu.T - np.diag(np.diag(pu))
    a = csc_dense(seq["a"])
    n = h.shape[0]
    out = {
        "generator": "bench/peers/mpc_goldens.py",
        "tools": {"casadi": ca.__version__, "numpy": np.__version__},
        "call": "casadi.conic('S', plugin, {'h': DM(H).sparsity(), 'a': DM(A).sparsity()}, opts)"
                "(h=H, g=q_k, a=A, lba=-inf, uba=b_k, lbx=-inf, ubx=inf); H = P + P' - diag(P);"
                " qpoases opts {'printLevel': 'none'}, daqp opts {}",
        "sequence": seq,
    }
    for plugin, opts in [("qpoases", {"printLevel": "none"}), ("daqp", {})]:
        s = ca.conic("S", plugin, {"h": ca.DM(h).sparsity(), "a": ca.DM(a).sparsity()}, opts)
        first = []
        for q, b in zip(seq["q"], seq["b"]):
            r = s(h=h, g=np.asarray(q), a=a, lba=-np.inf, uba=np.asarray(b), lbx=-np.inf * np.ones(n), ubx=np.inf * np.ones(n))
            assert s.stats()["success"], plugin
            first.append(float(r["x"][seq["first_move_index"]]))
        out["first_moves_" + plugin] = first
    with open(out_path, "w") as f:
        json.dump(out, f)
    _real_stdout.write("wrote %s\n" % out_path)


if __name__ == "__main__":
    main()
