#!/usr/bin/env python3
"""Golden files for millcomp-doe (doe/tests/golden/*.json), computed with independent Python peers.

Run:  $(bench/peers/setup-venv) bench/peers/doe_goldens.py        (or /tmp/pyvenv/bin/python …)
      add --skip-ma-search to reuse the minimum-aberration word-length patterns already in fractional.json.

Writes
  anova_clayton.json  statsmodels OLS + anova_lm(typ=2) on seed 000 Table 3-3 (main-effects and 2FI models)
  anova_more.json     statsmodels on a face-centred CCD (quadratic, non-orthogonal terms) and on an unbalanced
                      3-level-label x numeric data set (multi-df terms), with influence diagnostics and the
                      actual-unit coefficients/covariance of the CCD fit
  fractional.json     every catalogue entry (doe/data/fractional_catalogue.csv): pyDOE3 fracfact() design,
                      fracfact_aliasing() alias groups, word-length pattern from the pyDOE3 design, and the
                      minimum-aberration word-length pattern found by exhaustive search; pyDOE3
                      fracfact_by_res() run counts for k = 4..11, resolutions III..V
  noncentral_f.json   scipy.stats.ncf cdf/sf and F-test power values
  lenth.json          Montgomery Example 6.2 effects, Lenth PSE/ME/SME with scipy t quantiles
  rsm.json            pyDOE3 ccdesign / bbdesign points and CCD axial distances

Every file records the script, the tool versions and the exact calls.
"""
import itertools
import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import scipy
import statsmodels
import statsmodels.api as sm
import statsmodels.formula.api as smf
from scipy import stats
from statsmodels.stats.outliers_influence import OLSInfluence

import pyDOE3
from pyDOE3 import bbdesign, ccdesign, fracfact, fracfact_by_res
from pyDOE3.doe_factorial import fracfact_aliasing

ROOT = Path(__file__).resolve().parents[2]
GOLD = ROOT / "doe" / "tests" / "golden"
FIX = ROOT / "doe" / "tests" / "fixtures"
LETTERS = "ABCDEFGHJKLMNOPQRSTUVWXYZ"  # millcomp letters (I skipped)
PYLET = "abcdefghijklmnopqrstuvwxyz"  # pyDOE3 letters

VERSIONS = {
    "python": sys.version.split()[0],
    "numpy": np.__version__,
    "scipy": scipy.__version__,
    "pandas": pd.__version__,
    "statsmodels": statsmodels.__version__,
    "pyDOE3": getattr(pyDOE3, "__version__", "1.6.2"),
}


def header(calls):
    return {"script": "bench/peers/doe_goldens.py", "versions": VERSIONS, "calls": calls}


def write(name, obj):
    GOLD.mkdir(parents=True, exist_ok=True)
    with open(GOLD / name, "w") as f:
        json.dump(obj, f, indent=1, sort_keys=False)
        f.write("\n")
    print("wrote", GOLD / name)


def code(v):
    lo, hi = v.min(), v.max()
    return (v - (lo + hi) / 2) / ((hi - lo) / 2)


def anova_record(df, formula, term_names):
    """OLS + type II ANOVA; term_names maps patsy term -> millcomp term name."""
    fit = smf.ols(formula, df).fit()
    tab = sm.stats.anova_lm(fit, typ=2)
    infl = OLSInfluence(fit)
    terms = []
    for patsy_name, ours in term_names.items():
        row = tab.loc[patsy_name]
        terms.append({
            "term": ours,
            "sum_sq": float(row["sum_sq"]),
            "df": float(row["df"]),
            "f": None if math.isnan(row["F"]) else float(row["F"]),
            "p_value": None if math.isnan(row["PR(>F)"]) else float(row["PR(>F)"]),
        })
    out = {
        "formula": formula,
        "terms": terms,
        "params": {k: float(v) for k, v in fit.params.items()},
        "bse": {k: float(v) for k, v in fit.bse.items()} if fit.df_resid > 0 else None,
        "residual_df": float(fit.df_resid),
        "ssr": float(fit.ssr),
        "r_squared": float(fit.rsquared),
        "adj_r_squared": float(fit.rsquared_adj) if fit.df_resid > 0 else None,
    }
    if fit.df_resid > 0:
        out["hat"] = [float(x) for x in infl.hat_matrix_diag]
        out["studentized"] = [float(x) for x in infl.resid_studentized_internal]
        out["cooks_d"] = [float(x) for x in infl.cooks_distance[0]]
        h = infl.hat_matrix_diag
        press = float(np.sum((fit.resid / (1 - h)) ** 2))
        sst = float(np.sum((fit.model.endog - fit.model.endog.mean()) ** 2))
        out["pred_r_squared"] = 1 - press / sst
    return out


def anova_clayton():
    d = pd.read_csv(FIX / "clayton_table_3_3.csv")
    for c in ["depth_um", "speed_rpm", "upfeed_um"]:
        d[c + "_c"] = code(d[c].astype(float))
    main = {"depth_um_c": "depth_um", "speed_rpm_c": "speed_rpm", "upfeed_um_c": "upfeed_um"}
    twofi = dict(main)
    twofi.update({
        "depth_um_c:speed_rpm_c": "depth_um:speed_rpm",
        "depth_um_c:upfeed_um_c": "depth_um:upfeed_um",
        "speed_rpm_c:upfeed_um_c": "speed_rpm:upfeed_um",
    })
    res = {}
    calls = []
    for y in ["fx_n", "fy_n", "fz_n"]:
        f_main = f"{y} ~ depth_um_c + speed_rpm_c + upfeed_um_c"
        f_2fi = f"{y} ~ depth_um_c + speed_rpm_c + upfeed_um_c + depth_um_c:speed_rpm_c + depth_um_c:upfeed_um_c + speed_rpm_c:upfeed_um_c"
        res[y] = {"main": anova_record(d, f_main, main), "2fi": anova_record(d, f_2fi, twofi)}
        # Same F/p with actual (uncoded) units: coding does not change the ANOVA.
        fa = smf.ols(f"{y} ~ depth_um + speed_rpm + upfeed_um", d).fit()
        ta = sm.stats.anova_lm(fa, typ=2)
        res[y]["main_actual_units_F"] = {k: float(ta.loc[k, "F"]) for k in ["depth_um", "speed_rpm", "upfeed_um"]}
        calls += [f"statsmodels.formula.api.ols('{f_main}', coded).fit(); statsmodels.api.stats.anova_lm(fit, typ=2)",
                  f"statsmodels.formula.api.ols('{f_2fi}', coded).fit(); anova_lm(fit, typ=2)"]
    calls.append("coded = (x - (min+max)/2) / ((max-min)/2) for depth_um, speed_rpm, upfeed_um")
    calls.append("statsmodels.stats.outliers_influence.OLSInfluence(fit): hat_matrix_diag, resid_studentized_internal, cooks_distance[0]")
    out = header(calls)
    out["data"] = "doe/tests/fixtures/clayton_table_3_3.csv (seed 000, Table 3-3)"
    out["responses"] = res
    write("anova_clayton.json", out)


def anova_more():
    # (1) Face-centred CCD in 2 factors + 3 centre runs (11 runs), deterministic response with curvature.
    pts = [(-1, -1), (1, -1), (-1, 1), (1, 1), (-1, 0), (1, 0), (0, -1), (0, 1), (0, 0), (0, 0), (0, 0)]
    d = pd.DataFrame(pts, columns=["a_c", "b_c"]).astype(float)
    # actual units: a = depth 100..200 um, b = upfeed 10..20 um/rev
    d["depth_um"] = 150 + 50 * d["a_c"]
    d["upfeed_um"] = 15 + 5 * d["b_c"]
    noise = np.array([0.031, -0.052, 0.017, 0.044, -0.021, 0.008, -0.039, 0.026, 0.012, -0.018, 0.005])
    d["force_n"] = 2.0 + 0.64 * d.a_c + 0.61 * d.b_c + 0.05 * d.a_c * d.b_c + 0.30 * d.a_c ** 2 - 0.12 * d.b_c ** 2 + noise
    f_q = "force_n ~ a_c + b_c + a_c:b_c + I(a_c**2) + I(b_c**2)"
    names = {"a_c": "depth_um", "b_c": "upfeed_um", "a_c:b_c": "depth_um:upfeed_um",
             "I(a_c ** 2)": "depth_um^2", "I(b_c ** 2)": "upfeed_um^2"}
    ccd = anova_record(d, f_q, names)
    # lack of fit: the 3 centre runs give 2 pure-error df
    # actual-unit fit (coefficients and covariance in actual units)
    fa = smf.ols("force_n ~ depth_um + upfeed_um + depth_um:upfeed_um + I(depth_um**2) + I(upfeed_um**2)", d).fit()
    ccd["actual_params"] = {k: float(v) for k, v in fa.params.items()}
    ccd["actual_cov"] = fa.cov_params().values.tolist()
    ccd["actual_param_order"] = list(fa.params.index)
    pe = d.loc[(d.a_c == 0) & (d.b_c == 0), "force_n"]
    ss_pe = float(((pe - pe.mean()) ** 2).sum())
    fit = smf.ols(f_q, d).fit()
    df_pe = len(pe) - 1
    df_lof = int(fit.df_resid) - df_pe
    ss_lof = float(fit.ssr) - ss_pe
    F = (ss_lof / df_lof) / (ss_pe / df_pe)
    ccd["lack_of_fit"] = {"ss_lof": ss_lof, "df_lof": df_lof, "ss_pe": ss_pe, "df_pe": df_pe, "f": F,
                          "p_value": float(stats.f.sf(F, df_lof, df_pe))}
    ccd["data"] = {"depth_um": d.depth_um.tolist(), "upfeed_um": d.upfeed_um.tolist(), "force_n": d.force_n.tolist()}

    # (2) Unbalanced 3-level label x numeric with interaction (multi-df type II terms).
    mat = ["S7", "1018", "6061"] * 4
    dep = [100, 100, 100, 200, 200, 200, 100, 100, 100, 200, 200, 200]
    w = {"S7": 2.4, "1018": 1.8, "6061": 1.0}
    noise2 = [0.05, -0.03, 0.02, -0.04, 0.06, -0.01, 0.03, 0.01, -0.05, 0.02, -0.02, 0.04]
    y = [w[m] * (d_ / 100) + 0.2 * (m == "S7") * (d_ == 200) + e for m, d_, e in zip(mat, dep, noise2)]
    m2 = pd.DataFrame({"material": mat, "depth_um": dep, "fz_n": y}).iloc[:-1]  # drop the last run: unbalanced
    m2["depth_c"] = code(m2.depth_um.astype(float))
    f_m = "fz_n ~ C(material, Sum) + depth_c + C(material, Sum):depth_c"
    mixed = anova_record(m2, f_m, {"C(material, Sum)": "material", "depth_c": "depth_um",
                                   "C(material, Sum):depth_c": "material:depth_um"})
    mixed["data"] = {"material": m2.material.tolist(), "depth_um": m2.depth_um.tolist(), "fz_n": m2.fz_n.tolist()}
    calls = [f"statsmodels.formula.api.ols('{f_q}', ccd).fit(); anova_lm(fit, typ=2)",
             "statsmodels.formula.api.ols('force_n ~ depth_um + upfeed_um + depth_um:upfeed_um + I(depth_um**2) + I(upfeed_um**2)', ccd).fit(): params, cov_params()",
             "lack of fit by hand: pure error from the 3 centre runs, scipy.stats.f.sf",
             f"statsmodels.formula.api.ols('{f_m}', mixed).fit(); anova_lm(fit, typ=2)"]
    out = header(calls)
    out["ccd"] = ccd
    out["mixed"] = mixed
    write("anova_more.json", out)


# ---------------------------------------------------------------- fractional factorials
def popcount(x):
    return bin(x).count("1")


def parse_gens(gens):
    out = []
    for g in gens.split():
        lhs, rhs = g.split("=")
        out.append((LETTERS.index(lhs), [LETTERS.index(c) for c in rhs]))
    return out


def wlp_exhaustive(k, n):
    """Minimum-aberration word-length pattern (A3..Ak) over all generator sets of a 2^(k-(k-n)) design."""
    p = k - n
    for R in range(k, 2, -1):
        cands = [c for c in range(1, 1 << n) if popcount(c) >= max(2, R - 1)]
        if len(cands) < p:
            continue
        best = None
        for combo in itertools.combinations(cands, p):
            words = [g | (1 << (n + j)) for j, g in enumerate(combo)]
            counts = [0] * (k + 1)
            acc = 0
            ok = True
            for i in range(1, 1 << p):
                acc ^= words[(i & -i).bit_length() - 1]
                L = popcount(acc)
                if L < R:
                    ok = False
                    break
                counts[L] += 1
            if not ok:
                continue
            key = counts[3:]
            if best is None or key < best:
                best = key
        if best is not None:
            return best, R
    return None, None


def fractional(skip_search):
    rows = []
    for line in open(ROOT / "doe" / "data" / "fractional_catalogue.csv"):
        if line.startswith("#") or line.startswith("k,") or not line.strip():
            continue
        k, runs, gens, res, wlp, src = line.rstrip("\n").split(",")
        rows.append((int(k), int(runs), gens, int(res), [int(x) for x in wlp.split()], src))
    prev = {}
    if skip_search and (GOLD / "fractional.json").exists():
        for e in json.load(open(GOLD / "fractional.json"))["designs"]:
            prev[(e["k"], e["runs"])] = (e["ma_wlp_exhaustive"], e["ma_resolution_exhaustive"])
    designs = []
    for k, runs, gens, res, wlp, src in rows:
        n = runs.bit_length() - 1
        g = parse_gens(gens)
        # pyDOE3 generator string: base factors a b c …, then the words in pyDOE3 letters
        word_of = {f: w for f, w in g}
        parts = []
        for i in range(k):
            if i in word_of:
                parts.append("".join(PYLET[j] for j in word_of[i]))
            else:
                parts.append(PYLET[i])
        genstr = " ".join(parts)
        H = fracfact(genstr)
        # word-length pattern and resolution from the pyDOE3 design itself
        counts = [0] * (k + 1)
        for r in range(1, k + 1):
            for c in itertools.combinations(range(k), r):
                v = np.prod(H[:, c], axis=1)
                if np.all(v == v[0]):
                    counts[r] += 1
        res_py = next((r for r in range(1, k + 1) if counts[r]), None)
        amap, _ = fracfact_aliasing(H)
        # alias structure in millcomp's convention: for each main effect and 2FI, aliases of order <= 3
        alias = {}
        for grp in amap:
            members = [m.strip() for m in grp.split("=")]
            members = [m for m in members if m]
            for m in members:
                if len(m) <= 2:
                    others = sorted([o for o in members if o != m and len(o) <= 3],
                                    key=lambda o: (len(o), [PYLET.index(ch) for ch in o]))
                    if others:
                        key = ":".join(LETTERS[PYLET.index(ch)] for ch in m)
                        alias[key] = [":".join(LETTERS[PYLET.index(ch)] for ch in o) for o in others]
        if (k, runs) in prev:
            ma, ma_r = prev[(k, runs)]
        elif skip_search:
            ma, ma_r = None, None
        else:
            ma, ma_r = wlp_exhaustive(k, n)
            print(f"  MA search k={k} runs={runs}: {ma}", flush=True)
        designs.append({
            "k": k, "runs": runs, "generators": gens.split(), "catalogue_source": src,
            "pydoe3_gen": genstr, "pydoe3_runs": int(H.shape[0]),
            "pydoe3_wlp": counts[3:], "pydoe3_resolution": res_py,
            "alias_structure": alias,
            "ma_wlp_exhaustive": ma, "ma_resolution_exhaustive": ma_r,
        })
    by_res = []
    for k in range(4, 12):
        for R in (3, 4, 5):
            try:
                H = fracfact_by_res(k, R)
                r = int(H.shape[0])
                # the resolution pyDOE3's design actually has (shortest constant product of columns)
                actual = next((L for L in range(1, k + 1) for c in itertools.combinations(range(k), L)
                               if np.all(np.prod(H[:, c], axis=1) == np.prod(H[0, c]))), None)
            except ValueError as e:
                r, actual = None, None
            by_res.append({"k": k, "resolution": R, "pydoe3_runs": r, "pydoe3_actual_resolution": actual})
    calls = ["pyDOE3.fracfact(gen) with gen = base letters + generator words in pyDOE3's a..z letters",
             "pyDOE3.doe_factorial.fracfact_aliasing(design) -> alias groups (kept: aliases of order <= 3 of main effects and 2FIs)",
             "word-length pattern: products of all factor subsets of the pyDOE3 design that are constant",
             "minimum-aberration WLP: exhaustive search over all generator sets (wlp_exhaustive in this script)",
             "pyDOE3.fracfact_by_res(k, R) for k = 4..11, R = 3..5: row count and the resolution the returned design really has"]
    out = header(calls)
    out["letters"] = LETTERS
    out["designs"] = designs
    out["fracfact_by_res"] = by_res
    write("fractional.json", out)


# ---------------------------------------------------------------- distributions
def noncentral_f():
    pts = []
    for x, d1, d2, lam in [(0.5, 1, 4, 0.0), (3.0, 2, 10, 4.0), (1.0, 1, 4, 8.0), (7.7086, 1, 4, 8.0),
                           (2.5, 3, 12, 10.0), (4.0, 1, 1, 2.0), (1.5, 5, 30, 40.0), (10.0, 2, 7, 150.0),
                           (0.2, 4, 9, 0.5), (25.0, 1, 16, 300.0)]:
        pts.append({"x": x, "d1": d1, "d2": d2, "lambda": lam,
                    "cdf": float(stats.ncf.cdf(x, d1, d2, lam)) if lam > 0 else float(stats.f.cdf(x, d1, d2)),
                    "sf": float(stats.ncf.sf(x, d1, d2, lam)) if lam > 0 else float(stats.f.sf(x, d1, d2))})
    powers = []
    for d1, d2, lam, alpha in [(1, 4, 8.0, 0.05), (1, 4, 32.0, 0.05), (1, 8, 16.0, 0.05), (2, 10, 12.0, 0.01),
                               (1, 1, 50.0, 0.05)]:
        crit = float(stats.f.ppf(1 - alpha, d1, d2))
        powers.append({"d1": d1, "d2": d2, "lambda": lam, "alpha": alpha, "f_crit": crit,
                       "power": float(stats.ncf.sf(crit, d1, d2, lam))})
    calls = ["scipy.stats.ncf.cdf(x, d1, d2, lambda), scipy.stats.ncf.sf(...) (scipy.stats.f for lambda = 0)",
             "power: scipy.stats.ncf.sf(scipy.stats.f.ppf(1 - alpha, d1, d2), d1, d2, lambda)"]
    out = header(calls)
    out["points"] = pts
    out["power"] = powers
    write("noncentral_f.json", out)


def lenth_golden():
    d = pd.read_csv(FIX / "montgomery_example_6_2.csv")
    X = d[list("ABCD")].values.astype(float)
    y = d.filtration_rate.values.astype(float)
    effects = {}
    for r in range(1, 5):
        for c in itertools.combinations(range(4), r):
            effects[":".join("ABCD"[i] for i in c)] = float(np.prod(X[:, c], axis=1) @ y / 8)
    a = np.abs(np.array(list(effects.values())))
    m = len(a)
    s0 = 1.5 * np.median(a)
    pse = 1.5 * np.median(a[a < 2.5 * s0])
    dd = m / 3
    me = float(stats.t.ppf(0.975, dd) * pse)
    gamma = (1 + 0.95 ** (1 / m)) / 2
    sme = float(stats.t.ppf(gamma, dd) * pse)
    calls = ["effects = contrast/8 from doe/tests/fixtures/montgomery_example_6_2.csv",
             "Lenth (1989): s0 = 1.5 median|c|, PSE = 1.5 median{|c| < 2.5 s0}, d = m/3",
             "ME = scipy.stats.t.ppf(0.975, d) * PSE; SME = scipy.stats.t.ppf((1 + 0.95**(1/m))/2, d) * PSE"]
    out = header(calls)
    out["published"] = {"source": "Montgomery, Design and Analysis of Experiments, 8th ed. (2013), Example 6.2, Table 6.11 effect estimates",
                        "effects": {"A": 21.625, "B": 3.125, "C": 9.875, "D": 14.625, "A:B": 0.125, "A:C": -18.125,
                                    "A:D": 16.625, "B:C": 2.375, "B:D": -0.375, "C:D": -1.125, "A:B:C": 1.875,
                                    "A:B:D": 4.125, "A:C:D": -1.625, "B:C:D": -2.625, "A:B:C:D": 1.375},
                        "pse": 2.625}
    out["computed"] = {"effects": effects, "s0": float(s0), "pse": float(pse), "df": dd, "me": me, "sme": sme,
                       "t_0975": float(stats.t.ppf(0.975, dd)), "t_gamma": float(stats.t.ppf(gamma, dd))}
    write("lenth.json", out)


def rsm():
    out = header(["pyDOE3.ccdesign(k, center=(4, 4), alpha='o'|'r', face='ccc') for k = 2, 3, 4",
                  "pyDOE3.bbdesign(k, center=3) for k = 3, 4, 5"])
    out["ccd"] = []
    for k in (2, 3, 4):
        for alpha in ("o", "r"):
            H = ccdesign(k, center=(4, 4), alpha=alpha, face="ccc")
            a = float(np.abs(H).max())
            out["ccd"].append({"k": k, "alpha_rule": alpha, "alpha": a, "points": H.tolist()})
    out["bbd"] = []
    for k in (3, 4, 5):
        H = bbdesign(k, center=3)
        out["bbd"].append({"k": k, "points": H.tolist()})
    write("rsm.json", out)


if __name__ == "__main__":
    skip = "--skip-ma-search" in sys.argv
    anova_clayton()
    anova_more()
    noncentral_f()
    lenth_golden()
    rsm()
    fractional(skip)
