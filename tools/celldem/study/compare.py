"""Two ensembles of one deck on the same seeds, compared (tools/study.py compare BASE_DIR OTHER_DIR): what a change
of settings (e.g. the deck as written and with --tolerance 1) does to every summary quantity, in units of the
seed-to-seed noise floor, and what it saves.

Each directory is a `celldem run --seeds` folder (seed-<k>/summary.json). Per quantity (each test's peak σ1/σ3,
ε1 and b at the peak, b, εv and Z at the test's end, and the prepared e and Z; celldem's summary.json definitions):
- the paired differences OTHER - BASE over the seeds both have (a test whose control failed in either run is left
  out, and its peak quantities where either run reached no peak, as celldem's ensembles do);
- the floor: BASE's seed-to-seed standard deviation of the quantity (ddof 1, over all its seeds);
- the mean paired difference in floors, the paired t-test of no difference (two-sided, n - 1 dof, Holm-adjusted
  over the quantities) and TOST of equivalence within ±margin floors (default 1), both from SciPy
  (celldem.stats); the verdict as tools/sufficiency.py gives it: "equivalent" (TOST p <= alpha), else "different"
  (Holm-adjusted paired p <= alpha), else "undecided at n seeds". The runs are chaotic: a round-off change alone
  scores about 0.7 floors on one seed, so a claim needs several.
And the cost: particle-steps (each stage's steps × the particles) and wall time (summary.json's wall_s of the
preparation and the tests) summed over the paired seeds, BASE over OTHER (a speed-up above 1).
"""

import glob
import math
import os
import re

from .. import stats
from ..files import load_json

ALPHA = 0.05
MARGIN_FLOORS = 1.0

# (label, summary path under the test) of each test; the peak quantities need a peak in both runs.
TEST_QUANTITIES = (
    ("peak σ1/σ3", "peak_ratio13", True),
    ("ε1 at peak", "e1_at_peak", True),
    ("b at peak", "b_at_peak", True),
    ("b at the end", "b_final", False),
    ("εv at the end", "end_window.ev", False),
    ("Z at the end", "end_window.Z", False),
)
PREPARED_QUANTITIES = (("prepared e", "void_ratio"), ("prepared Z", "Z"))


class CompareError(Exception):
    """Folders that cannot be compared (no seeds, no seed in common, different tests or particle counts)."""


def _get(tree, path):
    for part in path.split("."):
        tree = tree.get(part) if isinstance(tree, dict) else None
    return float(tree) if isinstance(tree, (int, float)) and math.isfinite(tree) else None


def load_seeds(directory):
    """{seed: summary.json} of an ensemble folder's seed-<k>/ runs."""
    out = {}
    for path in glob.glob(os.path.join(directory, "seed-*", "summary.json")):
        match = re.search(r"seed-(\d+)$", os.path.dirname(path))
        if match:
            out[int(match.group(1))] = load_json(path)
    if not out:
        raise CompareError(f"{directory}: no seed-<k>/summary.json (a `celldem run --seeds` folder is needed)")
    return out


def _usable(test, peak):
    """Whether a test's summary counts: controlled, and for a peak quantity a peak reached."""
    if not isinstance(test, dict) or not test.get("controlled", True):
        return False
    return test.get("peak_reached", True) or not peak


def quantity_values(summary, key):
    """The value of quantity `key` ((test or None for prepared, path, needs peak)) in one summary, None when not
    usable."""
    test, path, peak = key
    if test is None:
        return _get(summary.get("prepared") or {}, path)
    t = (summary.get("tests") or {}).get(test)
    return _get(t, path) if _usable(t, peak) else None


def quantities_of(summaries):
    """The (label, key) of every compared quantity of these summaries' tests, in the order above."""
    tests = []
    for s in summaries:
        for name in s.get("tests") or {}:
            if name not in tests:
                tests.append(name)
    out = [(f"{test} {label}", (test, path, peak)) for test in tests for label, path, peak in TEST_QUANTITIES]
    out += [(label, (None, path, False)) for label, path in PREPARED_QUANTITIES]
    return out


def cost(summary):
    """(particle-steps, wall seconds) of one run: the preparation's and the tests' steps × particles, their wall_s."""
    particles = _get(summary.get("settings") or {}, "particles") or 0
    parts = [summary.get("prepared") or {}] + list((summary.get("tests") or {}).values())
    steps = sum(_get(p, "steps") or 0 for p in parts)
    wall = sum(_get(p, "wall_s") or 0 for p in parts)
    return steps * particles, wall


def compare_quantity(base_values, pairs, margin=MARGIN_FLOORS):
    """One quantity: base_values over all BASE seeds (the floor), pairs [(base, other)] over the seeds both have.
    Returns {"n", "floor", "mean_difference", "floors", "p", "p_tost", "differences"}; floors, p and p_tost None
    where the floor or two pairs are missing."""
    floor_stat = stats.describe(base_values)
    floor = floor_stat["std"] if floor_stat and floor_stat["n"] >= 2 and floor_stat["std"] > 0 else None
    diffs = [o - b for b, o in pairs]
    d = stats.describe(diffs)
    out = {"n": len(diffs), "floor": floor, "differences": diffs,
           "mean_difference": d["mean"] if d else None, "floors": None, "p": None, "p_tost": None}
    if d is None or floor is None:
        return out
    out["floors"] = d["mean"] / floor
    out["p"] = stats.one_sample_p(d)
    t = stats.tost(d, margin * floor)
    out["p_tost"] = None if t is None else t["p"]
    return out


def compare(base_dir, other_dir, margin=MARGIN_FLOORS, alpha=ALPHA, seeds=None):
    """The comparison of two ensemble folders: {"seeds", "quantities": [{label, n, floor, mean_difference, floors,
    p, p_holm, p_tost, verdict}], "cost": {...}}. seeds: only these seeds of either folder count (the floor's
    included); None: every seed."""
    base, other = load_seeds(base_dir), load_seeds(other_dir)
    if seeds is not None:
        wanted = set(seeds)
        base = {s: v for s, v in base.items() if s in wanted}
        other = {s: v for s, v in other.items() if s in wanted}
    seeds = sorted(set(base) & set(other))
    if not seeds:
        raise CompareError(f"{base_dir} (seeds {sorted(base)}) and {other_dir} (seeds {sorted(other)}) have no seed "
                           "in common: a paired comparison needs the same seeds")
    for s in seeds:
        b, o = base[s], other[s]
        if sorted(b.get("tests") or {}) != sorted(o.get("tests") or {}):
            raise CompareError(f"seed {s}: the tests differ ({sorted(b.get('tests') or {})} and "
                               f"{sorted(o.get('tests') or {})}): not one deck")
        nb, no = _get(b.get("settings") or {}, "particles"), _get(o.get("settings") or {}, "particles")
        if nb != no:
            raise CompareError(f"seed {s}: {nb} and {no} particles: not one deck")
    rows = []
    for label, key in quantities_of(base[s] for s in seeds):
        base_values = [v for v in (quantity_values(base[s], key) for s in sorted(base)) if v is not None]
        pairs = [(quantity_values(base[s], key), quantity_values(other[s], key)) for s in seeds]
        pairs = [(b, o) for b, o in pairs if b is not None and o is not None]
        rows.append({"label": label, **compare_quantity(base_values, pairs, margin)})
    adjusted, _ = stats.holm([r["p"] for r in rows], alpha)
    for r, a in zip(rows, adjusted):
        r["p_holm"] = a
        r["verdict"] = ("untested (fewer than two paired seeds or no floor)" if r["p"] is None
                        else stats.equivalence_verdict(a, r["p_tost"], r["n"], alpha))
    base_cost = [cost(base[s]) for s in seeds]
    other_cost = [cost(other[s]) for s in seeds]
    total = {"base_particle_steps": sum(c[0] for c in base_cost), "other_particle_steps": sum(c[0] for c in other_cost),
             "base_wall_s": sum(c[1] for c in base_cost), "other_wall_s": sum(c[1] for c in other_cost)}
    total["particle_steps_ratio"] = (total["base_particle_steps"] / total["other_particle_steps"]
                                     if total["other_particle_steps"] else None)
    total["wall_time_ratio"] = total["base_wall_s"] / total["other_wall_s"] if total["other_wall_s"] else None
    return {"base": os.path.abspath(base_dir), "other": os.path.abspath(other_dir), "seeds": seeds,
            "margin_floors": margin, "alpha": alpha, "quantities": rows, "cost": total}


def _f(x, spec):
    return "—" if x is None else format(x, spec)


def markdown(result):
    """The comparison as a Markdown table with the cost line."""
    c = result["cost"]
    lines = [f"BASE {result['base']}, OTHER {result['other']}; seeds {', '.join(map(str, result['seeds']))}. "
             f"Difference OTHER - BASE, mean over the paired seeds in BASE's seed-to-seed floors; paired t (Holm over "
             f"the quantities) and TOST within ±{result['margin_floors']:g} floor at α = {result['alpha']:g}.", "",
             "| quantity | seeds | floor | mean difference | floors | paired p (Holm) | TOST p | verdict |",
             "|---|---|---|---|---|---|---|---|"]
    for r in result["quantities"]:
        lines.append(f"| {r['label']} | {r['n']} | {_f(r['floor'], '.3g')} | {_f(r['mean_difference'], '+.3g')} | "
                     f"{_f(r['floors'], '+.2f')} | {_f(r['p'], '.2g')} ({_f(r['p_holm'], '.2g')}) | "
                     f"{_f(r['p_tost'], '.2g')} | {r['verdict']} |")
    lines += ["", f"Cost over these seeds: {c['base_particle_steps']:.3g} against {c['other_particle_steps']:.3g} "
                  f"particle-steps ({_f(c['particle_steps_ratio'], '.2f')}× fewer), {c['base_wall_s']:.4g} s against "
                  f"{c['other_wall_s']:.4g} s of wall time ({_f(c['wall_time_ratio'], '.2f')}× less)."]
    return "\n".join(lines)
