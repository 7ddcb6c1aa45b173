"""The figures of a celldem run or seed ensemble (tools/figures.py, tools/report.py):
  - one figure per test, whatever its name, with a panel for each quantity its series holds (test_<name>.png);
  - the preparation against steps (prepare.png): p, void ratio, Z, unbalanced force, kinetic energy;
  - the paper's Figures 2-12 and two diagnostic figures, every test overlaid (for the paper's deck, or any run
    with two tests or more), and an overview of them;
  - the strong force chains at each test's peak (force_chains.png, tools/celldem/reports/force_chains.py);
  - the tests' incremental response probes: the stress probes' response envelopes and the strain probes'
    stiffness (probe_envelopes.png, probe_stiffness_<test>.png; tools/celldem/reports/probe_figures.py).
A figure or panel whose quantity the run does not hold is not drawn. For an ensemble every curve is the mean
over the seeds in bins of its x with a band of ± 1 standard deviation (metrics.seed_band).
"""

import collections
import os

import numpy as np

from . import force_chains, plotting, probe_figures
from .. import metrics
from .plotting import thin

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


BAND_TEXT = "mean over the seeds in bins of the x axis, band ± 1 standard deviation"


def test_color(run, name):
    return f"C{run.test_names.index(name) % 10}"


def with_data(curves, x_max=None):
    """The curves that hold finite values (up to x_max), cut at x_max."""
    out = []
    for x, y in curves:
        keep = np.isfinite(x) & np.isfinite(y)
        if x_max is not None:
            keep &= x <= x_max * (1 + 1e-9)
        if np.any(keep):
            out.append((x[keep], y[keep]))
    return out


def draw_curves(ax, curves, color, label=None, linestyle="-", x_scale=1.0, y_scale=1.0):
    """One run: its curve. Several (the seeds of an ensemble): the mean curve and a band of ± 1 std."""
    if len(curves) == 1:
        x, y = thin(curves[0][0] * x_scale, curves[0][1] * y_scale)
        ax.plot(x, y, linestyle=linestyle, color=color, label=label, linewidth=1.2)
        return
    x, mean, std, _ = metrics.seed_band(curves)
    ax.fill_between(x * x_scale, (mean - std) * y_scale, (mean + std) * y_scale, color=color, alpha=0.2, lw=0)
    ax.plot(x * x_scale, mean * y_scale, linestyle=linestyle, color=color, label=label, linewidth=1.2)


def plot_vs_e1(ax, run, name, scale=1.0, e1_max=None, linestyle="-", label_suffix="", label_tests=True):
    """Plots column `name` of every test against ε1 (%); returns how many tests had data for it."""
    plotted = 0
    for test in run.test_names:
        curves = with_data(run.curves(test, name), e1_max)
        if not curves:
            continue
        label = f"{test}{label_suffix}" if label_tests else None
        draw_curves(ax, curves, test_color(run, test), label, linestyle, PERCENT, scale)
        plotted += 1
    return plotted


def has_data(run, tests, names, x="e1"):
    """Whether any of `tests` holds finite values of any column in `names`."""
    return any(with_data(run.curves(t, n, x)) for t in tests for n in names)


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
        hs = with_data(run.curves(test, "Hs11_Hs33"), FIG12_E1_MAX)
        ratio = with_data(run.curves(test, "ratio13"), FIG12_E1_MAX)
        if not hs or not ratio:
            continue
        color = test_color(run, test)
        if len(hs) == 1:
            x, y = hs[0][1], metrics.on_grid(hs[0][0], *ratio[0])
            ax.plot(*thin(x, y), "-o", markersize=2.0, linewidth=0.8, color=color, label=test)
        else:  # seed means of both in bins of ε1; the band is the spread of σ1/σ3
            edges = metrics.bin_edges(hs)
            hs_t, r_t = metrics.seed_table(hs, edges), metrics.seed_table(ratio, edges)
            keep = np.sum(np.isfinite(hs_t) & np.isfinite(r_t), axis=0) >= 2
            x, y = np.nanmean(hs_t[:, keep], axis=0), np.nanmean(r_t[:, keep], axis=0)
            std = np.nanstd(r_t[:, keep], axis=0, ddof=1)
            ax.fill_between(x, y - std, y + std, color=color, alpha=0.2, lw=0)
            ax.plot(x, y, "-o", markersize=2.0, linewidth=0.8, color=color, label=test)
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
    if n:
        ax.set_yscale("log")  # it spans decades between shear start and steady flow
    finish(ax, n, e1_label(run), "unbalanced force ratio " + unit(run, "unbalanced_force"), "Extra  Quasi-static check")


def draw_energy(ax, run):
    """The energy budget's partition stacked against ε1, per test (its first seed): the change of stored and
    kinetic energy, friction's and damping's dissipation, filled one on the other, with the boundary work as
    a line above them (the gap between the stack's top and the line is the closure error; docs/energy.md)."""
    plotted = 0
    layers = (("stored", "/"), ("kinetic", "."), ("friction", None), ("damping", "x"))
    for test in run.test_names:
        work = with_data(run.curves(test, "energy_boundary_work"))
        if not work:
            continue
        x = run.curves(test, "energy_boundary_work")[0][0]

        def col(name):
            curves = run.curves(test, name)
            return np.nan_to_num(curves[0][1]) if curves else np.zeros_like(x)

        parts = {
            "stored": sum(col(c) for c in ("energy_normal", "energy_tangential", "energy_rotational_springs")),
            "kinetic": col("energy_kinetic_translation") + col("energy_kinetic_rotation"),
            "friction": col("energy_friction") + col("energy_rotational_friction"),
            "damping": col("energy_body_damping") + col("energy_contact_damping"),
        }
        parts["stored"] = parts["stored"] - parts["stored"][0]
        parts["kinetic"] = parts["kinetic"] - parts["kinetic"][0]
        color = test_color(run, test)
        base = np.zeros_like(x)
        for name, hatch in layers:
            top = base + parts[name]
            ax.fill_between(x * PERCENT, base, top, color=color, alpha=0.15 if hatch else 0.35, hatch=hatch, lw=0,
                            label=f"{test}: {name}")
            base = top
        ax.plot(x * PERCENT, col("energy_boundary_work"), color=color, linewidth=1.2, label=f"{test}: boundary work")
        plotted += 1
    finish(ax, plotted, e1_label(run), "energy since the test started (J)", "Extra  Energy budget")


# The overlaid figures: (file stem, paper figure number or None, caption, columns it needs, drawing function);
# the order is the overview's panel order. The drawing functions title their axes as the paper numbers them.
FIGURES = (
    ("fig02_stress_ratio", 2, "stress ratio σ1/σ3 vs ε1", ("ratio13",), draw_stress_ratio),
    ("fig03_strains", 3, "strains ε1, ε2, ε3 vs ε1 (first 5 % of ε1)", ("e2", "e3"), draw_strains),
    ("fig04_volumetric_strain", 4, "volumetric strain εv vs ε1", ("ev",), draw_volumetric),
    ("fig05_dilatancy_index", 5, "dilatancy index DI vs ε1", ("DI",), draw_dilatancy),
    ("fig06_b_value", 6, "b value vs ε1", ("b",), draw_b),
    ("fig07_coordination", 7, "coordination number Z (solid) and Zm (dashed) vs ε1", ("Z", "Zm"),
     draw_coordination),
    ("fig08_sliding_fraction", 8, "sliding contact fraction vs ε1", ("sliding_fraction",), draw_sliding),
    ("fig09_fabric_all", 9, "fabric ratio H11/H33 (all contacts) vs ε1", ("H11_H33",),
     draw_fabric("H11_H33", r"$H_{11}/H_{33}$", "Fig. 9  Fabric ratio, all contacts")),
    ("fig10_fabric_strong", 10, "fabric ratio Hs11/Hs33 (strong contacts) vs ε1", ("Hs11_Hs33",),
     draw_fabric("Hs11_Hs33", r"$H^s_{11}/H^s_{33}$", "Fig. 10  Fabric ratio, strong contacts")),
    ("fig11_fabric_weak", 11, "fabric ratio Hw11/Hw33 (weak contacts) vs ε1", ("Hw11_Hw33",),
     draw_fabric("Hw11_Hw33", r"$H^w_{11}/H^w_{33}$", "Fig. 11  Fabric ratio, weak contacts")),
    ("fig12_macro_micro", 12, "σ1/σ3 vs Hs11/Hs33 for ε1 ≤ 1 %", ("Hs11_Hs33",), draw_macro_micro),
    ("extra_stresses", None, "stress components σ11, σ22, σ33 vs ε1 (checks the stress control)",
     ("s11", "s22", "s33"), draw_stresses),
    ("extra_balance", None, "unbalanced force ratio vs ε1 (checks the loading is quasi-static)",
     ("unbalanced_force",), draw_balance),
    ("extra_energy", None, "energy budget vs ε1: stored, kinetic, friction and damping stacked under the boundary "
     "work (the deck's energy_budget)", ("energy_boundary_work",), draw_energy),
)
OVERVIEW = "overview"
FORCE_CHAINS = "force_chains"
PREPARE = "prepare"

# A panel of a per-test or preparation figure: its y label, its curves (column, scale, line style, legend
# label), log scale, y limits. Drawn only when the series holds one of its columns.
Panel = collections.namedtuple("Panel", "ylabel curves log ylim", defaults=(False, None))

TEST_PANELS = (
    Panel(r"stress ratio $\sigma_{11}/\sigma_{33}$ (–)", (("ratio13", 1.0, "-", None),)),
    Panel("p, q (kPa)", (("p", KPA, "-", "p"), ("q", KPA, "--", "q"))),
    Panel(r"volumetric strain $\varepsilon_v$ (%, compression +)", (("ev", PERCENT, "-", None),)),
    Panel("b (–)", (("b", 1.0, "-", "b (axis stresses)"), ("b_principal", 1.0, "--", "b (principal)")),
          ylim=(-0.2, 1.05)),
    Panel("coordination number (–)", (("Z", 1.0, "-", "Z"), ("Zm", 1.0, "--", r"$Z_m$"))),
    Panel("sliding contacts (% of contacts)", (("sliding_fraction", PERCENT, "-", None),)),
    Panel("fabric ratio (–)", (("H11_H33", 1.0, "-", r"$H_{11}/H_{33}$"), ("Hs11_Hs33", 1.0, "--", "strong"),
                               ("Hw11_Hw33", 1.0, ":", "weak"))),
    Panel(r"dilatancy index $-d\varepsilon_v/d\varepsilon_1$ (–)", (("DI", 1.0, "-", None),)),
    # The rate it ran at (an adaptive leg's varies: tests[].adaptive_rate) and the quasi-static indicators.
    Panel("loading rate and quasi-static indicators (–)",
          (("inertial_number", 1.0, "-", "inertial number"), ("unbalanced_force", 1.0, "--", "unbalanced force ratio"),
           ("kinetic_to_elastic", 1.0, ":", "kinetic / elastic energy")), log=True),
)

PREPARE_PANELS = (
    Panel("mean stress p (kPa)", (("p", KPA, "-", None),)),
    Panel("void ratio e (–)", (("void_ratio", 1.0, "-", None),)),
    Panel("coordination number (–)", (("Z", 1.0, "-", "Z"), ("Zm", 1.0, "--", r"$Z_m$"))),
    Panel("unbalanced force ratio (–)", (("unbalanced_force", 1.0, "-", None),), log=True),
    Panel("kinetic energy (J)", (("kinetic_energy", 1.0, "-", None),), log=True),
)


def x_axis(run, stage):
    """(column, scale, label) of a stage's x axis: ε1 (%) for a test whose e1 moves, else the step."""
    if stage != PREPARE:
        spans = [np.ptp(x) for x, _ in with_data(run.curves(stage, "e1"))]
        if spans and max(spans) > 1e-6:
            return "e1", PERCENT, e1_label(run)
    return "step", 1.0, "step"


def panels_with_data(run, stage, panels):
    x = x_axis(run, stage)[0]
    return [p for p in panels if has_data(run, [stage], [c[0] for c in p.curves], x)]


def draw_panels(plt, run, stage, panels, title):
    """A figure with one panel per entry of `panels` that the stage's series holds."""
    x_name, x_scale, x_label = x_axis(run, stage)
    rows = -(-len(panels) // 4)
    cols = -(-len(panels) // rows)  # 5 panels: 2 rows of 3, 8: 2 of 4
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 3.2 * rows), squeeze=False)
    for ax, panel in zip(axes.flat, panels):
        labelled = False
        for k, (name, scale, style, label) in enumerate(panel.curves):
            curves = with_data(run.curves(stage, name, x_name))
            if curves:
                draw_curves(ax, curves, f"C{k}", label, style, x_scale, scale)
                labelled |= label is not None
        if panel.log:
            ax.set_yscale("log")
        if panel.ylim:
            low, high = ax.get_ylim()
            ax.set_ylim(max(low, panel.ylim[0]), min(high, panel.ylim[1]))
        ax.set_xlabel(x_label)
        if x_name == "step":
            ax.ticklabel_format(axis="x", style="sci", scilimits=(0, 3))
        ax.set_ylabel(panel.ylabel, fontsize=9)
        ax.grid(True, linewidth=0.4, alpha=0.5)
        if labelled:
            ax.legend(fontsize=8)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.suptitle(title, fontsize=11)
    return fig


def is_ensemble(run):
    return len(run.runs) > 1


def run_label(run):
    name = os.path.basename(os.path.abspath(run.directory))
    if is_ensemble(run):
        return f"{name} ({len(run.runs)} seeds; {BAND_TEXT})"
    return name


# One figure to write: file stem, caption, report section ("tests", "compare", "prepare", "force_chains",
# "probes", "overview"), and a function of pyplot that returns the figure.
Plan = collections.namedtuple("Plan", "stem caption section make")


def overlay_figure(run, draw, title_number, paper):
    def make(plt):
        fig, ax = plt.subplots(figsize=(6.4, 4.6))
        draw(ax, run)
        if not paper:  # "Fig. 2  Stress–strain" -> "Stress–strain": the paper's numbers only for the paper's deck
            ax.set_title(ax.get_title().split("  ", 1)[-1], fontsize=10)
        if is_ensemble(run):
            ax.text(0.01, 0.01, f"{len(run.runs)} seeds: {BAND_TEXT}", transform=ax.transAxes, fontsize=6,
                    color="0.4")
        return fig
    return make


def overview_figure(run, chosen, paper):
    def make(plt):
        cols = 4
        rows = -(-len(chosen) // cols)
        fig, axes = plt.subplots(rows, cols, figsize=(5.0 * cols, 3.9 * rows), squeeze=False)
        for ax, (_, number, _, _, draw) in zip(axes.flat, chosen):
            draw(ax, run)
            if not paper:
                ax.set_title(ax.get_title().split("  ", 1)[-1], fontsize=10)
        for ax in list(axes.flat)[len(chosen):]:
            ax.axis("off")
        fig.suptitle(f"celldem {run_label(run)}: tests " + ", ".join(run.test_names), fontsize=12)
        return fig
    return make


def plan(run, paper=False):
    """What to draw for this run: every figure it holds data for, in the report's order."""
    out = []
    for test in run.test_names:
        panels = panels_with_data(run, test, TEST_PANELS)
        if panels:
            out.append(Plan(f"test_{test}", f"test {test}: every quantity its series holds", "tests",
                            lambda plt, t=test, p=panels: draw_panels(plt, run, t, p, f"test {t}: {run_label(run)}")))
    if paper or len(run.test_names) > 1:
        chosen = [f for f in FIGURES if has_data(run, run.test_names, f[3])]
        for stem, number, caption, _, draw in chosen:
            caption = f"Figure {number}: {caption}" if paper and number else caption
            out.append(Plan(stem, caption, "compare", overlay_figure(run, draw, number, paper)))
        if chosen:
            out.append(Plan(OVERVIEW, "all the panels above", "overview", overview_figure(run, chosen, paper)))
    chains = force_chains.tests_with_contacts(run.runs[0])
    if chains:
        seed = f" (seed {run.seeds[0]})" if is_ensemble(run) else ""
        out.append(Plan(FORCE_CHAINS, f"strong force chains at the peak of {', '.join(chains)}{seed}",
                        "force_chains", lambda plt: force_chains.draw(plt, run.runs[0], chains, seed)))
    # An ensemble's probes: the first seed's, as its force chains.
    probes_label = f"seed {run.seeds[0]}" if is_ensemble(run) else run_label(run)
    out += probe_figures.plans(run.runs[0], probes_label, Plan)
    panels = panels_with_data(run, PREPARE, PREPARE_PANELS)
    if panels:
        out.append(Plan(PREPARE, "the preparation against steps: p, void ratio, Z, unbalanced force, kinetic energy",
                        "prepare", lambda plt: draw_panels(plt, run, PREPARE, panels,
                                                           f"preparation: {run_label(run)}")))
    return out


def figure_paths(fig_dir, planned):
    return [os.path.join(fig_dir, p.stem + ".png") for p in planned]


def write_figures(run, fig_dir, paper=False):
    """Writes every figure of `run` (a Run or an Ensemble) into fig_dir; returns the paths written."""
    plt = plotting.pyplot()
    os.makedirs(fig_dir, exist_ok=True)
    written = []
    for p in plan(run, paper):
        fig = p.make(plt)
        dpi = {"overview": 90, "compare": 130}.get(p.section, 110)
        layout = {} if p.section == "compare" else {"rect": (0, 0, 1, 0.96)}  # room for the suptitle
        written.append(plotting.save(fig, os.path.join(fig_dir, p.stem + ".png"), dpi=dpi, **layout))
    return written


def missing(fig_dir, planned):
    """Whether any planned figure is missing from fig_dir."""
    return not all(os.path.isfile(p) for p in figure_paths(fig_dir, planned))


def stale(fig_dir, planned, run_dir):
    """Whether any planned figure is missing, or older than a file of the run it is drawn from (a test that
    went on, an ensemble that gained seeds): every file under run_dir but figures and reports (an ensemble's
    members have their own)."""
    if missing(fig_dir, planned):
        return True
    oldest_figure = min(os.path.getmtime(p) for p in figure_paths(fig_dir, planned))
    for root, dirs, files in os.walk(run_dir):
        dirs[:] = [d for d in dirs if d != "figures"]
        for name in files:
            if name != "report.md" and os.path.getmtime(os.path.join(root, name)) > oldest_figure:
                return True
    return False
