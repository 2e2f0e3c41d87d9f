"""The Python call's overhead against the Rust call it wraps, as medians side by side in one run.

    .venv/bin/python python/bench/overhead.py [--repeats 2000]

`doe.analyze` on the Table 3-3 frame (a polars frame in memory): the whole Python call (argument
conversion, the Arrow stream into Rust, the analysis, the result object) against the same Rust work timed
inside Rust (`_core._time_analyze`: the frame read into a table and analysed, no Python around it), and
the ``.anova`` frame crossing back.

`Controller.step`: one Python call per control cycle (`ctl.step(x_mm, force_n, gauge_um)`, the
command object back) against the Rust step timed inside Rust (`_core._time_step`: the same
measurement stepped in a loop), per controller: the same cycles from a reset each time, the Rust and
the Python batches interleaved so that the machine's load falls on both alike. Build with `python/install --release` for numbers
worth quoting.
"""

from __future__ import annotations

import argparse
import statistics
import time

import polars as pl

import millcomp
from millcomp import _core

FACTORS = ["depth_um", "speed_rpm", "upfeed_um"]
BUNDLE = "runtime/tests/data/bundle_s7.toml"
PROGRAM = "runtime/tests/data/ramp_20deg.toml"


def timings(f, repeats):
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        out.append(time.perf_counter() - t)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=2000)
    args = ap.parse_args()
    frame = pl.read_csv("datasets/data/clayton_doe.csv")
    n = args.repeats
    # warm up both paths
    millcomp.doe.analyze(frame, response="max_fx_n", factors=FACTORS).anova
    _core._time_analyze(frame.__arrow_c_stream__(), "max_fx_n", FACTORS, 10)

    rust = _core._time_analyze(frame.__arrow_c_stream__(), "max_fx_n", FACTORS, n)
    py_call = timings(lambda: millcomp.doe.analyze(frame, response="max_fx_n", factors=FACTORS), n)
    a = millcomp.doe.analyze(frame, response="max_fx_n", factors=FACTORS)
    anova = timings(lambda: a.anova, n)

    med = lambda xs: statistics.median(xs) * 1e6  # noqa: E731
    print(f"doe.analyze on Table 3-3 (8 runs, 3 factors), {n} calls each, medians:")
    print(f"  Rust call (frame -> table -> analysis)      {med(rust):9.1f} us")
    print(f"  Python doe.analyze(frame, ...)              {med(py_call):9.1f} us   "
          f"overhead {med(py_call) - med(rust):7.1f} us  ratio {med(py_call) / med(rust):5.2f}")
    print(f"  .anova (Rust frame -> Arrow -> polars)      {med(anova):9.1f} us")

    steps = 200
    print(f"Controller.step, {n} x {steps} steps each (the program's first {steps} cycles, Rust and "
          f"Python batches interleaved, each from a reset), medians per step:")
    for kind in ("none", "open-loop", "pid", "pid-tuned", "pid-ff", "mpc"):
        ctl = millcomp.Controller.from_bundle(BUNDLE, PROGRAM, controller=kind)
        step = ctl.step
        nan = float("nan")
        rust_ns, py_ns = [], []
        for _ in range(n):
            ctl.reset()
            rust_ns.append(_core._time_step(ctl, steps, 1)[0])
            ctl.reset()
            t = time.perf_counter()
            for _ in range(steps):
                step(nan, 0.1, 0.0)
            py_ns.append((time.perf_counter() - t) / steps * 1e9)
        r, p = statistics.median(rust_ns), statistics.median(py_ns)
        print(f"  {kind:<10} Rust step {r:9.1f} ns   Python ctl.step(...) {p:9.1f} ns   "
              f"overhead {p - r:7.1f} ns  ratio {p / r:5.2f}")

if __name__ == "__main__":
    main()
