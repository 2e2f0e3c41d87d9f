"""`millcomp.doe`: design and analyze equal the CLI's, and the ANOVA equals statsmodels' anova_lm(typ=2).

Reference: statsmodels 0.15.0 (bench/peers/requirements.txt), `ols(...).fit()` then
`anova_lm(fit, typ=2)`, on Table 3-3 of the seed document 000_367e180efde69d0c.txt
(datasets/data/clayton_doe.csv) — computed here, in the test environment only.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import polars as pl
import pytest

import millcomp

CLAYTON = "datasets/data/clayton_doe.csv"
FACTORS = ["depth_um", "speed_rpm", "upfeed_um"]
RESPONSES = ["max_fx_n", "max_fy_n", "max_fz_n"]


def statsmodels_anova(df: pd.DataFrame, response: str, formula_rhs: str) -> pd.DataFrame:
    from statsmodels.formula.api import ols
    from statsmodels.stats.anova import anova_lm

    fit = ols(f"{response} ~ {formula_rhs}", data=df).fit()
    return anova_lm(fit, typ=2)


def coded(df: pd.DataFrame) -> pd.DataFrame:
    out = df.copy()
    for f in FACTORS:
        lo, hi = df[f].min(), df[f].max()
        out[f] = (df[f] - (lo + hi) / 2) / ((hi - lo) / 2)
    return out


def compare(ours: pl.DataFrame, ref: pd.DataFrame, rename: dict[str, str]) -> None:
    ours_terms = ours["term"].to_list()
    ref_terms = [rename.get(t, t) for t in ref.index]
    assert ours_terms == ref_terms
    np.testing.assert_allclose(ours["sum_sq"].to_numpy(), ref["sum_sq"].to_numpy(), rtol=0, atol=1e-10)
    np.testing.assert_array_equal(ours["df"].to_numpy(), ref["df"].to_numpy())
    f_ours = ours["f"].to_numpy()[:-1].astype(float)
    f_ref = ref["F"].to_numpy()[:-1]
    np.testing.assert_allclose(f_ours, f_ref, rtol=1e-10)
    p_ours = ours["p_value"].to_numpy()[:-1].astype(float)
    np.testing.assert_allclose(p_ours, ref["PR(>F)"].to_numpy()[:-1], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("response", RESPONSES)
def test_anova_main_effects_equals_statsmodels_typ2(response):
    frame = pd.read_csv(CLAYTON)
    a = millcomp.doe.analyze(frame, response=response, factors=FACTORS)
    ref = statsmodels_anova(frame, response, " + ".join(FACTORS))
    compare(a.anova, ref, {})


@pytest.mark.parametrize("response", RESPONSES)
def test_anova_two_factor_interactions_equals_statsmodels_typ2(response):
    # with interactions the type II sums of squares depend on the coding: millcomp codes −1/+1
    frame = pl.read_csv(CLAYTON)
    a = millcomp.doe.analyze(frame, response=response, factors=FACTORS, model="2fi")
    ref = statsmodels_anova(coded(pd.read_csv(CLAYTON)), response, "(" + " + ".join(FACTORS) + ")**2")
    compare(a.anova, ref, {})


def analyze_args(response, model="main"):
    return ["doe", "analyze", CLAYTON, "--response", response, "--factors", ",".join(FACTORS),
            "--model", model]


@pytest.mark.parametrize("model", ["main", "2fi"])
def test_analyze_equals_cli_from_path_polars_pandas_and_dict(cli, model):
    want = cli.json(*analyze_args("max_fx_n", model))
    pl_frame = pl.read_csv(CLAYTON)
    inputs = [CLAYTON, pl_frame, pd.read_csv(CLAYTON), pl_frame.to_dict(as_series=False),
              {c: pl_frame[c].to_numpy() for c in pl_frame.columns if c != "source"}]
    for frame in inputs:
        got = millcomp.doe.analyze(frame, response="max_fx_n", factors=FACTORS, model=model)
        assert got.report == want, type(frame)


def test_analyze_reduce_equals_cli(cli):
    want = cli.json(*analyze_args("max_fz_n", "2fi"), "--reduce", "--alpha", "0.1")
    got = millcomp.doe.analyze(CLAYTON, "max_fz_n", FACTORS, model="2fi", reduce=True, alpha=0.1)
    assert got.report == want


def test_effects_and_lenth_frames_follow_the_report(cli, tmp_path):
    a = millcomp.doe.analyze(CLAYTON, response="max_fx_n", factors=FACTORS)
    rep = a.report
    assert a.effects["term"].to_list() == [t["term"] for t in rep["terms"]]
    assert a.effects["effect"].to_list() == [t["effect"] for t in rep["terms"]]
    assert a.lenth is None  # residual degrees of freedom left: the F-tests apply
    # a saturated model of an unreplicated 2^2: Lenth's pseudo standard error instead
    d = millcomp.doe.design("full", "A,B", randomize=False)
    d = d.with_columns(y=pl.Series([3.1, 4.0, 5.2, 9.9]))
    path = tmp_path / "sat.csv"
    d.write_csv(path)
    s = millcomp.doe.analyze(d, response="y", factors=["A", "B"], model="2fi")
    assert s.report == cli.json("doe", "analyze", str(path), "--response", "y", "--factors", "A,B",
                                "--model", "2fi")
    assert s.lenth["term"].to_list() == [t["term"] for t in s.report["lenth"]["terms"]]
    assert s.lenth_limits["pse"] == s.report["lenth"]["pse"]


def test_analysis_save_is_a_model_file_the_cli_writes(cli, tmp_path):
    ours, theirs = tmp_path / "py.toml", tmp_path / "cli.toml"
    millcomp.doe.analyze(CLAYTON, response="max_fx_n", factors=FACTORS).save(ours)
    cli.run(*analyze_args("max_fx_n"), "--save", str(theirs))

    def model_part(p):
        text = p.read_text()
        return text[text.index("[model]"):]

    assert model_part(ours) == model_part(theirs)


DESIGNS = [
    ["fractional", "depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20,wearland_um=4:12",
     {"resolution": 4, "seed": 3}],
    ["full", "A,B,C", {"replicates": 2, "seed": 1}],
    ["ccd", "x=0:1,y=-2:2", {"seed": 5, "center_points": 3}],
    ["box-behnken", "a=1:3,b=1:3,c=1:3", {"randomize": False, "seed": 4}],
    ["lhs", "a=0:1,b=0:10", {"runs": 7, "seed": 11}],
    ["plackett-burman", "A,B,C,D,E", {"seed": 2, "blocks": 1}],
]


def cli_flags(options):
    out = []
    for k, v in options.items():
        if k == "randomize":
            if not v:
                out.append("--no-randomize")
            continue
        out += ["--" + k.replace("_", "-"), str(v)]
    return out


@pytest.mark.parametrize("design,factors,options", DESIGNS)
def test_design_equals_cli(cli, tmp_path, design, factors, options):
    out = tmp_path / "d.csv"
    want = cli.json("doe", "design", "--design", design, "--factors", factors, *cli_flags(options),
                    "--out", str(out))
    frame, report = millcomp.doe.design(design, factors, report=True, **options)
    assert report == want
    cli_frame = pl.read_csv(out)
    assert frame.columns == cli_frame.columns
    for c in frame.columns:
        np.testing.assert_allclose(frame[c].cast(pl.Float64).to_numpy(),
                                   cli_frame[c].cast(pl.Float64).to_numpy(), rtol=1e-12, atol=0)


def test_design_takes_a_dict_of_factor_ranges():
    a = millcomp.doe.design("full", {"depth_um": (100, 200), "speed_rpm": (10000, 20000)}, seed=1)
    b = millcomp.doe.design("full", "depth_um=100:200,speed_rpm=10000:20000", seed=1)
    assert a.equals(b)
    assert a.height == 4


def test_a_bad_factor_list_is_an_argument_error_with_the_cli_causes(cli):
    want = cli.error("doe", "design", "--design", "full", "--factors", "a=1:1")
    with pytest.raises(millcomp.ArgumentError) as e:
        millcomp.doe.design("full", "a=1:1")
    got = str(e.value)
    assert got.splitlines()[0] == "argument `factors`"
    assert want.splitlines()[0] == "--factors"
    assert got.splitlines()[1:] == want.splitlines()[1:]
    assert isinstance(e.value, ValueError)


def test_an_unknown_design_argument_is_named():
    with pytest.raises(millcomp.ArgumentError, match="argument `design`"):
        millcomp.doe.design("nonsense", "a=1:2")
    with pytest.raises(TypeError):
        millcomp.doe.design("full", "a=1:2", replicatez=2)  # a Python typo is Python's TypeError


def test_a_missing_response_column_has_the_cli_message(cli):
    want = cli.error("doe", "analyze", CLAYTON, "--response", "max_fw_n")
    with pytest.raises(millcomp.MillcompError) as e:
        millcomp.doe.analyze(CLAYTON, response="max_fw_n")
    assert str(e.value) == want


def test_a_text_cell_in_a_frame_is_named_by_column():
    frame = pl.read_csv(CLAYTON).with_columns(pl.col("max_fx_n").cast(pl.Utf8))
    frame = frame.with_columns(pl.when(pl.col("trial") == 3).then(pl.lit("n/a")).otherwise(pl.col("max_fx_n")).alias("max_fx_n"))
    with pytest.raises(millcomp.MillcompError, match="max_fx_n"):
        millcomp.doe.analyze(frame, response="max_fx_n", factors=FACTORS)


def test_a_frame_argument_of_the_wrong_type_is_named():
    with pytest.raises(millcomp.ArgumentError, match="argument `frame`"):
        millcomp.doe.analyze(42, response="y")
    with pytest.raises(millcomp.ArgumentError, match="argument `frame`"):
        millcomp.doe.analyze(np.zeros((3, 2)), response="y")
    with pytest.raises(millcomp.ArgumentError, match="argument `alpha`"):
        millcomp.doe.analyze(CLAYTON, response="max_fx_n", alpha=2.0)
