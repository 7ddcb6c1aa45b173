"""What a run holds, judged from its content rather than its folder's name: the paper's deck (its scene and its
TTC/PSC tests), a failure-surface deck (constant-b tests). Reads summary.json's settings and the deck celldem
saved in progress.json; the paper's values come from inputs/paper.json.
"""

from __future__ import annotations

import math
from typing import Any, Dict, Mapping, Optional

import numpy as np

from . import decks
from .files import number
from .results import Loaded, RunArrays

PAPER_TESTS = ("ttc", "psc")


def close(a: Any, b: Any, rel: float = 1e-9) -> bool:
    """Whether two JSON values are finite numbers within `rel` of each other."""
    a, b = number(a), number(b)
    return a is not None and b is not None and math.isclose(a, b, rel_tol=rel)


def paper_scene(summary: Mapping[str, Any], paper: Optional[Dict[str, Any]] = None) -> bool:
    """Whether a run's scene is the paper's.

    Parameters
    ----------
    summary : dict
        The run's summary.json.
    paper : dict, optional
        The paper's deck; default inputs/paper.json (decks.load()).

    Returns
    -------
    bool
        True when summary.json's settings are the paper deck's sample and contact law: sphere count, density, kn,
        kt and (when the run lists them) the diameters.
    """
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


def is_paper(run: Loaded) -> bool:
    """Whether a run (or ensemble) is of the paper's deck.

    Parameters
    ----------
    run : results.RunArrays or results.EnsembleArrays
        The run.

    Returns
    -------
    bool
        The paper's scene with a test named ttc or psc (inputs/paper.json, fast.json and balanced.json are; a
        failure-surface run of the same sample is not).
    """
    return bool(set(PAPER_TESTS) & set(run.test_names)) and paper_scene(run.runs[0].summary)


def has_b_control(test: Mapping[str, Any]) -> bool:
    """Whether a deck test holds an axis servoed to a constant b, in its axes or any leg.

    Parameters
    ----------
    test : dict
        A test of a deck (tests[k]).

    Returns
    -------
    bool
        True when an axis of the test or of any of its legs (repeats included) has a "b" target.
    """
    legs: list[Mapping[str, Any]] = [test] + list(test.get("legs") or [])
    while legs:
        leg = legs.pop()
        legs += list(leg.get("legs") or []) if "repeat" in leg else []
        if any(isinstance(a, dict) and "b" in a for a in (leg.get("axes") or {}).values()):
            return True
    return False


def constant_b_tests(run: RunArrays) -> list[str]:
    """The tests of a failure-surface deck.

    Parameters
    ----------
    run : results.RunArrays
        The run.

    Returns
    -------
    list of str
        Those with a constant-b axis (inputs/failure_surface.json), in the run's order; [] when the deck is
        unknown (no progress.json).
    """
    return [t for t in run.test_names if has_b_control(run.deck_test(t))] if run.deck else []
