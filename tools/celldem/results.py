"""The tools' view of a run or an ensemble: celldem.api's Run and Ensemble with their series as dicts of arrays.

There is one run type, `celldem.api.Run` (series as pandas DataFrames; `celldem.api.Ensemble` for a seed
ensemble). The reports, figures and study work on numpy arrays and on a few questions about summary.json
(is a test controlled, what is its quantity at a key path), so they read a RunArrays, which is derived from an
api.Run (`RunArrays(api_run)`, or `load_run(path)`): its series are the DataFrames' columns as arrays, its
summary, deck and folder the api.Run's own. EnsembleArrays is the same over an api.Ensemble's seeds.

Figures ask either kind for `curves(test, column)`: a list of (e1, values) pairs, one per run (one for a run,
one per seed for an ensemble). The files themselves are read by celldem.files (re-exported here).
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import api
from .binary import PathLike
from .files import (Arrays, Columns, FileFormatError, RunError, discover_tests, load_columns, load_deck, load_json,
                    load_series, load_summary, number, read_json)

# The readers of celldem.files are re-exported: the tools and tests read a series or a summary.json through here.
__all__ = ["RATIO_FALLBACKS", "Arrays", "Columns", "FileFormatError", "RunError", "RunArrays", "EnsembleArrays",
           "Loaded", "arrays", "units", "column", "discover_tests", "is_ensemble", "load_columns", "load_deck", "load_ensemble",
           "load_json", "load_run", "load_run_or_report", "load_series", "load_summary", "number", "read_json",
           "run_dir_parser"]

# Columns that can be rebuilt from others when a series lacks them (a series of another code, an older run):
# name -> (numerator, denominator). ratio13 is s11/s33 by its definition in the series table.
RATIO_FALLBACKS = {
    "ratio13": ("s11", "s33"),
    "H11_H33": ("H11", "H33"),
    "Hs11_Hs33": ("Hs11", "Hs33"),
    "Hw11_Hw33": ("Hw11", "Hw33"),
}

Array = npt.NDArray[np.float64]
Curve = Tuple[Array, Array]


def arrays(stage: api.Stage) -> Arrays:
    """A stage's series as arrays.

    Parameters
    ----------
    stage : celldem.api.Stage
        The stage.

    Returns
    -------
    dict of str to numpy.ndarray
        Each column of `stage.series` as a float array.
    """
    frame = stage.series
    return {str(name): frame[name].to_numpy(dtype=float) for name in frame.columns}


def units(stages: List[api.Stage]) -> Columns:
    """The units and meanings of the stages' columns ({name: {"unit", "meaning"}}), from their series' attrs."""
    out: Columns = {}
    for stage in stages:
        attrs = stage.series.attrs
        for name, unit in (attrs.get("units") or {}).items():
            out[name] = {"unit": unit, "meaning": (attrs.get("meanings") or {}).get(name)}
    return out


class RunArrays:
    """An api.Run as the tools read it (its damaged tests, whose series.csv is missing, left out: load_run warns).

    Attributes
    ----------
    source : celldem.api.Run
        The run this view is derived from.
    directory : str
        The run folder.
    summary : dict
        summary.json.
    series : dict of str to dict of str to numpy.ndarray
        Each test's series (test name -> {column -> array}), in the api.Run's order.
    prepare : dict of str to numpy.ndarray or None
        The preparation's series, None when the run did not prepare its sample.
    columns : dict
        {column: {"unit", "meaning"}} from series.columns.json; {} for runs older than it.
    deck : dict or None
        The deck as celldem read it (progress.json), None when unknown.
    """

    def __init__(self, run: api.Run) -> None:
        self.source = run
        self.directory: str = run.directory
        self.summary: Dict[str, Any] = run.summary
        self.deck: Optional[Dict[str, Any]] = run.deck
        self.series: Dict[str, Arrays] = {name: arrays(stage) for name, stage in run.tests.items()
                                          if stage.damaged is None}
        prepare = run.stages.get(api.PREPARE)
        self.prepare: Optional[Arrays] = arrays(prepare) if prepare is not None else None
        self.columns: Columns = units([stage for stage in run.stages.values() if stage.damaged is None])

    @property
    def runs(self) -> List[RunArrays]:
        """What an EnsembleArrays holds: here the one run."""
        return [self]

    @property
    def test_names(self) -> List[str]:
        """The tests' names, in the run's order."""
        return list(self.series)

    def test(self, name: str) -> Optional[Arrays]:
        """The series of test `name`, or None when the run has no such test."""
        return self.series.get(name)

    def column(self, test: str, name: str) -> Optional[Array]:
        """Column `name` of test `test` (see `column`), None when missing."""
        return column(self.series.get(test), name)

    def test_summary(self, name: str) -> Dict[str, Any]:
        """summary.json's entry for test `name` ({} when there is none)."""
        info = (self.summary.get("tests") or {}).get(name)
        return info if isinstance(info, dict) else {}

    def quantity(self, test: str, key: str) -> Optional[float]:
        """A number of summary.json's entry for `test`; `key` may be a path ("end_window.ev", "peak_state.p")."""
        value: Any = self.test_summary(test)
        for part in key.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        return number(value)

    def controlled(self, test: str) -> bool:
        """summary.json's "controlled" of `test`: False when a control failed and the deck chose to continue
        (a run from before the key existed counts as controlled)."""
        return self.test_summary(test).get("controlled", True) is not False

    def peak_reached(self, test: str) -> bool:
        """summary.json's "peak_reached" of `test`: False when the largest s11/s33 is the test's last row (a run
        from before the key existed counts as having one)."""
        return self.test_summary(test).get("peak_reached", True) is not False

    def control_failures(self, test: str) -> List[Any]:
        """summary.json's "control_failures" of `test` ([] when there are none or the run predates them)."""
        return list(self.test_summary(test).get("control_failures") or [])

    def unit(self, name: str) -> Optional[str]:
        """The unit of series column `name` from series.columns.json, or None when unknown."""
        return (self.columns.get(name) or {}).get("unit")

    def curves(self, test: str, name: str, x: str = "e1") -> List[Curve]:
        """[(x, column)] of test `test` (test "prepare": the preparation), [] when either column is missing."""
        series = self.prepare if test == api.PREPARE else self.test(test)
        xs, ys = column(series, x), column(series, name)
        return [] if xs is None or ys is None else [(xs, ys)]

    def deck_test(self, name: str) -> Dict[str, Any]:
        """The deck's entry for test `name` (progress.json), {} when the deck is unknown."""
        for test in (self.deck or {}).get("tests") or []:
            if isinstance(test, dict) and test.get("name") == name:
                return test
        return {}

    def mean_diameter(self) -> Optional[float]:
        """The mean sphere diameter [m]: summary.json's settings.mean_diameter_m (celldem's, a grading's included),
        else the mean of settings.diameters_m, each size equally likely (runs of earlier versions)."""
        settings = self.summary.get("settings") or {}
        mean = number(settings.get("mean_diameter_m"))
        if mean:
            return mean
        sizes = [d for d in (number(v) for v in settings.get("diameters_m") or []) if d]
        return sum(sizes) / len(sizes) if sizes else None


class EnsembleArrays:
    """An api.Ensemble as the tools read it: its statistics and a RunArrays per seed.

    Attributes
    ----------
    source : celldem.api.Ensemble
        The ensemble this view is derived from.
    directory : str
        The ensemble folder.
    stats : dict
        ensemble.json (celldem's statistics over the seeds).
    runs : list of RunArrays
        Each seed's run, in ensemble.json's order of seeds.
    """

    def __init__(self, ensemble: api.Ensemble) -> None:
        self.source = ensemble
        self.directory: str = ensemble.directory
        self.stats: Dict[str, Any] = ensemble.statistics
        self.runs: List[RunArrays] = [RunArrays(run) for run in ensemble.runs.values()]

    @property
    def seeds(self) -> List[int]:
        """The seeds ensemble.json lists."""
        return list(self.stats.get("seeds") or [])

    @property
    def test_names(self) -> List[str]:
        """Every seed's tests, in the order first met."""
        names: List[str] = []
        for run in self.runs:
            names += [n for n in run.test_names if n not in names]
        return names

    @property
    def prepare(self) -> Optional[Arrays]:
        """The first seed's preparation series, None when no seed prepared."""
        return next((r.prepare for r in self.runs if r.prepare is not None), None)

    def test(self, name: str) -> Optional[Arrays]:
        """The first seed's series of `name` (for what needs one series: which columns exist)."""
        return next((r.test(name) for r in self.runs if r.test(name) is not None), None)

    def unit(self, name: str) -> Optional[str]:
        """The unit of series column `name`, None when unknown."""
        return next((r.unit(name) for r in self.runs if r.unit(name)), None)

    def curves(self, test: str, name: str, x: str = "e1") -> List[Curve]:
        """Each seed's [(x, column)] of `test`."""
        return [c for run in self.runs for c in run.curves(test, name, x)]

    def statistic(self, group: str, *keys: str) -> Optional[Dict[str, Any]]:
        """ensemble.json's entry {"n", "mean", "std", "sem", "ci95", "values"} under `group` ("prepared", "tests",
        "paired") and keys: statistic("tests", "psc", "b_at_peak"), statistic("paired", "ttc-psc", "peak_ratio13");
        None when it has none."""
        node: Any = self.stats.get(group)
        for key in keys:
            node = node.get(key) if isinstance(node, dict) else None
        return node if isinstance(node, dict) and "mean" in node else None


Loaded = Union[RunArrays, EnsembleArrays]


def load_run(run_dir: PathLike) -> RunArrays:
    """A run folder as the tools read it.

    Parameters
    ----------
    run_dir : str or os.PathLike
        The run folder.

    Returns
    -------
    RunArrays
        Derived from `celldem.api.open_run(run_dir)`, its series read at once.

    Raises
    ------
    RunError
        The folder, its summary.json or a series cannot be read (FileFormatError, a RunError, for a JSON file that
        is not JSON).

    A damaged test (in summary.json, its series.csv missing) is left out with a warning naming the file.
    """
    try:
        run = api.open_run(run_dir)
    except FileNotFoundError as err:
        raise RunError(str(err)) from err
    for name in run.damaged:
        path = os.path.join(run.directory, name, "series.csv")
        warnings.warn(f"test '{name}' is in summary.json but {path} is missing; skipped")
    return RunArrays(run)


def is_ensemble(directory: PathLike) -> bool:
    """Whether `directory` is a seed ensemble (it holds ensemble.json)."""
    return os.path.isfile(os.path.join(directory, "ensemble.json"))


def load_ensemble(directory: PathLike) -> EnsembleArrays:
    """An ensemble folder as the tools read it.

    Parameters
    ----------
    directory : str or os.PathLike
        The folder of `celldem run DECK --seeds K-L`.

    Returns
    -------
    EnsembleArrays
        Derived from `celldem.api.open_ensemble(directory)`.

    Raises
    ------
    RunError
        ensemble.json cannot be read, or no seed-<k>/ it names holds a summary.json.
    """
    try:
        ensemble = api.open_ensemble(directory)
    except RunError:
        raise
    except (OSError, ValueError) as err:
        raise RunError(f"cannot read {os.path.join(directory, 'ensemble.json')}: {err}") from err
    if not ensemble.runs:
        raise RunError(f"{directory}: ensemble.json names seeds {ensemble.seeds} but no seed-<k>/summary.json "
                       "is there")
    try:
        return EnsembleArrays(ensemble)
    except FileNotFoundError as err:
        raise RunError(str(err)) from err


def run_dir_parser(doc: str) -> argparse.ArgumentParser:
    """An argparse parser for a tool that reads one run directory: its description is the docstring's first line."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("run_dir", help="run directory holding summary.json and <test>/series.csv, or an ensemble "
                        "directory holding ensemble.json and seed-<k>/")
    return parser


def load_run_or_report(run_dir: PathLike, tool: str) -> Optional[Loaded]:
    """load_run (load_ensemble for a folder with ensemble.json), or None after printing '<tool>: error: ...' on
    stderr (the entry scripts then exit 2)."""
    try:
        return load_ensemble(run_dir) if is_ensemble(run_dir) else load_run(run_dir)
    except RunError as err:
        print(f"{tool}: error: {err}", file=sys.stderr)
        return None


def column(series: Optional[Arrays], name: str) -> Optional[Array]:
    """A column of a series, rebuilt from its parts for ratio columns.

    Parameters
    ----------
    series : dict of str to numpy.ndarray or None
        The series.
    name : str
        The column; a ratio of RATIO_FALLBACKS is rebuilt from its numerator and denominator when the series
        lacks it or holds no finite value of it.

    Returns
    -------
    numpy.ndarray or None
        The values; None when the series cannot supply them.
    """
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
