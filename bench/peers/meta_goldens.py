#!/usr/bin/env python3
"""Golden values of the across-units meta-analysis (identify/src/units.rs), from an independent peer:
statsmodels.stats.meta_analysis.combine_effects.

Writes identify/tests/golden/meta_<case>.json with the peer's call, its versions, the inputs and the
values; identify/tests/units.rs computes the same with millcomp and compares.

* meta_bcg: the 13 BCG vaccine trials (Colditz et al. 1994, JAMA 271:698; the `dat.bcg` example of
  R's metafor), log risk ratios yi = log(tpos/(tpos+tneg)) - log(cpos/(cpos+cneg)) with
  vi = 1/tpos - 1/(tpos+tneg) + 1/cpos - 1/(cpos+cneg), combined by DerSimonian-Laird (method_re='dl')
  and Paule-Mandel (method_re='pm', atol 1e-12). The metafor documentation (Viechtbauer 2010, J. Stat.
  Softw. 36(3)) reports for DL: tau^2 = 0.3088, Q(12) = 152.2330, I^2 = 92.12 %, estimate -0.7141 (SE 0.1787).
* meta_phm_c1_c4: the slope k of force_y__rms against the mean flank wear VB of the three flutes
  (F = F0 + k VB) of PHM 2010 cutters c1 and c4 (datasets/real/phm2010_c{1,4}/, all 315 cuts, the force
  file joined to the wear file on `run`), each by statsmodels OLS with its Newey-West covariance
  (Bartlett kernel, maxlags from Andrews' AR(1) plug-in ceil(1.1447 (alpha n)^(1/3)), alpha =
  4 r^2/(1 - r)^4, r the lag-1 autocorrelation of the OLS residuals clamped to [0, 0.98], at most n/2,
  use_correction=True), and the force at VB = 100 um, F0 + 100 k with its delta-method SE; then the two
  cutters combined by combine_effects (dl and pm) — the whole `identify wear --columns unit=case` path
  computed by the peer.
* meta_phm_c1_c4_c6: the same with the third cutter c6 (datasets/real/phm2010_c6/): three units, where the
  DerSimonian-Laird and Paule-Mandel tau^2 differ and the HKSJ scale is not 1.

statsmodels' DL tau^2 (and I^2) are not truncated at 0 and its HKSJ variance is not truncated at q = 1;
millcomp truncates all three. Where Q < k - 1 (the force at VB = 100 um of c1 and c4: Q = 0.81) the test
checks the truncated values against the peer's fixed-effect ones; where q < 1 it does not compare the
HKSJ interval.

Usage: .venv/bin/python bench/peers/meta_goldens.py   (from the repository root; bench/peers/setup-venv)
"""
import json
import math
import os

import numpy as np
import pandas as pd
import statsmodels.api as sm
from statsmodels.stats.meta_analysis import combine_effects

from real_goldens import versions  # the same peer versions record as the real-record goldens

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "identify", "tests", "golden")
SCRIPT = "bench/peers/meta_goldens.py"

# Colditz et al. (1994), Table 1: tpos, tneg, cpos, cneg (metafor's dat.bcg)
BCG = [
    (4, 119, 11, 128), (6, 300, 29, 274), (3, 228, 11, 209), (62, 13536, 248, 12619),
    (33, 5036, 47, 5761), (180, 1361, 372, 1079), (8, 2537, 10, 619), (505, 87886, 499, 87892),
    (29, 7470, 45, 7232), (17, 1699, 65, 1600), (186, 50448, 141, 27197), (5, 2493, 3, 2338),
    (27, 16886, 29, 17825),
]


def write(case, doc):
    doc["generator"] = SCRIPT
    doc["versions"] = versions()
    with open(os.path.join(OUT, f"meta_{case}.json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


def combine(y, se):
    y = np.asarray(y, dtype=float)
    v = np.asarray(se, dtype=float) ** 2
    out = {}
    for method, kw in (("dl", {}), ("pm", {"atol": 1e-12, "maxiter": 1000})):
        r = combine_effects(y, v, method_re=method, use_t=True, **kw)
        out[method] = {
            "call": f"combine_effects(y, se**2, method_re='{method}', use_t=True"
                    + (", atol=1e-12, maxiter=1000)" if kw else ")"),
            "tau2": float(r.tau2),
            "mean_re": float(r.mean_effect_re),
            "se_re": float(r.sd_eff_w_re),
            "hksj_q": float(r.scale_hksj_re),
            "se_hksj": float(r.sd_eff_w_re_hksj),
            "ci_hksj": [float(x) for x in r.conf_int(alpha=0.05, use_t=True)[3]],
            "mean_fe": float(r.mean_effect_fe),
            "se_fe": float(r.sd_eff_w_fe),
            "q": float(r.q),
            "q_p": float(r.test_homogeneity().pvalue),
            "i2": float(r.i2),
        }
    return out


def bcg():
    y, se = [], []
    for tp, tn, cp, cn in BCG:
        y.append(math.log(tp / (tp + tn)) - math.log(cp / (cp + cn)))
        se.append(math.sqrt(1 / tp - 1 / (tp + tn) + 1 / cp - 1 / (cp + cn)))
    write("bcg", {
        "data": "Colditz et al. 1994 BCG trials (metafor dat.bcg): log risk ratios and their standard errors",
        "metafor_dl": {"tau2": 0.3088, "q": 152.2330, "i2": 0.9212, "mean": -0.7141, "se": 0.1787},
        "estimate": y,
        "std_err": se,
        "peer": combine(y, se),
    })


def hac_fit(y, x):
    xt = sm.add_constant(x)
    ols = sm.OLS(y, xt).fit()
    u = ols.resid
    uc = u - u.mean()
    r = float(np.sum(uc[1:] * uc[:-1]) / np.sum(uc * uc))
    rc = min(max(r, 0.0), 0.98)
    alpha = 4 * rc * rc / (1 - rc) ** 4
    n = len(u)
    lags = min(math.ceil(1.1447 * (alpha * n) ** (1 / 3)), n // 2)
    hac = sm.OLS(y, xt).fit(cov_type="HAC", cov_kwds={"maxlags": lags, "use_correction": True})
    return hac, r, lags


def phm(cutters):
    units = []
    for c in cutters:
        f = pd.read_csv(os.path.join(ROOT, f"datasets/real/phm2010_{c}/per_cut_force_features_{c}.csv"))
        w = pd.read_csv(os.path.join(ROOT, f"datasets/real/phm2010_{c}/per_cut_wear_{c}.csv"))
        d = f.merge(w[["run", "VB_flute_1", "VB_flute_2", "VB_flute_3"]], on="run", how="left")
        vb = d[["VB_flute_1", "VB_flute_2", "VB_flute_3"]].mean(axis=1).to_numpy()
        hac, r, lags = hac_fit(d["force_y__rms"].to_numpy(), vb)
        f0, k = (float(v) for v in hac.params)
        cov = np.asarray(hac.cov_params())
        g = np.array([1.0, 100.0])
        units.append({
            "unit": str(int(d["case"].iloc[0])),
            "lag1": r,
            "maxlags": lags,
            "f0_n": [f0, float(math.sqrt(cov[0, 0]))],
            "k_n_per_um": [k, float(math.sqrt(cov[1, 1]))],
            "force_at_vb_100um_n": [f0 + 100 * k, float(math.sqrt(g @ cov @ g))],
        })
    combined = {}
    for q in ("f0_n", "k_n_per_um", "force_at_vb_100um_n"):
        combined[q] = combine([u[q][0] for u in units], [u[q][1] for u in units])
    case = "phm_" + "_".join(cutters)
    write(case, {
        "data": f"datasets/real/phm2010_{{{','.join(cutters)}}}/per_cut_force_features_*.csv joined to per_cut_wear_*.csv on run; "
                "force_y__rms = F0 + k * mean(VB_flute_1..3), all 315 cuts of each cutter",
        "per_unit_call": "statsmodels.api.OLS(y, add_constant(vb)).fit(cov_type='HAC', "
                         "cov_kwds={'maxlags': L, 'use_correction': True})",
        "units": units,
        "peer": combined,
    })


if __name__ == "__main__":
    bcg()
    phm(("c1", "c4"))
    phm(("c1", "c4", "c6"))
