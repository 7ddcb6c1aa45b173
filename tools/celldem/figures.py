"""The paper's figures (Figures 2-12) of a celldem run, every test overlaid on the same axes, two diagnostic
figures and an overview (tools/figures.py, tools/report.py)."""

import os

import numpy as np

from . import plotting
from .plotting import thin
from .results import column

PERCENT = 100.0
KPA = 1e-3

# The paper plots the strain components for the first 5 % of ε1 only, and Figure 12 up to ε1 = 1 %.
FIG03_E1_MAX = 0.05
FIG12_E1_MAX = 0.01


def unit(run, column, scale=1.0, default="-"):
    """'(kPa)', '(%)', '(–)': the column's unit from the run's series.columns.json (`default` for older runs),
    as the plot scales it."""
    return plotting.unit_text(run.unit(column) or default, scale)


def e1_label(run):
    return r"axial strain $\varepsilon_1$ " + unit(run, "e1", PERCENT)


def test_color(run, name):
    return f"C{run.test_names.index(name) % 10}"


def plot_vs_e1(ax, run, name, scale=1.0, e1_max=None, linestyle="-", label_suffix="", label_tests=True):
    """Plots column `name` of every test against ε1 (%); returns how many tests had the column."""
    plotted = 0
    for test in run.test_names:
        series = run.test(test)
        e1, y = column(series, "e1"), column(series, name)
        if e1 is None or y is None:
            continue
        keep = np.ones_like(e1, dtype=bool) if e1_max is None else e1 <= e1_max * (1 + 1e-9)
        label = f"{test}{label_suffix}" if label_tests else None
        x_plot, y_plot = thin(e1[keep] * PERCENT, y[keep] * scale)
        ax.plot(x_plot, y_plot, linestyle=linestyle, color=test_color(run, test), label=label, linewidth=1.2)
        plotted += 1
    return plotted


def finish(ax, plotted, xlabel, ylabel, title):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, linewidth=0.4, alpha=0.5)
    if plotted:
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no data in this run", transform=ax.transAxes, ha="center", va="center")


def draw_stress_ratio(ax, run):
    n = plot_vs_e1(ax, run, "ratio13")
    finish(ax, n, e1_label(run), r"stress ratio $\sigma_1/\sigma_3$ " + unit(run, "ratio13"), "Fig. 2  Stress–strain")


def draw_strains(ax, run):
    n = 0
    for comp, style in (("e1", "-"), ("e2", "--"), ("e3", ":")):
        n += plot_vs_e1(ax, run, comp, PERCENT, FIG03_E1_MAX, style, rf" $\varepsilon_{comp[1]}$")
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    finish(ax, n, e1_label(run), r"strain $\varepsilon_1, \varepsilon_2, \varepsilon_3$ " + unit(run, "e2", PERCENT),
           r"Fig. 3  Strains (first 5 % of $\varepsilon_1$)")


def draw_volumetric(ax, run):
    n = plot_vs_e1(ax, run, "ev", PERCENT)
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    finish(ax, n, e1_label(run), r"volumetric strain $\varepsilon_v$ " + unit(run, "ev", PERCENT)[:-1]
           + ", compression +)", "Fig. 4  Volumetric strain")


def draw_dilatancy(ax, run):
    n = plot_vs_e1(ax, run, "DI")
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    finish(ax, n, e1_label(run), r"dilatancy index $DI = -d\varepsilon_v/d\varepsilon_1$ " + unit(run, "DI"),
           "Fig. 5  Dilatancy index")


def draw_b(ax, run):
    n = plot_vs_e1(ax, run, "b")
    # b is 0/0 while σ1 ≈ σ3 at the start; its spikes there would hide the curve, which lies in [0, 1].
    low, high = ax.get_ylim()
    ax.set_ylim(max(low, -0.2), min(high, 1.05))
    finish(ax, n, e1_label(run), r"$b = (\sigma_2-\sigma_3)/(\sigma_1-\sigma_3)$ " + unit(run, "b"), "Fig. 6  b value")


def draw_coordination(ax, run):
    n = plot_vs_e1(ax, run, "Z", label_suffix=" Z")
    n += plot_vs_e1(ax, run, "Zm", linestyle="--", label_suffix=r" $Z_m$")
    finish(ax, n, e1_label(run), "coordination number " + unit(run, "Z"),
           r"Fig. 7  Coordination number (Z, $Z_m$ dashed)")


def draw_sliding(ax, run):
    n = plot_vs_e1(ax, run, "sliding_fraction", PERCENT)
    finish(ax, n, e1_label(run), "sliding contacts (% of contacts)", "Fig. 8  Sliding contact fraction")


def draw_fabric(column, symbol, title):
    def draw(ax, run):
        n = plot_vs_e1(ax, run, column)
        ax.axhline(1.0, color="0.6", linewidth=0.6)
        finish(ax, n, e1_label(run), f"fabric ratio {symbol} " + unit(run, column), title)
    return draw


def draw_macro_micro(ax, run):
    n = 0
    for test in run.test_names:
        series = run.test(test)
        e1, hs, r = (column(series, c) for c in ("e1", "Hs11_Hs33", "ratio13"))
        if e1 is None or hs is None or r is None:
            continue
        keep = e1 <= FIG12_E1_MAX * (1 + 1e-9)
        ax.plot(*thin(hs[keep], r[keep]), "-o", markersize=2.0, linewidth=0.8, color=test_color(run, test), label=test)
        n += 1
    finish(ax, n, r"strong-contact fabric ratio $H^s_{11}/H^s_{33}$ " + unit(run, "Hs11_Hs33"),
           r"stress ratio $\sigma_1/\sigma_3$ " + unit(run, "ratio13"),
           r"Fig. 12  Macro–micro ($\varepsilon_1 \leq$ 1 %)")


def draw_stresses(ax, run):
    n = 0
    for comp, style in (("s11", "-"), ("s22", "--"), ("s33", ":")):
        n += plot_vs_e1(ax, run, comp, KPA, None, style, rf" $\sigma_{{{comp[1:]}}}$")
    finish(ax, n, e1_label(run), "normal stress " + unit(run, "s11", KPA, "Pa")[:-1] + ", compression +)",
           "Extra  Stress components")


def draw_balance(ax, run):
    n = plot_vs_e1(ax, run, "unbalanced_force")
    values = [run.column(t, "unbalanced_force") for t in run.test_names]
    if any(v is not None and np.any(v > 0) for v in values):
        ax.set_yscale("log")  # it spans decades between shear start and steady flow
    finish(ax, n, e1_label(run), "unbalanced force ratio " + unit(run, "unbalanced_force"), "Extra  Quasi-static check")


# (file stem, caption, drawing function); the order is the overview's panel order.
FIGURES = (
    ("fig02_stress_ratio", "Figure 2: stress ratio σ1/σ3 vs ε1", draw_stress_ratio),
    ("fig03_strains", "Figure 3: strains ε1, ε2, ε3 vs ε1 (first 5 % of ε1)", draw_strains),
    ("fig04_volumetric_strain", "Figure 4: volumetric strain εv vs ε1", draw_volumetric),
    ("fig05_dilatancy_index", "Figure 5: dilatancy index DI vs ε1", draw_dilatancy),
    ("fig06_b_value", "Figure 6: b value vs ε1", draw_b),
    ("fig07_coordination", "Figure 7: coordination number Z (solid) and Zm (dashed) vs ε1", draw_coordination),
    ("fig08_sliding_fraction", "Figure 8: sliding contact fraction vs ε1", draw_sliding),
    ("fig09_fabric_all", "Figure 9: fabric ratio H11/H33 (all contacts) vs ε1",
     draw_fabric("H11_H33", r"$H_{11}/H_{33}$", "Fig. 9  Fabric ratio, all contacts")),
    ("fig10_fabric_strong", "Figure 10: fabric ratio Hs11/Hs33 (strong contacts) vs ε1",
     draw_fabric("Hs11_Hs33", r"$H^s_{11}/H^s_{33}$", "Fig. 10  Fabric ratio, strong contacts")),
    ("fig11_fabric_weak", "Figure 11: fabric ratio Hw11/Hw33 (weak contacts) vs ε1",
     draw_fabric("Hw11_Hw33", r"$H^w_{11}/H^w_{33}$", "Fig. 11  Fabric ratio, weak contacts")),
    ("fig12_macro_micro", "Figure 12: σ1/σ3 vs Hs11/Hs33 for ε1 ≤ 1 %", draw_macro_micro),
    ("extra_stresses", "Not in the paper: stress components σ11, σ22, σ33 vs ε1 (checks the stress control)",
     draw_stresses),
    ("extra_balance", "Not in the paper: unbalanced force ratio vs ε1 (checks the loading is quasi-static)",
     draw_balance),
)
OVERVIEW = "overview"


def figure_paths(fig_dir):
    stems = [stem for stem, _, _ in FIGURES] + [OVERVIEW]
    return [os.path.join(fig_dir, stem + ".png") for stem in stems]


def write_figures(run, fig_dir):
    """Writes every figure of `run` into fig_dir; returns the paths written."""
    plt = plotting.pyplot()
    os.makedirs(fig_dir, exist_ok=True)
    written = []
    for stem, _, draw in FIGURES:
        fig, ax = plt.subplots(figsize=(6.4, 4.6))
        draw(ax, run)
        written.append(plotting.save(fig, os.path.join(fig_dir, stem + ".png"), dpi=130))

    cols = 4
    rows = -(-len(FIGURES) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.0 * cols, 3.9 * rows))
    for ax, (_, _, draw) in zip(axes.flat, FIGURES):
        draw(ax, run)
    for ax in list(axes.flat)[len(FIGURES):]:
        ax.axis("off")
    fig.suptitle(f"celldem run {os.path.basename(os.path.abspath(run.directory))}: tests "
                 + ", ".join(run.test_names), fontsize=12)
    written.append(plotting.save(fig, os.path.join(fig_dir, OVERVIEW + ".png"), dpi=90, rect=(0, 0, 1, 0.98)))
    return written


def missing(fig_dir):
    """Whether any figure is missing from fig_dir."""
    return not all(os.path.isfile(p) for p in figure_paths(fig_dir))
