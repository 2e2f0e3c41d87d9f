"""A notebook's first cells with millcomp: design, analyse, identify, commission, simulate, diagnose.

Run from the repository root after `python/install`:

    .venv/bin/python python/examples/first_steps.py

Each step is the library call the CLI makes (`millcomp doe design`, `doe analyze`, `identify`,
`commission`, `simulate`, `diagnose`); tables are polars frames; files go to ./out/first-steps/.
"""

from pathlib import Path

import polars as pl

import millcomp

out = Path("out/first-steps")
out.mkdir(parents=True, exist_ok=True)

# 1. A 2^(4-1) design of resolution IV over the cutting conditions
design = millcomp.doe.design(
    "fractional",
    {"depth_um": (100, 200), "speed_rpm": (10000, 20000), "upfeed_um": (10, 20), "wearland_um": (4, 12)},
    resolution=4,
    seed=3,
)
print("design:", design.shape)
print(design.select("run_order", "depth_um", "speed_rpm", "upfeed_um", "wearland_um").head(4))

# 2. The measured 2^3 of Table 3-3: effects and type II ANOVA of the peak X force
measured = pl.read_csv("datasets/data/clayton_doe.csv")
analysis = millcomp.doe.analyze(measured, response="max_fx_n", factors=["depth_um", "speed_rpm", "upfeed_um"])
print(analysis)
print(analysis.anova)

# 3. Models of your machine from its calibration records, saved as the CLI's model files
spindle = millcomp.identify.fit("spindle", "datasets/runs/spindle_step_synthetic.csv")
stiffness = millcomp.identify.fit("stiffness", pl.read_csv("datasets/runs/stiffness_masses_synthetic.csv"))
force = millcomp.identify.fit("force", measured, material="6061")
for name, m in [("spindle", spindle), ("stiffness", stiffness), ("force", force)]:
    m.save(out / f"{name}.toml")
    print(f"{name}: {m.status};", ", ".join(f"{k} = {v:.4g} [{lo:.4g}, {hi:.4g}]"
                                           for k, v in m.params.items()
                                           for lo, hi in [m.intervals[k]]))

# 4. A bundle from them (what `millcomp commission --spindle … --material 6061 --out` writes)
bundle = millcomp.commission(spindle=out / "spindle.toml", force=out / "force.toml",
                             stiffness=out / "stiffness.toml", material="6061")
bundle.save(out / "models.toml")
print(bundle)

# 5. A closed-loop run of the groove scenario with PID: metrics and the per-cycle trace
run = millcomp.simulate("datasets/scenarios/groove_s7_20deg.toml", controller="pid")
print(run)
print({k: round(v, 3) for k, v in run.metrics.items() if isinstance(v, float)})
print(run.trace.select(pl.col("x_mm"), pl.col("^.*error_um$")).describe())

# 6. A measured groove session against its model: the missing effects, named
measured_grooves = millcomp.simulate_session("datasets/sessions/example.toml", noise_seed=9).trace
diagnosis = millcomp.diagnose("datasets/sessions/example.toml", measured_grooves)
print(diagnosis)
print("gap:", diagnosis.gap)
