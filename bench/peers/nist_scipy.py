#!/usr/bin/env python3
"""The peer on the NIST StRD nonlinear problems: scipy.optimize.least_squares from NIST's two
certified starts (central-difference Jacobian), with scipy's default tolerances (1e-8) and with tight ones (1e-15), printing the
same LREs (log relative error against NIST's certified values, capped at 11) as
identify/tests/nist_strd.rs prints for millcomp's solver. A comparison, not a test.

Usage: "$(bench/peers/setup-venv)" bench/peers/nist_scipy.py   (from the repository root)
"""
import math
import os

import numpy as np
import scipy
from scipy.optimize import least_squares

HERE = os.path.dirname(os.path.abspath(__file__))
DIR = os.path.join(HERE, "../../identify/tests/fixtures/nist_strd/nonlinear")

# f(x, b) as the files state them (x: the predictor column)
MODELS = {
    "Misra1a": lambda x, b: b[0] * (1 - np.exp(-b[1] * x)),
    "BoxBOD": lambda x, b: b[0] * (1 - np.exp(-b[1] * x)),
    "MGH09": lambda x, b: b[0] * (x**2 + x * b[1]) / (x**2 + x * b[2] + b[3]),
    "MGH10": lambda x, b: b[0] * np.exp(b[1] / (x + b[2])),
    "Bennett5": lambda x, b: b[0] * (b[1] + x) ** (-1 / b[2]),
    "Eckerle4": lambda x, b: (b[0] / b[1]) * np.exp(-0.5 * ((x - b[2]) / b[1]) ** 2),
    "Lanczos1": lambda x, b: b[0] * np.exp(-b[1] * x) + b[2] * np.exp(-b[3] * x) + b[4] * np.exp(-b[5] * x),
    "Rat43": lambda x, b: b[0] / (1 + np.exp(b[1] - b[2] * x)) ** (1 / b[3]),
}


def read(name):
    lines = open(os.path.join(DIR, name + ".dat")).read().splitlines()
    rng = {}
    for l in lines[:15]:
        w = l.split()
        if w and w[0] in ("Certified", "Data") and "(lines" in l:
            nums = [int(t.strip(")")) for t in l.split("(lines")[1].split() if t.strip(")").isdigit()]
            rng[w[0]] = nums
    starts, cert = [[], []], []
    for l in lines[rng["Certified"][0] - 1:rng["Certified"][1]]:
        if "=" in l and l.strip().startswith("b"):
            v = [float(t) for t in l.split("=")[1].split()]
            starts[0].append(v[0])
            starts[1].append(v[1])
            cert.append(v[2])
    data = np.array([[float(t) for t in l.split()] for l in lines[rng["Data"][0] - 1:rng["Data"][1]]])
    return starts, np.array(cert), data[:, 1], data[:, 0]


def lre(x, c):
    e = abs((x - c) / c)
    return 11.0 if e == 0 else max(0.0, min(11.0, -math.log10(e)))


def main():
    print(f"scipy {scipy.__version__}: least_squares(method='trf', jac='3-point'), min LRE over parameters, nfev, status")
    print(f"{'problem':9} {'start':>5} {'default tol':>18} {'tol 1e-15':>18}")
    for name, f in MODELS.items():
        starts, cert, x, y = read(name)
        for k, s in enumerate(starts):
            row = []
            for tol in (1e-8, 1e-15):
                r = least_squares(lambda b: f(x, b) - y, np.array(s), ftol=tol, xtol=tol, gtol=tol,
                                  max_nfev=10000, jac="3-point")
                row.append(f"{min(lre(b, c) for b, c in zip(r.x, cert)):5.1f} {r.nfev:5d} {r.status:2d}")
            print(f"{name:9} {k + 1:>5} {row[0]:>18} {row[1]:>18}")


if __name__ == "__main__":
    main()
