"""Type stubs of the compiled part of millcomp (``millcomp._core``, Rust via PyO3)."""

from os import PathLike
from typing import Any, Callable

import polars as pl

__version__: str

class ArrowTable:
    """A table on its way to Python: ``polars.DataFrame(table)`` reads it through ``__arrow_c_stream__``."""

    @property
    def shape(self) -> tuple[int, int]: ...
    def __arrow_c_stream__(self, requested_schema: object | None = None) -> object: ...

class Analysis:
    """An analysis of one response (:func:`millcomp.doe.analyze`).

    Example::

        >>> a = millcomp.doe.analyze("datasets/data/clayton_doe.csv", response="max_fx_n",
        ...                          factors=["depth_um", "speed_rpm", "upfeed_um"])
        >>> round(a.anova["sum_sq"][0], 6)
        3.289612
    """

    @property
    def anova(self) -> pl.DataFrame:
        """Type II ANOVA: ``term, df, sum_sq, mean_sq, f, p_value``, the residual last."""
    @property
    def effects(self) -> pl.DataFrame:
        """Per term: ``term, effect, coef, std_err, p_value``."""
    @property
    def coefficients(self) -> pl.DataFrame:
        """Coefficients in coded units: ``name, coef, std_err, t, p_value``."""
    @property
    def lenth(self) -> pl.DataFrame | None:
        """Lenth's method: ``term, effect, t_pse, exceeds_me, exceeds_sme`` (``None`` where it does not apply)."""
    @property
    def lenth_limits(self) -> dict[str, float] | None:
        """Lenth's ``s0, pse, df, me, sme``."""
    @property
    def report(self) -> dict[str, Any]:
        """The analysis as ``millcomp --json doe analyze`` prints it."""
    @property
    def response(self) -> str: ...
    @property
    def r_squared(self) -> float: ...
    @property
    def notes(self) -> list[str]: ...
    def save(self, path: str | PathLike[str], command: str = ...) -> None:
        """Writes the response surface (kind ``response_surface``) in the model-file format, atomically."""

class Model:
    """An identified model (:func:`millcomp.identify.fit`, :func:`millcomp.identify.load`).

    Example::

        >>> m = millcomp.identify.fit("stiffness", "datasets/runs/stiffness_masses_synthetic.csv")
        >>> sorted(m.intervals) == sorted(m.params)
        True
    """

    @property
    def kind(self) -> str: ...
    @property
    def params(self) -> dict[str, float]: ...
    @property
    def std_err(self) -> dict[str, float]: ...
    @property
    def intervals(self) -> dict[str, tuple[float, float]]:
        """95 % intervals ``(low, high)`` by parameter."""
    @property
    def fixed(self) -> dict[str, float]: ...
    @property
    def status(self) -> str:
        """``converged``, ``stalled_at_rounding_level``, ``not_converged`` or ``rank_deficient``."""
    @property
    def warnings(self) -> list[str]: ...
    @property
    def notes(self) -> list[str]: ...
    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def header(self) -> dict[str, Any] | None: ...
    def save(self, path: str | PathLike[str], command: str = ...) -> None:
        """Writes the model file the CLI reads (``models/MODEL.md``), atomically."""

class Simulation:
    """A closed-loop run or a simulated session (:func:`millcomp.simulate`)."""

    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def metrics(self) -> dict[str, Any]: ...
    @property
    def trace(self) -> pl.DataFrame: ...

class Commissioning:
    """A model bundle (:func:`millcomp.commission`)."""

    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def bundle(self) -> dict[str, Any]: ...
    def save(self, path: str | PathLike[str], command: str = ...) -> None: ...

class Diagnosis:
    """A diagnosis (:func:`millcomp.diagnose`)."""

    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def named(self) -> list[Any]: ...
    @property
    def gap(self) -> dict[str, float | None]: ...
    @property
    def verdict(self) -> str: ...

class BatchSummary:
    """A batch's outcome (:func:`millcomp.batch`)."""

    @property
    def summary(self) -> dict[str, Any]: ...
    @property
    def results(self) -> pl.DataFrame: ...
    @property
    def out(self) -> str: ...

class Command:
    """What a controller sent in one cycle."""

    @property
    def voltage_v(self) -> float:
        """The voltage for the PZT amplifier (V)."""
    @property
    def flags(self) -> int:
        """The cycle's flag bits (docs/runtime.md: planned 1, fallback 2, deadline miss 4, no reading 8, ...)."""
    @property
    def iterations(self) -> int:
        """The QP's interior-point iterations (0 when none was solved)."""
    @property
    def planned(self) -> bool: ...
    @property
    def fallback(self) -> bool: ...

class Controller:
    """The controller runtime: built from a commissioned bundle and a program file, stepped once per period.

    Example::

        >>> ctl = millcomp.Controller.from_bundle("runtime/tests/data/bundle_s7.toml",
        ...                                       "runtime/tests/data/ramp_20deg.toml", budget=50)
        >>> c = ctl.step()                      # no reading yet
        >>> (ctl.kind, c.planned, 0.0 <= c.voltage_v <= 1000.0)
        ('mpc', True, True)
    """

    @staticmethod
    def from_bundle(
        bundle_path: str | PathLike[str],
        program_path: str | PathLike[str],
        *,
        controller: str | None = None,
        budget: str | int | None = None,
    ) -> Controller:
        """The controller the program names (or `controller`: none, open-loop, pid, ..., mpc), built
        from the bundle (``millcomp commission --out``). `budget`: ``None`` (the program's),
        ``"iterations"``, an iteration cap (1..500, deterministic) or ``"wall-clock"``.

        Raises :class:`millcomp.ModelFileError` (the bundle), :class:`millcomp.ControllerError`
        (the program file, naming the key), :class:`millcomp.ArgumentError`."""
    def step(self, x_mm: float = ..., force_n: float = ..., gauge_um: float = ...) -> Command:
        """One control cycle: the NC position (mm), the force (N) and gauge (um) readings (NaN or
        omitted: no reading) in, the command out."""
    def reset(self) -> None:
        """Back to the state right after construction (between cuts)."""
    def replay(self, log: object) -> pl.DataFrame:
        """A sensor log (a CSV/Parquet path or a frame with ``t_s, x_mm, force_n, gauge_um``) through
        the controller from its current state, by the runtime's replay (as ``millcomp replay``): the
        commands table ``controller, cycle, t_s, voltage_v, flags, iterations``.

        Raises :class:`millcomp.DatasetError` naming the column and row."""
    @property
    def kind(self) -> str: ...
    @property
    def period_s(self) -> float: ...
    @property
    def cycle(self) -> int: ...
    @property
    def counts(self) -> dict[str, int]: ...

def _time_step(ctl: Controller, steps: int, repeats: int) -> list[float]: ...
def design(options: dict[str, Any]) -> tuple[pl.DataFrame, dict[str, Any]]: ...
def analyze(
    source: object,
    response: str,
    factors: list[str] | None = None,
    model: str = "main",
    alpha: float = 0.05,
    reduce: bool = False,
    columns: str | None = None,
) -> Analysis: ...
def fit(kind: str, source: object, **options: Any) -> Model: ...
def load(path: str | PathLike[str]) -> Model: ...
def simulate(
    scenario: str | PathLike[str],
    controller: str = "none",
    realtime: bool = False,
    budget_fraction: float | None = None,
) -> Simulation: ...
def simulate_session_file(session: str | PathLike[str], noise_seed: int | None = None) -> Simulation: ...
def commission(
    scenario: str | None = None,
    seed: int | None = None,
    spindle: str | None = None,
    force: str | None = None,
    stiffness: str | None = None,
    material: str | None = None,
) -> Commissioning: ...
def diagnose(session: str, measured: object, **options: Any) -> Diagnosis: ...
def batch(
    out: str,
    controllers: str = "pid,mpc",
    scenarios: object | None = None,
    design: dict[str, Any] | None = None,
    columns: str | None = None,
    threads: int | None = None,
    cache: str | None = None,
    progress: bool | Callable[[dict[str, Any]], Any] | None = None,
    plots: bool = True,
) -> BatchSummary: ...
