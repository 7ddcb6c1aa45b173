"""Curve helpers on series columns (numpy arrays): what the tools measure on curves beyond summary.json.

Nothing here redefines a quantity celldem puts in summary.json (the peak of s11/s33, its plateau, b at the
peak, the end values): read those with results.RunArrays.quantity.
"""

from __future__ import annotations

import math
from typing import Iterable, Mapping, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
MaybeArray = Optional[Array]
# A curve: (x, y) of one run, each a float array (or array-like) of its rows.
Curve = Tuple[npt.ArrayLike, npt.ArrayLike]


def finite_pair(x: Array, y: Array) -> Tuple[Array, Array]:
    """The rows where both x and y are finite."""
    keep = np.isfinite(x) & np.isfinite(y)
    return x[keep], y[keep]


def max_of(values: MaybeArray) -> Optional[float]:
    """The largest finite value, or None."""
    return None if values is None or not np.any(np.isfinite(values)) else float(np.nanmax(values))


def first_last(values: MaybeArray) -> Tuple[Optional[float], Optional[float]]:
    """(first, last) value of a column, or (None, None) when it is missing or empty."""
    return (None, None) if values is None or not values.size else (float(values[0]), float(values[-1]))


def x_at_max(x: MaybeArray, y: MaybeArray) -> Optional[float]:
    """x on the first row of the largest finite y, or None."""
    if x is None or y is None or not np.any(np.isfinite(y)):
        return None
    return float(x[int(np.nanargmax(y))])


def value_at(x: MaybeArray, y: MaybeArray, x0: float) -> Optional[float]:
    """y linearly interpolated at x0, or None when x0 lies outside the finite data (no extrapolation)."""
    if x is None or y is None:
        return None
    x, y = finite_pair(x, y)
    if x.size == 0 or x0 < x.min() or x0 > x.max():
        return None
    order = np.argsort(x, kind="stable")
    return float(np.interp(x0, x[order], y[order]))


def on_grid(x_ref: Array, x: Array, y: Array) -> Array:
    """y(x) interpolated at x_ref (NaN outside the range of x): one code's curve on another's rows."""
    order = np.argsort(x)
    out = np.interp(x_ref, x[order], y[order])
    out[(x_ref < x.min() - 1e-12) | (x_ref > x.max() + 1e-12)] = np.nan
    return out


def pearson(x: MaybeArray, y: MaybeArray) -> Optional[float]:
    """Pearson correlation of the finite pairs, or None with fewer than 3 or a constant curve."""
    if x is None or y is None:
        return None
    x, y = finite_pair(x, y)
    if x.size < 3 or np.std(x) == 0 or np.std(y) == 0:
        return None
    return float(np.corrcoef(x, y)[0, 1])


def binned_means(x: Array, y: Array, edges: Array) -> Array:
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


def binned_pair(xa: MaybeArray, ya: MaybeArray, xb: MaybeArray, yb: MaybeArray,
                bins: int = 100) -> Optional[Tuple[Array, Array]]:
    """Two noisy curves y(x) averaged in `bins` equal bins of the x range both cover: (means of a, means of b) over
    the bins both have data in, or None without overlap."""
    if xa is None or ya is None or xb is None or yb is None:
        return None
    xa, ya = finite_pair(xa, ya)
    xb, yb = finite_pair(xb, yb)
    if xa.size < 2 or xb.size < 2:
        return None
    lo, hi = max(xa.min(), xb.min()), min(xa.max(), xb.max())
    if not hi > lo:
        return None
    edges = np.linspace(lo, hi, bins + 1)
    ma, mb = binned_means(xa, ya, edges), binned_means(xb, yb, edges)
    both = np.isfinite(ma) & np.isfinite(mb)
    return (ma[both], mb[both]) if np.count_nonzero(both) >= 2 else None


def curve_difference(xa: MaybeArray, ya: MaybeArray, xb: MaybeArray, yb: MaybeArray, bins: int = 100,
                     relative_to: str = "range") -> Tuple[Optional[float], int]:
    """RMS difference of two noisy curves y(x) over the x range both cover.

    Both curves are averaged in `bins` equal bins of x. relative_to="range" divides the RMS difference by the
    span of the binned curves (max - min); relative_to="value" takes the RMS of the pointwise difference
    divided by the mean of the two values. Returns (difference, bins used) or (None, 0) without overlap.
    """
    pair = binned_pair(xa, ya, xb, yb, bins)
    if pair is None:
        return None, 0
    ma, mb = pair
    if relative_to == "range":
        span = max(ma.max(), mb.max()) - min(ma.min(), mb.min())
        if span <= 0:
            return 0.0, ma.size
        return float(math.sqrt(np.mean((ma - mb) ** 2)) / span), ma.size
    mean = 0.5 * (ma + mb)
    return float(math.sqrt(np.mean(((ma - mb) / mean) ** 2))), ma.size


def mean_difference(xa: MaybeArray, ya: MaybeArray, xb: MaybeArray, yb: MaybeArray, bins: int = 100,
                    relative: bool = False) -> Optional[float]:
    """The signed mean of b - a over the binned curves (binned_pair), divided by the mean value when `relative`;
    None without overlap. Over seeds, its spread says whether two tests' curves differ."""
    pair = binned_pair(xa, ya, xb, yb, bins)
    if pair is None:
        return None
    ma, mb = pair
    return float(np.mean((mb - ma) / (0.5 * (ma + mb)) if relative else mb - ma))


def all_finite(series: Mapping[str, Array], names: Iterable[str] = ("e1", "s11", "s22", "s33")) -> bool:
    """Whether the named columns of a series (those it has) hold finite values only: a run that blew up has not."""
    return bool(all(np.all(np.isfinite(series[c])) for c in names if c in series))


def seed_table(curves: Sequence[Curve], edges: Array) -> Array:
    """Binned means of y (rows: curves, columns: bins of x; NaN where a curve has no data in a bin)."""
    return np.array([binned_means(np.asarray(x, float), np.asarray(y, float), edges) for x, y in curves])


def bin_edges(curves: Sequence[Curve], bins: Optional[int] = None) -> Optional[Array]:
    """Equal bins over the x range the curves cover together; by default about two rows of a curve per bin
    (10 to 100 bins). None when no curve has finite x."""
    xs = [np.asarray(x, float)[np.isfinite(x)] for x, _ in curves]
    xs = [x for x in xs if x.size]
    if not xs:
        return None
    lo, hi = min(x.min() for x in xs), max(x.max() for x in xs)
    if not hi > lo:
        return None
    if bins is None:
        bins = int(np.clip(min(x.size for x in xs) // 2, 10, 100))
    return np.linspace(lo, hi, bins + 1)


def seed_band(curves: Sequence[Curve], edges: Optional[Array] = None) -> Tuple[Array, Array, Array, Array]:
    """The mean curve of several runs (one per seed) and its band: in each bin of x, the mean over the seeds of
    each seed's binned mean of y, and their sample standard deviation (n - 1). Bins where fewer than two seeds
    have data are left out. Returns (bin centres, mean, std, seeds per bin), empty arrays without data."""
    edges = bin_edges(curves) if edges is None else edges
    if edges is None:
        return (np.empty(0),) * 4
    table = seed_table(curves, edges)
    count = np.sum(np.isfinite(table), axis=0)
    keep = count >= 2
    centres = 0.5 * (edges[:-1] + edges[1:])
    sub = table[:, keep]
    return centres[keep], np.nanmean(sub, axis=0), np.nanstd(sub, axis=0, ddof=1), count[keep]
