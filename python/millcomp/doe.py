"""Design of experiments: treatment matrices and their analysis, as ``millcomp doe design|analyze``.

Example::

    >>> import millcomp
    >>> d = millcomp.doe.design("full", {"depth_um": (100, 200), "speed_rpm": (10000, 20000)}, seed=1)
    >>> d.shape
    (4, 4)
    >>> a = millcomp.doe.analyze("datasets/data/clayton_doe.csv", response="max_fx_n", factors=["depth_um", "speed_rpm", "upfeed_um"])
    >>> a.anova.columns
    ['term', 'df', 'sum_sq', 'mean_sq', 'f', 'p_value']
"""

from __future__ import annotations

import os
from typing import Any, Mapping, Sequence

import polars as pl

from . import _core, _frames
from ._core import Analysis

__all__ = ["design", "analyze", "Analysis"]


def _factors(factors: str | Mapping[str, Any] | Sequence[str]) -> str:
    """`factors` as the CLI's ``--factors`` text: ``"a=1:2,b=3:4"`` or bare names ``"A,B,C"``."""
    if isinstance(factors, str):
        return factors
    if isinstance(factors, Mapping):
        parts = []
        for name, levels in factors.items():
            if isinstance(levels, (tuple, list)) and len(levels) == 2:
                parts.append(f"{name}={levels[0]}:{levels[1]}")
            elif levels is None:
                parts.append(str(name))
            else:
                raise _core_argument(f"argument `factors`: `{name}` takes (low, high), got {levels!r}")
        return ",".join(parts)
    return ",".join(str(f) for f in factors)


def _core_argument(message: str) -> Exception:
    from .errors import ArgumentError

    return ArgumentError(message)


def design(
    design: str,
    factors: str | Mapping[str, Any] | Sequence[str],
    *,
    resolution: int | None = None,
    generators: str | None = None,
    runs: int | None = None,
    replicates: int = 1,
    center_points: int | None = None,
    blocks: int = 1,
    seed: int | None = None,
    randomize: bool = True,
    ccd_variant: str = "circumscribed",
    alpha: str | float = "rotatable",
    model: str | None = None,
    constraints: str | None = None,
    report: bool = False,
) -> pl.DataFrame | tuple[pl.DataFrame, dict[str, Any]]:
    """A treatment matrix, as ``millcomp doe design --design DESIGN --factors FACTORS --out``.

    `design` is one of ``full, fractional, plackett-burman, ccd, ccf, cci, box-behnken, lhs, dsd,
    d-optimal``; `factors` ``"depth_um=100:200,speed_rpm=10000:20000"``, a dict
    ``{"depth_um": (100, 200)}`` or bare names ``["A", "B"]`` (coded −1/+1). The frame has the columns
    the CLI writes (``std_order, run_order, block``, the factors in actual units, then coded ``*_coded``
    ones where they differ). With ``report=True`` the design's report (``doe design --json``:
    resolution, aliases, criteria) comes too.

    Example::

        >>> millcomp.doe.design("fractional", "a=1:2,b=1:2,c=1:2,d=1:2", resolution=4).height
        8

    Raises :class:`millcomp.ArgumentError` naming the argument, :class:`millcomp.DoeError` when the
    design cannot be built.
    """
    options = {
        "design": design,
        "factors": _factors(factors),
        "resolution": resolution,
        "generators": generators,
        "runs": runs,
        "replicates": replicates,
        "center_points": center_points,
        "blocks": blocks,
        "seed": seed,
        "randomize": randomize,
        "ccd_variant": ccd_variant,
        "alpha": str(alpha),
        "model": model,
        "constraints": constraints,
    }
    frame, rep = _core.design(options)
    return (frame, rep) if report else frame


def analyze(
    frame: Any,
    response: str,
    factors: Sequence[str] | None = None,
    *,
    model: str = "main",
    alpha: float = 0.05,
    reduce: bool = False,
    columns: str | None = None,
) -> Analysis:
    """Effects, type II ANOVA and Lenth's method of one response, as ``millcomp doe analyze``.

    `frame` is a polars or pandas frame, a dict of columns, a numpy structured array, or a CSV/Parquet
    path (read as the CLI reads it). `factors` defaults to every other numeric column; `model` is
    ``main``, ``2fi``, ``quadratic`` or a formula; `reduce` eliminates terms backwards at `alpha`;
    `columns` maps roles to column names as ``--columns``.

    The result has ``.anova`` (``term, df, sum_sq, mean_sq, f, p_value``: the sums of squares of
    statsmodels' ``anova_lm(typ=2)``), ``.effects``, ``.coefficients``, ``.lenth`` (``None`` where it does
    not apply), ``.report`` (``doe analyze --json``) and ``.save(path)`` (the response surface model).

    Example::

        >>> a = millcomp.doe.analyze(pl.read_csv("datasets/data/clayton_doe.csv"), response="max_fx_n", factors=["depth_um", "speed_rpm", "upfeed_um"])
        >>> a.anova.filter(pl.col("term") == "Residual")["df"][0]
        4

    Raises :class:`millcomp.DatasetError` naming the column, :class:`millcomp.DoeError`.
    """
    if isinstance(factors, str):
        factors = [f for f in factors.split(",") if f]
    return _core.analyze(
        _frames.source(frame, "frame"),
        response,
        list(factors) if factors is not None else None,
        model,
        float(alpha),
        bool(reduce),
        columns,
    )
