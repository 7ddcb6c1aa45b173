"""pytest: tools/celldem/stats.py against scipy and against cases worked by hand."""
import math

import numpy as np
import pytest
from scipy import stats as st

from celldem import stats


def test_describe_intervals_against_scipy():
    values = [1.0, 2.0, 3.0, 4.0, 6.0, 5.5, 2.5, 3.1]
    d = stats.describe(values)
    n, mean, sd = len(values), np.mean(values), np.std(values, ddof=1)
    assert d["n"] == n and d["mean"] == pytest.approx(mean) and d["std"] == pytest.approx(sd)
    t = st.t.ppf(0.975, n - 1)
    assert d["ci95"] == pytest.approx([mean - t * sd / math.sqrt(n), mean + t * sd / math.sqrt(n)])
    assert d["pi95"] == pytest.approx([mean - t * sd * math.sqrt(1 + 1 / n), mean + t * sd * math.sqrt(1 + 1 / n)])
    # scipy's own interval of the mean agrees
    lo, hi = st.t.interval(0.95, n - 1, loc=mean, scale=st.sem(values))
    assert d["ci95"] == pytest.approx([lo, hi])


def test_prediction_interval_is_three_times_the_mean_interval_at_8():
    d = stats.describe([0.30, 0.28, 0.33, 0.25, 0.29, 0.31, 0.27, 0.26])
    ci, pi = d["ci95"][1] - d["mean"], d["pi95"][1] - d["mean"]
    assert pi / ci == pytest.approx(3.0)  # sqrt(1 + 1/8) / sqrt(1/8) = sqrt(9)


def test_t_quantile_beyond_30_dof_is_not_the_normal_one():
    assert stats.t95(40) == pytest.approx(2.021, abs=1e-3)
    assert stats.t95(7) == pytest.approx(2.365, abs=1e-3)


def test_prediction_p_matches_the_interval():
    d = stats.describe([1.0, 2.0, 3.0, 4.0, 5.0])
    hi = d["pi95"][1]
    assert stats.prediction_p(d, hi) == pytest.approx(0.05)
    assert stats.prediction_p(d, hi - 1e-6) > 0.05 > stats.prediction_p(d, hi + 1e-6)


def test_one_sample_p_is_scipys():
    x = [0.1, -0.3, 0.5, 0.7, 0.2, 0.4]
    assert stats.one_sample_p(stats.describe(x), 0.0) == pytest.approx(st.ttest_1samp(x, 0.0).pvalue)


def test_tost_decisions_on_constructed_data():
    rng = np.random.default_rng(3)
    tight = list(0.01 + 0.02 * rng.standard_normal(12))          # small difference, small spread
    far = list(1.0 + 0.02 * rng.standard_normal(12))             # large difference
    wide = list(0.0 + 2.0 * rng.standard_normal(4))              # few, scattered
    margin = 0.1
    for values, want in ((tight, "equivalent"), (far, "different"), (wide, "undecided at 4 seeds")):
        d = stats.describe(values)
        verdict = stats.equivalence_verdict(stats.one_sample_p(d), stats.tost(d, margin)["p"], d["n"])
        assert verdict == want
    # the TOST p is the larger of the two one-sided t-tests, each scipy's
    d = stats.describe(tight)
    r = stats.tost(d, margin)
    p_lo = st.ttest_1samp(tight, -margin, alternative="greater").pvalue
    p_hi = st.ttest_1samp(tight, margin, alternative="less").pvalue
    assert r["p"] == pytest.approx(max(p_lo, p_hi))
    # equivalent at 5 % exactly when the 90 % interval lies within the margin
    assert (r["p"] < 0.05) == (-margin < r["interval"][0] and r["interval"][1] < margin)


def test_holm_textbook_case():
    # Holm (1979)-style example: m = 4, alpha = 0.05; sorted p 0.010 < 0.05/4, 0.015 < 0.05/3, 0.030 > 0.05/2:
    # stop; the first two are rejected, the rest are not (0.040 < 0.05 alone would have been).
    p = [0.030, 0.010, 0.040, 0.015]
    adjusted, rejected = stats.holm(p, 0.05)
    assert rejected == [False, True, False, True]
    assert adjusted == pytest.approx([0.06, 0.04, 0.06, 0.045])
    # untested entries are skipped and do not count in m
    adjusted, rejected = stats.holm([None, 0.02, 0.03], 0.05)
    assert adjusted[0] is None and rejected == [False, True, True]


def test_holm_against_scipy_p_values():
    # p-values of three one-sample t-tests from scipy, adjusted by hand: m p_(1), max(., (m-1) p_(2)), ...
    samples = [[0.5, 0.7, 0.6, 0.8, 0.4], [0.1, -0.2, 0.3, 0.0, 0.2], [1.2, 1.5, 0.9, 1.1, 1.3]]
    p = [st.ttest_1samp(s, 0.0).pvalue for s in samples]
    order = sorted(range(3), key=lambda i: p[i])
    want, running = [0.0] * 3, 0.0
    for k, i in enumerate(order):
        running = max(running, min(1.0, (3 - k) * p[i]))
        want[i] = running
    adjusted, rejected = stats.holm(p)
    assert adjusted == pytest.approx(want)
    assert rejected == [a <= 0.05 for a in want]


def test_smallest_detectable_effect_has_80_percent_power():
    n, sd = 6, 2.0
    delta = stats.smallest_detectable(n, sd)
    crit = st.t.ppf(0.975, n - 1)
    nc = delta / sd * math.sqrt(n)
    power = st.nct.sf(crit, n - 1, nc) + st.nct.cdf(-crit, n - 1, nc)
    assert power == pytest.approx(0.8, abs=1e-6)
    # and a Monte Carlo check of that power
    rng = np.random.default_rng(1)
    x = delta + sd * rng.standard_normal((20000, n))
    p = st.ttest_1samp(x, 0.0, axis=1).pvalue
    assert np.mean(p < 0.05) == pytest.approx(0.8, abs=0.015)


def test_fisher_z_is_scipys_transform():
    # scipy's Pearson confidence interval is tanh(artanh(r) -+ z(0.975) / sqrt(n - 3)): the same transform.
    rng = np.random.default_rng(11)
    x = rng.standard_normal(40)
    y = 0.7 * x + 0.5 * rng.standard_normal(40)
    res = st.pearsonr(x, y)
    half = st.norm.ppf(0.975) / np.sqrt(40 - 3)
    ci = res.confidence_interval(0.95)
    z = stats.fisher_z(res.statistic)
    assert (np.tanh(z - half), np.tanh(z + half)) == pytest.approx((ci.low, ci.high), rel=1e-12)
    assert stats.fisher_z(1.0) == pytest.approx(np.arctanh(1 - 1e-12)) and stats.fisher_z(None) is None


def test_lost_to_adjustment():
    assert stats.lost_to_adjustment(0.01, 0.08) and not stats.lost_to_adjustment(0.01, 0.04)
    assert not stats.lost_to_adjustment(0.2, 0.6) and not stats.lost_to_adjustment(None, None)
