"""celldem's public Python API, for one's own scripts (docs/python.md has the tour and an example).

    import celldem
    run = celldem.open_run("results/paper")          # a run folder
    df = run.tests["ttc"].series                     # pandas DataFrame, one column per series column
    df.attrs["units"]["s11"]                         # "Pa", from series.columns.json
    run.tests["ttc"].summary["peak_ratio13"]         # summary.json's value, computed by celldem

    deck = celldem.Deck.load("inputs/paper.json")
    deck["sample"]["count"] = 500
    celldem.check_deck(deck)                         # raises DeckError with celldem's message
    small = celldem.run_deck(deck, "results/small", threads=2)

Everything here reads what celldem wrote or asks the binary; nothing is computed again (the peak of a test is
summary.json's, what a deck implies is `celldem plan`'s). The binary is found as the tools find it: the
`celldem` argument, else $CELLDEM, else celldem on PATH, else the checkout's build/celldem (binary.find).
"""

from __future__ import annotations

import copy
import json
import os
import subprocess
import tempfile
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Union

from . import binary, decks, files
from .binary import PathLike

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Stage", "Run", "Ensemble", "open_run", "open_ensemble", "Deck", "DeckError", "RunFailed",
           "check_deck", "run_deck"]

PREPARE = "prepare"


class Stage:
    """One stage of a run: the preparation ("prepare") or a test.

    name     the stage's name (a test's name in the deck)
    summary  its entry of summary.json (for the preparation summary.json's "prepared"), a dict ({} if absent)
    series   <stage>/series.csv as a pandas DataFrame, one column per header name, read on first use; its
             attrs["units"] and attrs["meanings"] map column names to series.columns.json's unit and meaning
             (empty for runs older than that file)
    path     the stage's folder
    """

    def __init__(self, name: str, path: str, summary: Dict[str, Any]) -> None:
        self.name, self.path, self.summary = name, path, summary
        self._series: Optional[pd.DataFrame] = None

    @property
    def series(self) -> pd.DataFrame:
        """<stage>/series.csv as a pandas DataFrame (units and meanings in attrs), read on first use."""
        if self._series is None:
            import pandas as pd  # here, so that `import celldem` stays quick

            csv = os.path.join(self.path, "series.csv")
            frame = pd.DataFrame(files.load_series(csv))
            columns = files.load_columns(csv)
            frame.attrs["units"] = {n: c["unit"] for n, c in columns.items() if n in frame.columns}
            frame.attrs["meanings"] = {n: c["meaning"] for n, c in columns.items() if n in frame.columns}
            self._series = frame
        return self._series

    def __repr__(self) -> str:
        return f"Stage({self.name!r}, {self.path!r})"


class Run:
    """A run folder (`celldem run DECK --out DIR`).

    directory  the folder
    summary    summary.json as a dict
    deck       the deck celldem ran (from progress.json), a dict, or None for a run without progress.json
    stages     {name: Stage}: the preparation first when the run prepared its sample, then the tests
    tests      {name: Stage}: the tests only, in the deck's order (then any other <name>/series.csv)
    """

    def __init__(self, directory: PathLike) -> None:
        self.directory = os.path.abspath(directory)
        try:
            self.summary = files.load_summary(self.directory)
        except files.RunError as err:
            raise FileNotFoundError(str(err)) from err
        self.deck: Optional[Dict[str, Any]] = files.load_deck(self.directory)
        self.tests: Dict[str, Stage] = {}
        names = files.discover_tests(self.directory, self.summary)
        if self.deck:  # the deck's order (summary.json's keys are sorted)
            order = [t.get("name") for t in self.deck.get("tests") or [] if isinstance(t, dict)]
            names.sort(key=lambda n: order.index(n) if n in order else len(order))
        for name in names:
            path = os.path.join(self.directory, name)
            if os.path.isfile(os.path.join(path, "series.csv")):
                self.tests[name] = Stage(name, path, (self.summary.get("tests") or {}).get(name) or {})
        self.stages: Dict[str, Stage] = {}
        prepare = os.path.join(self.directory, PREPARE)
        if os.path.isfile(os.path.join(prepare, "series.csv")):
            self.stages[PREPARE] = Stage(PREPARE, prepare, self.summary.get("prepared") or {})
        self.stages.update(self.tests)

    def __repr__(self) -> str:
        return f"Run({self.directory!r}, stages={list(self.stages)})"


class Ensemble:
    """A seed ensemble folder (`celldem run DECK --seeds 1-8 --out DIR`).

    directory   the folder
    statistics  ensemble.json as a dict (celldem's mean, std, intervals of every summary quantity over the seeds,
                and the paired differences between tests)
    seeds       the seeds ensemble.json lists
    runs        {seed: Run} for each seed-<k>/ that holds a summary.json
    """

    def __init__(self, directory: PathLike) -> None:
        self.directory = os.path.abspath(directory)
        path = os.path.join(self.directory, "ensemble.json")
        if not os.path.isfile(path):
            raise FileNotFoundError(f"ensemble.json not found in {self.directory} (not a --seeds run folder)")
        with open(path, encoding="utf-8") as f:
            self.statistics: Dict[str, Any] = json.load(f)
        self.seeds: List[int] = list(self.statistics.get("seeds") or [])
        self.runs = {k: Run(os.path.join(self.directory, f"seed-{k}")) for k in self.seeds
                     if os.path.isfile(os.path.join(self.directory, f"seed-{k}", "summary.json"))}

    def __repr__(self) -> str:
        return f"Ensemble({self.directory!r}, seeds={self.seeds})"


def open_run(path: PathLike) -> Run:
    """Open a run folder.

    Parameters
    ----------
    path : str or os.PathLike
        The folder of `celldem run DECK --out DIR`.

    Returns
    -------
    Run
        Its summary, deck and stages (series as pandas DataFrames).

    Raises
    ------
    FileNotFoundError
        The folder or its summary.json is missing.
    """
    return Run(path)


def open_ensemble(path: PathLike) -> Ensemble:
    """Open a seed ensemble folder.

    Parameters
    ----------
    path : str or os.PathLike
        The folder of `celldem run DECK --seeds K-L --out DIR`.

    Returns
    -------
    Ensemble
        ensemble.json's statistics and each seed's Run.

    Raises
    ------
    FileNotFoundError
        The folder has no ensemble.json.
    """
    return Ensemble(path)


class DeckError(ValueError):
    """celldem refused a deck; the message is celldem's (it names the key path)."""


class RunFailed(RuntimeError):
    """`celldem run` failed while running (exit 1: a control that failed, a write that failed, ...)."""

    def __init__(self, message: str, returncode: int) -> None:
        super().__init__(message)
        self.returncode = returncode


class Deck:
    """A deck as data: a dict in `data`, indexable like one (deck["sample"]["count"]), and the folder its relative
    paths (initial_state, say) resolve from, `directory`: the deck file's folder, or for a deck built from a dict
    the working folder when it was built, unless given."""

    def __init__(self, data: Dict[str, Any], directory: Optional[PathLike] = None) -> None:
        if not isinstance(data, dict):
            raise TypeError(f"a deck is a JSON object (a dict), not {type(data).__name__}")
        self.data = data
        self.directory = os.path.abspath(directory or os.getcwd())

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], directory: Optional[PathLike] = None) -> Deck:
        """A deck from a dict (deep-copied: later changes to `data` do not reach the deck)."""
        return cls(copy.deepcopy(dict(data)), directory)

    @classmethod
    def load(cls, path: PathLike) -> Deck:
        """The deck in the JSON file at `path`."""
        with open(path, encoding="utf-8") as f:
            return cls(json.load(f), os.path.dirname(os.path.abspath(path)))

    def save(self, path: PathLike) -> PathLike:
        """Writes the deck as JSON (the tools' layout) to `path`; returns the path. Relative paths in it keep
        resolving from `directory`, so save into that folder unless the deck has none."""
        decks.write(str(path), self.data)
        return path

    def to_dict(self) -> Dict[str, Any]:
        """A deep copy of the deck's data."""
        return copy.deepcopy(self.data)

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def __setitem__(self, key: str, value: Any) -> None:
        self.data[key] = value

    def __contains__(self, key: object) -> bool:
        return key in self.data

    def __repr__(self) -> str:
        return f"Deck({json.dumps(self.data)[:80]}...)"


DeckLike = Union[Deck, Mapping[str, Any]]


def _as_deck(deck: DeckLike) -> Deck:
    return deck if isinstance(deck, Deck) else Deck.from_dict(deck)


class _DeckFile:
    """The deck written to a temporary file in its own folder (so that its relative paths resolve as they
    would from a deck file there), removed on exit."""

    def __init__(self, deck: DeckLike) -> None:
        self.deck = _as_deck(deck)
        self.path = ""

    def __enter__(self) -> str:
        fd, self.path = tempfile.mkstemp(prefix=".celldem-deck-", suffix=".json", dir=self.deck.directory)
        os.close(fd)
        self.deck.save(self.path)
        return self.path

    def __exit__(self, *exc: object) -> None:
        os.remove(self.path)


def check_deck(deck: DeckLike, *, celldem: Optional[PathLike] = None) -> str:
    """`celldem check` on a deck.

    Parameters
    ----------
    deck : Deck or dict
        The deck; its relative paths resolve from its `directory`.
    celldem : str or os.PathLike, optional
        The binary; default as binary.find: $CELLDEM, PATH, the checkout's build.

    Returns
    -------
    str
        What celldem prints for a valid deck (particles, tests, critical time step, cost estimate); the
        temporary file's name reads "<deck>".

    Raises
    ------
    DeckError
        celldem refused the deck; the message is celldem's, naming the key.
    binary.BinaryError
        No binary was found (the message lists the places tried).
    """
    with _DeckFile(deck) as path:
        try:
            return binary.check(path, celldem).replace(path, "<deck>")
        except binary.BinaryError as err:
            if not os.access(binary.find(celldem), os.X_OK):
                raise
            raise DeckError(str(err).replace(path, "<deck>")) from err


def run_deck(deck: DeckLike, out: PathLike, *, threads: Optional[int] = None, seeds: Optional[str] = None,
             force: bool = False, resume: bool = False, quiet: bool = True, fixed_threads: bool = False,
             tolerance: Optional[float] = None, include_uncontrolled: bool = False, verify_rate: bool = False,
             verify_rate_factor: Optional[float] = None, no_verify_twin: bool = False,
             floors: Optional[PathLike] = None,
             probes: Optional[str] = None, progress_interval: Optional[float] = None,
             celldem: Optional[PathLike] = None) -> Union[Run, Ensemble]:
    """`celldem run` of a deck into a folder; every option of `celldem run --help` is a keyword.

    Parameters
    ----------
    deck : Deck or dict
        The deck; its relative paths resolve from its `directory`.
    out : str or os.PathLike
        The run folder (`--out`).
    threads : int, optional
        `--threads`; None: celldem's default (all cores).
    seeds : str, optional
        `--seeds` ("1-8"; "3": one share of a job array): an ensemble.
    force, resume : bool
        `--force` (replace an earlier run's outputs), `--resume` (continue an interrupted run); not both.
    quiet : bool
        `--quiet`; False lets celldem's progress lines through to stderr.
    fixed_threads : bool
        `--fixed-threads`: no trials of one thread.
    tolerance : float, optional
        `--tolerance T`: answer within T noise floors in fewer steps.
    include_uncontrolled : bool
        `--include-uncontrolled` (with seeds): keep uncontrolled tests in the ensemble statistics.
    verify_rate : bool
        `--verify-rate`: each test checks its own convergence.
    verify_rate_factor, no_verify_twin, floors : optional
        `--verify-rate-factor`, `--no-verify-twin`, `--floors` (with verify_rate).
    probes : str, optional
        `--probes K-L`: only these probes (a job array's share).
    progress_interval : float, optional
        `--progress-interval` [s].
    celldem : str or os.PathLike, optional
        The binary; default as binary.find: $CELLDEM, PATH, the checkout's build.

    Returns
    -------
    Run or Ensemble
        open_run(out), or open_ensemble(out) with seeds.

    Raises
    ------
    DeckError
        celldem refused the deck or the options (exit 2).
    RunFailed
        The run failed (exit 1: a control that failed, a write that failed, ...).
    ValueError
        Options that exclude each other (force and resume; verify options without verify_rate).
    binary.BinaryError
        No binary was found (the message lists the places tried).
    """
    exe = binary.require(celldem)
    with _DeckFile(deck) as path:
        cmd = binary.run_command(path, os.path.abspath(out), threads, seeds, force, resume, quiet, exe,
                                 fixed_threads=fixed_threads, tolerance=tolerance,
                                 include_uncontrolled=include_uncontrolled, verify_rate=verify_rate,
                                 verify_rate_factor=verify_rate_factor, no_verify_twin=no_verify_twin,
                                 floors=floors, probes=probes,
                                 progress_interval=progress_interval)
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE if quiet else None, text=True)
    message = (r.stderr or "").strip().replace(path, "<deck>")
    if r.returncode == 2:
        raise DeckError(message or "celldem refused the deck (exit 2)")
    if r.returncode != 0:
        raise RunFailed(message or f"celldem run failed (exit {r.returncode})", r.returncode)
    return open_ensemble(out) if seeds is not None else open_run(out)
