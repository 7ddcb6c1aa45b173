"""The celldem binary, for what a deck implies: `celldem plan DECK --json` (a test's steps, strain per step and
rows, the particle types' masses and damping, the critical time step, the inertial number, the mean contact at
the confining stress), for the deck's keys: `celldem schema --json`, and for what a
series implies: `celldem summarize SERIES` (summary.json's peak and end quantities of any series). The tools
ask it instead of deriving these again. `celldem check` and the command line of `celldem run` are here too.
"""

from __future__ import annotations

import ctypes
import fcntl
import json
import os
import re
import signal
import shutil
import subprocess
import tempfile
import time
from typing import IO, Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

PathLike = Union[str, "os.PathLike[str]"]

# The checkout around the package when it is one (an editable install, or tools/ on PYTHONPATH): its build/celldem
# is the last place the binary is looked for, and the study's inputs/ and results/ are there. An installed copy
# of the package has no checkout: REPO is then where a checkout would be, and CHECKOUT False.
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CHECKOUT = os.path.isdir(os.path.join(REPO, "solver")) and os.path.isfile(os.path.join(REPO, "CMakeLists.txt"))
BUILT = os.path.join(REPO, "build", "celldem")


class BinaryError(RuntimeError):
    """The binary is missing or refused the deck; the message says which and why."""


def candidates(path: Optional[PathLike] = None) -> List[str]:
    """Where the binary is looked for, in order: `path` if given, else $CELLDEM, then celldem on PATH, then the
    checkout's build/celldem (when the package lies in a checkout)."""
    if path:
        return [os.path.abspath(path)]
    found = []
    if os.environ.get("CELLDEM"):
        found.append(os.path.abspath(os.environ["CELLDEM"]))
    on_path = shutil.which("celldem")
    found.append(os.path.abspath(on_path) if on_path else "celldem on PATH")
    if CHECKOUT:
        found.append(BUILT)
    return found


def find(path: Optional[PathLike] = None) -> str:
    """The binary to use: the first executable of candidates(path); when none is, the first candidate (that
    require() then refuses, naming every place tried)."""
    places = [p for p in candidates(path) if os.path.isabs(p)] or [BUILT]
    return next((p for p in places if os.access(p, os.X_OK)), places[0])


def require(path: Optional[PathLike] = None) -> str:
    """find(path), checked to be celldem (identify): BinaryError naming every place tried when none holds an
    executable binary, or naming the path when the binary there is not celldem. Every function of the package that
    runs a binary it was given (or found) goes through here."""
    exe = find(path)
    if not os.access(exe, os.X_OK):
        tried = candidates(path)
        if not path and not os.environ.get("CELLDEM"):
            tried.insert(0, "$CELLDEM (not set)")
        raise BinaryError("no celldem binary found; tried: " + ", ".join(tried) +
                          " (build it with tools/build.sh, set $CELLDEM, or give its path)")
    identify(exe)
    return exe


# What `celldem --version` prints (solver/app/main.cpp: "celldem " CELLDEM_VERSION, the project's version).
VERSION_LINE = re.compile(r"celldem (\d+(?:\.\d+)*\S*)")
VERSION_TIMEOUT_S = 30.0
_VERSIONS: Dict[Tuple[str, int, int], str] = {}


def identify(exe: PathLike) -> str:
    """The version of the celldem binary at `exe`, from the line `celldem --version` prints ("celldem 0.1.0");
    read once per file (its path, size and modification time). A program that prints anything else, or fails, is
    not believed to be celldem: BinaryError naming the path and what it printed."""
    exe = os.path.abspath(exe)
    try:
        st = os.stat(exe)
    except OSError as err:
        raise BinaryError(f"{exe}: cannot use it as the celldem binary ({err.strerror or err})") from err
    key = (exe, st.st_size, st.st_mtime_ns)
    if key in _VERSIONS:
        return _VERSIONS[key]
    try:
        r = subprocess.run([exe, "--version"], stdin=subprocess.DEVNULL, capture_output=True, text=True,
                           errors="replace", timeout=VERSION_TIMEOUT_S)
    except subprocess.TimeoutExpired as err:
        raise BinaryError(f"{exe} is not the celldem binary: `{exe} --version` did not answer in "
                          f"{VERSION_TIMEOUT_S:g} s") from err
    except OSError as err:
        raise BinaryError(f"{exe} is not the celldem binary: it cannot be run ({err.strerror or err})") from err
    lines = (r.stdout or "").strip().splitlines()
    match = VERSION_LINE.fullmatch(lines[0].strip()) if r.returncode == 0 and len(lines) == 1 else None
    if not match:
        printed = ((r.stdout or "").strip() or (r.stderr or "").strip()).splitlines()
        said = repr(printed[0][:120]) + (" ..." if len(printed) > 1 else "") if printed else "nothing"
        raise BinaryError(f"{exe} is not the celldem binary: `{exe} --version` exited {r.returncode} and printed "
                          f"{said}, not a line 'celldem <version>' (give the path of a celldem build)")
    _VERSIONS[key] = match.group(1)
    return match.group(1)


def run_json(args: Sequence[str], binary: Optional[PathLike] = None) -> Any:
    """Runs `celldem ARGS` and parses its JSON output."""
    exe = require(binary)
    r = subprocess.run([exe] + list(args), capture_output=True, text=True)
    if r.returncode != 0:
        raise BinaryError(f"celldem {' '.join(args)} failed (exit {r.returncode}): {r.stderr.strip()}")
    try:
        return json.loads(r.stdout)
    except json.JSONDecodeError as err:
        raise BinaryError(f"celldem {' '.join(args)}: output is not JSON ({err})") from err


_SCHEMAS: Dict[str, Any] = {}
_CONSTANTS: Dict[str, Dict[str, Any]] = {}


def constants(binary: Optional[PathLike] = None) -> Dict[str, Any]:
    """`celldem schema --constants`: the limits the solver judges runs by, as {name: {"value", "meaning"}}
    (quasi_static_inertial_number, servo_tolerance: the largest relative error of a stress-controlled axis,
    b_tolerance, mean_stress_tolerance), read once per binary. The tools take them from here, never a copy."""
    exe = require(binary)
    if exe not in _CONSTANTS:
        _CONSTANTS[exe] = run_json(["schema", "--constants"], exe)
    return _CONSTANTS[exe]


def constant(name: str, binary: Optional[PathLike] = None) -> float:
    """The value of one of constants() (KeyError naming the known ones for another name)."""
    known = constants(binary)
    if name not in known:
        raise KeyError(f"celldem schema --constants has no {name!r} (it has {sorted(known)})")
    return float(known[name]["value"])


def schema(binary: Optional[PathLike] = None) -> List[Dict[str, Any]]:
    """`celldem schema --json` as a list of key entries (key, type, unit, default, choices, min, max, ...; for the
    keys of contact sub-models "sub_models": [{"sub_model": "normal", "choices": ["hertz"]}, ...], the choices
    that use the key, which celldem refuses otherwise, and "required_when_used"), read once per binary."""
    exe = require(binary)
    if exe not in _SCHEMAS:
        _SCHEMAS[exe] = run_json(["schema", "--json"], exe)
    return _SCHEMAS[exe]


def check(deck_path: PathLike, binary: Optional[PathLike] = None) -> str:
    """`celldem check DECK`: returns what it prints for a valid deck (particles, tests, the critical time step,
    the estimated cost); raises BinaryError with celldem's own message (naming the key) when it refuses it."""
    exe = require(binary)
    r = subprocess.run([exe, "check", str(deck_path)], capture_output=True, text=True)
    if r.returncode != 0:
        raise BinaryError(r.stderr.strip() or f"celldem check {deck_path} failed (exit {r.returncode})")
    return r.stdout


def run_command(deck_path: PathLike, out: PathLike, threads: Optional[int] = None, seeds: Optional[str] = None,
                force: bool = False, resume: bool = False, quiet: bool = True, binary: Optional[PathLike] = None,
                *, fixed_threads: bool = False, tolerance: Optional[float] = None,
                include_uncontrolled: bool = False, verify_rate: bool = False,
                verify_rate_factor: Optional[float] = None, no_verify_twin: bool = False,
                verify_rate_rungs: Optional[str] = None, verify_twins: Optional[int] = None,
                floors: Optional[PathLike] = None,
                probes: Optional[str] = None, progress_interval: Optional[float] = None) -> List[str]:
    """The command line of `celldem run DECK --out OUT` with the given options, the binary first (find(binary)).
    Each keyword is the option of the same name (`celldem run --help`); None or False leaves it out."""
    if force and resume:
        raise ValueError("force and resume exclude each other")
    verify_options = {"verify_rate_factor": verify_rate_factor, "verify_rate_rungs": verify_rate_rungs,
                      "verify_twins": verify_twins, "floors": floors,
                      "no_verify_twin": True if no_verify_twin else None}
    if not verify_rate and any(v is not None for v in verify_options.values()):
        raise ValueError(f"{', '.join(k for k, v in verify_options.items() if v is not None)} need verify_rate=True")
    if include_uncontrolled and seeds is None:
        raise ValueError("include_uncontrolled needs seeds")
    cmd = [find(binary), "run", str(deck_path), "--out", str(out)]
    valued = [("--threads", threads), ("--seeds", seeds), ("--tolerance", tolerance),
              ("--verify-rate-factor", verify_rate_factor), ("--verify-rate-rungs", verify_rate_rungs),
              ("--verify-twins", verify_twins),
              ("--floors", floors), ("--probes", probes), ("--progress-interval", progress_interval)]
    for flag, value in valued:
        if value is not None:
            cmd += [flag, str(value)]
    for flag, on in (("--fixed-threads", fixed_threads), ("--include-uncontrolled", include_uncontrolled),
                     ("--verify-rate", verify_rate), ("--no-verify-twin", no_verify_twin), ("--quiet", quiet), ("--resume", resume), ("--force", force)):
        if on:
            cmd.append(flag)
    return cmd


def _stop_with(parent: int) -> Callable[[], None]:
    """For the child, before it runs: SIGTERM when `parent` (the process that starts it) dies, even by SIGKILL
    (Linux's PR_SET_PDEATHSIG), and at once if it died before the request was made; elsewhere nothing."""
    def request() -> None:
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):
            return
        if os.getppid() != parent:
            os.kill(os.getpid(), signal.SIGTERM)
    return request


RUN_LOCK = "run.lock"  # what a running `celldem run` holds (flock) in its folder (solver/run/run_directory.hpp)


def wait_for_run_folder(directory: PathLike, timeout: float = 60.0) -> bool:
    """Waits until no celldem process holds directory's run lock (a run stopped by SIGTERM writes its checkpoint
    first, in a second or two); True once it is free (or there is none), False after `timeout` seconds."""
    path = os.path.join(directory, RUN_LOCK)
    deadline = time.monotonic() + timeout
    while True:
        try:
            with open(path, "rb") as f:
                try:
                    fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    return True
                except OSError:
                    pass
        except FileNotFoundError:
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)


def start(cmd: Sequence[str], **popen_args: Any) -> "subprocess.Popen[Any]":
    """subprocess.Popen(cmd, **popen_args) for a process that must not outlive the caller: it gets SIGTERM (a run
    writes its checkpoint and stops) when the calling process dies, even by SIGKILL (_stop_with). What every run
    the package starts in the background or waits for goes through (start_run, api.run_deck)."""
    return subprocess.Popen(list(cmd), preexec_fn=_stop_with(os.getpid()), **popen_args)


def start_run(cmd: Sequence[str], directory: PathLike,
              append_log: bool = False) -> Tuple["subprocess.Popen[bytes]", IO[str]]:
    """Starts `cmd` (a run_command with one thread) in `directory` as a batch runs it beside others: OpenMP threads
    that wait passively, its output into directory/celldem.log after a "$ cmd" line (appended to an earlier log, or
    a new one). The run gets SIGTERM (it writes its checkpoint and stops) when the calling process dies, even by
    SIGKILL (start), so that no run outlives the tool that started it and writes into a folder the next call starts
    again. Returns (the Popen, the open log: close it once the run has ended)."""
    env = dict(os.environ, OMP_WAIT_POLICY="passive", OMP_NUM_THREADS="1")
    log = open(os.path.join(directory, "celldem.log"), "a" if append_log else "w", encoding="utf-8")
    log.write(f"$ {' '.join(map(str, cmd))}\n")
    log.flush()
    proc = start(cmd, cwd=directory, stdout=log, stderr=subprocess.STDOUT, env=env)
    return proc, log


def plan(deck_path: PathLike, binary: Optional[PathLike] = None) -> Dict[str, Any]:
    """`celldem plan DECK --json` as a dict (see README: tests[] with steps, strain_per_step, rows, end_axis,
    inertial_number; particle_types[] with mass; critical_time_step; time_step_ratio; sample.count)."""
    return run_json(["plan", str(deck_path), "--json"], binary)


def plan_deck(deck: Dict[str, Any], directory: Optional[PathLike],
              binary: Optional[PathLike] = None) -> Dict[str, Any]:
    """The plan of a deck given as a dict, as if it were a file in `directory` (relative paths in it, such as
    initial_state, resolve from there; the state file need not exist yet). directory None: the system's
    temporary folder, where only the resolved paths differ."""
    if directory is not None:
        os.makedirs(directory, exist_ok=True)
    fd, path = tempfile.mkstemp(prefix=".plan-", suffix=".json", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(deck, f)
        return plan(path, binary)
    finally:
        os.remove(path)


def summarize(series_path: PathLike, end_axis: str = "x1",
              binary: Optional[PathLike] = None) -> Dict[str, Any]:
    """`celldem summarize SERIES --end-axis AXIS` as a dict: what summary.json says of a test that its series
    alone determines (peak_ratio13, e1_at_peak, e1_peak_range, peak_reached, peak_robust, b_at_peak, final_e1,
    ev_final, Z_final, b_final, end_window, ...), for any series CSV, another code's included (its ratio13 from
    s11/s33 when it has none). The one definition is solver/run/summary.cpp."""
    return run_json(["summarize", str(series_path), "--end-axis", end_axis], binary)


def test_plan(deck_plan: Dict[str, Any], name: str) -> Dict[str, Any]:
    """The entry of test `name` in a plan (KeyError when the deck has no such test)."""
    for test in deck_plan["tests"]:
        if test["name"] == name:
            return test
    raise KeyError(f"no test {name!r} in the plan of {deck_plan.get('deck')}")


def solid_volume(deck_plan: Dict[str, Any]) -> float:
    """[m^3] the spheres' volume: count × the plan's mean sphere volume (a grading's included), or for plans of
    earlier versions the mean over the equally likely sizes of mass / density."""
    sample = deck_plan["sample"]
    if sample.get("mean_sphere_volume") is not None:
        return sample["count"] * sample["mean_sphere_volume"]
    types = deck_plan["particle_types"]
    return sample["count"] * sum(t["mass"] for t in types) / len(types) / sample["density"]

