"""Tables into the Rust core as Arrow C streams (no CSV round trip).

A polars frame (or anything with ``__arrow_c_stream__``, such as a pyarrow table) crosses as is; a
pandas frame, a dict of columns (lists or numpy arrays) and a numpy structured array are turned into
a polars frame first. A ``str`` or ``os.PathLike`` is a file the core reads as the CLI reads it.
"""

from __future__ import annotations

import os
from typing import Any

import polars as pl

from .errors import ArgumentError


def source(obj: Any, argument: str) -> Any:
    """`obj` as what the core takes: a path string or an Arrow stream capsule."""
    if isinstance(obj, (str, os.PathLike)):
        return os.fspath(obj)
    return stream(obj, argument)


def stream(obj: Any, argument: str) -> Any:
    """The Arrow stream capsule of a table-like `obj`; `argument` names it in errors."""
    frame = to_polars(obj, argument)
    if hasattr(frame, "__arrow_c_stream__"):
        return frame.__arrow_c_stream__()
    raise ArgumentError(f"argument `{argument}`: cannot export {type(obj).__name__} as an Arrow stream")


def to_polars(obj: Any, argument: str) -> Any:
    """`obj` as a polars frame (or kept as is when it already speaks the Arrow stream protocol)."""
    if isinstance(obj, pl.DataFrame):
        return obj
    if isinstance(obj, pl.LazyFrame):
        return obj.collect()
    mod = type(obj).__module__.split(".")[0]
    if mod == "pandas":
        import pandas as pd  # only when the caller already uses pandas

        if isinstance(obj, pd.DataFrame):
            return _from_pandas(obj.reset_index(drop=True))
    if mod == "numpy":
        names = getattr(getattr(obj, "dtype", None), "names", None)
        if names:
            return pl.DataFrame({n: obj[n] for n in names})
        raise ArgumentError(
            f"argument `{argument}`: a plain numpy array has no column names; "
            "pass a dict of columns or a structured array"
        )
    if isinstance(obj, dict):
        try:
            return pl.DataFrame(obj)
        except Exception as e:  # noqa: BLE001 - polars' own message, named by the argument
            raise ArgumentError(f"argument `{argument}`: {e}") from e
    if hasattr(obj, "__arrow_c_stream__"):
        return obj
    raise ArgumentError(
        f"argument `{argument}`: expected a table (a polars or pandas DataFrame, a dict of columns, "
        f"a numpy structured array) or a file path, got {type(obj).__name__}"
    )


def _from_pandas(df: Any) -> pl.DataFrame:
    """A pandas frame as polars: numeric columns through numpy, others (text) as Python values, so
    pyarrow is not needed."""
    columns = {}
    for name in df.columns:
        col = df[name]
        if col.dtype.kind in "iufb":
            columns[str(name)] = col.to_numpy()
        else:
            columns[str(name)] = [None if v is None or v != v else v for v in col.tolist()]
    return pl.DataFrame(columns, strict=False)
