#!/usr/bin/env python3
"""Peer for bench/mpc-vs-casadi: solve a recorded millcomp MPC QP sequence with CasADi `conic`
(qpOASES and DAQP) and compare with millcomp's Clarabel replay.

Input: the sequence JSON written by `qp_replay record` (millcomp-closedloop example):
    min 1/2 z'Pz + q_k'z  s.t.  A z + s = b_k, s >= 0        (P: upper triangle, CSC)
which CasADi receives as
    conic(h = P + P' - diag(P), g = q_k, a = A, lba = -inf, uba = b_k, lbx = -inf, ubx = +inf).

Usage: mpc_casadi.py SEQ.json CLARABEL.json FIRST_MOVES.json
  CLARABEL.json     the line printed by `qp_replay replay` (median_us, p99_us, ...)
  FIRST_MOVES.json  Clarabel's first move per cycle (written by `qp_replay replay`)
Prints one JSON object on stdout:
  {"horizon", "clarabel": {"median_us","p99_us","solve_median_us","solve_p99_us",...},
   "casadi_qpoases": {"median_us","p99_us","solver_median_us",...}, "casadi_daqp": {...},
   "max_first_move_diff", "clarabel_solve_over_qpoases_solver", ...}
`max_first_move_diff` is max_k |u0_clarabel - u0_peer| / input_range over both peers (a fraction of the input
range; the target is <= 1e-6). For the peers, `median_us`/`p99_us` time the whole call from Python
(`time.perf_counter` around `S(...)`, numpy inputs prepared beforehand); `solver_median_us`/`solver_p99_us`
are CasADi's own `t_wall_solver` statistics (the plugin alone, no Python/CasADi call overhead). CasADi's
qpOASES interface hot-starts every call after the first from the previous call's active set
(casadi/interfaces/qpoases/qpoases_interface.cpp: once `called_once`, `m->sqp->hotstart(h, g, a, ...)`
instead of `init`), so the peer runs with hot-start on.
Clarabel's counterpart is `solve_median_us`: its `solve()` call alone, timed around the call.
"""
import json
import os
import sys
import time

# qpOASES prints a banner on stdout: route fd 1 to stderr while CasADi runs, keep the real stdout for JSON.
_real_stdout = os.fdopen(os.dup(1), "w")
os.dup2(2, 1)

import numpy as np  # noqa: E402
import casadi as ca  # noqa: E402


def csc_dense(d):
    m, n = d["m"], d["n"]
    out = np.zeros((m, n))
    cp, rv, nz = d["colptr"], d["rowval"], d["nzval"]
    for j in range(n):
        for k in range(cp[j], cp[j + 1]):
            out[rv[k], j] = nz[k]
    return out


def pct(v, p):
    v = sorted(v)
    if not v:
        return 0.0
    rank = int(np.ceil(p / 100.0 * len(v)))
    return v[min(max(rank, 1), len(v)) - 1]


def run_peer(plugin, opts, seq, H, A):
    n = H.shape[0]
    S = ca.conic("S", plugin, {"h": ca.DM(H).sparsity(), "a": ca.DM(A).sparsity()}, opts)
    Hdm, Adm = ca.DM(H), ca.DM(A)
    qs = [np.asarray(q) for q in seq["q"]]
    bs = [np.asarray(b) for b in seq["b"]]
    lba = -np.inf * np.ones(A.shape[0])
    lbx, ubx = -np.inf * np.ones(n), np.inf * np.ones(n)
    idx = seq["first_move_index"]
    # warm-up pass (allocations, caches), not timed
    for q, b in zip(qs[:20], bs[:20]):
        S(h=Hdm, g=q, a=Adm, lba=lba, uba=b, lbx=lbx, ubx=ubx)
    wall, solver, first, failures = [], [], [], 0
    for q, b in zip(qs, bs):
        t0 = time.perf_counter()
        r = S(h=Hdm, g=q, a=Adm, lba=lba, uba=b, lbx=lbx, ubx=ubx)
        wall.append((time.perf_counter() - t0) * 1e6)
        st = S.stats()
        solver.append(st.get("t_wall_solver", float("nan")) * 1e6)
        if not st.get("success", False):
            failures += 1
        first.append(float(r["x"][idx]))
    return {
        "median_us": pct(wall, 50),
        "p99_us": pct(wall, 99),
        "solver_median_us": pct(solver, 50),
        "solver_p99_us": pct(solver, 99),
        "failures": failures,
    }, first


def main():
    seq_path, clar_path, fm_path = sys.argv[1:4]
    with open(seq_path) as f:
        seq = json.load(f)
    with open(clar_path) as f:
        clar = json.load(f)
    with open(fm_path) as f:
        fm_clar = json.load(f)
    Pu = csc_dense(seq["p"])
    H = Pu + Pu.T - np.diag(np.diag(Pu))
    A = csc_dense(seq["a"])
    rng = seq["input_range"]
    out = {"horizon": seq["horizon"]}
    out["clarabel"] = {
        "median_us": clar["median_us"],
        "p99_us": clar["p99_us"],
        "solve_median_us": clar["solve_median_us"],
        "solve_p99_us": clar["solve_p99_us"],
        "failures": clar["failures"],
        "median_iterations": clar["median_iterations"],
    }
    diffs = []
    peers = [
        ("casadi_qpoases", "qpoases", {"printLevel": "none", "error_on_fail": False}),
        ("casadi_daqp", "daqp", {"error_on_fail": False}),
    ]
    for key, plugin, opts in peers:
        res, first = run_peer(plugin, opts, seq, H, A)
        d = max(abs(a - b) for a, b in zip(first, fm_clar))
        res["max_first_move_diff"] = d / rng
        diffs.append(d)
        out[key] = res
    out["max_first_move_diff"] = max(diffs) / rng
    out["max_first_move_diff_abs"] = max(diffs)
    out["input_range"] = rng
    out["cycles"] = len(seq["q"])
    out["n_variables"] = Pu.shape[0]
    out["n_constraints"] = A.shape[0]
    out["clarabel_median_le_qpoases"] = clar["median_us"] <= out["casadi_qpoases"]["median_us"]
    # solver against solver: Clarabel's solve() call against qpOASES's own t_wall_solver (hot-started)
    out["clarabel_solve_over_qpoases_solver"] = (
        clar["solve_median_us"] / out["casadi_qpoases"]["solver_median_us"]
    )
    out["versions"] = {"casadi": ca.__version__, "numpy": np.__version__, "clarabel": "0.11 (Rust)"}
    out["source"] = seq["source"]
    _real_stdout.write(json.dumps(out) + "\n")
    _real_stdout.flush()


if __name__ == "__main__":
    main()
