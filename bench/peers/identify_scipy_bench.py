#!/usr/bin/env python3
"""Time per fit of scipy.optimize.least_squares on the identify golden problems, side by side
with millcomp-identify's criterion benchmark (identify/benches/fits.rs) on the same data, model
and starting point.

Usage (from the repository root):
  CARGO_TARGET_DIR=/tmp/target-identify cargo bench -p millcomp-identify --bench fits
  /tmp/pyvenv/bin/python bench/peers/identify_scipy_bench.py [--criterion-dir DIR]

The criterion directory defaults to $CARGO_TARGET_DIR/criterion (or target/criterion). scipy is
called exactly as in bench/peers/identify_goldens.py (method='trf', x_scale='jac', tolerances
1e-15 raised to EPS by scipy; analytic Jacobian for the thermal model, '3-point' for the spindle,
whose Rust Jacobian is also a central difference).
"""
import argparse
import json
import os
import statistics
import sys
import time
import warnings

import numpy as np
import scipy
from scipy.optimize import least_squares

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from identify_goldens import TOL, spindle_sim, thermal_jac, thermal_model  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GOLDEN = os.path.join(ROOT, "identify", "tests", "golden")
CASES = ["thermal_exponential", "spindle_2nd", "spindle_pole_deadtime"]


def problem(case):
    g = json.load(open(os.path.join(GOLDEN, case + ".json")))
    x0 = np.array(g["x0"])
    if case == "thermal_exponential":
        t = np.array(g["data"]["t_s"]); y = np.array(g["data"]["drift_um"])
        return (lambda: least_squares(lambda p: thermal_model(p, t) - y, x0,
                                      jac=lambda p: thermal_jac(p, t), method="trf",
                                      x_scale="jac", max_nfev=10000, **TOL)), g
    t = np.array(g["data"]["t_s"]); u = np.array(g["data"]["u_v"]); y = np.array(g["data"]["y_um"])
    ep, dt = g["extra_pole"], g["dead_time"]
    return (lambda: least_squares(lambda p: spindle_sim(p, t, u, ep, dt) - y, x0, jac="3-point",
                                  method="trf", x_scale="jac", max_nfev=10000, **TOL)), g


def time_it(fn, min_time=2.0, min_reps=5):
    times = []
    start = time.perf_counter()
    while len(times) < min_reps or time.perf_counter() - start < min_time:
        t0 = time.perf_counter(); fn(); times.append(time.perf_counter() - t0)
    return statistics.median(times), len(times)


def criterion_ns(cdir, case):
    path = os.path.join(cdir, "identify_fit", case, "new", "estimates.json")
    try:
        e = json.load(open(path))
        return e["median"]["point_estimate"]
    except (OSError, KeyError, ValueError):
        return None


def main():
    ap = argparse.ArgumentParser()
    tgt = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    ap.add_argument("--criterion-dir", default=os.path.join(tgt, "criterion"))
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    print(f"scipy {scipy.__version__}, numpy {np.__version__}; criterion dir {args.criterion_dir}")
    print(f"{'problem':<24}{'scipy median':>14}{'reps':>6}{'rust median':>14}{'speed-up':>10}")
    out = {}
    for case in CASES:
        fn, g = problem(case)
        s, reps = time_it(fn)
        r_ns = criterion_ns(args.criterion_dir, case)
        r = r_ns * 1e-9 if r_ns is not None else None
        ratio = s / r if r else None
        out[case] = dict(scipy_s=s, rust_s=r, speedup=ratio, reps=reps)
        rs = f"{r*1e3:11.3f} ms" if r else "   (no bench)"
        rt = f"{ratio:9.1f}x" if ratio else "        -"
        print(f"{case:<24}{s*1e3:11.3f} ms{reps:>6}{rs}{rt}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
