#!/usr/bin/env python3
"""Golden values on the real records (datasets/real/), from independent peers.

Writes identify/tests/golden/real_<case>.json with the peer's call, its versions and the values;
identify/tests/real_records.rs computes the same quantities with millcomp and compares.

* real_thermal_baseline: the plain least-squares baseline of the thermal study — disp_ch1_um on all
  16 temperatures (as rise from row 0) plus an intercept, on the training rows of the record
  decimated to every 8th row (rows 0, 8, 16, ...; the first half by time, t < 50 % of the span) —
  by statsmodels OLS, with its Newey-West (HAC) covariance: Bartlett kernel, maxlags from Andrews'
  AR(1) plug-in ceil(1.1447 (alpha n)^(1/3)), alpha = 4 r^2/(1 - r)^4, r the lag-1 autocorrelation of
  the OLS residuals clamped to [0, 0.98], use_correction=True (the n/(n - k) factor).
* real_wear_power: force_y__rms of PHM 2010 cutter c1 against the cut number n, cuts 1..199,
  F = a + b (n/100)^c, by scipy.optimize.least_squares (trf, analytic Jacobian) from a = 6, b = 2, c = 1.

Usage: .venv/bin/python bench/peers/real_goldens.py   (from the repository root; bench/peers/setup-venv)
"""
import json
import math
import os
import platform

import numpy as np
import pandas as pd
import scipy
import statsmodels
import statsmodels.api as sm
from scipy.optimize import least_squares

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "identify", "tests", "golden")
SCRIPT = "bench/peers/real_goldens.py"


def versions():
    return {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "statsmodels": statsmodels.__version__,
        "pandas": pd.__version__,
    }


def write(case, doc):
    doc["generator"] = SCRIPT
    doc["versions"] = versions()
    with open(os.path.join(OUT, f"real_{case}.json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


def thermal_baseline():
    d = pd.read_csv(os.path.join(ROOT, "datasets/real/fl_thermal/thermal_drift.csv"))
    d = d.iloc[::8].reset_index(drop=True)
    t = d["time_s"].to_numpy()
    half = t[0] + 0.5 * (t[-1] - t[0])
    train = t < half
    temps = [f"temp_t{i}_C" for i in range(1, 17)]
    x = d[temps].to_numpy()
    x = x - x[0]
    y = d["disp_ch1_um"].to_numpy()
    xt = sm.add_constant(x[train], prepend=False)
    ols = sm.OLS(y[train], xt).fit()
    u = ols.resid
    uc = u - u.mean()
    r = float(np.sum(uc[1:] * uc[:-1]) / np.sum(uc * uc))
    rc = min(max(r, 0.0), 0.98)
    alpha = 4 * rc * rc / (1 - rc) ** 4
    n = len(u)
    lags = min(math.ceil(1.1447 * (alpha * n) ** (1 / 3)), n // 2)
    hac = sm.OLS(y[train], xt).fit(cov_type="HAC", cov_kwds={"maxlags": lags, "use_correction": True})
    names = [f"m_{c}_um_per_k" for c in temps] + ["offset_um"]
    write("thermal_baseline", {
        "call": "statsmodels.api.OLS(y, add_constant(dT, prepend=False)).fit(cov_type='HAC', "
                "cov_kwds={'maxlags': L, 'use_correction': True})",
        "data": "datasets/real/fl_thermal/thermal_drift.csv rows 0, 8, 16, ...; training rows t < 50 % of the span; "
                "disp_ch1_um on temp_t1_C..temp_t16_C minus their row-0 values",
        "n_train": int(train.sum()),
        "lag1": r,
        "maxlags": lags,
        "names": names,
        "params": [float(v) for v in hac.params],
        "std_err": [float(v) for v in hac.bse],
    })


def wear_power():
    f = pd.read_csv(os.path.join(ROOT, "datasets/real/phm2010_c1/per_cut_force_features_c1.csv"))
    n = f["run"].to_numpy(dtype=float)
    y = f["force_y__rms"].to_numpy()
    m = (n >= 1) & (n <= 199)
    n, y = n[m], y[m]

    def res(p):
        return p[0] + p[1] * (n / 100.0) ** p[2] - y

    def jac(p):
        s = (n / 100.0) ** p[2]
        return np.column_stack([np.ones_like(n), s, p[1] * s * np.log(n / 100.0)])

    x0 = [6.0, 2.0, 1.0]
    sol = least_squares(res, x0, jac=jac, method="trf", x_scale="jac", ftol=1e-15, xtol=1e-15,
                        gtol=1e-15, max_nfev=10000)
    write("wear_power", {
        "call": "scipy.optimize.least_squares(res, [6, 2, 1], jac=jac, method='trf', x_scale='jac', "
                "ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=10000)",
        "data": "datasets/real/phm2010_c1/per_cut_force_features_c1.csv, force_y__rms against run, cuts 1..199",
        "model": "F = a + b (n/100)^c",
        "names": ["a_n", "b_n", "c"],
        "params": [float(v) for v in sol.x],
        "cost": float(sol.cost),
    })


if __name__ == "__main__":
    thermal_baseline()
    wear_power()
