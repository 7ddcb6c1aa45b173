"""The equivalence gate's error rates by simulation (tools/celldem/performance/equivalence_sim.py: synthetic paired
ensembles judged by the gate's own per-quantity code; seeded). Each rate is checked against its bound by the exact
binomial interval of the simulated count (scipy.stats.binomtest, 99.9 %), so a rule that keeps its stated rate
fails here by chance about once in a thousand runs: at a true shift equal to the margin TOST passes at most 5 %
(with loose and with tight pairs), a harmless NEW trips the spread check at most 5 %, a NEW with twice the chaos
mostly fails, and a harmless one mostly passes (the power the docs quote)."""

import pytest
from scipy import stats as sps

from celldem.performance import equivalence_sim as sim

REPS = 1200


def bounds(result, rate):
    ci = sps.binomtest(result["counts"][rate], result["reps"]).proportion_ci(0.999)
    return ci.low, ci.high


@pytest.mark.parametrize("rho", [0.5, 0.95])
def test_a_shift_equal_to_the_margin_passes_at_most_five_percent(rho):
    r = sim.simulate(n=30, reference_n=20, rho=rho, shift=1.0, shift_mode="margin", reps=REPS, seed=11)
    low, _ = bounds(r, "pass")
    assert low <= 0.05, r["rates"]


def test_a_harmless_new_passes_mostly_and_trips_the_spread_check_at_most_five_percent():
    r = sim.simulate(n=30, reference_n=20, rho=0.9, shift=0.0, reps=REPS, seed=12)
    low, _ = bounds(r, "spread")
    assert low <= 0.05, r["rates"]
    _, high = bounds(r, "different")
    assert high > 0 and r["rates"]["different"] <= 0.05 + 3 * (0.05 * 0.95 / REPS) ** 0.5, r["rates"]
    low, _ = bounds(r, "gate")
    assert low >= 0.85, r["rates"]  # tight pairs at 30 seeds: about 0.95 (docs/performance.md)


def test_twice_the_chaos_mostly_fails():
    r = sim.simulate(n=30, reference_n=20, rho=0.5, shift=0.0, chaos=2.0, reps=REPS, seed=13)
    _, high = bounds(r, "gate")
    low, _ = bounds(r, "spread")
    assert high <= 0.10 and low >= 0.6, r["rates"]


def test_the_old_rule_floor_from_the_judged_seeds_is_what_the_reference_replaces():
    # The margin stated in floors of the judged seeds moves with them; with tight pairs and few seeds a shift of
    # 0.5 true floors then passes far more than 5 % (the 19 %); a margin fixed by an independent reference
    # holds 5 % at the margin it states.
    legacy = sim.simulate(n=8, reference_n=8, rho=0.99, shift=0.5, shift_mode="sigma", reps=REPS, seed=14,
                          legacy=True)
    low, _ = bounds(legacy, "pass")
    assert low > 0.05, legacy["rates"]
    fixed = sim.simulate(n=8, reference_n=8, rho=0.99, shift=1.0, shift_mode="margin", reps=REPS, seed=14)
    low, _ = bounds(fixed, "pass")
    assert low <= 0.05, fixed["rates"]
