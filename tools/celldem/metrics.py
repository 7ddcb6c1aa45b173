"""Curve helpers on series columns (numpy arrays): what the tools measure on curves beyond summary.json.

Nothing here redefines a quantity celldem puts in summary.json (the peak of s11/s33, its plateau, b at the
peak, the end values): read those with results.Run.quantity.
"""

import math

import numpy as np


def finite_pair(x, y):
    keep = np.isfinite(x) & np.isfinite(y)
    return x[keep], y[keep]


def max_of(values):
    """The largest finite value, or None."""
    return None if values is None or not np.any(np.isfinite(values)) else float(np.nanmax(values))


def first_last(values):
    """(first, last) value of a column, or (None, None) when it is missing or empty."""
    return (None, None) if values is None or not values.size else (float(values[0]), float(values[-1]))


def x_at_max(x, y):
    """x on the first row of the largest finite y, or None."""
    if x is None or y is None or not np.any(np.isfinite(y)):
        return None
    return float(x[int(np.nanargmax(y))])


def value_at(x, y, x0):
    """y linearly interpolated at x0, or None when x0 lies outside the finite data (no extrapolation)."""
    if x is None or y is None:
        return None
    x, y = finite_pair(x, y)
    if x.size == 0 or x0 < x.min() or x0 > x.max():
        return None
    order = np.argsort(x, kind="stable")
    return float(np.interp(x0, x[order], y[order]))


def on_grid(x_ref, x, y):
    """y(x) interpolated at x_ref (NaN outside the range of x): one code's curve on another's rows."""
    order = np.argsort(x)
    out = np.interp(x_ref, x[order], y[order])
    out[(x_ref < x.min() - 1e-12) | (x_ref > x.max() + 1e-12)] = np.nan
    return out


def pearson(x, y):
    """Pearson correlation of the finite pairs, or None with fewer than 3 or a constant curve."""
    if x is None or y is None:
        return None
    x, y = finite_pair(x, y)
    if x.size < 3 or np.std(x) == 0 or np.std(y) == 0:
        return None
    return float(np.corrcoef(x, y)[0, 1])


def binned_means(x, y, edges):
    """Mean of y in each bin of x (NaN for empty bins). Binning averages out DEM noise before comparing curves."""
    x, y = finite_pair(x, y)
    inside = (x >= edges[0]) & (x <= edges[-1])
    x, y = x[inside], y[inside]
    n_bins = len(edges) - 1
    which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, n_bins - 1)  # x == edges[-1] in the last bin
    sums = np.bincount(which, weights=y, minlength=n_bins)
    counts = np.bincount(which, minlength=n_bins)
    means = np.full(n_bins, np.nan)
    np.divide(sums, counts, out=means, where=counts > 0)
    return means


def curve_difference(xa, ya, xb, yb, bins=100, relative_to="range"):
    """RMS difference of two noisy curves y(x) over the x range both cover.

    Both curves are averaged in `bins` equal bins of x. relative_to="range" divides the RMS difference by the
    span of the binned curves (max - min); relative_to="value" takes the RMS of the pointwise difference
    divided by the mean of the two values. Returns (difference, bins used) or (None, 0) without overlap.
    """
    if xa is None or ya is None or xb is None or yb is None:
        return None, 0
    xa, ya = finite_pair(xa, ya)
    xb, yb = finite_pair(xb, yb)
    if xa.size < 2 or xb.size < 2:
        return None, 0
    lo, hi = max(xa.min(), xb.min()), min(xa.max(), xb.max())
    if not hi > lo:
        return None, 0
    edges = np.linspace(lo, hi, bins + 1)
    ma, mb = binned_means(xa, ya, edges), binned_means(xb, yb, edges)
    both = np.isfinite(ma) & np.isfinite(mb)
    if np.count_nonzero(both) < 2:
        return None, 0
    ma, mb = ma[both], mb[both]
    if relative_to == "range":
        span = max(ma.max(), mb.max()) - min(ma.min(), mb.min())
        if span <= 0:
            return 0.0, int(both.sum())
        return float(math.sqrt(np.mean((ma - mb) ** 2)) / span), int(both.sum())
    mean = 0.5 * (ma + mb)
    return float(math.sqrt(np.mean(((ma - mb) / mean) ** 2))), int(both.sum())


def all_finite(series, names=("e1", "s11", "s22", "s33")):
    """Whether the named columns of a series (those it has) hold finite values only: a run that blew up has not."""
    return bool(all(np.all(np.isfinite(series[c])) for c in names if c in series))
