"""Two celldem binaries judged equal in their results on paired seeds (tools/compare_binaries.py OLD NEW
--equivalence): the rule a change of the solver's arithmetic (another summation order, single-precision storage)
must pass to land is equivalence by two one-sided tests within ±0.5 noise floor on every summary quantity.

The scene: by default the speed–accuracy study's reference (tools/celldem/study/scene.py: 1000 spheres, the
paper's sizes and physics, TTC and PSC to ε1 = 3 %; its decks are study.runs' sample_spec and reference_spec),
or any deck that prepares its own sample (--deck: its preparation with sample.seed = k, then its tests).

Paired seeds: for each seed OLD prepares the sample once (the deck without its tests) and keeps its
prepared.state; then OLD and NEW each run the deck's tests from that state (the deck with initial_state in place
of prepare, study.runs.deck_of), one thread each, `jobs` processes at once. A test from a saved state gives the
same bytes as the test straight after the preparation (tests/tools/test_equivalence.py checks it on a small deck;
docs/performance.md has the 1000-sphere scene), so OLD's side is OLD's ordinary run. Each pair differs only by the
binary: the difference NEW - OLD on one sample is the binary's effect plus the chaos a round-off change sets off,
which is what the margin must bound.

Layout of OUT: equivalence.json (the two binaries' paths and sha256, the scene and its decks' sha256, the margin:
a later call with others is refused), equivalence.lock (one process at a time), samples/seed-<k>/ (OLD's
preparation), base/seed-<k>/ (OLD's tests) and other/seed-<k>/ (NEW's), each a celldem run folder with its deck.json,
celldem.log and, once the run succeeded, done.json; then equivalence.md and verdict.json. A run folder without
done.json is half-written: the next call runs it again from scratch.

The verdict: when every seed's outputs are the same bytes in both (every file of every test folder, and
summary.json but for its run times), "identical bits", with no statistics. Otherwise the two ensemble folders go
to celldem.study.compare.compare(base, other, margin) (per summary quantity the paired differences in units of
OLD's seed-to-seed standard deviation, paired t Holm-adjusted, TOST within ±margin floors, SciPy through
celldem.stats). "equivalent" only when every compared quantity's TOST p <= alpha (the claim on all of them then
errs at most alpha: intersection-union), no test's control failed and no quantity was left untested; else the
quantities that are "different", "undecided at n seeds" or untested, and the failed controls, are named. A
quantity whose paired differences are all exactly 0 is "identical on every seed" (equivalent; celldem.stats would
give TOST p = 0 from a zero spread), one whose differences are all one non-zero value is undecided (the t-tests
are degenerate), one paired on fewer than MIN_SEEDS seeds untested. No seed drops out unseen: a value one binary
gives and the other does not (NaN, a missing field) where the control held and the peak was reached is "missing";
whether each test reached its peak is a quantity of its own (peak_reached_rows), judged as the others. The prepared e and Z are the same sample's for both binaries, and the summaries of runs from a
state do not have them: they are listed as not compared.
"""

from __future__ import annotations

import fcntl
import filecmp
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from .. import binary, decks, stats
from ..files import load_json, read_json
from ..study import compare as study_compare
from ..study import runs as study_runs
from ..study.scene import END_STRAIN, SCENE_COUNT

MARGIN_FLOORS = 0.5       # the project's rule: within ±0.5 noise floor on every quantity
ALPHA = study_compare.ALPHA
DEFAULT_SEEDS = 30
MIN_SEEDS = 3             # a floor (a standard deviation) and a paired t-test need a spread
DEFAULT_JOBS = 2
MAX_SEEDS = 1000          # a study of more seeds is a mistake in --seeds (1000 seeds: about 4 hours here)
MAX_SEED = 2**53           # sample.seed's largest (kMaxSeed, `celldem schema`)
FORMAT = 1

ROLES = ("prepare", "old", "new")
FOLDERS = {"prepare": "samples", "old": "base", "new": "other"}
IDENTITY = "equivalence.json"
LOCK = "equivalence.lock"
OUTPUTS = ("equivalence.md", "verdict.json")
DONE = "done.json"
LOG = "celldem.log"
# summary.json keys that record how long a run took, not what it computed (at any depth), and the top-level ones
# that name the deck file or the build
RUN_TIME_KEYS = frozenset({"wall_s", "particle_steps_per_s"})
UNCOMPARED_TOP_KEYS = frozenset({"celldem_version", "deck"})
EQUIVALENT_VERDICTS = ("equivalent", "identical on every seed")


class EquivalenceError(Exception):
    """Input the study cannot use (the message names the option), or a folder it may not write into."""


class RunFailed(Exception):
    """A celldem run failed: the message names the seed, the binary and gives the end of its log."""


class Stopped(Exception):
    """SIGINT or SIGTERM: the runs were stopped; the same command continues."""


# ---- the scene ------------------------------------------------------------------------------------------------

@dataclass
class Scene:
    """What each seed runs: sample_deck(seed) OLD's preparation, test_deck(seed, state) the tests from its state."""

    name: str
    description: str
    deck_path: Optional[str]
    sample_spec: Callable[[int], Dict[str, Any]]
    test_spec: Callable[[int], Dict[str, Any]]
    paper: Optional[Dict[str, Any]] = None

    def sample_deck(self, seed: int) -> Dict[str, Any]:
        return study_runs.deck_of(self.sample_spec(seed), self.paper)

    def test_deck(self, seed: int, state_path: str) -> Dict[str, Any]:
        return study_runs.deck_of(self.test_spec(seed), self.paper, state_path)

    def fingerprint(self) -> str:
        """sha256 of seed 1's two decks: another scene (or the paper deck edited) has another."""
        text = json.dumps([self.sample_deck(1), self.test_deck(1, "STATE")], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


def study_scene() -> Scene:
    """The study's reference scene at the paper's settings: study.runs.sample_spec and reference_spec."""
    return Scene("study", f"the study's reference scene ({SCENE_COUNT} spheres, the paper's sizes, physics and "
                 f"settings, TTC and PSC to ε1 = {END_STRAIN * 100:g} %; tools/celldem/study/scene.py)", None,
                 lambda seed: study_runs.sample_spec(seed=seed), study_runs.reference_spec, decks.load())


def deck_scene(path: str, celldem: str) -> Scene:
    """A deck of one's own: its preparation (sample.seed = k) and its tests. EquivalenceError naming --deck for a
    missing or unreadable file, a deck that starts from initial_state (no seeds to vary) or one OLD refuses."""
    if not os.path.isfile(path):
        raise EquivalenceError(f"--deck: no deck at {path}")
    try:
        deck = decks.load(path)
    except (OSError, ValueError) as err:
        raise EquivalenceError(f"--deck: {path} is not a JSON deck ({err})") from err
    if not isinstance(deck, dict):
        raise EquivalenceError(f"--deck: {path} is not a deck (a JSON object)")
    if "initial_state" in deck or "prepare" not in deck:
        raise EquivalenceError(f"--deck: {path} starts from initial_state (or has no prepare): paired seeds need a "
                               "deck that prepares its own sample, one per seed")
    if not deck.get("tests"):
        raise EquivalenceError(f"--deck: {path} has no tests to compare")
    try:
        binary.check(path, celldem)
    except binary.BinaryError as err:
        raise EquivalenceError(f"--deck: the old binary refuses {path}: {err}") from err

    def spec(kind: str) -> Callable[[int], Dict[str, Any]]:
        return lambda seed: {"kind": kind, "deck": decks.edited(deck, {"sample.seed": seed})}

    name = os.path.splitext(os.path.basename(path))[0]
    return Scene(name, f"{path} ({deck['sample']['count']} spheres; its preparation with sample.seed = k, then its "
                 "tests)", os.path.abspath(path), spec("sample"), spec("test"))


# ---- options --------------------------------------------------------------------------------------------------

def parse_seeds(text: str) -> List[int]:
    """--seeds: "N" (seeds 1 to N) or "A-B". EquivalenceError naming --seeds otherwise, or for fewer than
    MIN_SEEDS."""
    match = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", text or "")
    if not match:
        raise EquivalenceError(f"--seeds: {text!r} is neither a count N (seeds 1-N) nor a range A-B")
    first, last = (1, int(match.group(1))) if match.group(2) is None else (int(match.group(1)), int(match.group(2)))
    if first < 1 or last < first:
        raise EquivalenceError(f"--seeds: {text!r} is not a range of seeds from 1 up")
    if last > MAX_SEED or last - first + 1 > MAX_SEEDS:
        raise EquivalenceError(f"--seeds: {text!r} asks for more than {MAX_SEEDS} seeds or a seed above {MAX_SEED} "
                               "(sample.seed's range; 100 seeds already take about 30 minutes)")
    seeds = list(range(first, last + 1))
    if len(seeds) < MIN_SEEDS:
        raise EquivalenceError(f"--seeds must give at least {MIN_SEEDS} seeds (a noise floor and a paired test need "
                               f"a spread), got {len(seeds)}")
    return seeds


def check_margin(margin: float) -> float:
    if not (margin > 0 and margin != float("inf")):
        raise EquivalenceError(f"--margin must be a positive number of noise floors, got {margin}")
    return margin


def check_binary(what: str, path: str) -> str:
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        raise EquivalenceError(f"no executable {what} binary at {path}")
    return os.path.abspath(path)


def default_out(old: str, new: str, deck_path: Optional[str]) -> str:
    """results/equivalence/<old>-vs-<new> (file names; their folders' too when the names are the same and the
    paths not), with -<deck name> for a deck other than the study's scene."""
    def name(path: str) -> str:
        same = os.path.basename(old) == os.path.basename(new) and os.path.abspath(old) != os.path.abspath(new)
        parent = os.path.basename(os.path.dirname(os.path.abspath(path)))
        return f"{parent}-{os.path.basename(path)}" if same else os.path.basename(path)
    folder = f"{name(old)}-vs-{name(new)}"
    if deck_path:
        folder += "-" + os.path.splitext(os.path.basename(deck_path))[0]
    return os.path.join(binary.REPO, "results", "equivalence", folder)


def sha256_of(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# ---- the folder: identity, lock --------------------------------------------------------------------------------

def identity(old: str, new: str, scene: Scene, margin: float) -> Dict[str, Any]:
    return {"format": FORMAT, "old": {"path": old, "sha256": sha256_of(old)},
            "new": {"path": new, "sha256": sha256_of(new)},
            "scene": {"name": scene.name, "deck": scene.deck_path, "description": scene.description,
                      "sha256": scene.fingerprint()},
            "margin_floors": margin, "alpha": ALPHA}


def identity_differences(recorded: Dict[str, Any], wanted: Dict[str, Any]) -> List[str]:
    """What differs between the folder's equivalence.json and this call (binaries by content, not path)."""
    out = []
    for side in ("old", "new"):
        r, w = recorded.get(side) or {}, wanted[side]
        if r.get("sha256") != w["sha256"]:
            out.append(f"the {side} binary ({r.get('path')}, sha256 {str(r.get('sha256'))[:12]} recorded; "
                       f"{w['path']}, sha256 {w['sha256'][:12]} now)")
    r = recorded.get("scene") or {}
    if r.get("sha256") != wanted["scene"]["sha256"]:
        now = wanted["scene"]["deck"] or "the study scene"
        out.append(f"the deck ({r.get('deck') or r.get('name')} recorded, {now} now, or its content changed)")
    if recorded.get("margin_floors") != wanted["margin_floors"]:
        out.append(f"the margin ({recorded.get('margin_floors')} floors recorded, {wanted['margin_floors']} now)")
    if recorded.get("format") != FORMAT:
        out.append(f"the folder's format ({recorded.get('format')}; this tool writes {FORMAT})")
    return out


def take_lock(out: str):
    """OUT/equivalence.lock held (an advisory flock, the pid inside) for as long as the returned file is open;
    EquivalenceError naming the holder when another process has it."""
    f = open(os.path.join(out, LOCK), "a+")
    try:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        f.seek(0)
        holder = f.read().strip() or "?"
        f.close()
        raise EquivalenceError(f"--out {out} is in use by another process (pid {holder}, {LOCK}): one study per "
                               "folder at a time")
    f.seek(0)
    f.truncate()
    f.write(f"{os.getpid()}\n")
    f.flush()
    return f


def remove_results(out: str) -> None:
    """What this tool wrote into OUT (and nothing else): the run folders, the outputs, equivalence.json."""
    for folder in FOLDERS.values():
        shutil.rmtree(os.path.join(out, folder), ignore_errors=True)
    for name in OUTPUTS + (IDENTITY,):
        if os.path.exists(os.path.join(out, name)):
            os.remove(os.path.join(out, name))


def open_folder(out: str, wanted: Dict[str, Any], force: bool):
    """Takes OUT for this call: refuses a folder that is not this tool's, one held by another process, or one of
    other binaries, deck or margin unless force (which removes its results first, as it does for a folder of this
    study). Returns the lock's file (keep it open)."""
    if os.path.isdir(out):
        entries = set(os.listdir(out)) - {LOCK}
        if entries and IDENTITY not in entries:
            raise EquivalenceError(f"--out {out} holds files but no {IDENTITY}: not an equivalence folder (give "
                                   "another --out)")
    elif os.path.exists(out):
        raise EquivalenceError(f"--out {out} is not a folder")
    os.makedirs(out, exist_ok=True)
    lock = take_lock(out)
    path = os.path.join(out, IDENTITY)
    recorded = None
    if os.path.exists(path):
        try:
            recorded = load_json(path)
        except ValueError:  # (a damaged record: differs from every identity)
            recorded = {}
    if recorded is not None and force:
        remove_results(out)
    elif recorded is not None:
        differ = identity_differences(recorded, wanted)
        if differ:
            lock.close()
            raise EquivalenceError(f"--out {out} holds the study of other inputs: {'; '.join(differ)}. Give another "
                                   "--out, or --force to remove its results and start again")
    study_runs.write_json(path, wanted)
    return lock


# ---- running ----------------------------------------------------------------------------------------------------

def run_dir(out: str, role: str, seed: int) -> str:
    return os.path.join(out, FOLDERS[role], f"seed-{seed}")


def complete(out: str, role: str, seed: int) -> bool:
    """The run succeeded and its result is there (prepared.state for a preparation, summary.json for tests)."""
    d = run_dir(out, role, seed)
    result = "prepared.state" if role == "prepare" else "summary.json"
    done = read_json(os.path.join(d, DONE))
    return isinstance(done, dict) and done.get("rc") == 0 and os.path.isfile(os.path.join(d, result))


def seed_complete(out: str, seed: int) -> bool:
    return all(complete(out, role, seed) for role in ROLES)


@dataclass
class Job:
    seed: int
    role: str
    directory: str
    proc: subprocess.Popen
    log: Any
    started: float


def start(out: str, scene: Scene, role: str, seed: int, exe: str) -> Job:
    """A fresh run folder (what was there is removed: a half-written run starts again) with its deck.json, and
    celldem run on it, one thread."""
    directory = run_dir(out, role, seed)
    # A run of a study that was killed may still be writing its checkpoint here: wait for it before starting again.
    if not binary.wait_for_run_folder(directory):
        raise RunFailed(f"seed {seed}: {directory} is still in use by another celldem process (its {binary.RUN_LOCK}):"
                        " stop it, then run the same command again")
    shutil.rmtree(directory, ignore_errors=True)
    os.makedirs(directory, exist_ok=True)
    if role == "prepare":
        deck = scene.sample_deck(seed)
    else:
        state = os.path.relpath(os.path.join(run_dir(out, "prepare", seed), "prepared.state"), directory)
        deck = scene.test_deck(seed, state)
    study_runs.write_json(os.path.join(directory, "deck.json"), deck)
    cmd = binary.run_command("deck.json", ".", threads=1, quiet=True, force=True, binary=exe)
    proc, log = binary.start_run(cmd, directory)
    return Job(seed, role, directory, proc, log, time.monotonic())


def log_tail(directory: str, chars: int = 2000) -> str:
    try:
        with open(os.path.join(directory, LOG), encoding="utf-8", errors="replace") as f:
            return f.read()[-chars:].strip()
    except OSError:
        return ""


def minutes(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    return f"{seconds // 60}m{seconds % 60:02d}s"


def to_stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def run_seeds(out: str, scene: Scene, old: str, new: str, seeds: Sequence[int], jobs: int = DEFAULT_JOBS,
              progress: Callable[[str], None] = to_stderr) -> Dict[str, Any]:
    """Runs what is missing of `seeds` (each seed: OLD's preparation, then OLD's and NEW's tests from it), `jobs`
    runs at a time, earlier seeds first. Returns {"ran": [seeds completed by this call], "wall_s"}. RunFailed
    when a run fails (the others are stopped first), Stopped on SIGINT/SIGTERM (the runs are stopped; their
    folders are redone by the next call)."""
    exe = {"prepare": old, "old": old, "new": new}
    todo = [(seed, role) for seed in seeds for role in ROLES if not complete(out, role, seed)]
    waiting = sorted({seed for seed, _ in todo})
    n, already = len(seeds), len(seeds) - len(waiting)
    if not todo:
        progress(f"equivalence: all {n} seeds complete in {out}")
        return {"ran": [], "wall_s": 0.0}
    progress(f"equivalence: {already} of {n} seeds complete in {out}; running {len(waiting)} (OLD prepares each "
             f"sample, then OLD and NEW run the tests from it; {jobs} run(s) at a time, one thread each)")
    # a preparation that runs again replaces the state its tests started from: they run again too
    for seed in {seed for seed, role in todo if role == "prepare"}:
        todo += [(seed, role) for role in ("old", "new") if (seed, role) not in todo]
    todo.sort(key=lambda t: (t[0], ROLES.index(t[1])))
    running: List[Job] = []
    stopping = {"signal": None}
    previous = {}

    def on_signal(signum, _frame):
        stopping["signal"] = signum
        for job in running:
            if job.proc.poll() is None:
                job.proc.send_signal(signal.SIGTERM)

    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, on_signal)
    t0 = time.monotonic()
    finished: List[int] = []
    walls: Dict[Tuple[int, str], float] = {}
    try:
        while todo or running:
            while not stopping["signal"] and len(running) < jobs:
                ready = next(((seed, role) for seed, role in todo
                              if role == "prepare" or complete(out, "prepare", seed)), None)
                if ready is None:
                    break
                todo.remove(ready)
                seed, role = ready
                if role == "prepare":
                    progress(f"equivalence: seed {seed} ({seeds.index(seed) + 1} of {n}): OLD prepares the sample")
                running.append(start(out, scene, role, seed, exe[role]))
            if not running:
                break
            time.sleep(0.05)
            for job in [j for j in running if j.proc.poll() is not None]:
                running.remove(job)
                job.log.close()
                rc = job.proc.returncode
                wall = time.monotonic() - job.started
                if rc != 0 and stopping["signal"]:
                    continue  # stopped: run again next time
                if rc != 0:
                    stop(running)
                    who = {"prepare": "OLD's preparation", "old": "OLD's tests", "new": "NEW's tests"}[job.role]
                    raise RunFailed(f"seed {job.seed}: {who} failed (exit {rc}; {exe[job.role]} in "
                                    f"{job.directory}):\n{log_tail(job.directory)}")
                result = "prepared.state" if job.role == "prepare" else "summary.json"
                if not os.path.isfile(os.path.join(job.directory, result)):
                    stop(running)
                    who = {"prepare": "OLD's preparation", "old": "OLD's tests", "new": "NEW's tests"}[job.role]
                    raise RunFailed(f"seed {job.seed}: {who} exited 0 but wrote no {result} ({exe[job.role]} in "
                                    f"{job.directory}): not a celldem run?\n{log_tail(job.directory)}")
                study_runs.write_json(os.path.join(job.directory, DONE),
                                      {"rc": 0, "wall_s": wall, "binary": exe[job.role],
                                       "finished": time.strftime("%Y-%m-%d %H:%M:%S")})
                walls[(job.seed, job.role)] = wall
                if seed_complete(out, job.seed) and job.seed not in finished:
                    finished.append(job.seed)
                    elapsed = time.monotonic() - t0
                    left = len(waiting) - len(finished)
                    parts = ", ".join(f"{label} {walls[(job.seed, r)]:.1f} s" for r, label in
                                      (("prepare", "preparation"), ("old", "OLD"), ("new", "NEW"))
                                      if (job.seed, r) in walls)
                    progress(f"equivalence: seed {job.seed} done, {already + len(finished)} of {n} ({parts}); "
                             f"elapsed {minutes(elapsed)}, ETA {minutes(elapsed / len(finished) * left)}")
        if stopping["signal"]:
            stop(running)
            raise Stopped(f"stopped by signal {stopping['signal']} with {already + len(finished)} of {n} seeds "
                          "complete: the same command continues")
    finally:
        stop(running)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return {"ran": finished, "wall_s": time.monotonic() - t0}


def stop(running: List[Job]) -> None:
    """SIGTERM to each running celldem (it writes a checkpoint and exits), then wait for it."""
    for job in running:
        if job.proc.poll() is None:
            job.proc.send_signal(signal.SIGTERM)
    for job in running:
        try:
            job.proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            job.proc.kill()
            job.proc.wait()
        job.log.close()
    running.clear()


# ---- the verdict ------------------------------------------------------------------------------------------------

def _without_run_time(tree: Any) -> Any:
    """A summary without what records how long the run took (RUN_TIME_KEYS at any depth), the build's version and
    the deck file's name (UNCOMPARED_TOP_KEYS, settings.deck)."""
    def strip(node: Any) -> Any:
        if isinstance(node, dict):
            return {k: strip(v) for k, v in node.items() if k not in RUN_TIME_KEYS}
        if isinstance(node, list):
            return [strip(v) for v in node]
        return node
    out = {k: v for k, v in strip(tree).items() if k not in UNCOMPARED_TOP_KEYS}
    if isinstance(out.get("settings"), dict):
        out["settings"] = {k: v for k, v in out["settings"].items() if k != "deck"}
    return out


def output_differences(base: str, other: str) -> List[str]:
    """The outputs of two test runs that differ: every file under their test folders (series, states, peak
    contacts) byte for byte, and summary.json without its run times and deck file name. [] when the same."""
    def files(root: str) -> List[str]:
        out = []
        for entry in sorted(os.listdir(root)):
            if os.path.isdir(os.path.join(root, entry)):
                for folder, _, names in os.walk(os.path.join(root, entry)):
                    out += [os.path.relpath(os.path.join(folder, n), root) for n in names]
        return sorted(out)

    a, b = files(base), set(files(other))
    differ = sorted(set(a) ^ b)
    differ += [f for f in a if f in b and not filecmp.cmp(os.path.join(base, f), os.path.join(other, f),
                                                             shallow=False)]
    sa, sb = (read_json(os.path.join(d, "summary.json")) for d in (base, other))
    if sa is None or sb is None or _without_run_time(sa) != _without_run_time(sb):
        differ.append("summary.json")
    return sorted(differ)


def control_failures(summaries: Dict[int, Dict[str, Any]], who: str) -> List[Dict[str, Any]]:
    out = []
    for seed, summary in sorted(summaries.items()):
        for name, test in (summary.get("tests") or {}).items():
            if isinstance(test, dict) and test.get("controlled") is False:
                out.append({"seed": seed, "binary": who, "test": name,
                            "failures": test.get("control_failures") or []})
    return out


def one_sided_missing(base: Dict[int, Dict[str, Any]], other: Dict[int, Dict[str, Any]], seeds: Sequence[int],
                      key) -> Dict[str, List[int]]:
    """{"OLD" or "NEW": [seeds]} where that binary gave no finite value of the quantity `key` and the other did,
    though its test's control held and (for a peak quantity) it reached a peak: a NaN or a missing field, never left
    out silently. (Where a run reached no peak, the peak-reached row counts it.)"""
    test, _, peak = key
    out: Dict[str, List[int]] = {}
    for seed in seeds:
        values = {"OLD": study_compare.quantity_values(base[seed], key),
                  "NEW": study_compare.quantity_values(other[seed], key)}
        for who, summary in (("OLD", base[seed]), ("NEW", other[seed])):
            t = (summary.get("tests") or {}).get(test) if test is not None else None
            explained = test is not None and (not isinstance(t, dict) or t.get("controlled") is False
                                              or (peak and t.get("peak_reached") is False))
            mate = values["NEW" if who == "OLD" else "OLD"]
            if values[who] is None and mate is not None and not explained:
                out.setdefault(who, []).append(seed)
    return out


def peak_reached_rows(base: Dict[int, Dict[str, Any]], other: Dict[int, Dict[str, Any]], seeds: Sequence[int],
                      margin: float) -> List[Dict[str, Any]]:
    """Whether each test reached its peak (1) or ended on its largest ratio (0), as one more quantity: a run whose
    peak is its last row has no peak quantities, so a binary that reaches the peak less (or more) often would
    otherwise go unseen. Paired over the seeds where both controls held, judged as the others (study.compare)."""
    rows = []
    tests = sorted({name for s in seeds for name in (base[s].get("tests") or {})})
    for name in tests:
        def reached(summary):
            t = (summary.get("tests") or {}).get(name)
            if not isinstance(t, dict) or t.get("controlled") is False or "peak_reached" not in t:
                return None
            return 1.0 if t["peak_reached"] else 0.0
        base_values = [v for v in (reached(base[s]) for s in sorted(base)) if v is not None]
        pairs = [(reached(base[s]), reached(other[s])) for s in seeds]
        pairs = [(b, o) for b, o in pairs if b is not None and o is not None]
        if not pairs:
            continue
        row = study_compare.compare_quantity(base_values, pairs, margin)
        row["label"] = f"{name} peak reached (1/0)"
        rows.append(row)
    return rows


def judge(out: str, seeds: Sequence[int], margin: float = MARGIN_FLOORS, alpha: float = ALPHA) -> Dict[str, Any]:
    """The verdict on the complete seeds `seeds` of OUT (see the module's doc): {"verdict": "identical bits",
    "equivalent" or "not shown equivalent", "exit": 0 or 1, "text": the verdict line, "differing_outputs"
    {seed: [files]}, "comparison": compare()'s result or None, "different", "undecided", "untested",
    "not_compared", "control_failures"}."""
    base_dir, other_dir = os.path.join(out, FOLDERS["old"]), os.path.join(out, FOLDERS["new"])
    differing = {seed: output_differences(run_dir(out, "old", seed), run_dir(out, "new", seed)) for seed in seeds}
    n = len(seeds)
    test_text = f"TOST, {alpha * 100:g} % per quantity"
    result: Dict[str, Any] = {"seeds": list(seeds), "margin_floors": margin, "alpha": alpha,
                              "test": f"two one-sided t-tests (TOST) of each quantity's mean paired difference "
                                      f"NEW - OLD within ±{margin:g} noise floors (OLD's seed-to-seed std), "
                                      f"{alpha * 100:g} % per quantity (SciPy via celldem.stats); paired t of no "
                                      "difference, Holm-adjusted",
                              "differing_outputs": {str(k): v for k, v in differing.items()}, "comparison": None,
                              "different": [], "undecided": [], "untested": [], "missing": [], "not_compared": [],
                              "control_failures": []}
    base = {k: v for k, v in study_compare.load_seeds(base_dir).items() if k in seeds}
    other = {k: v for k, v in study_compare.load_seeds(other_dir).items() if k in seeds}
    result["control_failures"] = control_failures(base, "OLD") + control_failures(other, "NEW")
    failed = ", ".join(f"seed {c['seed']} {c['binary']} {c['test']}" for c in result["control_failures"])
    if not any(differing.values()):
        result.update(verdict="identical bits", exit=0,
                      text=f"identical bits: OLD and NEW wrote the same series, states and summaries (run times "
                           f"aside) on all {n} seeds; no statistics needed"
                           + (f" (control failed in both alike: {failed})" if failed else ""))
        return result
    comparison = study_compare.compare(base_dir, other_dir, margin, alpha, seeds=seeds)
    paired = comparison["seeds"]
    keys = dict(study_compare.quantities_of(base[s] for s in paired))
    rows = []
    for row in comparison["quantities"] + peak_reached_rows(base, other, paired, margin):
        key = keys.get(row["label"])
        present = key is not None and any(study_compare.quantity_values(s, key) is not None
                                           for s in list(base.values()) + list(other.values()))
        if not present and key is not None and key[0] is None:
            result["not_compared"].append(row["label"])  # the prepared sample: OLD's, the same for both
            continue
        if key is not None:
            row["missing"] = one_sided_missing(base, other, paired, key)
        rows.append(row)
    adjusted, _ = stats.holm([r["p"] for r in rows], alpha)  # again: the peak-reached rows joined the family
    for row, p_holm in zip(rows, adjusted):
        row["p_holm"] = p_holm
        diffs = row["differences"]
        if row.get("missing"):
            row["verdict"] = "missing: " + "; ".join(f"no value from {who} on seeds {', '.join(map(str, s))}"
                                                      for who, s in row["missing"].items())
        elif row["n"] < MIN_SEEDS:
            row["verdict"] = f"untested (paired on {row['n']} seeds, fewer than {MIN_SEEDS})"
        elif all(d == 0 for d in diffs):
            row["verdict"] = "identical on every seed"
        elif row["p"] is None:
            row["verdict"] = "untested (no floor: OLD's value is the same on every seed)"
        elif (stats.describe(diffs) or {}).get("std") == 0:
            row["verdict"] = f"undecided at {row['n']} seeds (every difference the same: the tests are degenerate)"
        else:
            row["verdict"] = stats.equivalence_verdict(p_holm, row["p_tost"], row["n"], alpha)
    comparison["quantities"] = rows
    result["comparison"] = comparison
    for row in rows:
        v = row["verdict"]
        if v in EQUIVALENT_VERDICTS:
            continue
        bucket = ("different" if v == "different" else "untested" if v.startswith("untested")
                  else "missing" if v.startswith("missing") else "undecided")
        result[bucket].append(row["label"])
    equivalent = bool(rows) and not (result["different"] or result["undecided"] or result["untested"]
                                     or result["missing"] or result["control_failures"])
    if equivalent:
        result.update(verdict="equivalent", exit=0,
                      text=f"equivalent within ±{margin:g} floors on every quantity ({test_text}) over {n} "
                           "paired seeds")
        return result
    reasons = []
    if result["different"]:
        reasons.append("different: " + ", ".join(result["different"]))
    undecided: Dict[str, List[str]] = {}
    for row in rows:
        if row["label"] in result["undecided"]:
            undecided.setdefault(row["verdict"], []).append(row["label"])
    reasons += [f"{verdict}: {', '.join(labels)}" for verdict, labels in undecided.items()]
    if result["untested"]:
        reasons.append("untested: " + ", ".join(result["untested"]))
    for row in rows:
        if row["label"] in result["missing"]:
            reasons.append(f"{row['label']}: {row['verdict']}")
    if failed:
        reasons.append("control failed: " + failed)
    if not rows:
        reasons.append("no quantity compared")
    result.update(verdict="not shown equivalent", exit=1,
                  text=f"not shown equivalent within ±{margin:g} floors ({test_text}) over {n} paired seeds: "
                       + "; ".join(reasons))
    return result


def markdown(result: Dict[str, Any], old: str, new: str, scene: Scene) -> str:
    """The verdict as Markdown: what was compared, the table (compare.markdown) unless the bits are identical, the
    notes and the verdict line."""
    lines = ["# Equivalence of two celldem binaries", "",
             f"OLD {old}, NEW {new}; {scene.description}; seeds {', '.join(map(str, result['seeds']))}, each OLD's "
             "prepared sample, tested by both.", ""]
    if result["comparison"] is not None:
        lines += [study_compare.markdown(result["comparison"]), ""]
        lines.append("The wall times are of runs side by side (--jobs), not a speed measurement "
                     "(`tools/compare_binaries.py OLD NEW` without --equivalence is).")
        if result["not_compared"]:
            lines.append(f"Not compared: {', '.join(result['not_compared'])} (both binaries test OLD's prepared "
                         "sample).")
        short = [r for r in result["comparison"]["quantities"] if r["n"] < len(result["seeds"])]
        if short:
            lines.append("On fewer seeds (a test whose control failed, or a peak quantity where a run reached no "
                         "peak, is left out): " + ", ".join(f"{r['label']} ({r['n']})" for r in short) + ".")
        for c in result["control_failures"]:
            lines.append(f"Control failed: seed {c['seed']}, {c['binary']}'s {c['test']}: "
                         f"{'; '.join(map(str, c['failures'])) or 'no detail'}.")
        lines.append("")
    lines.append(f"**Verdict:** {result['text']}.")
    return "\n".join(lines) + "\n"
