#!/usr/bin/env python3
"""Rebuild the first cycle's QP of a `millcomp replay --export-mpc` document with CasADi and check the
first plan agrees with millcomp's (Clarabel) to solver tolerance.

The document's `first_cycle.qp` is Clarabel's form
    min 1/2 z'Pz + q'z  s.t.  A z + s = b, s >= 0        (P: upper triangle, CSC)
which CasADi's `conic` receives as h = P + P' - diag(P), g = q, a = A, uba = b (lba = -inf), solved
with qpOASES. The first move u_0 of both plans is compared, as a fraction of the input range
(config.limits.u_max - u_min); the check passes at <= 1e-6.

Usage: mpc_export_casadi.py EXPORT.json   (prints one JSON object; exit 1 if the check fails)
"""
import json
import os
import sys

_real_stdout = os.fdopen(os.dup(1), "w")
os.dup2(2, 1)  # qpOASES prints on stdout

import numpy as np  # noqa: E402
import casadi as ca  # noqa: E402


def csc(n_rows, n_cols, colptr, rowval, nzval):
    out = np.zeros((n_rows, n_cols))
    for j in range(n_cols):
        for k in range(colptr[j], colptr[j + 1]):
            out[rowval[k], j] = nzval[k]
    return out


def main(path):
    doc = json.load(open(path))
    assert doc["format"] == "millcomp-mpc-export", doc.get("format")
    qp = doc["first_cycle"]["qp"]
    n, m = qp["n"], qp["m"]
    P = csc(n, n, qp["p_colptr"], qp["p_rowval"], qp["p_nzval"])
    H = P + P.T - np.diag(np.diag(P))
    A = csc(m, n, qp["a_colptr"], qp["a_rowval"], qp["a_nzval"])
    S = ca.conic("S", "qpoases", {"h": ca.DM(H).sparsity(), "a": ca.DM(A).sparsity()},
                 {"printLevel": "none", "error_on_fail": False})
    r = S(h=ca.DM(H), g=ca.DM(qp["q"]), a=ca.DM(A), lba=-ca.inf, uba=ca.DM(qp["b"]))
    z = np.array(r["x"]).ravel()
    lim = doc["config"]["limits"]
    nu = len(lim["u_min"])
    span = np.array(lim["u_max"]) - np.array(lim["u_min"])
    clarabel = np.array(doc["first_cycle"]["solution"][:nu])
    diff = float(np.max(np.abs(z[:nu] - clarabel) / span))
    ok = diff <= 1e-6
    json.dump({"horizon": doc["horizon"], "n": n, "m": m, "u0_clarabel": clarabel.tolist(),
               "u0_casadi_qpoases": z[:nu].tolist(), "u0_diff_of_range": diff,
               "pass": ok}, _real_stdout)
    _real_stdout.write("\n")
    _real_stdout.flush()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
