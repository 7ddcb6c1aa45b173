"""The celldem binary, for what a deck implies: `celldem plan DECK --json` (a test's steps, strain per step and
rows, the particle types' masses and damping, the critical time step, the inertial number, the mean contact at
the confining stress), for the deck's keys: `celldem schema --json`, and for what a
series implies: `celldem summarize SERIES` (summary.json's peak and end quantities of any series). The tools
ask it instead of deriving these again. `celldem check` and the command line of `celldem run` are here too.
"""

import json
import os
import shutil
import subprocess
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILT = os.path.join(REPO, "build", "celldem")


class BinaryError(RuntimeError):
    """The binary is missing or refused the deck; the message says which and why."""


def find(path=None):
    """The binary to use: `path` if given, else $CELLDEM, else build/celldem, else celldem on PATH."""
    if path:
        return os.path.abspath(path)
    if os.environ.get("CELLDEM"):
        return os.path.abspath(os.environ["CELLDEM"])
    if os.access(BUILT, os.X_OK):
        return BUILT
    return shutil.which("celldem") or BUILT


def run_json(args, binary=None):
    """Runs `celldem ARGS` and parses its JSON output."""
    exe = find(binary)
    if not os.access(exe, os.X_OK):
        raise BinaryError(f"no celldem binary at {exe} (build it with tools/build.sh, or give --celldem)")
    r = subprocess.run([exe] + list(args), capture_output=True, text=True)
    if r.returncode != 0:
        raise BinaryError(f"celldem {' '.join(args)} failed (exit {r.returncode}): {r.stderr.strip()}")
    try:
        return json.loads(r.stdout)
    except json.JSONDecodeError as err:
        raise BinaryError(f"celldem {' '.join(args)}: output is not JSON ({err})") from err


_SCHEMAS = {}


def schema(binary=None):
    """`celldem schema --json` as a list of key entries (key, type, unit, default, choices, min, max, ...; for the
    keys of contact sub-models "sub_models": [{"sub_model": "normal", "choices": ["hertz"]}, ...], the choices
    that use the key, which celldem refuses otherwise, and "required_when_used"), read once per binary."""
    exe = find(binary)
    if exe not in _SCHEMAS:
        _SCHEMAS[exe] = run_json(["schema", "--json"], exe)
    return _SCHEMAS[exe]


def check(deck_path, binary=None):
    """`celldem check DECK`: returns what it prints for a valid deck (particles, tests, the critical time step,
    the estimated cost); raises BinaryError with celldem's own message (naming the key) when it refuses it."""
    exe = find(binary)
    if not os.access(exe, os.X_OK):
        raise BinaryError(f"no celldem binary at {exe} (build it with tools/build.sh, or give --celldem)")
    r = subprocess.run([exe, "check", str(deck_path)], capture_output=True, text=True)
    if r.returncode != 0:
        raise BinaryError(r.stderr.strip() or f"celldem check {deck_path} failed (exit {r.returncode})")
    return r.stdout


def run_command(deck_path, out, threads=None, seeds=None, force=False, resume=False, quiet=True, binary=None):
    """The command line of `celldem run DECK --out OUT` with the given options, the binary first (find(binary))."""
    if force and resume:
        raise ValueError("force and resume exclude each other")
    cmd = [find(binary), "run", str(deck_path), "--out", str(out)]
    if threads is not None:
        cmd += ["--threads", str(threads)]
    if seeds is not None:
        cmd += ["--seeds", str(seeds)]
    if quiet:
        cmd.append("--quiet")
    if resume:
        cmd.append("--resume")
    if force:
        cmd.append("--force")
    return cmd


def plan(deck_path, binary=None):
    """`celldem plan DECK --json` as a dict (see README: tests[] with steps, strain_per_step, rows, end_axis,
    inertial_number; particle_types[] with mass; critical_time_step; time_step_ratio; sample.count)."""
    return run_json(["plan", str(deck_path), "--json"], binary)


def plan_deck(deck, directory, binary=None):
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


def summarize(series_path, end_axis="x1", binary=None):
    """`celldem summarize SERIES --end-axis AXIS` as a dict: what summary.json says of a test that its series
    alone determines (peak_ratio13, e1_at_peak, e1_peak_range, peak_reached, peak_robust, b_at_peak, final_e1,
    ev_final, Z_final, b_final, end_window, ...), for any series CSV, another code's included (its ratio13 from
    s11/s33 when it has none). The one definition is solver/run/summary.cpp."""
    return run_json(["summarize", str(series_path), "--end-axis", end_axis], binary)


def test_plan(deck_plan, name):
    """The entry of test `name` in a plan (KeyError when the deck has no such test)."""
    for test in deck_plan["tests"]:
        if test["name"] == name:
            return test
    raise KeyError(f"no test {name!r} in the plan of {deck_plan.get('deck')}")


def solid_volume(deck_plan):
    """[m^3] the spheres' volume: count × the plan's mean sphere volume (a grading's included), or for plans of
    earlier versions the mean over the equally likely sizes of mass / density."""
    sample = deck_plan["sample"]
    if sample.get("mean_sphere_volume") is not None:
        return sample["count"] * sample["mean_sphere_volume"]
    types = deck_plan["particle_types"]
    return sample["count"] * sum(t["mass"] for t in types) / len(types) / sample["density"]

