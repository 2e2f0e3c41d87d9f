"""The package as a whole: it computes in Rust (no statsmodels or scipy imported), is an abi3 wheel,
has its stubs, and releases the GIL on long calls."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import millcomp


def test_it_imports_neither_statsmodels_nor_scipy():
    code = (
        "import sys, millcomp, polars as pl\n"
        "a = millcomp.doe.analyze('datasets/data/clayton_doe.csv', response='max_fx_n',"
        " factors=['depth_um','speed_rpm','upfeed_um'])\n"
        "a.anova; a.effects; a.lenth\n"
        "m = millcomp.identify.fit('stiffness', 'datasets/runs/stiffness_masses_synthetic.csv'); m.intervals\n"
        "millcomp.doe.design('ccd', 'a=0:1,b=0:1', seed=1)\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('statsmodels', 'scipy')]\n"
        "print(bad)\n"
    )
    from conftest import ROOT

    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_stubs_and_markers_ship_with_the_package():
    from importlib import resources

    files = {p.name for p in resources.files("millcomp").iterdir()}
    assert {"_core.pyi", "py.typed"} <= files


def test_every_public_function_has_a_docstring_with_an_example():
    for f in (millcomp.doe.design, millcomp.doe.analyze, millcomp.identify.fit, millcomp.identify.load,
              millcomp.simulate, millcomp.simulate_session, millcomp.batch, millcomp.commission,
              millcomp.diagnose, millcomp.Controller):
        assert f.__doc__ and "Example" in f.__doc__, f.__name__


def test_a_long_call_releases_the_gil():
    # a Python thread counts while a closed-loop run computes in Rust; with the GIL held it could not
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = len(ticks)
    millcomp.simulate("datasets/scenarios/groove_s7_20deg.toml", controller="pid")
    during = len(ticks) - start
    done.set()
    t.join()
    assert during > 10, during


def test_errors_are_one_family():
    for name in ("ArgumentError", "DatasetError", "ModelFileError", "DoeError", "IdentifyError",
                 "DiagnoseError", "ClosedLoopError", "SimulationError", "ControllerError",
                 "BatchInterrupted"):
        assert issubclass(getattr(millcomp, name), millcomp.MillcompError)
