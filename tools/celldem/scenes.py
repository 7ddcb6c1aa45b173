"""What a run holds, judged from its content rather than its folder's name: the paper's deck (its scene and its
TTC/PSC tests), a failure-surface deck (constant-b tests). Reads summary.json's settings and the deck celldem
saved in progress.json; the paper's values come from inputs/paper.json.
"""

import math

import numpy as np

from . import decks
from .results import number

PAPER_TESTS = ("ttc", "psc")


def close(a, b, rel=1e-9):
    a, b = number(a), number(b)
    return a is not None and b is not None and math.isclose(a, b, rel_tol=rel)


def paper_scene(summary, paper=None):
    """Whether summary.json's settings are inputs/paper.json's sample and contact law: sphere count, density,
    kn, kt and (when the run lists them) the diameters."""
    paper = paper or decks.load()
    settings = summary.get("settings") or {}
    sample, contact = paper["sample"], paper["contact"]
    wanted = {"particles": sample["count"], "density": sample["density"], "kn": contact["kn"], "kt": contact["kt"]}
    if not all(close(settings.get(k), v) for k, v in wanted.items()):
        return False
    sizes = settings.get("diameters_m")
    if sizes is None:
        return True
    d = sample["diameters"]
    paper_sizes = d["list"] if "list" in d else np.linspace(d["min"], d["max"], d["count"])
    return len(sizes) == len(paper_sizes) and all(close(a, b) for a, b in zip(sizes, paper_sizes))


def is_paper(run):
    """A run (or ensemble) of the paper's deck: the paper's scene with a test named ttc or psc (inputs/paper.json,
    fast.json and balanced.json are; a failure-surface run of the same sample is not)."""
    return bool(set(PAPER_TESTS) & set(run.test_names)) and paper_scene(run.runs[0].summary)


def has_b_control(test):
    """Whether a deck test holds an axis servoed to a constant b, in its axes or any leg."""
    legs = [test] + list(test.get("legs") or [])
    while legs:
        leg = legs.pop()
        legs += list(leg.get("legs") or []) if "repeat" in leg else []
        if any(isinstance(a, dict) and "b" in a for a in (leg.get("axes") or {}).values()):
            return True
    return False


def constant_b_tests(run):
    """The tests of a failure-surface deck: those with a constant-b axis (inputs/failure_surface.json), in the
    run's order; [] when the deck is unknown (no progress.json)."""
    return [t for t in run.test_names if has_b_control(run.deck_test(t))] if run.deck else []
