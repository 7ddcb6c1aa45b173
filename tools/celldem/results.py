"""Loading celldem run directories and seed ensembles.

A run directory holds summary.json (celldem's scalars per stage and test: read them, never recompute them),
prepare/series.csv when the run prepared its sample, one <test>/series.csv per test, whose columns are named by
its header row, and progress.json (the deck as celldem read it). celldem also writes
<stage>/series.columns.json beside each series ({"columns": [{"name", "unit", "meaning"}, ...]}); older runs
lack it, so units are optional. Strains are dimensionless and stresses in Pa, both compression positive.

An ensemble directory (`celldem run DECK --seeds 1-8`) holds ensemble.json (celldem's mean, std, sem and 95 %
interval of every summary quantity over the seeds, and the paired differences between tests) and one run
directory per seed, seed-<k>/.

Figures ask either kind for `curves(test, column)`: a list of (e1, values) pairs, one per run (one for a run,
one per seed for an ensemble).
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

    def __init__(self, directory, summary, series, columns=None, prepare=None, deck=None):
        self.directory = directory
        self.summary = summary
        self.series = series
        self.columns = columns or {}
        self.prepare = prepare  # prepare/series.csv ({column -> array}), None when the run did not prepare
        self.deck = deck        # the deck as celldem read it (progress.json), None when unknown

    runs = property(lambda self: [self])  # what an Ensemble holds: one run here

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

    def controlled(self, test):
        """summary.json's "controlled" of `test`: False when a control failed and the deck chose to continue
        (a run from before the key existed counts as controlled)."""
        return self.test_summary(test).get("controlled", True) is not False

    def peak_reached(self, test):
        """summary.json's "peak_reached" of `test`: False when the largest s11/s33 is the test's last row (a run
        from before the key existed counts as having one)."""
        return self.test_summary(test).get("peak_reached", True) is not False

    def control_failures(self, test):
        """summary.json's "control_failures" of `test` ([] when there are none or the run predates them)."""
        return list(self.test_summary(test).get("control_failures") or [])

    def unit(self, name):
        """The unit of series column `name` from series.columns.json, or None when unknown."""
        return (self.columns.get(name) or {}).get("unit")

    def curves(self, test, name, x="e1"):
        """[(x, column)] of test `test` (test "prepare": the preparation), [] when either column is missing."""
        series = self.prepare if test == "prepare" else self.test(test)
        xs, ys = column(series, x), column(series, name)
        return [] if xs is None or ys is None else [(xs, ys)]

    def deck_test(self, name):
        """The deck's entry for test `name` (progress.json), {} when the deck is unknown."""
        for test in (self.deck or {}).get("tests") or []:
            if isinstance(test, dict) and test.get("name") == name:
                return test
        return {}

    def mean_diameter(self):
        """The mean sphere diameter [m]: summary.json's settings.mean_diameter_m (celldem's, a grading's included),
        else the mean of settings.diameters_m, each size equally likely (runs of earlier versions)."""
        settings = self.summary.get("settings") or {}
        if number(settings.get("mean_diameter_m")):
            return number(settings["mean_diameter_m"])
        sizes = [number(d) for d in settings.get("diameters_m") or []]
        sizes = [d for d in sizes if d]
        return sum(sizes) / len(sizes) if sizes else None


class Ensemble:
    """A seed ensemble: ensemble.json (`stats`: celldem's statistics) and the Run of each seed-<k>/ (`runs`)."""

    def __init__(self, directory, stats, runs):
        self.directory = directory
        self.stats = stats
        self.runs = runs

    @property
    def seeds(self):
        return list(self.stats.get("seeds") or [])

    @property
    def test_names(self):
        names = []
        for run in self.runs:
            names += [n for n in run.test_names if n not in names]
        return names

    @property
    def prepare(self):
        return next((r.prepare for r in self.runs if r.prepare is not None), None)

    def test(self, name):
        """The first seed's series of `name` (for what needs one series: which columns exist)."""
        return next((r.test(name) for r in self.runs if r.test(name) is not None), None)

    def unit(self, name):
        return next((r.unit(name) for r in self.runs if r.unit(name)), None)

    def curves(self, test, name, x="e1"):
        return [c for run in self.runs for c in run.curves(test, name, x)]

    def statistic(self, group, *keys):
        """ensemble.json's entry {"n", "mean", "std", "sem", "ci95", "values"} under `group` ("prepared", "tests",
        "paired") and keys: statistic("tests", "psc", "b_at_peak"), statistic("paired", "ttc-psc", "peak_ratio13");
        None when it has none."""
        node = self.stats.get(group)
        for key in keys:
            node = node.get(key) if isinstance(node, dict) else None
        return node if isinstance(node, dict) and "mean" in node else None


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


def load_deck(run_dir):
    """The deck celldem ran, from progress.json (canonical JSON text), or None."""
    progress = read_json(os.path.join(run_dir, "progress.json"))
    try:
        deck = json.loads(progress["deck"]) if isinstance(progress, dict) else None
    except (KeyError, TypeError, json.JSONDecodeError):
        return None
    return deck if isinstance(deck, dict) else None


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
    prepare_path = os.path.join(run_dir, "prepare", "series.csv")
    prepare = None
    if os.path.isfile(prepare_path):
        prepare = load_series(prepare_path)
        columns.update(load_columns(prepare_path))
    return Run(run_dir, summary, series, columns, prepare, load_deck(run_dir))


def is_ensemble(directory):
    return os.path.isfile(os.path.join(directory, "ensemble.json"))


def load_ensemble(directory):
    """An ensemble directory: ensemble.json and each seed-<k>/ run that has a summary.json."""
    stats = read_json(os.path.join(directory, "ensemble.json"))
    if not isinstance(stats, dict):
        raise RunError(f"cannot read {os.path.join(directory, 'ensemble.json')}")
    seeds = stats.get("seeds") or []
    runs = [load_run(os.path.join(directory, f"seed-{k}")) for k in seeds
            if os.path.isfile(os.path.join(directory, f"seed-{k}", "summary.json"))]
    if not runs:
        raise RunError(f"{directory}: ensemble.json names seeds {seeds} but no seed-<k>/summary.json is there")
    return Ensemble(directory, stats, runs)


def run_dir_parser(doc):
    """An argparse parser for a tool that reads one run directory: its description is the docstring's first line."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("run_dir", help="run directory holding summary.json and <test>/series.csv, or an ensemble "
                        "directory holding ensemble.json and seed-<k>/")
    return parser


def load_run_or_report(run_dir, tool):
    """load_run (load_ensemble for a folder with ensemble.json), or None after printing '<tool>: error: ...' on
    stderr (the entry scripts then exit 2)."""
    try:
        return load_ensemble(run_dir) if is_ensemble(run_dir) else load_run(run_dir)
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
