"""The long calls equal the CLI's: simulate (a scenario and a session), commission, diagnose, batch."""

from __future__ import annotations

import json

import numpy as np
import polars as pl
import pytest

import millcomp

SCENARIO = "datasets/scenarios/groove_s7_20deg.toml"
SESSION = "datasets/sessions/example.toml"


def without_timing(report):
    """A closed-loop report without what depends on the wall clock."""
    if isinstance(report, dict):
        return {k: without_timing(v) for k, v in report.items()
                if not (k.endswith("_wall_s") or k.startswith("solve_time") or k.endswith("_time_s")
                        or k in ("elapsed_s", "wall_s", "wall_clock_s"))}
    if isinstance(report, list):
        return [without_timing(v) for v in report]
    return report


@pytest.mark.parametrize("controller", ["none", "pid"])
def test_simulate_a_scenario_equals_the_cli(cli, tmp_path, controller):
    out = tmp_path / "trace.csv"
    want = cli.json("simulate", SCENARIO, "--controller", controller, "--no-realtime", "--out", str(out))
    got = millcomp.simulate(SCENARIO, controller=controller)
    assert without_timing(got.report) == without_timing(want)
    assert got.metrics == want["metrics"]
    trace = pl.read_csv(out)
    assert got.trace.columns == trace.columns
    np.testing.assert_array_equal(got.trace.to_numpy(), trace.to_numpy())


def test_simulate_a_session_equals_the_cli(cli, tmp_path):
    out = tmp_path / "measured.csv"
    want = cli.json("simulate", SESSION, "--noise-seed", "4", "--out", str(out))
    got = millcomp.simulate_session(SESSION, noise_seed=4)
    rep = dict(got.report)
    rep["out"] = want["out"]
    assert rep == want
    theirs = pl.read_csv(out)
    assert got.trace.columns == theirs.columns
    for c in theirs.columns:
        if theirs[c].dtype.is_numeric():
            np.testing.assert_allclose(got.trace[c].cast(pl.Float64).to_numpy(),
                                       theirs[c].cast(pl.Float64).to_numpy(), rtol=1e-12)
        else:
            assert got.trace[c].to_list() == theirs[c].to_list()


def test_commission_a_scenario_equals_the_cli(cli, tmp_path):
    want = cli.json("commission", SCENARIO, "--seed", "3", "--out", str(tmp_path / "cli.toml"))
    got = millcomp.commission(SCENARIO, seed=3)
    assert got.report["bundle"] == want["bundle"]
    assert got.report["spindle_bic"] == want["spindle_bic"]
    got.save(tmp_path / "py.toml")

    def model_part(p):
        text = p.read_text()
        return text[text.index("[model]"):]

    assert model_part(tmp_path / "py.toml") == model_part(tmp_path / "cli.toml")


def test_commission_without_inputs_is_an_argument_error():
    with pytest.raises(millcomp.ArgumentError, match="scenario"):
        millcomp.commission()
    with pytest.raises(millcomp.ArgumentError, match="material"):
        millcomp.commission(stiffness="x.toml")


def test_diagnose_a_measured_file_and_frame_equals_the_cli(cli, tmp_path):
    measured = tmp_path / "measured.csv"
    cli.run("simulate", SESSION, "--noise-seed", "9", "--out", str(measured))
    want = cli.json("diagnose", SESSION, str(measured))
    got = millcomp.diagnose(SESSION, measured)
    assert got.report == want
    # the same cells as a frame: the same diagnosis (only the input's name differs)
    frame = millcomp.simulate_session(SESSION, noise_seed=9).trace
    by_frame = millcomp.diagnose(SESSION, frame).report
    assert by_frame["named"] == want["named"]
    assert by_frame["final_rms_um"] == want["final_rms_um"]
    assert by_frame["initial_rms_um"] == want["initial_rms_um"]
    assert got.gap["final_rms_um"] == want["final_rms_um"]
    assert got.named == want["named"]


def test_diagnose_bad_measured_rows_name_the_column():
    frame = millcomp.simulate_session(SESSION).trace
    bad = frame.with_columns(pl.lit(None, dtype=pl.Float64).alias(frame.columns[-1]))
    with pytest.raises(millcomp.DatasetError, match=frame.columns[-1]):
        millcomp.diagnose(SESSION, bad)


def test_batch_equals_the_cli_and_reports_progress(cli, tmp_path):
    doe = "--design full --factors tilt_deg=20:40 --seed 1"
    want = cli.json("batch", "--doe", doe, "--controllers", "none,pid", "--out", str(tmp_path / "cli"),
                    "--threads", "1")
    updates = []
    got = millcomp.batch(tmp_path / "py", controllers=["none", "pid"],
                         design={"design": "full", "factors": "tilt_deg=20:40", "seed": 1},
                         threads=1, progress=updates.append)
    for k in ("fingerprint", "n_runs", "controllers", "by_controller", "anova"):
        assert got.summary[k] == want[k], k
    assert updates and updates[-1]["done"] == updates[-1]["total"] == want["n_runs"]
    results = got.results
    cli_results = pl.read_parquet(tmp_path / "cli" / "results.parquet")
    assert results.columns == cli_results.columns
    assert results.height == want["n_runs"]
    assert (tmp_path / "py" / "summary.json").read_text() == (tmp_path / "cli" / "summary.json").read_text()


def test_batch_stops_when_the_progress_callback_raises(tmp_path):
    def stop(update):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        millcomp.batch(tmp_path / "b", controllers="none",
                       design={"design": "full", "factors": "tilt_deg=20:40,depth_um=80:120", "seed": 1},
                       threads=1, progress=stop)


def test_batch_needs_one_source():
    with pytest.raises(millcomp.ArgumentError, match="scenarios"):
        millcomp.batch("x")
