"""Loading celldem run directories.

A run directory holds summary.json (celldem's scalars per stage and test: read them, never recompute them) and
one <test>/series.csv per test, whose columns are named by its header row. celldem also writes
<stage>/series.columns.json beside each series ({"columns": [{"name", "unit", "meaning"}, ...]}); older runs
lack it, so units are optional. Strains are dimensionless and stresses in Pa, both compression positive.
"""

import argparse
import io
import json
import math
import os
import re
import sys
import warnings

import numpy as np

# Columns that can be rebuilt from others when a series lacks them (a series of another code, an older run):
# name -> (numerator, denominator). ratio13 is s11/s33 by its definition in the series table.
RATIO_FALLBACKS = {
    "ratio13": ("s11", "s33"),
    "H11_H33": ("H11", "H33"),
    "Hs11_Hs33": ("Hs11", "Hs33"),
    "Hw11_Hw33": ("Hw11", "Hw33"),
}

# An empty CSV field: after a comma and before a comma or line end, or a line that starts with a comma.
EMPTY_FIELD = re.compile(r"(?<=,)(?=,|$)|^(?=,)", re.MULTILINE)


class RunError(Exception):
    """A run directory that cannot be read; the message says which file and why."""


def read_json(path):
    """The JSON value in `path`, or None when the file is missing or unreadable."""
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, json.JSONDecodeError):
        return None


def number(value):
    """A finite float, or None (summary.json writes null for non-finite values)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


class Run:
    """One run directory: its summary (dict), its series (test name -> {column -> array}) and the units of
    the series columns (column -> {"unit", "meaning"}; empty for runs older than series.columns.json)."""

    def __init__(self, directory, summary, series, columns=None):
        self.directory = directory
        self.summary = summary
        self.series = series
        self.columns = columns or {}

    @property
    def test_names(self):
        return list(self.series)

    def test(self, name):
        """The series of test `name`, or None when the run has no such test."""
        return self.series.get(name)

    def column(self, test, name):
        return column(self.series.get(test), name)

    def test_summary(self, name):
        """summary.json's entry for test `name` ({} when there is none)."""
        info = (self.summary.get("tests") or {}).get(name)
        return info if isinstance(info, dict) else {}

    def quantity(self, test, key):
        """A number of summary.json's entry for `test`; `key` may be a path ("end_window.ev", "peak_state.p")."""
        value = self.test_summary(test)
        for part in key.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        return number(value)

    def unit(self, name):
        """The unit of series column `name` from series.columns.json, or None when unknown."""
        return (self.columns.get(name) or {}).get("unit")


def load_summary(run_dir):
    path = os.path.join(run_dir, "summary.json")
    if not os.path.isdir(run_dir):
        raise RunError(f"run directory not found: {run_dir}")
    if not os.path.isfile(path):
        raise RunError(f"summary.json not found in run directory {run_dir}")
    try:
        with open(path, encoding="utf-8") as f:
            summary = json.load(f)
    except (OSError, json.JSONDecodeError) as err:
        raise RunError(f"cannot read {path}: {err}") from err
    if not isinstance(summary, dict):
        raise RunError(f"{path}: top level must be a JSON object")
    return summary


def load_series(path):
    """A series CSV (celldem's, or a translated LAMMPS/LIGGGHTS script's) -> dict of column name -> float array,
    the names from its header row. Empty fields and 'nan' (b while s11 ≈ s33, DI at the ends) become NaN."""
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


def load_columns(series_path):
    """series.columns.json beside `series_path` as {name: {"unit", "meaning"}}; {} when it is absent."""
    meta = read_json(os.path.join(os.path.dirname(series_path), "series.columns.json"))
    entries = meta.get("columns") if isinstance(meta, dict) else None
    return {c["name"]: {"unit": c.get("unit"), "meaning": c.get("meaning")}
            for c in entries or [] if isinstance(c, dict) and "name" in c}


def discover_tests(run_dir, summary):
    """Test names: those listed in summary.json first (in its order), then any other <dir>/series.csv.
    The preparation stage (prepare/series.csv) is not a loading test."""
    listed = list((summary.get("tests") or {}).keys())
    found = sorted(d for d in os.listdir(run_dir)
                   if d != "prepare" and os.path.isfile(os.path.join(run_dir, d, "series.csv")))
    return listed + [d for d in found if d not in listed]


def load_run(run_dir):
    summary = load_summary(run_dir)
    series, columns = {}, {}
    for name in discover_tests(run_dir, summary):
        path = os.path.join(run_dir, name, "series.csv")
        if not os.path.isfile(path):
            warnings.warn(f"test '{name}' is in summary.json but {path} is missing; skipped")
            continue
        series[name] = load_series(path)
        columns.update(load_columns(path))
    return Run(run_dir, summary, series, columns)


def run_dir_parser(doc):
    """An argparse parser for a tool that reads one run directory: its description is the docstring's first line."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("run_dir", help="run directory holding summary.json and <test>/series.csv")
    return parser


def load_run_or_report(run_dir, tool):
    """load_run, or None after printing '<tool>: error: ...' on stderr (the entry scripts then exit 2)."""
    try:
        return load_run(run_dir)
    except RunError as err:
        print(f"{tool}: error: {err}", file=sys.stderr)
        return None


def column(series, name):
    """A column by name, rebuilt from its parts for ratio columns; None when the series cannot supply it."""
    if series is None:
        return None
    values = series.get(name)
    if values is not None and np.any(np.isfinite(values)):
        return values
    if name in RATIO_FALLBACKS:
        num, den = (series.get(n) for n in RATIO_FALLBACKS[name])
        if num is not None and den is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                return num / den
    return values
