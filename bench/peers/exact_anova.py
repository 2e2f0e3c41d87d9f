#!/usr/bin/env python3
"""Exact references for the ANOVA numerics tests (doe/tests/offset_anova.rs).

Standard library only (fractions): every number below is computed in exact rational arithmetic.

1. The offset factorial: a 2^3 design, two replicates, responses 1e12 + d with d given to four
   decimals. For each main-effect term it prints the type II F
   * `decimal`: exact, from the decimal text of the responses (the true answer), and
   * `f64`: exact, from the responses as rounded to float64 (what a perfectly rounded computation
     on the same f64 inputs would give).
   The float64 limit of a term is LRE(f64 vs decimal): the correct digits left once the inputs are
   rounded to float64. A float64 program cannot be expected to do better than that.
2. The NIST StRD one-way ANOVA sets (doe/tests/fixtures/nist_strd/*.dat): the between-treatment F
   computed exactly from the f64-rounded data, and its LRE against NIST's certified F: the float64
   limit of each set.

Usage: python3 bench/peers/exact_anova.py [path/to/doe/tests/fixtures/nist_strd]
"""
import math
import os
import sys
from fractions import Fraction

# The offset factorial: A, B, C in standard order, replicate 1 then replicate 2; response = 1e12 + d
# with d from doe/tests/fixtures/offset_responses.txt (ten-thousandths), the file the tests read.
LEVELS = [(-1 if (i >> 0) & 1 == 0 else 1, -1 if (i >> 1) & 1 == 0 else 1, -1 if (i >> 2) & 1 == 0 else 1)
          for i in range(8)] * 2
HERE = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(HERE, "../../doe/tests/fixtures/offset_responses.txt")) as fh:
    Y_TEXT = [l.strip() for l in fh if l.strip() and not l.startswith("#")]
OFFSET = "1000000000000"


def solve(a, b):
    """Exact Gaussian elimination (a: list of rows of Fractions)."""
    n = len(a)
    m = [row[:] + [bb] for row, bb in zip(a, b)]
    for c in range(n):
        piv = next(r for r in range(c, n) if m[r][c] != 0)
        m[c], m[piv] = m[piv], m[c]
        for r in range(n):
            if r != c and m[r][c] != 0:
                f = m[r][c] / m[c][c]
                m[r] = [x - f * y for x, y in zip(m[r], m[c])]
    return [m[i][n] / m[i][i] for i in range(n)]


def rss(cols, y):
    """Exact residual sum of squares of y on the columns (normal equations: exact here)."""
    p = len(cols)
    xtx = [[sum(ci * cj for ci, cj in zip(cols[i], cols[j])) for j in range(p)] for i in range(p)]
    xty = [sum(ci * yi for ci, yi in zip(cols[i], y)) for i in range(p)]
    b = solve(xtx, xty)
    return sum((yi - sum(bj * c[k] for bj, c in zip(b, cols))) ** 2 for k, yi in enumerate(y))


def main_effect_f(y):
    n = len(y)
    one = [Fraction(1)] * n
    fac = [[Fraction(l[j]) for l in LEVELS] for j in range(3)]
    full = rss([one] + fac, y)
    df_e = n - 4
    out = []
    for j in range(3):
        without = rss([one] + [fac[k] for k in range(3) if k != j], y)
        out.append((without - full) / (full / df_e))
    return out


def lre(x, c):
    x, c = Fraction(x), Fraction(c)
    if x == c:
        return math.inf
    return -math.log10(abs((x - c) / c))


def dec(q, digits=17):
    """A Fraction as a decimal string with `digits` significant digits."""
    return f"{float(q):.{digits}e}" if digits <= 17 else str(q)


def offset_factorial():
    y_dec = [Fraction(t) for t in Y_TEXT]
    # float() of the decimal text is correctly rounded, as Rust's parse of the same text
    y_f64 = [Fraction(float(t)) for t in Y_TEXT]
    assert all(Fraction(OFFSET) < v < Fraction(OFFSET) + 2 for v in y_dec)
    f_dec = main_effect_f(y_dec)
    f_f64 = main_effect_f(y_f64)
    print("offset factorial (2^3 x 2, main effects, responses 1e12 + d):")
    for name, a, b in zip("ABC", f_dec, f_f64):
        print(f"  F_{name}: decimal {float(a):.17e}  f64-exact {float(b):.17e}  float64 limit LRE {lre(b, a):.2f}")


def offset_line():
    """The same responses against x = 1e6 + i (i = 0..15): slope and intercept of the straight
    line, exact on the decimal data and on their f64 values (for identify's fit_linear test)."""
    x = [Fraction(10**6 + i) for i in range(16)]
    for label, y in [("decimal", [Fraction(t) for t in Y_TEXT]),
                     ("f64-exact", [Fraction(float(t)) for t in Y_TEXT])]:
        n = len(x)
        mx, my = sum(x) / n, sum(y) / n
        sxx = sum((xi - mx) ** 2 for xi in x)
        slope = sum((xi - mx) * (yi - my) for xi, yi in zip(x, y)) / sxx
        icpt = my - slope * mx
        res = sum((yi - icpt - slope * xi) ** 2 for xi, yi in zip(x, y))
        print(f"  line {label}: slope {float(slope):.17e}  intercept - 1e12 {float(icpt - Fraction(OFFSET)):.17e}  "
              f"RSS {float(res):.17e}")


def read_anova(path):
    lines = open(path).read().splitlines()
    cert_f = None
    for l in lines[:60]:
        if l.startswith("Between "):
            cert_f = Fraction(l.split()[-1])
    data = []
    for l in lines[60:]:
        w = l.split()
        if len(w) == 2:
            data.append((w[0], w[1]))
    return cert_f, data


def oneway_f(data, conv):
    groups = {}
    for g, v in data:
        groups.setdefault(g, []).append(conv(v))
    allv = [v for vs in groups.values() for v in vs]
    n, k = len(allv), len(groups)
    grand = sum(allv) / n
    means = {g: sum(vs) / len(vs) for g, vs in groups.items()}
    ssb = sum(len(vs) * (means[g] - grand) ** 2 for g, vs in groups.items())
    ssw = sum((v - means[g]) ** 2 for g, vs in groups.items() for v in vs)
    return (ssb / (k - 1)) / (ssw / (n - k))


def nist_sets(d):
    print("NIST StRD one-way ANOVA: certified F, exact F of the f64-rounded data, float64 limit LRE")
    for name in ["SiRstv", "SmLs01", "SmLs02", "SmLs03", "AtmWtAg", "SmLs04", "SmLs05", "SmLs06",
                 "SmLs07", "SmLs08", "SmLs09"]:
        cert_f, data = read_anova(os.path.join(d, name + ".dat"))
        f64 = oneway_f(data, lambda s: Fraction(float(s)))
        exact = oneway_f(data, Fraction)
        print(f"  {name:8s} certified {float(cert_f):.15e}  decimal-exact {float(exact):.15e}  "
              f"f64-exact {float(f64):.17e}  limit LRE {min(lre(f64, cert_f), 15):.2f}")


if __name__ == "__main__":
    offset_factorial()
    print("offset straight line (y = 1e12 + d against x = 1e6 + i):")
    offset_line()
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "../../doe/tests/fixtures/nist_strd")
    nist_sets(d)
