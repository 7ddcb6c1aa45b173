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

import contextlib
import copy
import json
import os
import re
import signal
import subprocess
import tempfile
import threading
from types import FrameType
from typing import TYPE_CHECKING, Any, Dict, Iterator, List, Mapping, Optional, Set, Union

from . import binary, decks, files
from .binary import PathLike
from .files import FileFormatError, RunError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Stage", "Run", "Ensemble", "open_run", "open_ensemble", "Deck", "DeckError", "RunFailed",
           "RunError", "FileFormatError", "check_deck", "run_deck"]

PREPARE = "prepare"


class Stage:
    """One stage of a run: the preparation ("prepare") or a test.

    name     the stage's name (a test's name in the deck)
    summary  its entry of summary.json (for the preparation summary.json's "prepared"), a dict ({} if absent)
    series   <stage>/series.csv as a pandas DataFrame, one column per header name, read on first use; its
             attrs["units"] and attrs["meanings"] map column names to series.columns.json's unit and meaning
             (empty for runs older than that file)
    path     the stage's folder
    damaged  None for a stage whose series.csv is there; else why it cannot be read (a test summary.json lists
             whose <test>/series.csv is missing): its summary is still there, its series raises FileNotFoundError
             naming the file
    """

    def __init__(self, name: str, path: str, summary: Dict[str, Any], damaged: Optional[str] = None) -> None:
        self.name, self.path, self.summary, self.damaged = name, path, summary, damaged
        self._series: Optional[pd.DataFrame] = None

    @property
    def series(self) -> pd.DataFrame:
        """<stage>/series.csv as a pandas DataFrame (units and meanings in attrs), read on first use;
        FileNotFoundError naming the file for a damaged stage."""
        if self.damaged is not None:
            raise FileNotFoundError(f"{self.name!r} is damaged: {self.damaged}")
        if self._series is None:
            import pandas as pd  # here, so that `import celldem` stays quick

            csv = os.path.join(self.path, "series.csv")
            frame = pd.DataFrame(files.load_series(csv))
            columns = files.load_columns(csv)
            frame.attrs["units"] = {n: c["unit"] for n, c in columns.items() if n in frame.columns}
            frame.attrs["meanings"] = {n: c["meaning"] for n, c in columns.items() if n in frame.columns}
            self._series = frame
        return self._series

    ENERGY_COLUMNS = ("energy_boundary_work", "energy_normal", "energy_tangential", "energy_rotational_springs",
                      "energy_kinetic_translation", "energy_kinetic_rotation", "energy_friction",
                      "energy_rotational_friction", "energy_body_damping", "energy_contact_damping",
                      "energy_closure", "energy_closure_relative")

    @property
    def energy(self) -> Optional[pd.DataFrame]:
        """The energy budget's series (the deck's `energy_budget`, docs/energy.md): e1 and the energy_ columns,
        each row since the stage started, [J]; None when the run kept no budget (the columns are NaN or
        absent). The test's totals, per leg, worst closure and damping share are in summary["energy"]."""
        frame = self.series
        if "energy_boundary_work" not in frame.columns or frame["energy_boundary_work"].isna().all():
            return None
        keep = [c for c in ("step", "e1", "leg") + self.ENERGY_COLUMNS if c in frame.columns]
        return frame[keep]

    def __repr__(self) -> str:
        damaged = f", damaged={self.damaged!r}" if self.damaged is not None else ""
        return f"Stage({self.name!r}, {self.path!r}{damaged})"


class Run:
    """A run folder (`celldem run DECK --out DIR`).

    directory  the folder
    summary    summary.json as a dict
    deck       the deck celldem ran (from progress.json), a dict, or None for a run without progress.json
    stages     {name: Stage}: the preparation first when the run prepared its sample, then the tests
    tests      {name: Stage}: the tests only, in the deck's order (then any other <name>/series.csv); a test
               summary.json lists whose series.csv is missing is there too, damaged (Stage.damaged says why)
    damaged    {name: why} of the damaged tests ({} for a whole run)
    """

    def __init__(self, directory: PathLike) -> None:
        self.directory = os.path.abspath(directory)
        try:
            self.summary = files.load_summary(self.directory)
        except FileFormatError:
            raise
        except RunError as err:
            raise FileNotFoundError(str(err)) from err
        self.deck: Optional[Dict[str, Any]] = files.load_deck(self.directory)
        self.tests: Dict[str, Stage] = {}
        names = files.discover_tests(self.directory, self.summary)
        if self.deck:  # the deck's order (summary.json's keys are sorted)
            order = [t.get("name") for t in self.deck.get("tests") or [] if isinstance(t, dict)]
            names.sort(key=lambda n: order.index(n) if n in order else len(order))
        for name in names:
            path = os.path.join(self.directory, name)
            csv = os.path.join(path, "series.csv")
            damaged = None if os.path.isfile(csv) else f"summary.json lists the test but {csv} is missing"
            self.tests[name] = Stage(name, path, (self.summary.get("tests") or {}).get(name) or {}, damaged)
        self.damaged: Dict[str, str] = {n: t.damaged for n, t in self.tests.items() if t.damaged is not None}
        self.stages: Dict[str, Stage] = {}
        prepare = os.path.join(self.directory, PREPARE)
        if os.path.isfile(os.path.join(prepare, "series.csv")):
            self.stages[PREPARE] = Stage(PREPARE, prepare, self.summary.get("prepared") or {})
        self.stages.update(self.tests)

    @property
    def energy(self) -> Dict[str, Dict[str, Any]]:
        """{test: summary.json's tests.<test>.energy} for the tests that kept an energy budget: totals over the
        test and per leg ("legs"), the worst closure error, damping's share and the verdicts (docs/energy.md)."""
        return {n: t.summary["energy"] for n, t in self.tests.items() if isinstance(t.summary.get("energy"), dict)}

    def __repr__(self) -> str:
        damaged = f", damaged={list(self.damaged)}" if self.damaged else ""
        return f"Run({self.directory!r}, stages={list(self.stages)}{damaged})"


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
        statistics = files.load_json(path)
        if not isinstance(statistics, dict):
            raise FileFormatError(path, f"top level is {files.json_type(statistics)}, not a JSON object")
        seeds = statistics.get("seeds")
        if not isinstance(seeds, list):
            raise FileFormatError(path, f'"seeds" is {files.json_type(seeds)}, not an array of whole numbers')
        if not all(isinstance(k, int) and not isinstance(k, bool) for k in seeds):
            raise FileFormatError(path, f'"seeds" holds a value that is not a whole number: {seeds}')
        self.statistics: Dict[str, Any] = statistics
        self.seeds: List[int] = list(seeds)
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
    FileFormatError
        summary.json, progress.json or series.columns.json is not JSON (the message names the file, the line and
        the column), or summary.json is not a JSON object.

    A test summary.json lists whose series.csv is missing is kept, damaged: run.damaged names it, and its series
    raises FileNotFoundError naming the file.
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
    FileFormatError
        ensemble.json is not JSON (the message names the file, the line and the column), not a JSON object, or its
        "seeds" is not an array of whole numbers.
    """
    return Ensemble(path)


class DeckError(ValueError):
    """A deck that is refused: by celldem (the message is celldem's; it names the key path), or, for a deck file
    that is not a JSON object, by Deck.load (the message names the file, and for one that is not JSON the line and
    column)."""


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
        """The deck in the JSON file at `path`; its relative paths resolve from the file's folder. DeckError naming
        the file when it is not JSON (with the line and column) or not a JSON object; FileNotFoundError when it is
        missing."""
        try:
            data = files.load_json(path)
        except FileFormatError as err:
            raise DeckError(str(err)) from err
        if not isinstance(data, dict):
            raise DeckError(f"{os.fspath(path)}: a deck is a JSON object, and the file holds {files.json_type(data)}")
        return cls(data, os.path.dirname(os.path.abspath(path)))

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


DeckLike = Union[Deck, Mapping[str, Any], str, "os.PathLike[str]"]


def _as_deck(deck: DeckLike, parameter: str = "deck") -> Deck:
    """A Deck of what the API takes as one: a Deck, a dict (copied) or a deck file's path (Deck.load); TypeError
    naming the parameter and the type for anything else."""
    if isinstance(deck, Deck):
        return deck
    if isinstance(deck, Mapping):
        return Deck.from_dict(deck)
    if isinstance(deck, (str, os.PathLike)) and isinstance(os.fspath(deck), str):
        return Deck.load(deck)
    raise TypeError(f"{parameter}: a Deck, a dict or a deck file's path (str or os.PathLike) is needed, not "
                    f"{type(deck).__name__}")


class _DeckFile:
    """The deck written to a temporary file in its own folder (so that its relative paths resolve as they
    would from a deck file there), removed on exit however the block ends."""

    def __init__(self, deck: DeckLike) -> None:
        self.deck = _as_deck(deck)
        self.path = ""

    def __enter__(self) -> str:
        fd, self.path = tempfile.mkstemp(prefix=".celldem-deck-", suffix=".json", dir=self.deck.directory)
        os.close(fd)
        try:
            self.deck.save(self.path)
        except BaseException:
            self._remove()
            raise
        return self.path

    def __exit__(self, *exc: object) -> None:
        self._remove()

    def _remove(self) -> None:
        for path in (self.path, self.path + ".tmp"):  # (.tmp: Deck.save's, when a write fails)
            with contextlib.suppress(FileNotFoundError):
                os.remove(path)


class _Terminated(BaseException):
    """SIGTERM arrived while run_deck waited for celldem (_sigterm_raises)."""


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """Within the block, SIGTERM (a batch system's time limit) raises _Terminated, so that the block's cleanup runs
    (celldem stopped, the temporary deck removed); on leaving, the previous handler is back and a SIGTERM that
    arrived is delivered again, so that the process ends as SIGTERM would have ended it. Only where SIGTERM has its
    default action and in the main thread (where Python runs handlers); elsewhere nothing changes: a handler of
    the caller's own runs as before."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return

    def terminated(signum: int, frame: Optional[FrameType]) -> None:
        raise _Terminated()

    previous = signal.signal(signal.SIGTERM, terminated)
    try:
        yield
    except _Terminated:
        signal.signal(signal.SIGTERM, previous)
        os.kill(os.getpid(), signal.SIGTERM)
        raise SystemExit(128 + signal.SIGTERM)  # (only where the default action did not end the process)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _stop(proc: "subprocess.Popen[str]") -> None:
    """Ends a celldem run that is still going (the caller was interrupted): SIGTERM, which celldem answers by
    writing its checkpoint and stopping, then waits for it."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            proc.terminate()
        proc.wait()


def check_deck(deck: DeckLike, *, celldem: Optional[PathLike] = None) -> str:
    """`celldem check` on a deck.

    Parameters
    ----------
    deck : Deck, dict, str or os.PathLike
        The deck (a path: the deck file, as Deck.load); its relative paths resolve from its `directory`.
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
        celldem refused the deck; the message is celldem's, naming the key. Or a deck file that is not a JSON
        object (the message names the file).
    TypeError
        `deck` is none of the types above.
    binary.BinaryError
        No binary was found (the message lists the places tried), or the one given is not celldem (its
        `--version` does not say so; the message names the path).
    """
    exe = binary.require(celldem)
    with _DeckFile(deck) as path:
        try:
            return binary.check(path, exe).replace(path, "<deck>")
        except binary.BinaryError as err:
            raise DeckError(str(err).replace(path, "<deck>")) from err


def run_deck(deck: DeckLike, out: PathLike, *, threads: Optional[int] = None, seeds: Optional[str] = None,
             force: bool = False, resume: bool = False, quiet: bool = True, fixed_threads: bool = False,
             tolerance: Optional[float] = None, include_uncontrolled: bool = False, verify_rate: bool = False,
             verify_rate_factor: Optional[float] = None, no_verify_twin: bool = False,
             verify_rate_rungs: Optional[str] = None, verify_twins: Optional[int] = None,
             floors: Optional[PathLike] = None,
             probes: Optional[str] = None, progress_interval: Optional[float] = None,
             celldem: Optional[PathLike] = None) -> Union[Run, Ensemble]:
    """`celldem run` of a deck into a folder; every option of `celldem run --help` is a keyword.

    Parameters
    ----------
    deck : Deck, dict, str or os.PathLike
        The deck (a path: the deck file, as Deck.load); its relative paths resolve from its `directory`.
    out : str or os.PathLike
        The run folder (`--out`).
    threads : int, optional
        `--threads`; None: celldem's default (all cores).
    seeds : str, optional
        `--seeds` ("1-8", "1,3,5"): an ensemble. One seed ("3", or "3-3"): one share of a job array, run into
        out/seed-3/ with no ensemble.json (`celldem merge` gathers the shares).
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
    verify_rate_factor, verify_rate_rungs, verify_twins, no_verify_twin, floors : optional
        `--verify-rate-factor`, `--verify-rate-rungs` (e.g. "0.5,0.25"), `--verify-twins`, `--no-verify-twin`,
        `--floors` (with verify_rate).
    probes : str, optional
        `--probes K-L`: only these probes (a job array's share).
    progress_interval : float, optional
        `--progress-interval` [s].
    celldem : str or os.PathLike, optional
        The binary; default as binary.find: $CELLDEM, PATH, the checkout's build.

    Returns
    -------
    Run or Ensemble
        open_run(out); with seeds open_ensemble(out), or for one seed k (a share) open_run(out/seed-k).

    Raises
    ------
    DeckError
        celldem refused the deck or the options (exit 2), or a deck file that is not a JSON object.
    RunFailed
        The run failed (exit 1: a control that failed, a write that failed, ...).
    ValueError
        Options that exclude each other (force and resume; verify options without verify_rate).
    TypeError
        `deck` is none of the types above.
    binary.BinaryError
        No binary was found (the message lists the places tried), or the one given is not celldem (its
        `--version` does not say so; the message names the path).

    celldem does not outlive the call: interrupted (an exception, KeyboardInterrupt, SIGTERM), run_deck stops it
    (SIGTERM: it writes its checkpoint, so that resume=True continues) and waits for it; and it gets SIGTERM when
    the calling process dies, even by SIGKILL (binary.start). The temporary deck file is removed however the call
    ends, but for SIGKILL. A SIGTERM with its default action still ends the process, after that cleanup.
    """
    exe = binary.require(celldem)
    with _sigterm_raises(), _DeckFile(deck) as path:
        cmd = binary.run_command(path, os.path.abspath(out), threads, seeds, force, resume, quiet, exe,
                                 fixed_threads=fixed_threads, tolerance=tolerance,
                                 include_uncontrolled=include_uncontrolled, verify_rate=verify_rate,
                                 verify_rate_factor=verify_rate_factor, no_verify_twin=no_verify_twin,
                                 verify_rate_rungs=verify_rate_rungs, verify_twins=verify_twins,
                                 floors=floors, probes=probes,
                                 progress_interval=progress_interval)
        proc = binary.start(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE if quiet else None, text=True)
        try:
            _, stderr = proc.communicate()
        finally:
            _stop(proc)
    message = (stderr or "").strip().replace(path, "<deck>")
    if proc.returncode == 2:
        raise DeckError(message or "celldem refused the deck (exit 2)")
    if proc.returncode != 0:
        raise RunFailed(message or f"celldem run failed (exit {proc.returncode})", proc.returncode)
    if seeds is None:
        return open_run(out)
    share = _one_seed(seeds)
    return open_run(os.path.join(out, f"seed-{share}")) if share is not None else open_ensemble(out)


def _one_seed(seeds: str) -> Optional[int]:
    """The seed of a `--seeds` list that names one ("3", "3-3", "3,3"): a job array's share; None otherwise (a list
    celldem accepted: K, K-L or comma-separated ones)."""
    found: Set[int] = set()
    for item in str(seeds).split(","):
        match = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", item)
        if not match:
            return None
        first = int(match.group(1))
        last = int(match.group(2)) if match.group(2) is not None else first
        found.update(range(first, min(last, first + 1) + 1))
        if len(found) > 1:
            return None
    return found.pop() if len(found) == 1 else None
