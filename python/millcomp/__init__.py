"""millcomp: micro-milling deflection compensation from Python, computed in Rust.

DOE (:mod:`millcomp.doe`), identification (:mod:`millcomp.identify`), closed-loop simulation
(:func:`simulate`, :func:`simulate_session`), batches (:func:`batch`), commissioning
(:func:`commission`), diagnosis (:func:`diagnose`) and the controller runtime (:class:`Controller`:
``step``, ``reset``, ``replay`` of a sensor log) — the library calls ``millcomp`` the CLI makes,
with tables as polars frames crossing as Arrow, and errors as :class:`MillcompError` subclasses with
the CLI's messages.

Example::

    >>> import millcomp
    >>> a = millcomp.doe.analyze("datasets/data/clayton_doe.csv", response="max_fx_n",
    ...                          factors=["depth_um", "speed_rpm", "upfeed_um"])
    >>> a.anova["term"].to_list()
    ['depth_um', 'speed_rpm', 'upfeed_um', 'Residual']
"""

from __future__ import annotations

from . import doe, errors, identify
from ._core import Command, Controller, __version__
from ._run import batch, commission, diagnose, simulate, simulate_session
from .errors import (
    ArgumentError,
    BatchInterrupted,
    ClosedLoopError,
    ControllerError,
    DatasetError,
    DiagnoseError,
    DoeError,
    IdentifyError,
    MillcompError,
    ModelFileError,
    SimulationError,
)

__all__ = [
    "__version__",
    "doe",
    "identify",
    "errors",
    "simulate",
    "simulate_session",
    "batch",
    "commission",
    "diagnose",
    "Controller",
    "Command",
    "MillcompError",
    "ArgumentError",
    "DatasetError",
    "ModelFileError",
    "DoeError",
    "IdentifyError",
    "DiagnoseError",
    "ClosedLoopError",
    "SimulationError",
    "ControllerError",
    "BatchInterrupted",
]
