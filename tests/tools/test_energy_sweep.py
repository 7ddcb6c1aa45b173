"""tools/energy_sweep.py: the order fit against exact power laws and SciPy's t interval, the variants' decks,
and a short real order sweep (150 spheres, 5 time steps, about 15 s): a frictionless packing's closure error is
second order in dt (docs/energy.md "Where the first-order term comes from"), the test that a first-order term in
the budget's own bookkeeping of the springs, the boundary or the kinetic energy would fail."""

import argparse
import csv
import math
import os

import numpy as np
import pytest
from scipy import stats

import energy_sweep as es


@pytest.mark.parametrize("order", [1.0, 2.0, 0.5])
def test_fit_order_recovers_an_exact_power_law(order):
    x = np.array([0.05, 0.1, 0.2, 0.3, 0.5])
    p, half, r2 = es.fit_order(x, -3e-4 * x ** order)  # (the sign is the closure's; the fit takes |y|)
    assert math.isclose(p, order, abs_tol=1e-12) and half < 1e-10 and math.isclose(r2, 1.0)


def test_fit_order_interval_is_the_t_interval_of_the_slope():
    rng = np.random.default_rng(7)
    x = np.array([0.05, 0.1, 0.2, 0.3, 0.5])
    y = 2e-4 * x * np.exp(rng.normal(0.0, 0.05, x.size))
    p, half, _ = es.fit_order(x, y)
    lr = stats.linregress(np.log(x), np.log(y))
    assert math.isclose(half, stats.t.ppf(0.975, 3) * lr.stderr)
    assert abs(p - 1.0) < half  # (the true order inside its interval for this seed)


def test_variants_switch_off_one_term_each():
    base = {"damping": {"translational": 0.05, "rotational": 0.05}, "contact": {"kn": 1e6, "kt": 1e6},
            "prepare": {}, "time_step": 1e-6,
            "tests": [{"name": "ttc", "friction": 0.5, "axes": {"x1": {"strain_increment": 1e-6},
                                                                 "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
                       "end": {"axis": "x1", "strain": 0.006}}]}
    deck = es.ttc_deck(base, "s.state", 2e-7, 2e-7, 0.003, variant="frictionless")
    assert deck["tests"][0]["friction"] == 0.0 and deck["damping"] == base["damping"]
    deck = es.ttc_deck(base, "s.state", 2e-7, 2e-7, 0.003, variant="no_damping")
    assert deck["damping"] == {"translational": 0.0, "rotational": 0.0} and deck["tests"][0]["friction"] == 0.5
    deck = es.ttc_deck(base, "s.state", 2e-7, 2e-7, 0.003, variant="simple_shear")
    axes = deck["tests"][0]["axes"]
    assert axes["x12"] == {"strain_increment": 2e-7} and axes["x1"] == {"strain_increment": 0.0}
    assert deck["tests"][0]["end"] == {"axis": "x12", "strain": 0.006}
    assert deck["initial_state"] == "s.state" and "prepare" not in deck and deck["tests"][0]["dynamic"]


def test_frictionless_closure_is_second_order(celldem, tmp_path):
    args = argparse.Namespace(celldem=celldem, out=str(tmp_path), strain=0.003, variants="frictionless")
    es.sweep_order(args)
    with open(tmp_path / "energy_order_fits.csv") as f:
        fit = next(csv.DictReader(f))
    p, half = float(fit["order"]), float(fit["order_95"])
    assert 1.5 < p - half and p + half < 2.5, fit  # (first order, p = 1, is far outside)
    assert os.path.isfile(tmp_path / "energy_order.csv")
