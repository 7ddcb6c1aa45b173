"""What the cross-check drivers share: skipping when a code is missing, a celldem-prepared state, and a work
folder that is kept when a check fails."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

CODE_BINARIES = {"lammps": "lmp", "liggghts": "liggghts"}


def need(*exes):
    """Exit with ctest's skip code (77) when a program is not installed."""
    missing = [e for e in exes if not shutil.which(e)]
    if missing:
        print("skipped: %s not installed (tools/install-deps.sh --with-crosscheck)" % ", ".join(missing))
        sys.exit(77)


def prepare_state(celldem, work, deck):
    """Prepares the deck's sample with celldem (its tests dropped) into work/prep; a kept one is reused."""
    state = os.path.join(work, "prep", "prepared.state")
    if os.path.exists(state):  # kept in --work
        return state
    deck = dict(deck, tests=[])
    path = os.path.join(work, "prepare.json")
    with open(path, "w") as f:
        json.dump(deck, f, indent=2)
    subprocess.run([celldem, "run", path, "--out", os.path.join(work, "prep"), "--threads", "1", "--quiet"],
                   check=True)
    return state


def in_work_folder(kept, prefix, check):
    """Runs check(work) in `kept` (when given) or a temporary folder, copied aside if check returns non-zero."""
    with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
        work = os.path.abspath(kept) if kept else tmp
        os.makedirs(work, exist_ok=True)
        rc = check(work)
        if rc != 0 and not kept:
            keep = tempfile.mkdtemp(prefix=prefix + "failed-")
            shutil.copytree(work, keep, dirs_exist_ok=True)
            print("the failed run is kept in %s" % keep)
    return rc


def main_for_codes(prefix, run):
    """The command line of a check that runs run(celldem, work, codes) for LAMMPS and/or LIGGGHTS."""
    import argparse
    p = argparse.ArgumentParser()
    p.add_argument("--celldem", required=True)
    p.add_argument("--work", help="keep the files in this folder (default: a temporary folder)")
    p.add_argument("--codes", default="lammps,liggghts", help="comma-separated: lammps, liggghts")
    args = p.parse_args()
    codes = args.codes.split(",")
    need(*[CODE_BINARIES[c] for c in codes])
    celldem = os.path.abspath(args.celldem)
    return in_work_folder(args.work, prefix, lambda work: run(celldem, work, codes))
