"""The strong force chains at each test's peak (figures/force_chains.png): a slab of the cell through its centre,
normal to axis 2, each strong contact drawn as a line between the two centres, its width proportional to the
normal force; every test side by side on the same length and force scales.

celldem writes the contact network of the row of the driven measure's peak (s11/s33, s33/s11 or |s_ij|/s_jj:
summary.json driven_measure) into <test>/peak_contacts.csv (one line
per contact: the wrapped centre of i, x_i y_i z_i, the centre of the image of j it touches, x_j y_j z_j, so that
j - i is the branch vector; the normal force [N]; 1 when sliding) and the cell matrix into peak_contacts.json
("cell": rows of h, whose columns are the cell vectors).
"""

import os

import numpy as np

from ..results import RunError, read_json

SLAB_DIAMETERS = 1.5   # slab thickness in mean diameters
MAX_WIDTH = 3.0        # line width (points) of the largest force of all the tests drawn



def peak_words(meta):
    """The peak the network was taken at, in the driven measure's own name (peak_contacts.json "measure", "value" and
    its strain, e.g. g12, for a shear or extension test; s11/s33 and e1 otherwise)."""
    if "measure" in meta:
        strain = next((k for k in meta if k not in ("measure", "value", "e1", "ratio13", "step", "cell", "columns")),
                      "e1")
        return (f"peak {meta['measure']} {meta.get('value', float('nan')):.2f} at {strain} = "
                f"{100 * meta.get(strain, float('nan')):.2f} %")
    return (f"peak σ1/σ3 {meta.get('ratio13', float('nan')):.2f} at ε1 = "
            f"{100 * meta.get('e1', float('nan')):.2f} %")

def tests_with_contacts(run):
    """The tests of a run with a peak_contacts.csv, in the run's order."""
    return [t for t in run.test_names if os.path.isfile(os.path.join(run.directory, t, "peak_contacts.csv"))]


def load(run, test):
    """(positions of i, branch vectors, normal forces, h, peak_contacts.json) of a test's peak contacts."""
    path = os.path.join(run.directory, test, "peak_contacts.csv")
    meta = read_json(os.path.join(run.directory, test, "peak_contacts.json"))
    if not isinstance(meta, dict) or "cell" not in meta:
        raise RunError(f"{os.path.dirname(path)}/peak_contacts.json missing or without 'cell'")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        data = np.empty((0, 8))
    h = np.array(meta["cell"], dtype=float)
    return data[:, 0:3], data[:, 3:6] - data[:, 0:3], np.abs(data[:, 6]), h, meta


def wrapped(h, x):
    """Positions brought into the cell (scaled coordinates in [0, 1))."""
    s = np.linalg.solve(h, x.T).T
    return (s - np.floor(s)) @ h.T


def slab_segments(xi, branch, force, h, thickness):
    """The strong contacts (normal force above the mean of all contacts) with a centre in the slab
    |x2 - centre| <= thickness/2, as (start, end, force): from the centre in the slab along the branch (from j
    back to i when only j's wrapped centre is in it)."""
    if not force.size:
        return np.empty((0, 3)), np.empty((0, 3)), np.empty(0)
    strong = force > force.mean()
    xi, branch, force = xi[strong], branch[strong], force[strong]
    centre = 0.5 * h[1, 1]  # the cells of these tests stay orthogonal: axis 2's extent is h22
    xj = wrapped(h, xi + branch)
    in_i = np.abs(xi[:, 1] - centre) <= thickness / 2
    in_j = ~in_i & (np.abs(xj[:, 1] - centre) <= thickness / 2)
    start = np.concatenate([xi[in_i], xj[in_j]])
    end = np.concatenate([xi[in_i] + branch[in_i], xj[in_j] - branch[in_j]])
    return start, end, np.concatenate([force[in_i], force[in_j]])


def draw(plt, run, tests=None, label=""):
    """The figure (None when no test has peak contacts): one panel per test, x3 across and x1 (the loading axis)
    up, in mm; widths scaled to the largest force of all the panels."""
    from matplotlib.collections import LineCollection

    tests = tests or tests_with_contacts(run)
    if not tests:
        return None
    diameter = run.mean_diameter()
    panels = []
    for test in tests:
        xi, branch, force, h, meta = load(run, test)
        d = diameter or (float(np.median(np.linalg.norm(branch, axis=1))) if force.size else 0.0)
        panels.append((test, slab_segments(xi, branch, force, h, SLAB_DIAMETERS * d), h, meta, force))
    f_max = max((p[1][2].max() for p in panels if p[1][2].size), default=1.0)
    extent = max(max(p[2][0, 0], p[2][2, 2]) for p in panels) * 1e3
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 5.0), squeeze=False)
    for ax, (test, (start, end, force), h, meta, all_forces) in zip(axes[0], panels, strict=True):
        # Axis 3 across, axis 1 (the loading axis) up; mm.
        lines = np.stack([start[:, [2, 0]], end[:, [2, 0]]], axis=1) * 1e3
        ax.add_collection(LineCollection(lines, linewidths=MAX_WIDTH * force / f_max, colors="k",
                                         capstyle="round"))
        ax.add_patch(plt.Rectangle((0, 0), h[2, 2] * 1e3, h[0, 0] * 1e3, fill=False, ec="0.6", lw=0.8, ls="--"))
        pad = 0.25 * extent
        ax.set_xlim(-pad, extent + pad)
        ax.set_ylim(-pad, extent + pad)
        ax.set_aspect("equal")
        ax.set_xlabel(r"$x_3$ (mm)")
        ax.set_ylabel(r"$x_1$ (mm, loading axis)")
        mean_f = all_forces.mean() if all_forces.size else float("nan")
        ax.set_title(f"{test}: {peak_words(meta)}\n{force.size} strong contacts in the slab "
                     f"(mean |fn| {mean_f:.3g} N)", fontsize=9)
    fig.suptitle(f"Strong force chains at the peak{label}: |fn| > mean, width ∝ |fn| (widest {f_max:.3g} N)\n"
                 f"slab {SLAB_DIAMETERS:g} mean diameters thick through the centre, normal to x2", fontsize=9)
    return fig
