"""Loading celldem run directories, and small curve helpers shared by the figure, report and study tools.

A run directory holds summary.json and one <test>/series.csv per test. The series columns are fixed by
SERIES_COLUMNS (strains dimensionless, compression positive; stresses in Pa, compression positive).
"""

import io
import json
import math
import os
import re
import warnings

import numpy as np

SERIES_COLUMNS = (
    "step", "time", "e1", "e2", "e3", "ev", "s11", "s22", "s33", "s12", "s13", "s23", "p", "q",
    "ratio13", "b", "sin_phi", "DI", "void_ratio", "Z", "Zm", "sliding_fraction", "n_contacts", "n_strong",
    "H11", "H22", "H33", "H12", "H13", "H23", "Hs11", "Hs22", "Hs33", "Hw11", "Hw22", "Hw33",
    "H11_H33", "Hs11_Hs33", "Hw11_Hw33", "kinetic_energy", "unbalanced_force",
)

# Columns that can be rebuilt from others when a series lacks them: name -> (numerator, denominator).
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


class Run:
    """One run directory: its summary (dict) and its series (test name -> {column -> array})."""

    def __init__(self, directory, summary, series):
        self.directory = directory
        self.summary = summary
        self.series = series

    @property
    def test_names(self):
        return list(self.series)

    def test(self, name):
        """The series of test `name`, or None when the run has no such test."""
        return self.series.get(name)


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
    """series.csv -> dict of column name -> float array. Empty fields (e.g. DI at the first rows) become NaN."""
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip()
        body = f.read().replace("\r", "")
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


def discover_tests(run_dir, summary):
    """Test names: those listed in summary.json first (in its order), then any other <dir>/series.csv.
    The preparation stage (prepare/series.csv) is not a loading test."""
    listed = list((summary.get("tests") or {}).keys())
    found = sorted(d for d in os.listdir(run_dir)
                   if d != "prepare" and os.path.isfile(os.path.join(run_dir, d, "series.csv")))
    return listed + [d for d in found if d not in listed]


def load_run(run_dir):
    summary = load_summary(run_dir)
    series = {}
    for name in discover_tests(run_dir, summary):
        path = os.path.join(run_dir, name, "series.csv")
        if not os.path.isfile(path):
            warnings.warn(f"test '{name}' is in summary.json but {path} is missing; skipped")
            continue
        series[name] = load_series(path)
    return Run(run_dir, summary, series)


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
    if name == "b":
        s11, s22, s33 = (series.get(n) for n in ("s11", "s22", "s33"))
        if s11 is not None and s22 is not None and s33 is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                return (s22 - s33) / (s11 - s33)
    return values


def finite_pair(x, y):
    keep = np.isfinite(x) & np.isfinite(y)
    return x[keep], y[keep]


def peak_index(values):
    """Index of the largest finite value, or None when there is none."""
    if values is None or not np.any(np.isfinite(values)):
        return None
    return int(np.nanargmax(values))


def value_at(x, y, x0):
    """y linearly interpolated at x0, or None when x0 lies outside the finite data (no extrapolation)."""
    if x is None or y is None:
        return None
    x, y = finite_pair(x, y)
    if x.size == 0 or x0 < x.min() or x0 > x.max():
        return None
    order = np.argsort(x, kind="stable")
    return float(np.interp(x0, x[order], y[order]))


def binned_means(x, y, edges):
    """Mean of y in each bin of x (NaN for empty bins). Binning averages out DEM noise before comparing curves."""
    x, y = finite_pair(x, y)
    inside = (x >= edges[0]) & (x <= edges[-1])
    x, y = x[inside], y[inside]
    n_bins = len(edges) - 1
    which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, n_bins - 1)  # x == edges[-1] in the last bin
    sums = np.bincount(which, weights=y, minlength=n_bins)
    counts = np.bincount(which, minlength=n_bins)
    means = np.full(n_bins, np.nan)
    np.divide(sums, counts, out=means, where=counts > 0)
    return means


def curve_difference(xa, ya, xb, yb, bins=100, relative_to="range"):
    """RMS difference of two noisy curves y(x) over the x range both cover.

    Both curves are averaged in `bins` equal bins of x. relative_to="range" divides the RMS difference by the
    span of the binned curves (max - min); relative_to="value" takes the RMS of the pointwise difference
    divided by the mean of the two values. Returns (difference, bins used) or (None, 0) without overlap.
    """
    if xa is None or ya is None or xb is None or yb is None:
        return None, 0
    xa, ya = finite_pair(xa, ya)
    xb, yb = finite_pair(xb, yb)
    if xa.size < 2 or xb.size < 2:
        return None, 0
    lo, hi = max(xa.min(), xb.min()), min(xa.max(), xb.max())
    if not hi > lo:
        return None, 0
    edges = np.linspace(lo, hi, bins + 1)
    ma, mb = binned_means(xa, ya, edges), binned_means(xb, yb, edges)
    both = np.isfinite(ma) & np.isfinite(mb)
    if np.count_nonzero(both) < 2:
        return None, 0
    ma, mb = ma[both], mb[both]
    if relative_to == "range":
        span = max(ma.max(), mb.max()) - min(ma.min(), mb.min())
        if span <= 0:
            return 0.0, int(both.sum())
        return float(math.sqrt(np.mean((ma - mb) ** 2)) / span), int(both.sum())
    mean = 0.5 * (ma + mb)
    return float(math.sqrt(np.mean(((ma - mb) / mean) ** 2))), int(both.sum())


def fmt(value, digits=3):
    """A number for a table; 'n/a' for missing or non-finite values."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(v):
        return "n/a"
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
        return f"{v:.{digits}g}"
    return f"{v:.{digits}f}"
