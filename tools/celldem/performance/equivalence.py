"""Two celldem binaries judged equal in their results on paired seeds (tools/compare_binaries.py OLD NEW
--equivalence): the rule a change of the solver's arithmetic (another summation order, single-precision storage)
must pass to land is equivalence by two one-sided tests (TOST) on every summary quantity, each within a margin
fixed before the judged seeds are looked at: ±0.5 noise floor of a reference ensemble (OLD's seed-to-seed standard
deviation over seeds that are not judged), or, for a quantity a control holds, the control's tolerance.

The scene: by default the speed–accuracy study's reference (tools/celldem/study/scene.py: 1000 spheres, the
paper's sizes and physics, TTC and PSC to ε1 = 3 %; its decks are study.runs' sample_spec and reference_spec),
or any deck that prepares its own sample (--deck: its preparation with sample.seed = k, then its tests).

Paired seeds: for each judged seed each binary prepares the sample (the deck without its tests) and runs the
deck's tests from its own prepared.state (the deck with initial_state in place of prepare, study.runs.deck_of),
one thread each, `jobs` processes at once. A test from a saved state gives the same bytes as the test straight
after the preparation (tests/tools/test_equivalence.py checks it on a small deck), so each side is that binary's
ordinary run: a change is tested where it prepares as well as where it tests, and the prepared e and Z are
compared too. The pair shares the seed (the sizes, the starting grid): NEW - OLD on one seed is the binary's
effect plus the chaos a round-off change sets off.

The reference: OLD alone (its preparation and tests) on --reference-seeds (default 1001-1020, disjoint from the
judged ones), run only when some judged seed's outputs differ (identical bits need no floor), or a stored
`celldem run DECK --seeds` folder of the same deck (--reference DIR). Its seed-to-seed standard deviation is the
floor, so the margin is fixed independently of the judged seeds and TOST holds its stated size: at a true mean
shift equal to the margin it passes at most alpha (a floor estimated from the judged seeds themselves passed such
a shift about 19 % of the time). The error rates are measured by simulation (performance/equivalence_sim.py,
tests/tools/test_equivalence_error_rates.py, docs/performance.md).

A quantity a control holds is judged against the control's tolerance, never tighter: b (at the peak and at the
end) of a single-leg test whose x2 and x3 are both held by stress servos (TTC), whose σ2 - σ3 the servos promise
within tol (|t2| + |t3|), i.e. b within tol (|t2| + |t3|) / (σ1 - σ3); or of a test holding b itself, the b
control's tolerance. tol is read from summary.json (a failure's `tolerance`, or the worst sustained error over
`control_error_over_tolerance` where every controlled axis is of one kind), averaged over the reference seeds; the
margin is the larger of this and the floors'.

Layout of OUT: equivalence.json (the two binaries' paths and sha256, the scene and its decks' sha256, the margin,
the format: a later call with others is refused), equivalence.lock (one process at a time), samples/seed-<k>/
(OLD's preparation), base/seed-<k>/ (OLD's tests), other-samples/seed-<k>/ (NEW's preparation) and other/seed-<k>/
(NEW's tests; a reference seed has only the first two), each a celldem run folder with its deck.json, celldem.log
and, once the run succeeded, done.json; then equivalence.md and verdict.json. A run folder without done.json is
half-written: the next call runs it again from scratch.

The verdict: when every judged seed's outputs are the same bytes in both (every file of every test and
preparation folder, prepared.state, and summary.json but for its run times), "identical bits", with no
statistics. Otherwise per quantity (judge_quantity): the paired differences NEW - OLD, the paired t-test of no
difference (Holm-adjusted over the quantities), TOST within ±margin, and the Pitman–Morgan test of equal
seed-to-seed variances of OLD's and NEW's values on the same seeds (Holm-adjusted over the quantities: a NEW that
changes the chaos or the spread); SciPy through celldem.stats. Each quantity's verdict (verdict_of): "identical on
every seed", "equivalent" (TOST p <= alpha), "different" (TOST fails and the paired test rejects no difference:
a constant shift beyond the margin on every seed is different, its p is 0), "undecided at n seeds", untested or
missing; and beside it "different spread" where Pitman–Morgan rejects. "equivalent" overall only when every
compared quantity is equivalent (the claim on all of them then errs at most alpha: intersection-union), no spread
differs, no test's control failed and no quantity was left untested. No seed drops out unseen: a value one binary
gives and the other does not (NaN, a missing field) where the control held and the peak was reached is "missing";
whether each test reached its peak is a quantity of its own (peak_reached_rows), judged as the others.
"""

from __future__ import annotations

import fcntl
import filecmp
import hashlib
import json
import math
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
DEFAULT_REFERENCE_SEEDS = "1001-1020"  # 20 seeds: the floor known to about ±16 % (1 / sqrt(2 (20 - 1)))
FORMAT = 2                # 1: NEW tested OLD's prepared samples and the floor came from the judged seeds

ROLES = ("prepare", "old", "prepare_new", "new")
REFERENCE_ROLES = ("prepare", "old")
FOLDERS = {"prepare": "samples", "old": "base", "prepare_new": "other-samples", "new": "other"}
PREPARATION_OF = {"old": "prepare", "new": "prepare_new"}  # each binary's tests start from its own preparation
WHO = {"prepare": "OLD's preparation", "old": "OLD's tests", "prepare_new": "NEW's preparation", "new": "NEW's tests"}
IDENTITY = "equivalence.json"
LOCK = "equivalence.lock"
OUTPUTS = ("equivalence.md", "verdict.json")
DONE = "done.json"
LOG = "celldem.log"
# summary.json keys that record how long a run took, not what it computed (at any depth), and the top-level ones
# that name the deck file or the build
RUN_TIME_KEYS = frozenset({"wall_s", "particle_steps_per_s"})
UNCOMPARED_TOP_KEYS = frozenset({"celldem_version", "deck", "initial_state"})  # (the states: compared as files)
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


def parse_reference_seeds(text: str, judged: Sequence[int]) -> List[int]:
    """--reference-seeds as --seeds, disjoint from the judged seeds (a floor from the judged seeds themselves makes
    the margin depend on what it judges). EquivalenceError naming --reference-seeds otherwise."""
    try:
        seeds = parse_seeds(text)
    except EquivalenceError as err:
        raise EquivalenceError(str(err).replace("--seeds", "--reference-seeds")) from err
    common = sorted(set(seeds) & set(judged))
    if common:
        raise EquivalenceError(f"--reference-seeds {text} shares seeds {common[0]}..{common[-1]} ({len(common)}) with "
                               "--seeds: the reference must be independent of the judged seeds")
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


def result_of(role: str) -> str:
    return "prepared.state" if role.startswith("prepare") else "summary.json"


def complete(out: str, role: str, seed: int) -> bool:
    """The run succeeded and its result is there (prepared.state for a preparation, summary.json for tests)."""
    d = run_dir(out, role, seed)
    result = result_of(role)
    done = read_json(os.path.join(d, DONE))
    return isinstance(done, dict) and done.get("rc") == 0 and os.path.isfile(os.path.join(d, result))


def seed_complete(out: str, seed: int, roles: Sequence[str] = ROLES) -> bool:
    return all(complete(out, role, seed) for role in roles)


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
    if role in PREPARATION_OF.values():
        deck = scene.sample_deck(seed)
    else:
        state = os.path.relpath(os.path.join(run_dir(out, PREPARATION_OF[role], seed), "prepared.state"), directory)
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
              progress: Callable[[str], None] = to_stderr, reference: bool = False) -> Dict[str, Any]:
    """Runs what is missing of `seeds` (each judged seed: each binary's preparation, then its tests from it; each
    reference seed: OLD's alone), `jobs` runs at a time, earlier seeds first. Returns {"ran": [seeds completed by
    this call], "wall_s"}. RunFailed when a run fails (the others are stopped first), Stopped on SIGINT/SIGTERM
    (the runs are stopped; their folders are redone by the next call)."""
    exe = {"prepare": old, "old": old, "prepare_new": new, "new": new}
    roles = REFERENCE_ROLES if reference else ROLES
    kind = "reference seeds" if reference else "seeds"
    todo = [(seed, role) for seed in seeds for role in roles if not complete(out, role, seed)]
    waiting = sorted({seed for seed, _ in todo})
    n, already = len(seeds), len(seeds) - len(waiting)
    if not todo:
        progress(f"equivalence: all {n} {kind} complete in {out}")
        return {"ran": [], "wall_s": 0.0}
    what = ("OLD prepares each sample and runs the tests from it" if reference else
            "OLD and NEW each prepare the sample and run the tests from their own preparation")
    progress(f"equivalence: {already} of {n} {kind} complete in {out}; running {len(waiting)} ({what}; {jobs} "
             "run(s) at a time, one thread each)")
    # a preparation that runs again replaces the state its tests started from: they run again too
    for seed, prep in {(seed, role) for seed, role in todo if role in PREPARATION_OF.values()}:
        todo += [(seed, t) for t, p in PREPARATION_OF.items() if p == prep and (seed, t) not in todo]
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
                              if role not in PREPARATION_OF or complete(out, PREPARATION_OF[role], seed)), None)
                if ready is None:
                    break
                todo.remove(ready)
                seed, role = ready
                if role in PREPARATION_OF.values():
                    progress(f"equivalence: {kind[:-1]} {seed} ({seeds.index(seed) + 1} of {n}): "
                             f"{WHO[role].split(chr(39))[0]} prepares the sample")
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
                    who = WHO[job.role]
                    raise RunFailed(f"seed {job.seed}: {who} failed (exit {rc}; {exe[job.role]} in "
                                    f"{job.directory}):\n{log_tail(job.directory)}")
                result = result_of(job.role)
                if not os.path.isfile(os.path.join(job.directory, result)):
                    stop(running)
                    who = WHO[job.role]
                    raise RunFailed(f"seed {job.seed}: {who} exited 0 but wrote no {result} ({exe[job.role]} in "
                                    f"{job.directory}): not a celldem run?\n{log_tail(job.directory)}")
                study_runs.write_json(os.path.join(job.directory, DONE),
                                      {"rc": 0, "wall_s": wall, "binary": exe[job.role],
                                       "finished": time.strftime("%Y-%m-%d %H:%M:%S")})
                walls[(job.seed, job.role)] = wall
                if seed_complete(out, job.seed, roles) and job.seed not in finished:
                    finished.append(job.seed)
                    elapsed = time.monotonic() - t0
                    left = len(waiting) - len(finished)
                    parts = ", ".join(f"{label} {walls[(job.seed, r)]:.1f} s" for r, label in
                                      (("prepare", "OLD's preparation"), ("old", "OLD's tests"),
                                       ("prepare_new", "NEW's preparation"), ("new", "NEW's tests"))
                                      if (job.seed, r) in walls)
                    progress(f"equivalence: {kind[:-1]} {job.seed} done, {already + len(finished)} of {n} ({parts}); "
                             f"elapsed {minutes(elapsed)}, ETA {minutes(elapsed / len(finished) * left)}")
        if stopping["signal"]:
            stop(running)
            raise Stopped(f"stopped by signal {stopping['signal']} with {already + len(finished)} of {n} {kind} "
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
    """The outputs of two runs that differ: every file under their stage folders (series, states, peak contacts)
    byte for byte, a preparation's prepared.state, and summary.json without its run times and deck file name. []
    when the same."""
    def files(root: str) -> List[str]:
        out = [n for n in ("prepared.state",) if os.path.isfile(os.path.join(root, n))]
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


def seed_differences(out: str, seed: int) -> List[str]:
    """What differs between OLD's and NEW's runs of a judged seed: their preparations' outputs (named
    "preparation: <file>") and their tests' outputs."""
    prepared = output_differences(run_dir(out, "prepare", seed), run_dir(out, "prepare_new", seed))
    return [f"preparation: {f}" for f in prepared] + output_differences(run_dir(out, "old", seed),
                                                                         run_dir(out, "new", seed))


def side(out: str, binary_role: str, seeds: Sequence[int]) -> Dict[int, Dict[str, Any]]:
    """{seed: summary} of one binary's runs ("old" or "new"): the tests' summary.json with its preparation's
    "prepared" record in place (the summary of a run from a state has none). Seeds without both are left out."""
    result = {}
    for seed in seeds:
        tests = read_json(os.path.join(run_dir(out, binary_role, seed), "summary.json"))
        prepared = read_json(os.path.join(run_dir(out, PREPARATION_OF[binary_role], seed), "summary.json"))
        if isinstance(tests, dict) and isinstance(prepared, dict):
            result[seed] = {**tests, "prepared": prepared.get("prepared") or {}}
    return result


def stored_reference(path: str, judged: Sequence[int]) -> Dict[int, Dict[str, Any]]:
    """--reference DIR: the seed-<k>/summary.json of a `celldem run DECK --seeds` folder (each with its prepared
    record and tests). EquivalenceError naming --reference for a folder without them, with fewer than MIN_SEEDS
    seeds or sharing a seed with the judged ones."""
    if not os.path.isdir(path):
        raise EquivalenceError(f"--reference: no folder at {path}")
    try:
        summaries = study_compare.load_seeds(path)
    except (study_compare.CompareError, ValueError) as err:
        raise EquivalenceError(f"--reference: {err}") from err
    if len(summaries) < MIN_SEEDS:
        raise EquivalenceError(f"--reference: {path} holds {len(summaries)} seeds; a floor needs at least {MIN_SEEDS}")
    common = sorted(set(summaries) & set(judged))
    if common:
        raise EquivalenceError(f"--reference: {path} holds judged seeds ({', '.join(map(str, common[:5]))}"
                               f"{', ...' if len(common) > 5 else ''}): the reference must be independent of them "
                               "(give --seeds outside its seeds)")
    return summaries


SETTINGS_NOT_COMPARED = frozenset({"seed", "deck", "threads"})


def reference_mismatch(reference: Dict[int, Dict[str, Any]], old: Dict[int, Dict[str, Any]]) -> Optional[str]:
    """Why a reference ensemble is not of the judged deck (other tests, or other settings than OLD's but for the
    seed, the deck file and the threads), None when it is."""
    if not reference or not old:
        return None
    mine = old[min(old)]
    def settings(summary):
        return {k: v for k, v in (summary.get("settings") or {}).items() if k not in SETTINGS_NOT_COMPARED}
    for seed, summary in sorted(reference.items()):
        if sorted(summary.get("tests") or {}) != sorted(mine.get("tests") or {}):
            return (f"reference seed {seed} has the tests {sorted(summary.get('tests') or {})}, the judged runs "
                    f"{sorted(mine.get('tests') or {})}")
        a, b = settings(summary), settings(mine)
        if a != b:
            keys = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            return f"reference seed {seed}'s settings differ from OLD's judged runs in {', '.join(keys)}"
    return None


# ---- the quantities a control holds ---------------------------------------------------------------------------

def control_tolerances(test: Dict[str, Any]) -> Dict[str, float]:
    """{kind: tolerance} of a test's controls as its summary.json gives them: a failure's `tolerance`, and, where
    every controlled axis of every leg is of one kind, the worst sustained error over
    `control_error_over_tolerance` (the rule that makes `controlled` true exactly when that ratio is at most 1)."""
    out: Dict[str, float] = {}
    for failure in test.get("control_failures") or []:
        if isinstance(failure, dict) and isinstance(failure.get("tolerance"), (int, float)):
            out[str(failure.get("kind"))] = float(failure["tolerance"])
    axes = [a for leg in test.get("legs") or [] for a in ((leg.get("control_errors") or {}).get("axes") or [])]
    controlled = [a for a in axes if a.get("kind") not in ("strain", "held")]
    kinds = {a.get("kind") for a in controlled}
    ratio = test.get("control_error_over_tolerance")
    sustained = [a.get("sustained") for a in controlled if isinstance(a.get("sustained"), (int, float))]
    if len(kinds) == 1 and sustained and isinstance(ratio, (int, float)) and ratio > 0 and max(sustained) > 0:
        out.setdefault(str(kinds.pop()), max(sustained) / ratio)
    return out


def b_tolerance(test: Dict[str, Any], at_peak: bool) -> Optional[Dict[str, Any]]:
    """How far the controls let b = (σ22 - σ33) / (σ11 - σ33) of one run move, at the peak or at the end, with its
    reason: a test holding b itself, the b control's tolerance; a single-leg test driving x1 with x2 and x3 held by
    stress servos (TTC), tol (|t2| + |t3|) / (σ11 - σ33). None where no control holds b or the tolerance is not in
    the summary."""
    legs = test.get("legs") or []
    tolerances = control_tolerances(test)
    axes = [a for leg in legs for a in ((leg.get("control_errors") or {}).get("axes") or [])]
    if any(a.get("kind") == "b" for a in axes):
        return ({"tolerance": tolerances["b"], "why": f"the b control's tolerance ±{tolerances['b']:.3g}"}
                if "b" in tolerances else None)
    if len(legs) != 1 or "stress" not in tolerances:
        return None
    by_name = {a.get("name"): a for a in axes}
    if not all(by_name.get(k, {}).get("kind") == "stress" for k in ("x2", "x3")):
        return None
    if by_name.get("x1", {}).get("kind") != "strain":
        return None
    t2, t3 = by_name["x2"].get("last_target"), by_name["x3"].get("last_target")
    if not all(isinstance(t, (int, float)) for t in (t2, t3)):
        return None
    if at_peak:
        ratio = test.get("peak_ratio13")
        span = abs(t3) * (ratio - 1.0) if isinstance(ratio, (int, float)) else None
    else:
        end = legs[0].get("end") or {}
        span = (end["s11"] - end["s33"] if all(isinstance(end.get(k), (int, float)) for k in ("s11", "s33"))
                else None)
    if not span or not math.isfinite(span) or span == 0:
        return None
    tol = tolerances["stress"]
    return {"tolerance": tol * (abs(t2) + abs(t3)) / abs(span),
            "why": f"x2 and x3 held by stress servos within {tol * 100:g} % each: σ22 - σ33 within "
                   f"±{tol * (abs(t2) + abs(t3)):.3g}"}


def control_margin(reference: Dict[int, Dict[str, Any]], key) -> Optional[Dict[str, Any]]:
    """The control's tolerance of quantity `key` in its own units, the mean over the reference seeds (fixed before
    the judged seeds are read), with its reason; None for a quantity no control holds."""
    test, path, _ = key
    if test is None or path not in ("b_at_peak", "b_final"):
        return None
    found = [b_tolerance(s["tests"][test], path == "b_at_peak") for s in reference.values()
             if isinstance((s.get("tests") or {}).get(test), dict) and s["tests"][test].get("controlled") is not False]
    held = [f for f in found if f is not None]
    if not held:
        return None
    return {"tolerance": sum(f["tolerance"] for f in held) / len(held), "why": held[0]["why"]}


# ---- one quantity ------------------------------------------------------------------------------------------------

def judge_quantity(reference_values: Sequence[float], pairs: Sequence[Tuple[float, float]], margin_floors: float,
                   tolerance: Optional[float] = None, spread: bool = True) -> Dict[str, Any]:
    """One quantity: the reference ensemble's values (the floor: their seed-to-seed standard deviation, ddof 1) and
    the judged pairs [(OLD, NEW)]. The margin, fixed before the pairs are read: margin_floors × the floor, or the
    control's tolerance where it is larger. Returns {"n", "floor", "margin", "margin_from", "differences",
    "mean_difference", "floors", "p" (paired t, two-sided), "p_tost", "tost_interval" (90 %), "spread"
    (Pitman–Morgan: ratio var NEW / var OLD over the pairs, r, p; None for 1/0 values or too few pairs)}."""
    floor_stat = stats.describe(reference_values)
    floor = floor_stat["std"] if floor_stat and floor_stat["n"] >= 2 else None
    margin, margin_from = None, None
    if floor is not None and floor > 0:
        margin, margin_from = margin_floors * floor, "floors"
    if tolerance is not None and (margin is None or tolerance > margin):
        margin, margin_from = tolerance, "control"
    diffs = [o - b for b, o in pairs]
    d = stats.describe(diffs)
    out: Dict[str, Any] = {"n": len(diffs), "reference_n": floor_stat["n"] if floor_stat else 0, "floor": floor,
                           "margin": margin, "margin_from": margin_from, "differences": diffs,
                           "mean_difference": d["mean"] if d else None, "floors": None, "p": None, "p_tost": None,
                           "tost_interval": None, "spread": None}
    if d is None:
        return out
    if floor:
        out["floors"] = d["mean"] / floor
    out["p"] = stats.one_sample_p(d)
    if margin is not None:
        t = stats.tost(d, margin)
        if t is not None:
            out["p_tost"], out["tost_interval"] = t["p"], t["interval"]
    if spread and not all(v in (0.0, 1.0) for pair in pairs for v in pair):
        out["spread"] = stats.pitman_morgan([b for b, _ in pairs], [o for _, o in pairs])
    return out


def verdict_of(row: Dict[str, Any], alpha: float = ALPHA) -> str:
    """A quantity's verdict on its means from its row (judge_quantity's, with "p_holm" and perhaps "missing")."""
    diffs = row["differences"]
    if row.get("missing"):
        return "missing: " + "; ".join(f"no value from {who} on seeds {', '.join(map(str, s))}"
                                       for who, s in row["missing"].items())
    if row["n"] < MIN_SEEDS:
        return f"untested (paired on {row['n']} seeds, fewer than {MIN_SEEDS})"
    if all(d == 0 for d in diffs):
        return "identical on every seed"
    if row["margin"] is None:
        return "untested (no margin: OLD's value is the same on every reference seed and no control holds it)"
    # A constant difference on every seed has no spread: stats gives the paired p 0 and TOST p 0 or 1, so a shift
    # beyond the margin is "different" and one inside it "equivalent", as the same shift with any scatter would be.
    return stats.equivalence_verdict(row.get("p_holm", row["p"]), row["p_tost"], row["n"], alpha)


def spread_verdict_of(row: Dict[str, Any], alpha: float = ALPHA) -> Optional[str]:
    """"different spread" where Pitman–Morgan rejects equal variances (Holm-adjusted "p_holm" in row["spread"]),
    None otherwise."""
    s = row.get("spread")
    if not s or s.get("p_holm", s.get("p")) is None or s.get("p_holm", s["p"]) > alpha:
        return None
    return (f"different spread (NEW's seed-to-seed variance {s['ratio']:.3g}× OLD's, Pitman–Morgan p "
            f"{s['p']:.2g}, Holm {s.get('p_holm', s['p']):.2g})")


# ---- the verdict ---------------------------------------------------------------------------------------------------

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


def peak_reached(summary: Dict[str, Any], name: str) -> Optional[float]:
    """1 when the test reached its peak, 0 when it ended on its largest ratio, None when not usable."""
    t = (summary.get("tests") or {}).get(name)
    if not isinstance(t, dict) or t.get("controlled") is False or "peak_reached" not in t:
        return None
    return 1.0 if t["peak_reached"] else 0.0


def quantity_rows(base: Dict[int, Dict[str, Any]], other: Dict[int, Dict[str, Any]],
                  reference: Dict[int, Dict[str, Any]], seeds: Sequence[int], margin: float) -> List[Dict[str, Any]]:
    """Every compared quantity's row (judge_quantity) over the paired seeds: the summary quantities
    (study.compare's list, the prepared e and Z included), then whether each test reached its peak (1/0; a run
    whose peak is its last row has no peak quantities, so a binary that reaches the peak less often would
    otherwise go unseen)."""
    rows = []
    for label, key in study_compare.quantities_of(base[s] for s in seeds):
        reference_values = [v for v in (study_compare.quantity_values(r, key) for r in reference.values())
                            if v is not None]
        pairs = [(study_compare.quantity_values(base[s], key), study_compare.quantity_values(other[s], key))
                 for s in seeds]
        pairs = [(b, o) for b, o in pairs if b is not None and o is not None]
        control = control_margin(reference, key)
        row = judge_quantity(reference_values, pairs, margin, control["tolerance"] if control else None)
        row.update(label=label, key=list(key), control=control["why"] if control else None)
        row["missing"] = one_sided_missing(base, other, seeds, key)
        rows.append(row)
    for name in sorted({n for s in seeds for n in (base[s].get("tests") or {})}):
        reference_values = [v for v in (peak_reached(r, name) for r in reference.values()) if v is not None]
        pairs = [(peak_reached(base[s], name), peak_reached(other[s], name)) for s in seeds]
        pairs = [(b, o) for b, o in pairs if b is not None and o is not None]
        if pairs:
            row = judge_quantity(reference_values, pairs, margin)
            row.update(label=f"{name} peak reached (1/0)", key=None, control=None, missing={})
            rows.append(row)
    return rows


def test_text(margin: float, alpha: float, n: int, reference_n: int) -> str:
    return (f"TOST within ±{margin:g} reference floors (the floor: OLD's seed-to-seed std over {reference_n} "
            f"reference seeds, none of them judged) or a holding control's tolerance, {alpha * 100:g} % per quantity "
            f"(the claim on all errs at most {alpha * 100:g} %), over {n} paired seeds; paired t of no difference "
            f"and Pitman–Morgan of equal spreads, each Holm-adjusted to {alpha * 100:g} % over the quantities")


def judge(out: str, seeds: Sequence[int], margin: float = MARGIN_FLOORS, alpha: float = ALPHA,
          reference: Optional[Dict[int, Dict[str, Any]]] = None) -> Dict[str, Any]:
    """The verdict on the complete seeds `seeds` of OUT (see the module's doc); reference: {seed: summary} of the
    reference ensemble (needed unless the bits are identical). {"verdict": "identical bits", "equivalent" or "not
    shown equivalent", "exit": 0 or 1, "text": the verdict line, "test", "differing_outputs" {seed: [files]},
    "quantities": [rows], "different", "different_spread", "undecided", "untested", "missing",
    "control_failures"}. study_compare.CompareError when the reference is not of this deck."""
    differing = {seed: seed_differences(out, seed) for seed in seeds}
    n = len(seeds)
    reference = reference or {}
    result: Dict[str, Any] = {"seeds": list(seeds), "margin_floors": margin, "alpha": alpha,
                              "reference_seeds": sorted(reference),
                              "test": test_text(margin, alpha, n, len(reference)),
                              "differing_outputs": {str(k): v for k, v in differing.items()}, "quantities": None,
                              "different": [], "different_spread": [], "undecided": [], "untested": [],
                              "missing": [], "control_failures": []}
    base, other = side(out, "old", seeds), side(out, "new", seeds)
    result["control_failures"] = control_failures(base, "OLD") + control_failures(other, "NEW")
    failed = ", ".join(f"seed {c['seed']} {c['binary']} {c['test']}" for c in result["control_failures"])
    if not any(differing.values()):
        result.update(verdict="identical bits", exit=0,
                      text=f"identical bits: OLD and NEW wrote the same preparations, series, states and summaries "
                           f"(run times aside) on all {n} seeds; no statistics needed"
                           + (f" (control failed in both alike: {failed})" if failed else ""))
        return result
    paired = sorted(set(base) & set(other))
    if not paired:
        raise study_compare.CompareError(f"{out}: no seed with both binaries' summaries")
    if len(reference) < MIN_SEEDS:
        raise study_compare.CompareError(f"the reference ensemble has {len(reference)} seeds with results; a floor "
                                         f"needs at least {MIN_SEEDS}")
    mismatch = reference_mismatch(reference, base)
    if mismatch:
        raise study_compare.CompareError(f"the reference ensemble is not of this deck: {mismatch}")
    rows = quantity_rows(base, other, reference, paired, margin)
    for field, family in (("p", rows), ("spread", [r for r in rows if r["spread"]])):
        ps = [r["p"] if field == "p" else r["spread"]["p"] for r in family]
        for r, adjusted in zip(family, stats.holm(ps, alpha)[0]):
            if field == "p":
                r["p_holm"] = adjusted
            else:
                r["spread"]["p_holm"] = adjusted
    for row in rows:
        row["verdict"] = verdict_of(row, alpha)
        row["spread_verdict"] = None if row["verdict"] == "identical on every seed" else spread_verdict_of(row, alpha)
        v = row["verdict"]
        if row["spread_verdict"]:
            result["different_spread"].append(row["label"])
        if v in EQUIVALENT_VERDICTS:
            continue
        bucket = ("different" if v == "different" else "untested" if v.startswith("untested")
                  else "missing" if v.startswith("missing") else "undecided")
        result[bucket].append(row["label"])
    result["quantities"] = rows
    equivalent = bool(rows) and not any(result[k] for k in ("different", "different_spread", "undecided",
                                                             "untested", "missing", "control_failures"))
    if equivalent:
        result.update(verdict="equivalent", exit=0,
                      text=f"equivalent on every quantity ({result['test']})")
        return result
    reasons = []
    if result["different"]:
        reasons.append("different: " + ", ".join(result["different"]))
    if result["different_spread"]:
        reasons.append("different spread: " + ", ".join(result["different_spread"]))
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
                  text=f"not shown equivalent ({result['test']}): " + "; ".join(reasons))
    return result


def _f(x: Optional[float], spec: str) -> str:
    return "—" if x is None else format(x, spec)


def table(result: Dict[str, Any]) -> List[str]:
    """The quantities as a Markdown table: margin and where it comes from, the mean difference, the tests' p and the
    verdicts."""
    lines = ["| quantity | seeds | reference floor | margin | mean NEW − OLD | in floors | paired p (Holm) | TOST p | "
             "spread NEW/OLD (Holm p) | verdict |", "|---|---:|---:|---|---:|---:|---:|---:|---:|---|"]
    for r in result["quantities"]:
        margin = "—" if r["margin"] is None else f"±{r['margin']:.3g}" + (" (control)" if r["margin_from"] ==
                                                                         "control" else "")
        s = r["spread"]
        spread = "—" if not s else f"{s['ratio']:.2f} ({s.get('p_holm', s['p']):.2g})"
        verdict = r["verdict"] + (f"; {r['spread_verdict']}" if r.get("spread_verdict") else "")
        lines.append(f"| {r['label']} | {r['n']} | {_f(r['floor'], '.3g')} | {margin} | "
                     f"{_f(r['mean_difference'], '+.3g')} | {_f(r['floors'], '+.2f')} | {_f(r['p'], '.2g')} "
                     f"({_f(r.get('p_holm'), '.2g')}) | {_f(r['p_tost'], '.2g')} | {spread} | {verdict} |")
    return lines


def markdown(result: Dict[str, Any], old: str, new: str, scene: Scene) -> str:
    """The verdict as Markdown: what was compared, the table unless the bits are identical, the notes and the
    verdict line with its test, margin and error rate."""
    lines = ["# Equivalence of two celldem binaries", "",
             f"OLD {old}, NEW {new}; {scene.description}; judged seeds {', '.join(map(str, result['seeds']))}, "
             "each prepared and tested by each binary.", ""]
    if result["quantities"] is not None:
        ref = result["reference_seeds"]
        lines += [f"Reference ensemble (the floors): {len(ref)} seeds "
                  f"({ref[0]}–{ref[-1]}{'' if len(ref) == ref[-1] - ref[0] + 1 else ', not all'})"
                  + (f", {result['reference']}" if result.get("reference") else "") + ".", ""]
        lines += table(result) + [""]
        controls = sorted({(r["label"], r["control"]) for r in result["quantities"] if r.get("control")
                           and r["margin_from"] == "control"})
        for label, why in controls:
            lines.append(f"{label}: judged against the control's tolerance ({why}), not tighter.")
        lines.append("The wall times are of runs side by side (--jobs), not a speed measurement "
                     "(`tools/compare_binaries.py OLD NEW` without --equivalence is).")
        short = [r for r in result["quantities"] if r["n"] < len(result["seeds"])]
        if short:
            lines.append("On fewer seeds (a test whose control failed, or a peak quantity where a run reached no "
                         "peak, is left out): " + ", ".join(f"{r['label']} ({r['n']})" for r in short) + ".")
        for c in result["control_failures"]:
            lines.append(f"Control failed: seed {c['seed']}, {c['binary']}'s {c['test']}: "
                         f"{'; '.join(map(str, c['failures'])) or 'no detail'}.")
        lines.append("")
    lines.append(f"**Verdict:** {result['text']}.")
    return "\n".join(lines) + "\n"
