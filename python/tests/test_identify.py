"""`millcomp.identify`: fits equal the CLI's on the same inputs, model files round-trip both ways."""

from __future__ import annotations

import polars as pl
import pytest

import millcomp

SPINDLE = "datasets/runs/spindle_step_synthetic.csv"
STIFFNESS = "datasets/runs/stiffness_masses_synthetic.csv"
CLAYTON = "datasets/data/clayton_doe.csv"

CASES = [
    ("stiffness", STIFFNESS, {}, []),
    ("spindle", SPINDLE, {}, []),
    ("force", CLAYTON, {"material": "6061"}, ["--material", "6061"]),
]


@pytest.mark.parametrize("kind,path,options,flags", CASES)
def test_fit_equals_cli_from_a_path_and_a_frame(cli, kind, path, options, flags):
    want = cli.json("identify", kind, path, *flags)
    for frame in (path, pl.read_csv(path)):
        m = millcomp.identify.fit(kind, frame, **options)
        rep = m.report
        # the input's name differs between a path and a frame; the fit does not
        assert rep == want, kind
        assert m.status == want["status"] if "status" in want else True
        assert set(m.intervals) == set(m.params)
        for name, (lo, hi) in m.intervals.items():
            assert lo <= m.params[name] <= hi


@pytest.mark.parametrize("kind,path,options,flags", CASES)
def test_save_writes_the_file_the_cli_writes_and_load_reads_both(cli, tmp_path, kind, path, options, flags):
    ours, theirs = tmp_path / "py.toml", tmp_path / "cli.toml"
    m = millcomp.identify.fit(kind, path, **options)
    m.save(ours)
    cli.run("identify", kind, path, *flags, "--save", str(theirs))

    def model_part(p):
        text = p.read_text()
        return text[text.index("[model]"):]

    assert model_part(ours) == model_part(theirs)
    a, b = millcomp.identify.load(ours), millcomp.identify.load(theirs)
    assert a.params == b.params == m.params
    assert a.std_err == b.std_err
    assert a.kind == b.kind == m.kind
    assert b.header["provenance"]["inputs"][0]["path"].endswith(path.split("/")[-1])


def test_models_saved_from_python_commission_as_the_cli_ones(cli, tmp_path):
    for kind, path, options, flags in CASES:
        millcomp.identify.fit(kind, path, **options).save(tmp_path / f"{kind}.toml")
        cli.run("identify", kind, path, *flags, "--save", str(tmp_path / f"cli_{kind}.toml"))
    ours = millcomp.commission(spindle=tmp_path / "spindle.toml", force=tmp_path / "force.toml",
                               stiffness=tmp_path / "stiffness.toml", material="6061")
    want = cli.json("commission", "--spindle", str(tmp_path / "cli_spindle.toml"),
                    "--force", str(tmp_path / "cli_force.toml"),
                    "--stiffness", str(tmp_path / "cli_stiffness.toml"), "--material", "6061")
    # the same bundle; only the provenance lines (`experiments`: the files and the command) differ
    strip = lambda b: {k: v for k, v in b.items() if k != "experiments"}  # noqa: E731
    assert strip(ours.report["bundle"]) == strip(want["bundle"])
    assert len(ours.report["bundle"]["experiments"]) == len(want["bundle"]["experiments"])


def test_a_missing_column_names_the_file_and_column(cli):
    frame = pl.read_csv(STIFFNESS).drop("deflection_um")
    with pytest.raises(millcomp.MillcompError, match="deflection_um"):
        millcomp.identify.fit("stiffness", frame)


def test_an_unknown_kind_is_an_argument_error(cli):
    want = cli.error("identify", "stifness", STIFFNESS)
    with pytest.raises(millcomp.ArgumentError) as e:
        millcomp.identify.fit("stifness", STIFFNESS)
    assert "argument `kind`" in str(e.value)


def test_load_of_a_missing_or_wrong_file_names_it(tmp_path):
    with pytest.raises(millcomp.MillcompError, match="nope.toml"):
        millcomp.identify.load(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[header]\nformat = 'x'\n")
    with pytest.raises(millcomp.ModelFileError, match="bad.toml"):
        millcomp.identify.load(bad)
