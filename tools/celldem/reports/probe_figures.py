"""The figures of the tests' incremental response probes (celldem.probes; tools/report.py's Probes section):
  - probe_envelopes.png: the stress probes' response envelopes, one column per test with stress probes (side by
    side, so that TTC's and PSC's envelopes at the same point share a row) and one row per point. Each panel holds,
    per magnitude M, the tips of the strain response vectors divided by M (a linear response gives one curve for
    every M): the total response as a closed curve through the directions in order (solid) and the plastic
    response left after unloading (dashed), in the probes' plane on the basis of their directions
    (celldem.probes.plane_bases: the solver's, σ1's axis up), with the stress directions as a rose beside it. Listed
    directions: the size of each response against the direction's index.
  - probe_stiffness_<test>.png: per point of a test with strain probes, its elastic and tangent stiffness (and the
    contact network's, when stiffness.json holds it) as heat maps in MPa, each with its asymmetry.
"""

import numpy as np

from .. import probes

PER_MPA = 1e6   # responses per Pa -> per MPa
MPA = 1e-6
PERCENT = 100.0

AXIS_LABELS = {  # (horizontal, vertical): the strain increment on u2 and on u1, over M
    "rendulic": (r"$\sqrt{2}\,(\Delta\varepsilon_2+\Delta\varepsilon_3)/2\;/\;M$ (1/MPa)",
                 r"$\Delta\varepsilon_1\;/\;M$ (1/MPa)"),
    "pi": (r"$(\Delta\varepsilon_2-\Delta\varepsilon_3)/\sqrt{2}\;/\;M$ (1/MPa)",
           r"$(2\Delta\varepsilon_1-\Delta\varepsilon_2-\Delta\varepsilon_3)/\sqrt{6}\;/\;M$ (1/MPa)"),
}
ROSE_LABELS = {"rendulic": (r"$\sqrt{2}\sigma_3$", r"$\sigma_1$"), "pi": ("", r"$\sigma_1$")}
ENVELOPES = "probe_envelopes"


def stiffness_stem(test):
    return f"probe_stiffness_{test}"


def magnitude_text(m, kind):
    return f"{m * 1e-3:g} kPa" if kind == "stress" else f"{m:g}"


def point_title(test, point, entry):
    """'ttc at peak (ε1 = 0.775 %)'; a point not run has no ε1 of its own."""
    e1 = probes.number(entry.get("e1"))
    known = e1 is not None and entry.get("status") != "not run"
    return f"{test} at {point}" + (f" (ε1 = {e1 * PERCENT:.3g} %)" if known else "")


def point_rows(sets):
    """The points that any of the sets has probes of, in order of first appearance: the rows of a figure with a
    column per set (a point no set ran is only in the report's table, with its reason)."""
    out = []
    for s in sets:
        out += [p for p in s.points if p not in out and any(t.point_rows(p) for t in sets)]
    return out


def closed(xy):
    return np.vstack([xy, xy[:1]])


def draw_rose(rose, rows, plane):
    """The probes' stress directions in the envelope's coordinates (σ1's axis up), as arrows from the centre."""
    directions = probes.in_plane(plane, np.array([probes.vector(r, probes.DIRECTION[:3]) for r in rows]))
    for k, (up, across) in enumerate(directions):
        rose.annotate("", xy=(across, up), xytext=(0, 0),
                      arrowprops=dict(arrowstyle="-|>", color="0.35", lw=0.8, mutation_scale=7))
        if len(directions) <= 12 or k % 2 == 0:
            rose.text(1.28 * across, 1.28 * up, f"{k}", fontsize=6, ha="center", va="center", color="0.2")
    horizontal, vertical = ROSE_LABELS[plane]
    rose.set_xlabel(horizontal, fontsize=7, labelpad=1)
    rose.set_ylabel(vertical, fontsize=7, labelpad=1)
    rose.set_xlim(-1.5, 1.5)
    rose.set_ylim(-1.5, 1.5)
    rose.set_aspect("equal")
    rose.set_xticks([])
    rose.set_yticks([])
    rose.set_title("stress directions d", fontsize=7)


def draw_plane_envelope(ax, rose, probe_set, point):
    plane = probe_set.plane
    drawn = []
    for k, m in enumerate(probe_set.point_magnitudes(point)):
        rows = probe_set.point_rows(point, m)
        if not rows:
            continue
        label = magnitude_text(m, "stress")
        for part, style, marker in (("total", "-", "o"), ("plastic", "--", "x")):
            # (u1, u2) -> plotted as (u2 across, u1 up): σ1's axis up, as the Rendulic and π planes are drawn
            xy = probes.envelope(rows, plane, part)[:, ::-1] * PER_MPA
            ax.plot(*closed(xy).T, style, marker=marker, markersize=3, linewidth=1.1, color=f"C{k}",
                    label=f"M = {label}, {part}")
            drawn.append(xy[np.all(np.isfinite(xy), axis=1)])
            if k == 0 and part == "total":  # which tip is which direction: the rose's numbers
                for n, (x, y) in enumerate(xy):
                    if np.isfinite(x) and np.isfinite(y):
                        ax.annotate(f"{n}", (x, y), xytext=(3, 3), textcoords="offset points", fontsize=6,
                                    color="0.25")
    ax.axhline(0.0, color="0.6", linewidth=0.5)
    ax.axvline(0.0, color="0.6", linewidth=0.5)
    ax.set_aspect("equal", adjustable="datalim")
    horizontal, vertical = AXIS_LABELS[plane]
    ax.set_xlabel(horizontal, fontsize=8)
    ax.set_ylabel(vertical, fontsize=8)
    rows = probe_set.point_rows(point)
    draw_rose(rose, probe_set.point_rows(point, rows[0]["magnitude"]), plane)
    return bool(drawn)


def draw_listed_envelope(ax, rose, probe_set, point):
    drawn = False
    for k, m in enumerate(probe_set.point_magnitudes(point)):
        rows = probe_set.point_rows(point, m)
        if not rows:
            continue
        index = np.arange(len(rows))
        for part, style, marker in (("total", "-", "o"), ("plastic", "--", "x")):
            ax.plot(index, probes.envelope(rows, "list", part) * PER_MPA, style, marker=marker, markersize=3,
                    color=f"C{k}", label=f"M = {magnitude_text(m, 'stress')}, {part}")
            drawn = True
        ax.set_xticks(index, [probes.direction_text(r, "list") for r in rows], rotation=60, fontsize=6,
                      ha="right")
    ax.set_xlabel("stress direction (ds11, ds22, ds33)", fontsize=8)
    ax.set_ylabel(r"$|\Delta\varepsilon|\;/\;M$ (1/MPa)", fontsize=8)
    rose.set_axis_off()  # listed directions are named on the axis
    return drawn


def draw_envelope(ax, side, probe_set, point):
    """One panel: the envelope of `probe_set` at `point` in ax; beside it (side) its directions and the legend."""
    entry = probe_set.points.get(point)
    ax.set_title(point_title(probe_set.test, point, entry or {}), fontsize=9)
    if entry is None or not probe_set.point_rows(point):
        why = (f"{probe_set.test} has no point {point}" if entry is None else
               f"{entry.get('status', 'no probes')}: {entry.get('reason', '')}")
        for a in (ax, side):
            a.axis("off")
        ax.text(0.5, 0.5, why, transform=ax.transAxes, ha="center", va="center", fontsize=8, wrap=True)
        return
    draw = draw_plane_envelope if probes.in_a_plane(probe_set.plane) else draw_listed_envelope
    if draw(ax, side, probe_set, point):
        side.legend(*ax.get_legend_handles_labels(), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12),
                    frameon=False)
    side.set_anchor("N")  # the rose at the top, the legend below it
    ax.grid(True, linewidth=0.4, alpha=0.5)


def envelopes_figure(sets, label):
    """The response envelopes of the stress-probe sets: a column per test, a row per point; beside each panel the
    stress directions and the legend."""
    def make(plt):
        rows = point_rows(sets)
        fig, axes = plt.subplots(len(rows), 2 * len(sets), figsize=(7.6 * len(sets), 5.0 * len(rows) + 0.4),
                                 squeeze=False, gridspec_kw={"width_ratios": [4.0, 1.6] * len(sets)})
        for i, point in enumerate(rows):
            for j, s in enumerate(sets):
                draw_envelope(axes[i, 2 * j], axes[i, 2 * j + 1], s, point)
        fig.suptitle(f"Stress probes: strain response per unit stress (solid total, dashed plastic)\n{label}",
                     fontsize=10)
        return fig
    return make


def draw_matrix(ax, c, title, limit):
    mpa = c * MPA
    image = ax.imshow(mpa, cmap="RdBu_r", vmin=-limit, vmax=limit)
    for i in range(6):
        for j in range(6):
            ax.text(j, i, f"{mpa[i, j]:.3g}", ha="center", va="center", fontsize=5.5,
                    color="white" if abs(mpa[i, j]) > 0.6 * limit else "black")
    ax.set_xticks(range(6), probes.VOIGT, fontsize=7)
    ax.set_yticks(range(6), probes.VOIGT, fontsize=7)
    ax.set_xlabel("strain", fontsize=7)
    ax.set_ylabel("stress", fontsize=7)
    ax.set_title(title, fontsize=8)
    return image


def stiffness_figure(probe_set, label):
    """A strain-probe set's stiffness matrices: a row per point, a heat map per matrix, one colour scale a row (its
    bar in the last, narrow column)."""
    def make(plt):
        rows = [(p, probes.stiffness_matrices(probe_set.stiffness_point(p))) for p in probe_set.points]
        cols = max([len(m) for _, m in rows] + [1])
        fig = plt.figure(figsize=(3.5 * cols + 0.9, 3.6 * len(rows) + 0.5))
        grid = fig.add_gridspec(len(rows), cols + 1, width_ratios=[1.0] * cols + [0.06])
        for i, (point, matrices) in enumerate(rows):
            entry = probe_set.points[point]
            title = point_title(probe_set.test, point, entry)
            if not matrices:
                ax = fig.add_subplot(grid[i, :cols])
                ax.axis("off")
                why = f": {entry['reason']}" if entry.get("reason") else ""
                ax.text(0.5, 0.5, f"{title}: {entry.get('status', 'no stiffness')}{why}", ha="center", va="center",
                        fontsize=8, wrap=True, transform=ax.transAxes)
                continue
            limit = max(np.max(np.abs(c)) * MPA for _, c, _ in matrices)
            for j, (name, c, asym) in enumerate(matrices):
                asym_text = "n/a" if asym is None else f"{asym:.3f}"
                image = draw_matrix(fig.add_subplot(grid[i, j]), c, f"{title}\n{name} (MPa), asymmetry {asym_text}",
                                    limit)
            fig.colorbar(image, cax=fig.add_subplot(grid[i, cols]), label="MPa")
        fig.suptitle(f"Strain probes: stiffness of {probe_set.test} (Voigt order 11, 22, 33, 12, 13, 23; engineering "
                     f"shear strains; compression +)\n{label}", fontsize=9)
        return fig
    return make


def plans(run, label, plan_type):
    """The probes' figures of `run` (a results.RunArrays) as plan_type(stem, caption, section, make) entries."""
    sets = probes.load_all(run)
    out = []
    stress = [s for s in sets if s.kind == "stress" and any(s.point_rows(p) for p in s.points)]
    if stress:
        tests = ", ".join(s.test for s in stress)
        out.append(plan_type(ENVELOPES, f"stress probes' response envelopes of {tests}: strain response per unit "
                             "stress, total (solid) and plastic (dashed), per point", "probes",
                             envelopes_figure(stress, label)))
    for s in sets:
        if s.kind == "strain" and any(probes.stiffness_matrices(s.stiffness_point(p)) for p in s.points):
            out.append(plan_type(stiffness_stem(s.test), f"strain probes' stiffness of {s.test} (MPa) per point",
                                 "probes", stiffness_figure(s, label)))
    return out
