"""Identification: least-squares fits from measured runs, as ``millcomp identify KIND FILE``.

Example::

    >>> import millcomp
    >>> m = millcomp.identify.fit("stiffness", "datasets/runs/stiffness_masses_synthetic.csv")
    >>> m.status
    'converged'
    >>> m.save("stiffness.toml")            # the model file `millcomp ... --stiffness` reads
    >>> millcomp.identify.load("stiffness.toml").params == m.params
    True
"""

from __future__ import annotations

import os
from typing import Any, Sequence

from . import _core, _frames
from ._core import Model

__all__ = ["fit", "load", "Model"]


def fit(
    kind: str,
    frame: Any,
    *,
    columns: str | None = None,
    model: str | None = None,
    extra_pole: bool = False,
    dead_time: bool = False,
    tilt_deg: Sequence[float] | None = None,
    machine_stiffness_n_per_um: float | None = None,
    free: Sequence[str] | str | None = None,
    material: str | None = None,
    relative_errors: bool = False,
    wall_geometry: Sequence[float] | None = None,
) -> Model:
    """Fits `kind` (``spindle, stiffness, force, thermal, wall, part, kienzle, feed-axis, hysteresis``)
    to `frame` (a polars/pandas frame, a dict of columns, a numpy structured array, or a CSV/Parquet
    path), with the options of the CLI's flags (``--model``, ``--extra-pole``, ``--dead-time``,
    ``--tilt-deg``, ``--machine-stiffness-n-per-um``, ``--free``, ``--material``,
    ``--relative-errors``, ``--wall-geometry``; ``columns`` as ``--columns role=column,...``).

    The model has ``.params``, ``.std_err``, ``.intervals`` (95 %), ``.status`` (an outcome: a fit that
    did not converge is reported, not raised), ``.warnings``, ``.report`` (``identify --json``) and
    ``.save(path)`` in the model-file format the CLI reads.

    Example::

        >>> millcomp.identify.fit("stiffness", {"load_n": [0.49, 0.98, 1.47, 1.96],
        ...                                    "deflection_um": [3.0, 9.0, 12.0, 18.0]}).kind
        'stiffness'

    Raises :class:`millcomp.DatasetError` naming the file or column, :class:`millcomp.IdentifyError`,
    :class:`millcomp.ArgumentError`.
    """
    if isinstance(free, str):
        free = [f for f in free.split(",") if f]
    return _core.fit(
        kind,
        _frames.source(frame, "frame"),
        columns=columns,
        model=model,
        extra_pole=extra_pole,
        dead_time=dead_time,
        tilt_deg=list(tilt_deg) if tilt_deg is not None else None,
        machine_stiffness_n_per_um=machine_stiffness_n_per_um,
        free=list(free) if free is not None else None,
        material=material,
        relative_errors=relative_errors,
        wall_geometry=list(wall_geometry) if wall_geometry is not None else None,
    )


def load(path: str | os.PathLike[str]) -> Model:
    """Reads a model file ``millcomp identify --save`` or :meth:`Model.save` wrote.

    Example::

        >>> millcomp.identify.load("stiffness.toml").kind
        'stiffness'

    Raises :class:`millcomp.ModelFileError` naming the file and key.
    """
    return _core.load(os.fspath(path))
