"""The equivalence gate's error rates measured by simulation (tools/equivalence_error_rates.py prints them and
draws docs/figures/equivalence_error_rates.png; tests/tools/test_equivalence_error_rates.py checks them): synthetic
ensembles judged by the gate's own per-quantity code (equivalence.judge_quantity, verdict_of, spread_verdict_of), so
what is measured is the rule as it runs, not a formula for it.

The model of one quantity, in units of its true seed-to-seed standard deviation σ = 1:
- the reference ensemble: R independent seeds of OLD, x_r ~ N(0, 1);
- the judged seeds: OLD x_i = √ρ c_i + √(1 - ρ) e_i and NEW y_i = shift + √ρ c_i + chaos √(1 - ρ) f_i, with c_i
  the seed's shared part (its sizes and starting grid: both binaries prepare the same seed) and e_i, f_i the part
  each run's chaos draws on its own. ρ is the correlation of OLD and NEW on one seed (measured on real pairs:
  docs/performance.md). chaos = 2 is a NEW whose own chaos is twice OLD's.

The rates, each over `reps` draws:
- "pass": the quantity is "equivalent" (TOST within the margin): at shift = the margin it is the test's size.
  shift_mode "margin": the shift equals the margin the gate uses on that draw (margin_floors × the reference's
  standard deviation, fixed before the judged seeds; its sign at random); "sigma": shift × σ, the true floor;
- "different": the paired t-test rejects no difference and TOST fails;
- "spread": Pitman–Morgan rejects equal variances (a family of one: no Holm);
- "gate": equivalent and the spread not rejected (what the gate needs of every quantity).
legacy=True judges as the gate did before: the floor from the judged seeds' OLD values themselves.
"""

from __future__ import annotations

import math
from typing import Any, Dict, Optional

import numpy as np

from . import equivalence


def draw(rng: np.random.Generator, n: int, reference_n: int, rho: float, shift: float, chaos: float):
    """(reference values, OLD's, NEW's) of one synthetic quantity, as the module's doc gives them (shift in σ)."""
    common = rng.standard_normal(n)
    old = math.sqrt(rho) * common + math.sqrt(1.0 - rho) * rng.standard_normal(n)
    new = shift + math.sqrt(rho) * common + chaos * math.sqrt(1.0 - rho) * rng.standard_normal(n)
    return rng.standard_normal(reference_n), old, new


def simulate(n: int = 30, reference_n: int = 20, rho: float = 0.5, shift: float = 0.0, shift_mode: str = "sigma",
             chaos: float = 1.0, margin_floors: float = equivalence.MARGIN_FLOORS, alpha: float = equivalence.ALPHA,
             reps: int = 2000, seed: int = 1, legacy: bool = False) -> Dict[str, Any]:
    """Counts of each rate (see the module's doc) over `reps` draws, with the settings. shift_mode "margin": the
    NEW's shift is `shift` × the margin of each draw (1: at the margin); "sigma": `shift` σ."""
    if shift_mode not in ("margin", "sigma"):
        raise ValueError(f"shift_mode must be 'margin' or 'sigma', got {shift_mode!r}")
    rng = np.random.default_rng(seed)
    counts = {"pass": 0, "different": 0, "spread": 0, "gate": 0}
    for _ in range(reps):
        reference, old, new = draw(rng, n, reference_n, rho, 0.0, chaos)
        floor_from = old if legacy else reference
        if shift_mode == "margin":
            step = shift * margin_floors * float(np.std(floor_from, ddof=1)) * (1.0 if rng.random() < 0.5 else -1.0)
        else:
            step = shift * (1.0 if rng.random() < 0.5 else -1.0)
        new = new + step
        row = equivalence.judge_quantity(list(floor_from), list(zip(old.tolist(), new.tolist())), margin_floors)
        verdict = equivalence.verdict_of(row, alpha)
        spread = equivalence.spread_verdict_of(row, alpha) is not None
        counts["pass"] += verdict == "equivalent"
        counts["different"] += verdict == "different"
        counts["spread"] += spread
        counts["gate"] += verdict == "equivalent" and not spread
    return {"n": n, "reference_n": reference_n, "rho": rho, "shift": shift, "shift_mode": shift_mode,
            "chaos": chaos, "margin_floors": margin_floors, "alpha": alpha, "reps": reps, "seed": seed,
            "legacy": legacy, "counts": counts, "rates": {k: v / reps for k, v in counts.items()}}


def interval(count: int, reps: int, level: float = 0.95) -> Optional[list]:
    """The exact (Clopper–Pearson) interval of a simulated rate, scipy.stats.binomtest."""
    from scipy import stats as sps
    ci = sps.binomtest(count, reps).proportion_ci(level)
    return [float(ci.low), float(ci.high)]
