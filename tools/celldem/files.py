"""The files celldem writes into a run folder, read as plain data: summary.json, <stage>/series.csv,
series.columns.json and progress.json's deck. `celldem.api` builds its Run and Stage on these readers; nothing
here interprets a value (what a quantity means is celldem's: docs/outputs.md).

A series CSV has one header row naming its columns; empty fields and 'nan' (b while s11 ≈ s33, DI at the ends)
read as NaN. Strains are dimensionless and stresses in Pa, both compression positive.

Every JSON file of the package is parsed by load_json (read_json for one that may be absent): a file that is not
JSON raises FileFormatError naming the file, the line and the column.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
from typing import Any, Dict, List, Optional

import numpy as np
import numpy.typing as npt

from .binary import PathLike

# A series as the readers return it: column name -> float array (one value per row).
Arrays = Dict[str, npt.NDArray[np.float64]]
# series.columns.json as {name: {"unit": ..., "meaning": ...}}.
Columns = Dict[str, Dict[str, Optional[str]]]

# An empty CSV field: after a comma and before a comma or line end, or a line that starts with a comma.
EMPTY_FIELD = re.compile(r"(?<=,)(?=,|$)|^(?=,)", re.MULTILINE)


class RunError(Exception):
    """A run folder or file that cannot be read; the message says which file and why."""


class FileFormatError(RunError, ValueError):
    """A file that is there but is not what it should be: not JSON (the message gives the line and column of the
    problem), or not the JSON value expected. The message starts with the file's path; `path` and `problem` hold
    them apart."""

    def __init__(self, path: PathLike, problem: str) -> None:
        self.path, self.problem = os.fspath(path), problem
        super().__init__(f"{self.path}: {problem}")


def load_json(path: PathLike) -> Any:
    """The JSON value in a file: the one place the package parses a JSON file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    object
        The parsed value.

    Raises
    ------
    FileFormatError
        The file is not JSON (its message names the file, and the line and column of the problem).
    OSError
        The file cannot be opened (FileNotFoundError when it is missing); the message names it.
    """
    with open(path, "rb") as f:
        raw = f.read()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise FileFormatError(path, f"not JSON: not UTF-8 text (byte {err.start}: {err.reason})") from err
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        empty = " (the file is empty)" if not text.strip() else ""
        raise FileFormatError(path, f"not JSON: {err.msg} at line {err.lineno} column {err.colno}{empty}") from err


def read_json(path: PathLike) -> Any:
    """The JSON value in a file that may be absent.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    object or None
        The parsed value; None when the file is missing.

    Raises
    ------
    FileFormatError
        The file is there but is not JSON (load_json).
    RunError
        The file is there but cannot be read.
    """
    try:
        return load_json(path)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as err:
        raise RunError(f"cannot read {os.fspath(path)}: {err.strerror or err}") from err


def number(value: Any) -> Optional[float]:
    """A finite float of a JSON value.

    Parameters
    ----------
    value : object
        A value of summary.json (which writes null for non-finite values).

    Returns
    -------
    float or None
        The value when it is a finite number (not a bool), else None.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def load_summary(run_dir: PathLike) -> Dict[str, Any]:
    """A run folder's summary.json.

    Parameters
    ----------
    run_dir : str or os.PathLike
        The run folder.

    Returns
    -------
    dict
        summary.json's top-level object.

    Raises
    ------
    RunError
        The folder or the file is missing or unreadable.
    FileFormatError
        summary.json is not JSON, or not a JSON object (a RunError too).
    """
    path = os.path.join(run_dir, "summary.json")
    if not os.path.isdir(run_dir):
        raise RunError(f"run directory not found: {run_dir}")
    if not os.path.isfile(path):
        raise RunError(f"summary.json not found in run directory {run_dir}")
    summary = read_json(path)
    if not isinstance(summary, dict):
        raise FileFormatError(path, f"top level is {json_type(summary)}, not a JSON object")
    return summary


def json_type(value: Any) -> str:
    """The JSON name of a parsed value's type (for messages): object, array, string, number, boolean, null."""
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    return "null" if value is None else type(value).__name__


def load_series(path: PathLike) -> Arrays:
    """A series CSV (celldem's, or a translated LAMMPS/LIGGGHTS script's) as arrays.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file; its header row names the columns.

    Returns
    -------
    dict of str to numpy.ndarray
        Column name -> float array, in the header's order; empty fields and 'nan' are NaN.

    Raises
    ------
    RunError
        The file is missing, has no header, or a row does not match the header.
    """
    try:
        with open(path, encoding="utf-8") as f:
            header = f.readline().strip()
            body = f.read().replace("\r", "")
    except OSError as err:
        raise RunError(f"cannot read {path}: {err}") from err
    if not header:
        raise RunError(f"{path}: empty file, no header row")
    names = [n.strip() for n in header.split(",")]
    # np.loadtxt is fast but rejects empty fields, so they are spelled out as nan first.
    if not body.strip():
        return {name: np.empty(0) for name in names}
    body = EMPTY_FIELD.sub("nan", body)
    try:
        data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=float)
    except ValueError as err:
        raise RunError(f"{path}: {err}") from err
    if data.shape[1] != len(names):
        raise RunError(f"{path}: {len(names)} header names but {data.shape[1]} values per row")
    return {name: data[:, i] for i, name in enumerate(names)}


def load_columns(series_path: PathLike) -> Columns:
    """The units and meanings of a series' columns.

    Parameters
    ----------
    series_path : str or os.PathLike
        The series CSV; series.columns.json is read from its folder.

    Returns
    -------
    dict
        {name: {"unit": str, "meaning": str}}; {} when series.columns.json is absent (runs older than it).
    """
    meta = read_json(os.path.join(os.path.dirname(series_path), "series.columns.json"))
    entries = meta.get("columns") if isinstance(meta, dict) else None
    return {c["name"]: {"unit": c.get("unit"), "meaning": c.get("meaning")}
            for c in entries or [] if isinstance(c, dict) and "name" in c}


def discover_tests(run_dir: PathLike, summary: Dict[str, Any]) -> List[str]:
    """The names of a run's tests.

    Parameters
    ----------
    run_dir : str or os.PathLike
        The run folder.
    summary : dict
        Its summary.json.

    Returns
    -------
    list of str
        Those summary.json lists first (in its order), then any other <name>/series.csv; the preparation
        (prepare/series.csv) is not a test.
    """
    listed = list((summary.get("tests") or {}).keys())
    found = sorted(d for d in os.listdir(run_dir)
                   if d != "prepare" and os.path.isfile(os.path.join(run_dir, d, "series.csv")))
    return listed + [d for d in found if d not in listed]


def load_deck(run_dir: PathLike) -> Optional[Dict[str, Any]]:
    """The deck celldem ran.

    Parameters
    ----------
    run_dir : str or os.PathLike
        The run folder.

    Returns
    -------
    dict or None
        progress.json's deck (canonical JSON text, parsed); None when the file or the deck is missing.

    Raises
    ------
    FileFormatError
        progress.json, or the deck text in it, is not JSON.
    """
    path = os.path.join(run_dir, "progress.json")
    progress = read_json(path)
    text = progress.get("deck") if isinstance(progress, dict) else None
    if not isinstance(text, str):
        return None
    try:
        deck = json.loads(text)
    except json.JSONDecodeError as err:
        raise FileFormatError(path, f'its "deck" is not JSON: {err.msg} at column {err.colno} of the deck text') \
            from err
    return deck if isinstance(deck, dict) else None
