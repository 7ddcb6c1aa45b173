"""Statistics over the seeds of an ensemble, for what the report measures on curves (celldem's ensemble.json
holds those of every summary.json quantity; read them there, never recompute them). Quantiles and p-values come
from scipy.stats; nothing here is a hand-typed table.

describe() gives the same fields, by the same definitions, as solver/run/ensemble.cpp: n, mean, std (n - 1),
sem = std / sqrt(n), ci95 = mean -+ t(0.975, n - 1) sem (the interval of the mean) and pi95 = mean -+
t(0.975, n - 1) std sqrt(1 + 1/n) (the prediction interval of one more sample).

The tests, each two-sided at level alpha unless said otherwise:
- one_sample_p: a mean against a fixed value (one-sample t, n - 1 dof); with paired per-seed differences of two
  tests on the same sample it is the paired t-test.
- prediction_p: a single value (one sample, e.g. the paper's) against the ensemble: t = (x - mean) /
  (std sqrt(1 + 1/n)), n - 1 dof; x lies outside pi95 exactly when p < 0.05.
- tost: equivalence within +-margin by two one-sided t-tests (Schuirmann); its p is the larger of the two.
- holm: Holm's step-down adjustment of a family of p-values, which keeps the family-wise error rate (the chance
  of any false verdict in the family) at alpha.
- pitman_morgan: equal variances of two paired samples (X_i, Y_i on the same unit): the correlation of D = Y - X
  and S = Y + X, whose covariance is var Y - var X, tested by Pearson's t with n - 2 dof (exact for bivariate
  normal pairs; Levene's and the F test assume independent samples, and lose their stated rate on paired ones).
- fisher_z: a correlation r as Fisher's z = artanh(r), nearly normal with a scale that does not depend on r: a
  correlation over the seeds is tested as the one-sample t of the seeds' z (never r itself, bounded and skewed
  near 1) against artanh(r0).
"""

from __future__ import annotations

import math
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple

import numpy as _np
from scipy import optimize as _opt
from scipy import stats as _st

# describe()'s result: {"n": int, "mean", "std", "sem": float, "ci95", "pi95": [lo, hi], "values": [float]}, as
# ensemble.json's entries.
Stat = Dict[str, Any]


def t_quantile(p: float, dof: float) -> float:
    """The p-quantile of Student's t with dof degrees of freedom."""
    return float(_st.t.ppf(p, dof))


def t95(dof: float) -> float:
    """t(0.975, dof): the two-sided 95 % quantile."""
    return t_quantile(0.975, dof)


def finite(values: Iterable[Optional[float]]) -> List[float]:
    """The finite values, as floats (None and NaN left out)."""
    return [float(v) for v in values if v is not None and math.isfinite(v)]


def describe(values: Iterable[Optional[float]]) -> Optional[Stat]:
    """{"n", "mean", "std", "sem", "ci95", "pi95", "values"} of the finite values (as ensemble.json), None without
    any."""
    values = finite(values)
    n = len(values)
    if n == 0:
        return None
    mean = sum(values) / n
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1)) if n > 1 else 0.0
    sem = std / math.sqrt(n)
    t = t95(n - 1) if n > 1 else 0.0
    half, half_one = t * sem, t * std * math.sqrt(1.0 + 1.0 / n)
    return {"n": n, "mean": mean, "std": std, "sem": sem, "ci95": [mean - half, mean + half],
            "pi95": [mean - half_one, mean + half_one], "values": values}


def prediction_interval(stat: Stat, level: float = 0.95) -> List[float]:
    """mean -+ t((1 + level)/2, n - 1) std sqrt(1 + 1/n): where one more sample falls with probability `level`."""
    n = stat["n"]
    half = t_quantile(0.5 + level / 2.0, n - 1) * stat["std"] * math.sqrt(1.0 + 1.0 / n)
    return [stat["mean"] - half, stat["mean"] + half]


def _two_sided(t: float, dof: float) -> float:
    return float(2.0 * _st.t.sf(abs(t), dof))


def one_sample_p(stat: Optional[Stat], value: float = 0.0) -> Optional[float]:
    """Two-sided p of the one-sample t-test of the mean against `value` (the paired t-test when the values are
    per-seed differences); None with fewer than two values; 0 or 1 when the values do not scatter."""
    if stat is None or stat.get("n", 0) < 2:
        return None
    if stat["sem"] == 0:
        return 1.0 if stat["mean"] == value else 0.0
    return _two_sided((stat["mean"] - value) / stat["sem"], stat["n"] - 1)


def prediction_p(stat: Optional[Stat], value: float) -> Optional[float]:
    """Two-sided p of a single value against the ensemble as one more sample of it: t = (value - mean) /
    (std sqrt(1 + 1/n)), n - 1 dof. None with fewer than two values."""
    if stat is None or stat.get("n", 0) < 2:
        return None
    scale = stat["std"] * math.sqrt(1.0 + 1.0 / stat["n"])
    if scale == 0:
        return 1.0 if stat["mean"] == value else 0.0
    return _two_sided((value - stat["mean"]) / scale, stat["n"] - 1)


def tost(stat: Optional[Stat], margin: float) -> Optional[Dict[str, Any]]:
    """Two one-sided t-tests of |mean| < margin (the mean of paired differences): {"p": the larger one-sided p,
    "p_lower", "p_upper", "interval": the (1 - 2 alpha) interval at alpha = 0.05, i.e. the 90 % interval}. The
    difference is equivalent to 0 within the margin at level alpha when p < alpha (that interval inside
    +-margin). None with fewer than two values."""
    if stat is None or stat.get("n", 0) < 2:
        return None
    n, mean, sem = stat["n"], stat["mean"], stat["sem"]
    if sem == 0:
        p = 0.0 if abs(mean) < margin else 1.0
        return {"p": p, "p_lower": p, "p_upper": p, "interval": [mean, mean]}
    p_lower = float(_st.t.sf((mean + margin) / sem, n - 1))   # H0: mean <= -margin
    p_upper = float(_st.t.cdf((mean - margin) / sem, n - 1))  # H0: mean >= +margin
    half = t_quantile(0.95, n - 1) * sem
    return {"p": max(p_lower, p_upper), "p_lower": p_lower, "p_upper": p_upper, "interval": [mean - half, mean + half]}


def pitman_morgan(x: Sequence[float], y: Sequence[float]) -> Optional[Dict[str, Any]]:
    """Pitman-Morgan test of var(Y) = var(X) for paired values (x_i, y_i): {"ratio": the sample variance ratio
    var(y) / var(x), "r": corr(y - x, y + x), "p": its two-sided p (scipy.stats.pearsonr, n - 2 dof)}. None with
    fewer than 4 pairs, or where either variance, or the spread of the differences or of the sums, is 0 (nothing
    to test)."""
    a, b = _np.asarray(x, dtype=float), _np.asarray(y, dtype=float)
    if a.size != b.size or a.size < 4:
        return None
    d, s = b - a, b + a
    va, vb = float(_np.var(a, ddof=1)), float(_np.var(b, ddof=1))
    if va == 0 or vb == 0 or float(_np.ptp(d)) == 0 or float(_np.ptp(s)) == 0:
        return None
    r, p = _st.pearsonr(d, s)
    return {"ratio": vb / va, "r": float(r), "p": float(p)}


# |r| is held below 1 by this much so that a perfect correlation has a finite z (artanh(1 - 1e-12) = 14.2)
FISHER_R_CLIP = 1e-12


def fisher_z(r: Optional[float]) -> Optional[float]:
    """Fisher's z = artanh(r) of a correlation (None for None); |r| = 1 is clipped to 1 - FISHER_R_CLIP."""
    if r is None or not math.isfinite(r):
        return None
    return float(_np.arctanh(_np.clip(r, -1.0 + FISHER_R_CLIP, 1.0 - FISHER_R_CLIP)))


def lost_to_adjustment(p: Optional[float], adjusted: Optional[float], alpha: float = 0.05) -> bool:
    """True when a hypothesis is rejected unadjusted (p <= alpha, the compared value outside its unadjusted
    interval) but not after the family's adjustment: its row must say so, since the interval it prints is the
    unadjusted one."""
    return p is not None and adjusted is not None and p <= alpha < adjusted


def holm(pvalues: Sequence[Optional[float]], alpha: float = 0.05) -> Tuple[List[Optional[float]], List[bool]]:
    """Holm's step-down procedure. pvalues: a list (None entries are not tested). Returns (adjusted p-values,
    rejected) lists in the same order: the k-th smallest of m p-values is compared with alpha / (m - k + 1), and
    testing stops at the first that is not rejected; the adjusted p is the running maximum of (m - k + 1) p_(k),
    capped at 1, so that rejected == (adjusted <= alpha)."""
    tested = {i: p for i, p in enumerate(pvalues) if p is not None}
    m = len(tested)
    adjusted: List[Optional[float]] = [None] * len(pvalues)
    rejected = [False] * len(pvalues)
    running = 0.0
    for k, i in enumerate(sorted(tested, key=lambda i: tested[i])):
        running = max(running, min(1.0, (m - k) * tested[i]))
        adjusted[i] = running
        rejected[i] = running <= alpha
    return adjusted, rejected


def equivalence_verdict(p_different: Optional[float], p_tost: Optional[float], n: int, alpha: float = 0.05) -> str:
    """The verdict of a sameness claim from its (Holm-adjusted) p-values: "equivalent" when TOST rejects a
    difference as large as the margin, else "different" when the paired t-test rejects no difference, else
    "undecided at n seeds"."""
    if p_tost is not None and p_tost <= alpha:
        return "equivalent"
    if p_different is not None and p_different <= alpha:
        return "different"
    return f"undecided at {n} seeds"


def smallest_detectable(n: int, std: Optional[float], alpha: float = 0.05, power: float = 0.8) -> Optional[float]:
    """The smallest true mean difference that a two-sided one-sample t-test at level alpha over n paired values of
    standard deviation `std` detects with probability `power`: solved exactly on the noncentral t distribution
    (scipy.stats.nct), not the normal approximation. None with fewer than two values."""
    if n < 2 or std is None:
        return None
    if std == 0:
        return 0.0
    dof = n - 1
    crit = t_quantile(1.0 - alpha / 2.0, dof)
    sqn = math.sqrt(n)

    def power_at(delta: float) -> float:  # delta in units of std
        nc = delta * sqn
        with _np.errstate(divide="ignore", invalid="ignore"):  # scipy's nct warns on its far tail, harmlessly
            return float(_st.nct.sf(crit, dof, nc) + _st.nct.cdf(-crit, dof, nc))

    hi = 1.0
    while power_at(hi) < power:
        hi *= 2.0
    return float(_opt.brentq(lambda d: power_at(d) - power, 0.0, hi, xtol=1e-10)) * std


# ---- the report's verdict helpers ---------------------------------------------------------------------------

def compare(stat: Optional[Stat], value: float = 0.0, interval: str = "ci95") -> Optional[int]:
    """-1, 0 or +1: the mean is below, not distinguishable from, or above `value` by the 95 % interval named
    (ci95: the mean's; pi95: one more sample's); None without a statistic or with fewer than two seeds."""
    if stat is None or stat.get("n", 0) < 2:
        return None
    lo, hi = stat[interval] if interval in stat else prediction_interval(stat)
    return 1 if lo > value else -1 if hi < value else 0


def t_text(stat: Optional[Stat], value: float = 0.0) -> str:
    """'t = 3.21, 2 dof' of the mean against `value`."""
    if stat is None or stat.get("n", 0) < 2:
        return "n < 2"
    if stat["sem"] == 0:
        return f"sem 0, {stat['n'] - 1} dof"
    return f"t = {(stat['mean'] - value) / stat['sem']:.2f}, {stat['n'] - 1} dof"


def p_text(p: Optional[float], adjusted: Optional[float] = None) -> str:
    """'p = 0.012, Holm 0.048'."""
    if p is None:
        return "p n/a"
    return f"p = {p:.3g}" + ("" if adjusted is None else f", Holm {adjusted:.3g}")


def not_distinguishable(stat: Optional[Stat]) -> str:
    """'not distinguishable at n seeds', 'n/a' without a statistic."""
    return f"not distinguishable at {stat['n']} seeds" if stat else "n/a"
