"""The long calls: closed-loop runs, sessions, batches, commissioning and diagnosis.

Each runs in Rust with the GIL released (other Python threads go on); a batch reports progress.
"""

from __future__ import annotations

import os
from typing import Any, Callable, Mapping, Sequence

from . import _core, _frames
from ._core import BatchSummary, Commissioning, Diagnosis, Simulation
from .doe import _factors

__all__ = ["simulate", "simulate_session", "batch", "commission", "diagnose"]


def _path(p: str | os.PathLike[str] | None) -> str | None:
    return None if p is None else os.fspath(p)


def simulate(
    scenario: str | os.PathLike[str],
    controller: str = "none",
    *,
    realtime: bool = False,
    budget_fraction: float | None = None,
) -> Simulation:
    """One closed-loop run of a scenario file, as ``millcomp simulate SCENARIO --controller K``.

    `controller` is ``none, open-loop, pid, pid-tuned, pid-ff, mpc`` (as the CLI). The result has
    ``.metrics`` (``pp_error_um``, ``rms_error_um``, ...), ``.trace`` (a polars frame, one row per
    controller cycle: the columns of ``simulate --out``) and ``.report`` (``simulate --json``).

    Example::

        >>> r = millcomp.simulate("datasets/scenarios/groove_s7_20deg.toml", controller="pid")
        >>> round(r.metrics["pp_error_um"], 2) < 7.3
        True

    Raises :class:`millcomp.ClosedLoopError` (scenario file, controller), :class:`millcomp.ArgumentError`.
    """
    return _core.simulate(os.fspath(scenario), controller, realtime, budget_fraction)


def simulate_session(session: str | os.PathLike[str], *, noise_seed: int | None = None) -> Simulation:
    """A groove session simulated, as ``millcomp simulate SESSION [--noise-seed N]``: ``.trace`` is the
    measured-groove table (what ``--out`` writes), ``.metrics`` the per-groove summary.

    Example::

        >>> s = millcomp.simulate_session("datasets/sessions/example.toml")
        >>> s.trace.columns[:2]
        ['groove_id', 'x_mm']

    Raises :class:`millcomp.SimulationError` naming the session file.
    """
    return _core.simulate_session_file(os.fspath(session), noise_seed)


def batch(
    out: str | os.PathLike[str],
    *,
    controllers: str | Sequence[str] = "pid,mpc",
    scenarios: Any = None,
    design: Mapping[str, Any] | None = None,
    columns: str | None = None,
    threads: int | None = None,
    cache: str | os.PathLike[str] | None = None,
    progress: bool | Callable[[dict[str, Any]], Any] | None = True,
    plots: bool = True,
) -> BatchSummary:
    """A batch of closed-loop runs over designed conditions, as ``millcomp batch`` (one library call).

    Give `scenarios` (a table — frame or CSV/Parquet path — one row per condition, with a
    ``scenario`` column) or `design` (the arguments of :func:`millcomp.doe.design` as a dict, e.g.
    ``{"design": "full", "factors": "depth_um=100:200,slope_deg=20:40"}``). Files go to `out`
    (``results.parquet``, ``summary.json``, ``plots/``); the same call over the same `out` resumes.
    `progress` is ``True`` (a line on stderr), ``False``/``None`` (quiet) or a callable taking a dict
    per update (``done, total, failed, elapsed_s, eta_s, line``); Ctrl-C or an exception in the
    callable stops the batch cleanly (finished runs are kept).

    The result has ``.summary`` (``batch --json``), ``.results`` (the results frame) and ``.out``.

    Example::

        >>> b = millcomp.batch("out/b", controllers="none,pid",
        ...                    design={"design": "full", "factors": "slope_deg=20:40", "seed": 1},
        ...                    progress=False)
        >>> b.results.height
        4

    Raises :class:`millcomp.ClosedLoopError`, :class:`millcomp.BatchInterrupted`.
    """
    if not isinstance(controllers, str):
        controllers = ",".join(controllers)
    src = None if scenarios is None else _frames.source(scenarios, "scenarios")
    if design is not None:
        design = dict(design)
        if "factors" in design:
            design["factors"] = _factors(design["factors"])
        if "alpha" in design and design["alpha"] is not None:
            design["alpha"] = str(design["alpha"])
    return _core.batch(
        os.fspath(out),
        controllers=controllers,
        scenarios=src,
        design=design,
        columns=columns,
        threads=threads,
        cache=_path(cache),
        progress=progress,
        plots=plots,
    )


def commission(
    scenario: str | os.PathLike[str] | None = None,
    *,
    seed: int | None = None,
    spindle: str | os.PathLike[str] | None = None,
    force: str | os.PathLike[str] | None = None,
    stiffness: str | os.PathLike[str] | None = None,
    material: str | None = None,
) -> Commissioning:
    """The model bundle controllers are built from, as ``millcomp commission``: a scenario's simulated
    machine commissioned through its instruments (`scenario`, `seed`), or your own model files
    (`spindle`, `force`, `stiffness` from :meth:`Model.save` or ``identify --save``, with `material`).

    The result has ``.bundle``, ``.report`` (``commission --json``) and ``.save(path)`` (what a
    scenario's ``control.bundle`` names).

    Example::

        >>> c = millcomp.commission("datasets/scenarios/groove_s7_20deg.toml", seed=7)
        >>> c.save("models.toml")

    Raises :class:`millcomp.ArgumentError`, :class:`millcomp.ModelFileError`,
    :class:`millcomp.ClosedLoopError`.
    """
    return _core.commission(
        scenario=_path(scenario),
        seed=seed,
        spindle=_path(spindle),
        force=_path(force),
        stiffness=_path(stiffness),
        material=material,
    )


def diagnose(
    session: str | os.PathLike[str],
    measured: Any,
    *,
    alpha: float = 0.01,
    candidates: Sequence[str] | str | None = None,
    free_offset: bool = False,
    bonferroni: bool = False,
    forces: str | os.PathLike[str] | None = None,
    columns: str | None = None,
) -> Diagnosis:
    """Where simulation and measurement disagree, as ``millcomp diagnose SESSION MEASURED``: the named
    physical effects and the gap (RMS residual before and after).

    `measured` is a measured-groove table (a frame or a CSV/Parquet path, the columns of
    ``datasets/sessions``' contract). The result has ``.named``, ``.gap``, ``.verdict`` and ``.report``
    (``diagnose --json``).

    Example::

        >>> d = millcomp.diagnose("datasets/sessions/example.toml", measured_frame)
        >>> d.gap["final_rms_um"] <= d.gap["nominal_rms_um"]
        True

    Raises :class:`millcomp.DatasetError` naming the row and column, :class:`millcomp.DiagnoseError`.
    """
    if isinstance(candidates, str):
        candidates = [c for c in candidates.split(",") if c]
    return _core.diagnose(
        os.fspath(session),
        _frames.source(measured, "measured"),
        alpha=alpha,
        candidates=list(candidates) if candidates is not None else None,
        free_offset=free_offset,
        bonferroni=bonferroni,
        forces=_path(forces),
        columns=columns,
    )
