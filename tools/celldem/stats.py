"""Statistics over the seeds of an ensemble, for what the report measures on curves (celldem's ensemble.json
holds those of every summary.json quantity; read them there, never recompute them).

describe() gives the same fields, by the same definitions, as solver/run/ensemble.cpp: n, mean, std (n - 1),
sem = std / sqrt(n), ci95 = mean -+ t(0.975, n - 1) sem. A difference is called only when its 95 % interval
excludes the value it is compared with: a two-sided Student t-test at the 5 % level (one-sample for a value
against a fixed one, paired when the values are per-seed differences of two tests on the same sample).
"""

import math

# Two-sided 95 % quantiles of Student's t for 1..30 degrees of freedom; 1.96 beyond (ensemble.cpp's table).
T95 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
       2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042)


def t95(dof):
    return T95[dof - 1] if 1 <= dof <= len(T95) else 1.96


def describe(values):
    """{"n", "mean", "std", "sem", "ci95", "values"} of the finite values (as ensemble.json), None without any."""
    values = [float(v) for v in values if v is not None and math.isfinite(v)]
    n = len(values)
    if n == 0:
        return None
    mean = sum(values) / n
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1)) if n > 1 else 0.0
    sem = std / math.sqrt(n)
    half = t95(n - 1) * sem if n > 1 else 0.0
    return {"n": n, "mean": mean, "std": std, "sem": sem, "ci95": [mean - half, mean + half], "values": values}


def compare(stat, value=0.0):
    """-1, 0 or +1: the mean is below, not distinguishable from, or above `value` (95 % interval); None without
    a statistic or with fewer than two seeds."""
    if stat is None or stat.get("n", 0) < 2:
        return None
    lo, hi = stat["ci95"]
    return 1 if lo > value else -1 if hi < value else 0


def t_text(stat, value=0.0):
    """'t = 3.21, 2 dof' of the mean against `value`."""
    if stat is None or stat.get("n", 0) < 2:
        return "n < 2"
    if stat["sem"] == 0:
        return f"sem 0, {stat['n'] - 1} dof"
    return f"t = {(stat['mean'] - value) / stat['sem']:.2f}, {stat['n'] - 1} dof"


def not_distinguishable(stat):
    return f"not distinguishable at {stat['n']} seeds" if stat else "n/a"
