"""The noise floor against the particle count (tools/study.py floors): the evidence for the floor model that
`celldem run --tolerance T` uses to carry the study's rules, calibrated on 1000 spheres, to a deck of N.

The scene is the study's (the paper's sizes, density, law and preparation, tests to ε1 = END_STRAIN) at several
counts, each a seed ensemble (`celldem run --seeds`) whose seed-to-seed standard deviation of each summary
quantity is its floor at that count. The model is floor = a_q N^b with one exponent b for every quantity and its
own a_q: least squares on log(floor) against log(N) with one intercept per quantity; the exponent's 95 % interval
comes from resampling each count's seeds (SciPy's bootstrap). 1/sqrt(N) holds where the interval contains -0.5.
"""

import copy
import json
import os
import subprocess
from typing import Any, Dict, List, Sequence

import numpy as np
from scipy import stats as sps

from ..files import load_json
from .scene import END_STRAIN

DEFAULT_COUNTS = (500, 1000, 2000)
DEFAULT_SEEDS = "1-8"
# ensemble.json quantities read (prepared state, each test's peak and end of test): the study's own set.
QUANTITIES = ("prepared.void_ratio", "prepared.Z",
              "ttc.peak_ratio13", "ttc.e1_at_peak", "ttc.end_window.ev", "ttc.end_window.Z",
              "psc.peak_ratio13", "psc.e1_at_peak", "psc.end_window.ev", "psc.end_window.Z", "psc.b_at_peak")
CONFIDENCE = 0.95


class FloorsError(Exception):
    """A run that failed or an ensemble without the quantities the fit needs."""


def floor_deck(paper: Dict[str, Any], count: int) -> Dict[str, Any]:
    """The study's scene at `count` spheres: the paper deck with its tests ending at END_STRAIN."""
    deck = copy.deepcopy(paper)
    deck["sample"]["count"] = int(count)
    deck["description"] = (f"celldem study floors: the paper's scene at {count} spheres, tests to "
                           f"e1 = {END_STRAIN:g}")
    for test in deck["tests"]:
        test["end"]["strain"] = END_STRAIN
    return deck


def run_count(root: str, paper: Dict[str, Any], count: int, seeds: str, celldem: str) -> str:
    """Runs (or resumes) the ensemble of `count` spheres under root/n<count>/; returns its run folder."""
    folder = os.path.join(root, f"n{count}")
    os.makedirs(folder, exist_ok=True)
    deck_path = os.path.join(folder, "deck.json")
    text = json.dumps(floor_deck(paper, count), indent=2)
    out = os.path.join(folder, "run")
    if os.path.exists(deck_path):
        with open(deck_path) as f:
            if f.read() != text and os.path.isdir(out):  # a run of another deck (the paper deck since edited)
                raise FloorsError(f"{out} was run from another deck than {deck_path} would be now: remove {folder} "
                                  "or give another --root")
    with open(deck_path, "w") as f:
        f.write(text)
    if os.path.exists(os.path.join(out, "ensemble.json")):
        return out
    cmd = [celldem, "run", deck_path, "--seeds", seeds, "--out", out, "--quiet"]
    if os.path.isdir(out):
        cmd.append("--resume")
    done = subprocess.run(cmd)
    if done.returncode != 0:
        raise FloorsError(f"{' '.join(cmd)} exited {done.returncode}")
    return out


def read_values(run_dir: str) -> Dict[str, List[float]]:
    """Each quantity's per-seed values (ensemble.json: "prepared" and "tests" by name, each quantity by its
    summary.json path, "values" in seed order); quantities missing a seed are left out."""
    ensemble = load_json(os.path.join(run_dir, "ensemble.json"))
    seeds = len(ensemble.get("seeds", [])) or None
    out = {}
    for q in QUANTITIES:
        section, key = q.split(".", 1)
        values = ensemble.get("prepared", {}) if section == "prepared" else ensemble.get("tests", {}).get(section, {})
        entry = values.get(key)
        if entry and len(entry.get("values", [])) >= 3 and (seeds is None or len(entry["values"]) == seeds):
            out[q] = [float(v) for v in entry["values"]]
    return out


def exponent_of(stds: np.ndarray, counts: Sequence[int]) -> float:
    """The common exponent b of std ∝ N^b: least squares on log std against log N, one intercept per quantity
    (stds: counts x quantities). With one intercept each, b is the slope of the quantity-centred logs."""
    logs = np.log(stds)
    x = np.log(np.asarray(counts, dtype=float))
    xc = x - x.mean()
    yc = logs - logs.mean(axis=0)
    return float((xc[:, None] * yc).sum() / (xc @ xc * stds.shape[1]))


def fit(values: Dict[int, Dict[str, List[float]]], resamples: int = 4000, seed: int = 1) -> Dict[str, Any]:
    """The common exponent over the quantities present at every count, with its interval from resampling each
    count's seeds (scipy.stats.bootstrap, percentile, the same seeds for every quantity of a count: the quantities
    of one sample are not independent)."""
    counts = sorted(values)
    if len(counts) < 2:
        raise FloorsError("the fit needs ensembles at two particle counts at least")
    common = [q for q in QUANTITIES if all(q in values[n] for n in counts)]
    if not common:
        raise FloorsError("no quantity has per-seed values at every count")
    data = {n: np.array([values[n][q] for q in common]).T for n in counts}  # seeds x quantities

    def stds_of(*rows: np.ndarray) -> np.ndarray:
        return np.array([np.std(data[n][r.astype(int)], axis=0, ddof=1) for n, r in zip(counts, rows)])

    def statistic(*rows: np.ndarray) -> float:
        s = stds_of(*rows)
        return exponent_of(s, counts) if np.all(s > 0) else np.nan

    everyone = [np.arange(len(data[n])) for n in counts]
    stds = stds_of(*everyone)
    exponent = exponent_of(stds, counts)
    boot = sps.bootstrap([r.astype(float) for r in everyone], statistic, n_resamples=resamples, vectorized=False,
                         paired=False, confidence_level=CONFIDENCE, method="percentile",
                         random_state=np.random.default_rng(seed))
    lo, hi = float(boot.confidence_interval.low), float(boot.confidence_interval.high)
    per_quantity = {q: {"exponent": exponent_of(stds[:, [i]], counts),
                        "floors": {str(n): float(stds[k, i]) for k, n in enumerate(counts)}}
                    for i, q in enumerate(common)}
    return {"model": "floor = a_q N^b, one b for all quantities (least squares in logs, one intercept each)",
            "counts": counts, "seeds": {str(n): int(len(data[n])) for n in counts}, "quantities": common,
            "exponent": exponent, "confidence": CONFIDENCE, "interval": [lo, hi],
            "interval_method": f"scipy.stats.bootstrap, percentile, {resamples} resamples of each count's seeds",
            "inverse_sqrt_inside": bool(lo <= -0.5 <= hi), "per_quantity": per_quantity}


def markdown(result: Dict[str, Any]) -> str:
    counts = result["counts"]
    lines = [f"Common exponent b = {result['exponent']:.3f} (95 % interval [{result['interval'][0]:.3f}, "
             f"{result['interval'][1]:.3f}], {result['interval_method']}); 1/sqrt(N) "
             + ("lies inside it." if result["inverse_sqrt_inside"] else "lies OUTSIDE it."), "",
             "| quantity | " + " | ".join(f"floor at {n}" for n in counts) + " | own exponent |",
             "|---|" + "---:|" * (len(counts) + 1)]
    for q in result["quantities"]:
        p = result["per_quantity"][q]
        lines.append(f"| {q} | " + " | ".join(f"{p['floors'][str(n)]:.4g}" for n in counts)
                     + f" | {p['exponent']:+.2f} |")
    return "\n".join(lines) + "\n"


def study(root: str, paper: Dict[str, Any], counts: Sequence[int], seeds: str, celldem: str) -> Dict[str, Any]:
    """Runs what is missing, fits, and writes root/floors.json and root/floors.md."""
    values = {int(n): read_values(run_count(root, paper, int(n), seeds, celldem)) for n in counts}
    result = fit(values)
    with open(os.path.join(root, "floors.json"), "w") as f:
        json.dump(result, f, indent=2)
    with open(os.path.join(root, "floors.md"), "w") as f:
        f.write(markdown(result))
    return result
