"""The controller runtime from Python equals the CLI's: `Controller.replay` gives `millcomp replay`'s
commands table, `step` the same commands one at a time, `reset` a fresh controller's; errors carry
the CLI's messages."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import polars as pl
import pytest

import millcomp

BUNDLE = "runtime/tests/data/bundle_s7.toml"
PROGRAM = "runtime/tests/data/ramp_20deg.toml"
STEPS = 1500


@pytest.fixture(scope="module")
def log(cli, tmp_path_factory):
    """A simulated run's sensor log (Parquet), recorded by `millcomp simulate PROGRAM --bundle`."""
    path = tmp_path_factory.mktemp("log") / "sensors.parquet"
    cli.run("simulate", PROGRAM, "--bundle", BUNDLE, "--sensor-log", str(path), "--steps", str(STEPS))
    return path


@pytest.mark.parametrize("controller", ["mpc", "pid-tuned"])
def test_replay_equals_millcomp_replay(cli, log, tmp_path, controller):
    out = tmp_path / "commands.parquet"
    cli.run("replay", BUNDLE, PROGRAM, str(log), "--controllers", controller, "--out", str(out))
    want = pl.read_parquet(out)
    ctl = millcomp.Controller.from_bundle(BUNDLE, PROGRAM, controller=controller)
    got = ctl.replay(str(log))
    assert got.columns == ["controller", "cycle", "t_s", "voltage_v", "flags", "iterations"]
    assert got.height == STEPS
    assert got.equals(want)
    # the same log as a frame in memory (polars, and pandas), from a reset controller
    ctl.reset()
    assert ctl.replay(pl.read_parquet(log)).equals(want)
    ctl.reset()
    frame = pl.read_parquet(log)
    assert ctl.replay(pd.DataFrame({c: frame[c].to_numpy() for c in frame.columns})).equals(want)


def test_step_by_step_equals_replay_and_reset_starts_over(log):
    frame = pl.read_parquet(log)
    ctl = millcomp.Controller.from_bundle(BUNDLE, PROGRAM, budget=50)
    assert (ctl.kind, ctl.period_s) == ("mpc", 5e-5)
    replayed = ctl.replay(frame)
    assert ctl.cycle == STEPS and ctl.counts["cycles"] == STEPS
    ctl.reset()
    assert ctl.cycle == 0
    stepped = [ctl.step(x, f, g) for x, f, g in frame.select("x_mm", "force_n", "gauge_um").iter_rows()]
    np.testing.assert_array_equal(
        np.array([c.voltage_v for c in stepped]).view(np.uint64),
        replayed["voltage_v"].to_numpy().view(np.uint64),
    )
    assert [c.flags for c in stepped] == replayed["flags"].to_list()
    assert [c.iterations for c in stepped] == replayed["iterations"].to_list()
    assert stepped[0].planned and math.isfinite(stepped[0].voltage_v)
    assert sum(c.planned for c in stepped) == ctl.counts["planned"]


def test_errors_carry_the_cli_messages(cli, log, tmp_path):
    with pytest.raises(millcomp.ModelFileError) as e:
        millcomp.Controller.from_bundle("no/such.toml", PROGRAM)
    assert str(e.value) == cli.error("replay", "no/such.toml", PROGRAM, str(log))
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,x_mm,force_n,gauge_um\n0,0,abc,0\n")
    ctl = millcomp.Controller.from_bundle(BUNDLE, PROGRAM)
    with pytest.raises(millcomp.DatasetError) as e:
        ctl.replay(str(bad))
    assert str(e.value) == cli.error("replay", BUNDLE, PROGRAM, str(bad))
    assert "force_n" in str(e.value) and "row 1" in str(e.value)
    with pytest.raises(millcomp.DatasetError, match="gauge_um"):
        ctl.replay({"t_s": [0.0], "x_mm": [0.0], "force_n": [0.0]})
    with pytest.raises(millcomp.ArgumentError, match="controller"):
        millcomp.Controller.from_bundle(BUNDLE, PROGRAM, controller="lqr")
    for budget in (0, 501, "fast", 1.5):
        with pytest.raises(millcomp.ArgumentError, match="budget"):
            millcomp.Controller.from_bundle(BUNDLE, PROGRAM, budget=budget)
