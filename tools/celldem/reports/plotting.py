"""matplotlib for the tools: no display (build and device machines have none), long curves thinned, axis units
taken from series.columns.json where a run has it."""

import numpy as np

# Long, noisy series make Agg rasterise millions of overlapping segments (minutes per figure); a few thousand
# points per curve look the same at these sizes.
MAX_POINTS_PER_CURVE = 4000

# (unit in series.columns.json, factor the plot applies) -> the unit to print. "-" is dimensionless.
DISPLAY_UNITS = {("-", 1.0): "–", ("-", 100.0): "%", ("Pa", 1.0): "Pa", ("Pa", 1e-3): "kPa", ("J", 1.0): "J",
                 ("deg", 1.0): "°", ("s", 1.0): "s"}


def pyplot():
    """matplotlib.pyplot on the Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def thin(*arrays):
    """Every k-th point of equally long arrays, k chosen to keep at most MAX_POINTS_PER_CURVE; keeps the last."""
    n = len(arrays[0])
    if n <= MAX_POINTS_PER_CURVE:
        return arrays
    pick = np.unique(np.append(np.arange(0, n, -(-n // MAX_POINTS_PER_CURVE)), n - 1))
    return tuple(a[pick] for a in arrays)


def unit_text(unit, scale=1.0, fallback="–"):
    """'(kPa)' for a column in Pa plotted × 1e-3, '(%)' for a strain × 100; `fallback` when the run does not say
    (older runs have no series.columns.json) or the pair is not known."""
    return f"({DISPLAY_UNITS.get((unit, float(scale)), fallback)})"


def save(fig, path, dpi=120, **layout):
    """tight_layout, write, close."""
    fig.tight_layout(**layout)
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    return path
