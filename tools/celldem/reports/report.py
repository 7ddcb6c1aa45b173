"""RUN_DIR/report.md (tools/report.py): the run's own tests first (values and figures, whatever they are named),
its preparation, the force chains at the peaks, the failure surface of a constant-b deck, the paper's findings
beside the run's for the paper's deck (scenes.is_paper, or --paper), its settings and timings, and the
speed–accuracy study when one lies beside it. An ensemble folder gets ensemble_report.py's report instead.

The peak of s11/s33, ε1 and b there, the final and end-window values come from summary.json (celldem computes
them); maxima, start values, interpolated values and the comparisons of curves are measured on series.csv.
"""

import json
import math
import os

import numpy as np

from . import failure_surface
from .. import metrics, probes, scenes
from ..results import number, read_json
from .tables import fmt, fmt_spec, md_table, scaled, yes_no

PERCENT = 100.0

# What the paper reports (sections 4, 6.2, 7, 8).
PAPER_VOID_RATIO = 0.57
PAPER_Z = 5.94
PAPER_B_AT_PEAK = 0.396
PAPER_B_AT_10 = 0.314

# Thresholds for calling the run's result a qualitative match.
PREPARED_REL_TOL = 0.05     # prepared e and Z within 5 % of the paper: a comparably dense packing
B_ABS_TOL = 0.10            # b within 0.1 of the paper: the same intermediate-principal-stress regime
ALIKE_THRESHOLD = 0.10      # two curves "alike" when RMS difference / their range < 10 %
UNIQUE_THRESHOLD = 0.10     # σ1/σ3(Hs11/Hs33) "one curve" when RMS relative difference < 10 %
ZERO_B_TOL = 0.02           # TTC b "stays 0" when max |b| < 0.02
ZERO_STRAIN_TOL = 1e-4      # PSC ε2 "stays 0" when max |ε2| < 0.01 %
TRACKS_MIN_R = 0.8          # one curve "tracks" another when their Pearson correlation over the test ≥ 0.8
CURVE_BINS = 100            # ε1 bins for comparing curves of two tests
MACRO_MICRO_BINS = 20       # Hs11/Hs33 bins for comparing the macro-micro relations
B_STRAIN = 0.10             # the paper's second b value is at ε1 = 10 %
MACRO_MICRO_E1_MAX = 0.01   # the paper's Figure 12 stops at ε1 = 1 %
B_DEFINED_MIN_E1 = 0.001    # b = (σ2-σ3)/(σ1-σ3) is 0/0-noisy until σ1 has moved away from σ3


def answer(flag, detail):
    """The run's yes/no with the numbers behind it; just 'n/a' when the run cannot say."""
    return "n/a" if flag is None else f"{'yes' if flag else 'no'} ({detail})"


def verdict(run_answer, paper_answer):
    """'yes' when the run says what the paper says, 'n/a' when the run cannot say."""
    return "n/a" if run_answer is None else ("yes" if run_answer == paper_answer else "no")


def within(value, target, tol):
    return None if value is None or not math.isfinite(value) else abs(value - target) <= tol


NEEDS_BOTH = ("n/a", "n/a", "needs tests named ttc and psc")


def both_tests(run):
    return run.test("ttc") is not None and run.test("psc") is not None


# --- the first table: the paper's findings beside the run's ------------------------------------------------

def prepared_rows(run):
    prepared = run.summary.get("prepared")
    source = "summary.json prepared"
    if isinstance(prepared, dict):
        e, z = prepared.get("void_ratio"), prepared.get("Z")
    else:
        # A deck that starts from a saved state has no preparation stage; its first output row is the start.
        e = z = None
        source = "n/a (no prepared stage)"
        for test in run.test_names:
            e0, z0 = run.column(test, "void_ratio"), run.column(test, "Z")
            if e0 is not None and z0 is not None and e0.size:
                e, z, source = float(e0[0]), float(z0[0]), f"first row of {test}/series.csv"
                break
    return [
        ("Prepared void ratio e", fmt(PAPER_VOID_RATIO), fmt(e),
         yes_no(within(e, PAPER_VOID_RATIO, PREPARED_REL_TOL * PAPER_VOID_RATIO)),
         f"{source}; match: within {PREPARED_REL_TOL:.0%} of the paper"),
        ("Prepared coordination number Z", fmt(PAPER_Z, 2), fmt(z, 2),
         yes_no(within(z, PAPER_Z, PREPARED_REL_TOL * PAPER_Z)),
         f"{source}; match: within {PREPARED_REL_TOL:.0%} of the paper"),
    ]


def b_rows(run):
    if run.test("psc") is None:
        na = ("n/a", "no test named psc")
        return [("PSC b at peak σ1/σ3", fmt(PAPER_B_AT_PEAK), "n/a", *na),
                ("PSC b at ε1 = 10 %", fmt(PAPER_B_AT_10), "n/a", *na),
                ("PSC b falls after the peak", "yes", "n/a", *na)]
    e1 = run.column("psc", "e1")
    b_peak = run.quantity("psc", "b_at_peak")
    b_10 = psc_b_at_10(run)
    falls = None if b_peak is None or b_10 is None else b_10 < b_peak
    end = "n/a" if e1 is None or not e1.size else f"{np.nanmax(e1) * PERCENT:.2f} %"
    return [
        ("PSC b at peak σ1/σ3", fmt(PAPER_B_AT_PEAK), fmt(b_peak), yes_no(within(b_peak, PAPER_B_AT_PEAK, B_ABS_TOL)),
         f"summary.json b_at_peak (b on the row of max σ1/σ3); match: within {B_ABS_TOL} of the paper"),
        ("PSC b at ε1 = 10 %", fmt(PAPER_B_AT_10), fmt(b_10), yes_no(within(b_10, PAPER_B_AT_10, B_ABS_TOL)),
         f"b interpolated at ε1 = 10 % (run ends at ε1 = {end}); match: within {B_ABS_TOL} of the paper"),
        ("PSC b falls after the peak", "yes", answer(falls, f"{fmt(b_peak)} → {fmt(b_10)}"),
         verdict(falls, True), "b at ε1 = 10 % < b at peak"),
    ]


def peak_rows(run):
    if not both_tests(run):
        return [("PSC peak σ1/σ3 exceeds TTC's", "yes", *NEEDS_BOTH)]
    peak_ttc, peak_psc = run.quantity("ttc", "peak_ratio13"), run.quantity("psc", "peak_ratio13")
    exceeds = None if peak_ttc is None or peak_psc is None else peak_psc > peak_ttc
    return [("PSC peak σ1/σ3 exceeds TTC's", "yes",
             answer(exceeds, f"psc {fmt(peak_psc)}, ttc {fmt(peak_ttc)}"), verdict(exceeds, True),
             "summary.json peak_ratio13 (max σ1/σ3) of each test")]


def psc_b_at_10(run):
    """PSC's b interpolated at ε1 = 10 % (None when the test ends before)."""
    return metrics.value_at(run.column("psc", "e1"), run.column("psc", "b"), B_STRAIN)


def ttc_max_b(run):
    """max |b| of TTC once b is defined (ε1 ≥ 0.1 %)."""
    b, e1 = run.column("ttc", "b"), run.column("ttc", "e1")
    if b is None or e1 is None or not np.any(e1 >= B_DEFINED_MIN_E1):
        return None
    return metrics.max_of(np.abs(b[e1 >= B_DEFINED_MIN_E1]))


def psc_max_e2(run):
    e2 = run.column("psc", "e2")
    return metrics.max_of(np.abs(e2)) if e2 is not None else None


def fabric_peak_lag(run, test):
    """ε1 at max H11/H33 minus summary.json's ε1 at the peak of σ1/σ3 (None when either is missing)."""
    e1_ratio = run.quantity(test, "e1_at_peak")
    e1_fabric = metrics.x_at_max(run.column(test, "e1"), run.column(test, "H11_H33"))
    return None if e1_ratio is None or e1_fabric is None else e1_fabric - e1_ratio


def tracks_r(run, test, name):
    """Pearson correlation of column `name` with σ1/σ3 over ε1 ≥ 0.1 %."""
    e1, y, ratio = run.column(test, "e1"), run.column(test, name), run.column(test, "ratio13")
    if e1 is None or y is None or ratio is None:
        return None
    keep = e1 >= B_DEFINED_MIN_E1
    return metrics.pearson(y[keep], ratio[keep])


def control_rows(run):
    """The loading paths themselves: σ2 = σ3 in TTC (b = 0) and ε2 = 0 in PSC."""
    rows = []
    b_max = ttc_max_b(run)
    ok = None if b_max is None else b_max < ZERO_B_TOL
    rows.append(("TTC b stays 0", "yes", answer(ok, f"max |b| = {fmt(b_max)}"), verdict(ok, True),
                 f"max |b| for ε1 ≥ {B_DEFINED_MIN_E1 * PERCENT:g} % below {ZERO_B_TOL}"))
    e2_max = psc_max_e2(run)
    ok = None if e2_max is None else e2_max < ZERO_STRAIN_TOL
    rows.append(("PSC ε2 stays 0", "yes", answer(ok, f"max |ε2| = {fmt(e2_max)}"), verdict(ok, True),
                 f"max |ε2| below {ZERO_STRAIN_TOL * PERCENT:g} %"))
    return rows


def alike_row(run, label, name):
    if not both_tests(run):
        return (label, "yes", *NEEDS_BOTH)
    diff, used = metrics.curve_difference(run.column("ttc", "e1"), run.column("ttc", name),
                                          run.column("psc", "e1"), run.column("psc", name), bins=CURVE_BINS)
    alike = None if diff is None else diff < ALIKE_THRESHOLD
    return (label, "yes", answer(alike, f"{fmt(scaled(diff, PERCENT), 1)} %"),
            verdict(alike, True),
            f"RMS difference of the two curves / their range, means in {CURVE_BINS} ε1 bins over the common ε1 "
            f"range ({used} used); alike below {ALIKE_THRESHOLD:.0%}")


def fabric_row(run, label, name):
    if not both_tests(run):
        return (label, "yes", *NEEDS_BOTH)
    m_ttc, m_psc = metrics.max_of(run.column("ttc", name)), metrics.max_of(run.column("psc", name))
    more = None if m_ttc is None or m_psc is None else m_psc > m_ttc
    return (label, "yes", answer(more, f"max psc {fmt(m_psc)}, ttc {fmt(m_ttc)}"), verdict(more, True),
            "max over the test")


def macro_micro_relation(run, test):
    e1, hs, ratio = (run.column(test, c) for c in ("e1", "Hs11_Hs33", "ratio13"))
    if e1 is None or hs is None or ratio is None:
        return None, None
    keep = e1 <= MACRO_MICRO_E1_MAX * (1 + 1e-9)
    return hs[keep], ratio[keep]


def macro_micro_row(run):
    label = "σ1/σ3 vs Hs11/Hs33 (ε1 ≤ 1 %) is one curve for both tests"
    if not both_tests(run):
        return (label, "yes", *NEEDS_BOTH)
    hs_t, r_t = macro_micro_relation(run, "ttc")
    hs_p, r_p = macro_micro_relation(run, "psc")
    diff, used = metrics.curve_difference(hs_t, r_t, hs_p, r_p, bins=MACRO_MICRO_BINS, relative_to="value")
    unique = None if diff is None else diff < UNIQUE_THRESHOLD
    return (label, "yes", answer(unique, f"{fmt(scaled(diff, PERCENT), 1)} %"),
            verdict(unique, True),
            f"mean σ1/σ3 of each test in {MACRO_MICRO_BINS} Hs11/Hs33 bins over the range both cover ({used} "
            f"used); RMS of the difference / mean value; one curve below {UNIQUE_THRESHOLD:.0%}")


def peak_order_row(run):
    """Section 7.3: σ1/σ3 peaks at small strain, H11/H33 (all contacts) at large strain."""
    label = "H11/H33 peaks at a larger ε1 than σ1/σ3"
    parts, answers = [], []
    for test in run.test_names:
        lag = fabric_peak_lag(run, test)
        if lag is None:
            continue
        e1_ratio = run.quantity(test, "e1_at_peak")
        answers.append(lag > 0)
        parts.append(f"{test}: {(e1_ratio + lag) * PERCENT:.1f} % vs {e1_ratio * PERCENT:.1f} %")
    later = all(answers) if answers else None
    return (label, "yes", answer(later, "; ".join(parts)), verdict(later, True),
            "ε1 at max H11/H33 vs summary.json e1_at_peak (ε1 at max σ1/σ3), every test")


def tracks_row(run, label, name, tests):
    rs = [(test, tracks_r(run, test, name)) for test in tests]
    rs = [(test, r) for test, r in rs if r is not None]
    tracks = min(r for _, r in rs) >= TRACKS_MIN_R if rs else None
    detail = ", ".join(f"{t} r = {r:.2f}" for t, r in rs)
    return (label, "yes", answer(tracks, detail), verdict(tracks, True),
            f"Pearson correlation with σ1/σ3 over ε1 ≥ {B_DEFINED_MIN_E1 * PERCENT:g} %; tracks when r ≥ "
            f"{TRACKS_MIN_R}")


def paper_table(run):
    rows = prepared_rows(run) + b_rows(run) + peak_rows(run)
    rows += [alike_row(run, "Z evolves alike in TTC and PSC", "Z"),
             alike_row(run, "Sliding fraction evolves alike in TTC and PSC", "sliding_fraction"),
             fabric_row(run, "H11/H33 grows more in PSC", "H11_H33"),
             macro_micro_row(run)]
    # Further findings of the paper's sections 6-9.
    rows += control_rows(run)
    rows += [alike_row(run, "DI evolves alike in TTC and PSC", "DI"),
             fabric_row(run, "Hs11/Hs33 grows more in PSC", "Hs11_Hs33"),
             fabric_row(run, "Hw11/Hw33 grows more in PSC", "Hw11_Hw33"),
             peak_order_row(run),
             tracks_row(run, "Hs11/Hs33 tracks σ1/σ3 over ε1", "Hs11_Hs33", [t for t in ("ttc", "psc")
                                                                            if run.test(t) is not None]),
             tracks_row(run, "PSC b tracks σ1/σ3 over ε1", "b", ["psc"] if run.test("psc") is not None else [])]
    # A finding the run cannot judge (a test missing, a column missing) is named once, not a row of n/a.
    judged = [r for r in rows if not (r[2] == "n/a" and r[3] == "n/a")]
    skipped = [r[0] for r in rows if r not in judged]
    out = md_table(("Quantity", "Paper", "This run", "Matches qualitatively", "How computed"), judged)
    if skipped:
        out += ("\n\nNot judged (the run lacks the test or the series column they need): "
                + "; ".join(skipped) + ".")
    return out


# --- the other sections ------------------------------------------------------------------------------------

# Settings whose null means a rule, not a missing value.
NULL_SETTING_MEANS = {"servo_max_strain_increment": "per leg: 10 × its driving strain per step, at least 1e-06 "
                                                    "(each leg's servo_cap in summary.json)"}


def setting_text(value, key=None):
    if isinstance(value, float):
        return f"{value:g}"
    return NULL_SETTING_MEANS.get(key, "n/a") if value is None else str(value)


def settings_section(run):
    settings = run.summary.get("settings") or {}
    out = [f"celldem version: {run.summary.get('celldem_version', 'n/a')}; deck: `{run.summary.get('deck', 'n/a')}`",
           ""]
    if settings:
        out.append(md_table(("Setting", "Value"), [(k, setting_text(v, k)) for k, v in settings.items()]))
    else:
        out.append("No settings in summary.json.")
    return "\n".join(out)


def timing_section(run):
    rows = []
    total = 0.0
    stages = []
    if isinstance(run.summary.get("prepared"), dict):
        stages.append(("prepare", run.summary["prepared"]))
    stages += [(name, info) for name, info in (run.summary.get("tests") or {}).items() if isinstance(info, dict)]
    for name, info in stages:
        wall = info.get("wall_s")
        if isinstance(wall, (int, float)):
            total += wall
        rows.append((name, fmt(info.get("steps")), fmt(wall, 1), fmt(info.get("particle_steps_per_s"), 3)))
    if not rows:
        return "No timings in summary.json."
    rows.append(("total", "", fmt(total, 1), ""))
    return md_table(("Stage", "Steps", "Wall time (s)", "Particle-steps per second"), rows)


def energy_section(run):
    """The energy budget of each test that kept one (the deck's energy_budget; docs/energy.md): totals, the
    worst closure error against its bound, and damping's share of the dissipation, flagged above its bound."""
    rows = []
    for name, info in (run.summary.get("tests") or {}).items():
        energy = info.get("energy") if isinstance(info, dict) else None
        if not isinstance(energy, dict):
            continue
        share = energy.get("damping_share")
        flags = []
        if energy.get("closure_within_bound") is False:
            flags.append(f"closure above {fmt(100 * energy.get('closure_bound', 0), 2)} % at step "
                         f"{fmt(energy.get('worst_closure_step'))}")
        if energy.get("damping_dominated"):
            flags.append("damping-dominated")
        rows.append((name, fmt(energy.get("boundary_work"), 4), fmt(energy.get("stored_change"), 4),
                     fmt(energy.get("friction"), 4), fmt(energy.get("body_damping"), 4),
                     fmt(None if share is None else 100 * share, 3),
                     fmt(None if energy.get("closure_relative") is None else 100 * energy["closure_relative"], 3),
                     fmt(None if energy.get("worst_closure_relative") is None
                         else 100 * energy["worst_closure_relative"], 3),
                     "; ".join(flags) or "ok"))
    if not rows:
        return None
    return md_table(("Test", "Boundary work (J)", "Δ stored (J)", "Friction (J)", "Body damping (J)",
                     "Damping share (%)", "Closure (% of work)", "Worst closure (%)", "Verdict"), rows)


def phi_degrees(sin_phi):
    return None if sin_phi is None or not -1 <= sin_phi <= 1 else math.degrees(math.asin(sin_phi))


def test_values(run, test):
    """(label, formatted value) pairs describing one test: summary.json's quantities, then the series'."""
    series = run.test(test)
    q = run.quantity

    def first_last(name):
        return metrics.first_last(run.column(test, name))

    lo, hi = (run.test_summary(test).get("e1_peak_range") or [None, None])[:2]
    e_start, e_end = first_last("void_ratio")
    return [
        ("rows in series.csv", fmt(len(next(iter(series.values()))) if series else None)),
        ("peak σ1/σ3 (–)", fmt(q(test, "peak_ratio13"))),
        ("ε1 at peak σ1/σ3 (%)", fmt(scaled(q(test, "e1_at_peak"), PERCENT))),
        ("ε1 range within 1 % of the peak, its centre (%)",
         f"{fmt(scaled(lo, PERCENT))}–{fmt(scaled(hi, PERCENT))}, {fmt(scaled(q(test, 'e1_at_peak_centre'), PERCENT))}"),
        ("b at peak σ1/σ3 (–)", fmt(q(test, "b_at_peak"))),
        ("mobilised friction angle at peak, asin((σ1−σ3)/(σ1+σ3)) (°)",
         fmt(phi_degrees(q(test, "peak_state.sin_phi")), 1)),
        ("p at peak (kPa)", fmt(scaled(q(test, "peak_state.p"), 1e-3), 1)),
        ("q at peak (kPa)", fmt(scaled(q(test, "peak_state.q"), 1e-3), 1)),
        ("final ε1 (%)", fmt(scaled(q(test, "final_e1"), PERCENT))),
        ("final σ1/σ3 (–)", fmt(first_last("ratio13")[1])),
        ("final b (–)", fmt(q(test, "b_final"))),
        ("max contraction, max εv (%)", fmt(scaled(metrics.max_of(run.column(test, "ev")), PERCENT))),
        ("final εv (%)", fmt(scaled(q(test, "ev_final"), PERCENT))),
        ("εv, Z over the end window (%, –)",
         f"{fmt(scaled(q(test, 'end_window.ev'), PERCENT))}, {fmt(q(test, 'end_window.Z'), 2)}"),
        ("max DI (–)", fmt(metrics.max_of(run.column(test, "DI")))),
        ("void ratio at start / end (–)", f"{fmt(e_start)} / {fmt(e_end)}"),
        ("Z at start / end (–)", f"{fmt(first_last('Z')[0], 2)} / {fmt(q(test, 'Z_final'), 2)}"),
        ("max sliding fraction (%)", fmt(scaled(metrics.max_of(run.column(test, "sliding_fraction")), PERCENT), 1)),
        ("max H11/H33 (–)", fmt(metrics.max_of(run.column(test, "H11_H33")))),
        ("max Hs11/Hs33 (–)", fmt(metrics.max_of(run.column(test, "Hs11_Hs33")))),
        ("max Hw11/Hw33 (–)", fmt(metrics.max_of(run.column(test, "Hw11_Hw33")))),
    ]


def peaks_section(run):
    if not run.test_names:
        return "No series.csv found."
    columns = [test_values(run, t) for t in run.test_names]
    rows = [(label, *(values[k][1] for values in columns)) for k, (label, _) in enumerate(columns[0])]
    return md_table(("Quantity", *run.test_names), [r for r in rows if not all(is_missing(c) for c in r[1:])])


def is_missing(cell):
    """A table cell with no number in it ('n/a', 'n/a / n/a', 'n/a–n/a, n/a')."""
    return not any(ch.isdigit() for ch in cell.replace("n/a", ""))


PREPARED_VALUES = (("void ratio e (–)", "void_ratio", 1.0, 3), ("coordination number Z (–)", "Z", 1.0, 2),
                   ("mechanical coordination number Zm (–)", "Zm", 1.0, 2), ("rattlers", "rattlers", 1.0, 0),
                   ("mean stress p (kPa)", "p", 1e-3, 2), ("unbalanced force ratio (–)", "unbalanced_force", 1.0, 3),
                   ("steps", "steps", 1.0, 0))


def prepared_section(run):
    """summary.json's prepared state, and where the preparation's figure is; None without a preparation."""
    prepared = run.summary.get("prepared")
    if not isinstance(prepared, dict):
        return None
    rows = [(label, fmt(scaled(prepared.get(key), factor), digits) if digits else fmt(prepared.get(key)))
            for label, key, factor, digits in PREPARED_VALUES if prepared.get(key) is not None]
    out = md_table(("Prepared sample (summary.json)", "Value"), rows)
    if prepared.get("equilibrium_criterion"):
        out += f"\n\nEquilibrium: {prepared['equilibrium_criterion']}."
    return out


def grading_section(run):
    """summary.json's grading: the percent passing each sieve, asked and realised by the run's sample (celldem
    computes both); None when the deck lists its sizes."""
    g = run.summary.get("grading")
    if not isinstance(g, dict):
        return None
    rows = [(fmt_spec(size * 1e3, ".4g"), fmt_spec(asked, ".2f"), fmt_spec(realised, ".2f"))
            for size, asked, realised in zip(g.get("sizes_m") or [], g.get("asked_percent") or [],
                                             g.get("realised_percent") or [])]
    out = md_table(("Sieve size (mm)", "Asked (% passing)", "Realised (% passing)"), rows, align="rrr")
    return (f"Grading by {g.get('by', 'n/a')}, realised by the run's {fmt(g.get('spheres'))} spheres (summary.json "
            f"grading); largest deviation {fmt_spec(g.get('largest_deviation_percent'), '.2f')} percentage points.\n\n"
            + out)


def end_window_text(run):
    widths = {run.quantity(t, "end_window.strain") for t in run.test_names} - {None}
    width = f"{PERCENT * widths.pop():g} %" if len(widths) == 1 else "the last 0.5 %"
    return f"the end window is {width} of the strain of the test's end axis"


SECTION_TITLES = {"tests": "Each test", "compare": "Tests compared", "overview": "Overview", "probes": "Probes",
                  "force_chains": "Force chains at the peak", "prepare": "Preparation"}


def figures_section(planned, sections=("tests", "compare", "overview", "prepare"), fig_dir_name="figures",
                    headings=True):
    """The planned figures (figures.plan) of the given sections, under a heading per section."""
    out = []
    for section in sections:
        chosen = [p for p in planned if p.section == section]
        if not chosen:
            continue
        out += [f"### {SECTION_TITLES[section]}", ""] if headings else []
        for p in chosen:
            out += [f"{p.caption}:", "", f"![{p.caption}]({fig_dir_name}/{p.stem}.png)", ""]
    return "\n".join(out)


def force_chain_section(planned):
    if not any(p.section == "force_chains" for p in planned):
        return None
    return "\n".join([
        "Each test's contact network on the row of its largest σ1/σ3 (celldem's `<test>/peak_contacts.csv`): the "
        "contacts whose normal force exceeds the mean of all contacts, drawn between the centres (along the branch "
        "vector, from the centre inside the slab for contacts across the periodic boundary) in a slab 1.5 mean "
        "diameters thick through the cell's centre, normal to x2; line width proportional to the force, on one "
        "scale for all the tests.", "", figures_section(planned, ("force_chains",), headings=False)])


def failure_surface_section(run):
    """The failure surface of the run's constant-b tests (tools/failure_surface.py's table and figures); None
    unless the deck has two or more of them with peak states."""
    tests = scenes.constant_b_tests(run)
    points = failure_surface.peaks(run.summary, tests)
    note = failure_surface.left_out_text(failure_surface.left_out(run.summary, tests))
    if len(points) < failure_surface.PARAMETERS + 1:
        return None if not note else f"Tests with a constant-b axis: {', '.join(tests)}. {note} No fit: fewer than " \
            f"{failure_surface.PARAMETERS + 1} tests left."
    body, phi_png, pi_png = failure_surface.analyse(run.directory, points)
    return "\n".join([f"Tests with a constant-b axis: {', '.join(tests)}. {failure_surface.HOW} {note}", ""] + body + [
        "", f"![peak friction angle against b](figures/{os.path.basename(phi_png)})", "",
        f"![peak states in the π-plane](figures/{os.path.basename(pi_png)})", ""])


def study_section(run):
    """The speed–accuracy study (tools/study.py) when its results lie beside the run folder (results/study), or None.

    Linked rather than embedded: the study's figures live in its own folder."""
    study_dir = os.path.join(os.path.dirname(os.path.abspath(run.directory)), "study")
    md = os.path.join(study_dir, "study.md")
    if not os.path.isfile(md):
        return None
    rel = os.path.relpath(study_dir, os.path.abspath(run.directory))
    out = [f"Speed against accuracy, the stability map and the modelling choices on a reduced scene: "
           f"[{rel}/study.md]({rel}/study.md) (charts: [error against run time]({rel}/figures/pareto.png), "
           f"[stability map]({rel}/figures/stability.png)).", ""]
    study = read_json(os.path.join(study_dir, "study.json"))
    if not isinstance(study, dict):
        return "\n".join(out)
    rows = []
    for name, p in (study.get("presets") or {}).items():
        rows.append((f"inputs/{name}.json", p.get("rule", "n/a"), p.get("preparation", "n/a"), fmt(p.get("time_step")),
                     fmt(p.get("strain_increment")), fmt(p.get("inertial_number")), fmt(p.get("score_stress"), 2),
                     fmt(p.get("score_volume"), 2), f"{fmt(p.get('test_steps_speedup'), 1)}×"))
    if rows:
        out += ["Presets (errors on the reduced scene as multiples of the seed-to-seed noise floor; speed-up of the "
                "tests over inputs/paper.json):", "",
                md_table(("deck", "rule", "preparation", "time_step (s)", "Δε1 per step", "inertial number",
                          "stress-ratio errors / floor", "εv, Z errors / floor", "speed-up"), rows)]
    return "\n".join(out)


CONTROL_ERROR_KINDS = (("stress", "stress"), ("b", "b"), ("mean_stress", "p"), ("volume", "volume"))


def percent_text(value):
    """'0.53 %', '138 %' (three significant digits); 'n/a (not measured)' for None."""
    return "n/a (not measured)" if value is None else f"{value * PERCENT:.3g} %"


def leg_errors_text(errors):
    """'stress 0.42 %, b 0.003' of a leg's control_errors (relative errors in %, b absolute); '—' where nothing was
    measured (null values, or none of a kind the leg controls)."""
    if not isinstance(errors, dict):
        return "—"
    bits = []
    for key, label in CONTROL_ERROR_KINDS:
        v = errors.get(key)
        if v is None or (isinstance(v, (int, float)) and v == 0.0):
            continue
        bits.append(f"{label} {v:.3g}" if key == "b" else f"{label} {percent_text(v)}")
    return ", ".join(bits) or "—"


def over_tolerance_text(info):
    """summary.json's control_error_over_tolerance: the worst control error of any kind as a multiple of its
    tolerance (above 1 is outside it), '—' where nothing was measured."""
    v = number(info.get("control_error_over_tolerance"))
    return "—" if v is None else f"{v:.2g}"


def control_state(run, test):
    """'controlled', or 'UNCONTROLLED: <failures>' (summary.json's controlled and control_failures)."""
    if run.controlled(test):
        return "controlled"
    failures = run.control_failures(test)
    text = "; ".join(f if isinstance(f, str) else json.dumps(f, sort_keys=True) for f in failures)
    return "**UNCONTROLLED**" + (f": {text}" if text else "")


def controls_section(run):
    """Each test's control errors: summary.json's servo_max_error (stress and mean-stress axes, relative),
    control_error_over_tolerance (the worst error of any kind over its tolerance), each leg's control_errors,
    whether the test held its controls and reached a peak; None without tests."""
    rows = []
    for test in run.test_names:
        info = run.test_summary(test)
        legs = info.get("legs") or []
        leg_text = "; ".join(f"leg {leg.get('leg', k)}: {leg_errors_text(leg.get('control_errors'))}"
                             for k, leg in enumerate(legs) if isinstance(leg, dict)) or "—"
        servo = info.get("servo_max_error")
        rows.append((test, control_state(run, test),
                     percent_text(number(servo)), over_tolerance_text(info), leg_text,
                     "yes" if run.peak_reached(test) else "**no** (largest σ1/σ3 at the test's end)"))
    if not rows:
        return None
    out = md_table(("Test", "Controls", "Largest stress or p error", "Worst error / tolerance", "Control errors per leg",
                    "Peak reached"), rows)
    bad = [t for t in run.test_names if not run.controlled(t)]
    if bad:
        out += (f"\n\n{', '.join(bad)}: a control failed and the deck chose to continue. Their values are shown but "
                "no verdict, fit or statistic uses them.")
    return out


def uncontrolled_note(run):
    bad = [t for t in run.test_names if not run.controlled(t)]
    return (f" **{', '.join(bad)}: a control failed (see Controls); a comparison that uses "
            f"{'it' if len(bad) == 1 else 'them'} does not judge the paper's loading path.**" if bad else "")


def verify_rate_section(run):
    """`celldem run --verify-rate`: per test and summary quantity, its value in the test and at the ladder's slower
    rungs (the same test from the same state over the whole path), its distance from I → 0 in noise floors by the
    fitted law Q0 + C r^p with its one-sided 95 % bounds, the fitted order, and the verdict (summary.json
    verify_rate); None when no test was checked."""
    rows, notes = [], []
    rungs = None
    for test in run.test_names:
        check = run.test_summary(test).get("verify_rate")
        if not isinstance(check, dict):
            continue
        rungs = rungs or check.get("rungs")
        notes.append(f"{test}: floors {check.get('floors', {}).get('source', 'n/a')}")
        for q, c in (check.get("comparisons") or {}).items():
            values = " → ".join(fmt(v) for v in [c.get("test")] + list(c.get("rungs") or []))
            bounds = c.get("bounds95_floors") or [None, None]
            order = c.get("order_interval90") or [None, None]
            rows.append((test, q, values,
                         f"{fmt_spec(c.get('error_floors'), '+.2f')} [{fmt_spec(bounds[0], '+.2f')}, "
                         f"{fmt_spec(bounds[1], '+.2f')}]",
                         f"{fmt_spec(c.get('order'), '.2f')} [{fmt_spec(order[0], '.2f')}, {fmt_spec(order[1], '.2f')}]",
                         c.get("verdict", "n/a")))
        rows.append((test, "**the test**", "", "", "", f"**{check.get('verdict', 'n/a')}**: {check.get('reason', '')}"))
    if not rows:
        return None
    intro = ("Each test was run again from the same starting state over its whole path at the ladder's slower rungs "
             f"({', '.join(fmt(r) for r in rungs or [])} times its rate; `--verify-rate`) and as twins at 1.001, "
             "1.002 ... times its rate (their spread with the test is one run's chaos). Each quantity is fitted as "
             "Q0 + C r^p over the rates (the order p fitted); distance: C in noise floors, the test's distance from "
             "the quasi-static answer Q0 (I → 0), with its one-sided 95 % bounds from the chaos propagated through "
             "the fit. Converged: the bounds within ± the tolerance; not converged: beyond it at the family's level "
             "(Bonferroni); unresolved: the rest. "
             + "; ".join(notes) + ".")
    return intro + "\n\n" + md_table(("Test", "Quantity", "Test → rungs", "Distance from I → 0 (floors) [95 %]",
                                       "Order [90 %]", "Verdict"), rows)


PROBES_INTRO = (
    "Incremental response probes (`tests[].probes`): from the test's state at each point, each probe loads, holds, "
    "unloads and holds again, and its response is net of a reference probe that loads nothing (the creep of a state "
    "in motion). Stress probes: the strain response at the end of the loaded hold (total) and what is left after "
    "unloading (plastic); linearity is celldem's median over directions of |Δε| at the largest magnitude over |Δε| "
    "at the smallest, divided by the magnitudes' ratio (1: linear). Strain probes: the stress increments per unit "
    "strain (tangent) and their recovered part (elastic); asymmetry is |C − Cᵀ| / |C|. The sentences under each "
    "table are measured on probes.csv; a plastic response larger than the total one means that unloading did not "
    "bring the sample back (as near a peak). Each point rests at its stresses before its probes; its checks: the "
    "reference's drift over a probe against the smallest response, and (stress probes) the worst probe's recovered "
    "strain against C_elastic⁻¹Δσ from six strain probes at the same state (a ratio ≥ 1; ∞: more than 60° apart). "
    "A point that fails one says which in its status, and its plastic reading is withheld.")


def probe_set_text(s):
    """'stress probes in the rendulic plane, 8 directions, M = 2, 4 kPa; ramps of 3000 steps, holds of 1000'."""
    magnitudes = ", ".join(f"{m * 1e-3:g}" if s.kind == "stress" else f"{m:g}" for m in s.magnitudes)
    if s.kind == "stress" and s.info.get("magnitude_factors"):
        factors = ", ".join(f"{f:g}" for f in s.info["magnitude_factors"])
        magnitudes = (f"{factors} times each point's scale (target strain {fmt(s.info.get('target_strain'))}; "
                      f"the points' M in the table), i.e. {magnitudes}")
    if s.kind == "stress":
        first = s.rows[0] if s.rows else None  # the directions of one point and magnitude
        count = len(s.point_rows(first["point"], first["magnitude"])) if first else 0
        where = f"in the {s.plane} plane" if probes.in_a_plane(s.plane) else "along listed directions"
        what = f"stress probes {where}, {count or 'n/a'} directions, M = {magnitudes} kPa"
    else:
        what = f"strain probes of the six strains (e11, e22, e33, g12, g13, g23), M = {magnitudes}"
    return (f"{what}; ramps of {fmt(s.info.get('steps'))} steps, holds of {fmt(s.info.get('hold_steps'))} "
            f"(`{s.info.get('table', 'n/a')}`{', `' + s.info['stiffness'] + '`' if s.info.get('stiffness') else ''})")


def probe_point_row(s, point, entry):
    status = entry.get("status", "n/a")
    ran = entry.get("probes")
    counts = "—" if ran is None else f"{fmt(ran)} / {fmt(entry.get('controlled'))} / {fmt(entry.get('failed'))}"
    if ran is not None and entry.get("controlled") is not None and \
            entry["controlled"] < ran - (entry.get("failed") or 0):
        counts += " (**not all controlled**)"
    if s.kind == "stress":
        linearity = entry.get("linearity") or {}
        measure = fmt(probes.number(linearity.get("median_ratio")))
        cones = [f"{cone} {fmt(probes.number(c.get('median_ratio')))} ({fmt(probes.number(c.get('min_ratio')))}–"
                 f"{fmt(probes.number(c.get('max_ratio')))})"
                 for cone in ("loading", "unloading") if isinstance(c := linearity.get(cone), dict)]
        if cones:
            measure += "; " + "; ".join(cones)
        if entry.get("linearity_withheld"):
            measure = "withheld"
    else:
        measure = fmt(probes.number(entry.get("elastic_asymmetry")))
    e1, step = probes.number(entry.get("e1")), probes.number(entry.get("step"))
    # A point not run has no place in the test (the reason says what the test reached).
    where = ("—", "—") if status == "not run" or e1 is None or step is None else (fmt(e1 * PERCENT), fmt(round(step)))
    drift = probes.number((entry.get("drift") or {}).get("ratio"))
    agreement = probes.number(((entry.get("elastic_check") or {}).get("agreement") or {}).get("worst_factor"))
    checks = f"drift {fmt_spec(drift, '.2g', 'n/a')} of the smallest response"
    if s.kind == "stress":
        turned = ((entry.get("elastic_check") or {}).get("agreement") or {}).get("turned") or 0
        checks += (f"; elastic part within {fmt_spec(agreement, '.3g', 'n/a')}× of C⁻¹Δσ" if not turned else
                   f"; {turned} elastic parts more than 60° from C⁻¹Δσ")
    if drift is None and agreement is None:  # a run before the checks, or a point not probed
        checks = "—"
    return (point, *where, f"**{status}**" if status != "ran" else status,
            counts, measure, checks, entry.get("reason", "") or "")


def envelope_lines(s, point):
    """What each magnitude's envelope at `point` shows, measured on probes.csv (probes.envelope_findings)."""
    lines = []
    for m in s.point_magnitudes(point):
        f = probes.envelope_findings(s.point_rows(point, m), s.plane)
        if f is None:
            continue
        lines.append(
            f"- {point}, M = {m * 1e-3:g} kPa: the largest total response is along {f['largest']}, "
            f"{fmt_spec(f['ratio'], '.3g', 'n/a')} times the smallest, along {f['smallest']}; the largest plastic "
            f"response is along {f['most_plastic']}, {f['most_plastic_compliance'] * 1e6:.3g} per MPa "
            f"({fmt_spec(f['most_plastic_over_total'], '.2f', 'n/a')} times that probe's total); the plastic responses "
            f"sum to {fmt_spec(f['plastic_over_total'], '.2f', 'n/a')} times the total ones.")
    return lines


def plastic_flow_line(s, point):
    """celldem's reading of the plastic responses at `point` (summary.json points.<point>.plastic), or None."""
    p = (s.points.get(point) or {}).get("plastic")
    if not isinstance(p, dict):
        return None
    return (f"- {point}, M = {p['magnitude'] * 1e-3:g} kPa, as an elastoplastic model reads it: plastic flow along "
            f"{p['flow_direction_deg']:.0f}° (concentration {p['flow_concentration']:.3f}; 1: one mechanism), the "
            f"loading surface's normal along {p['loading_normal_deg']:.0f}° (the fit |Δε_plastic| = c max(0, cos(a − "
            f"normal)) explains {p['fit_explains']:.1%} of the squared plastic response), so the flow is "
            f"{p['non_associativity_deg']:.0f}° from associated.")


def failed_probe_lines(s, point):
    return [f"- {point}, {r['probe']}: {r['status']}" for r in s.point_rows(point) if not probes.is_ok(r)]


def stiffness_table(s, point):
    """The diagonal of each stiffness matrix at `point` (MPa) and its asymmetry; None without matrices."""
    matrices = probes.stiffness_matrices(s.stiffness_point(point))
    if not matrices:
        return None
    rows = [(name, *(f"{c[i, i] * 1e-6:.4g}" for i in range(6)), fmt(asym)) for name, c, asym in matrices]
    return md_table(("Stiffness at " + point + " (MPa)", *(f"C{v}{v}" for v in probes.VOIGT), "asymmetry"), rows,
                    align="l" + "r" * 7)


def probes_section(run, planned, fig_dir_name="figures"):
    """Each test's probes: per point its status, the probes run, controlled and failed, the linearity (stress) or
    elastic asymmetry (strain), what the response envelopes show or the stiffness diagonals, and the figures; None
    when no test ran probes."""
    sets = probes.load_all(run)
    if not sets:
        return None
    out = [PROBES_INTRO, ""]
    for s in sets:
        measure = "Linearity" if s.kind == "stress" else "Elastic asymmetry"
        rows = [probe_point_row(s, p, e) for p, e in s.points.items()]
        out += [f"### {s.test}", "", probe_set_text(s) + ".", "",
                md_table(("Point", "ε1 (%)", "Step", "Status", "Probes / controlled / failed", measure,
                          "Checks (from rest)", "Why"), rows)
                if rows else "No points in summary.json.", ""]
        details = []
        for point in s.points:
            details += failed_probe_lines(s, point)
            if s.kind == "stress":
                details += envelope_lines(s, point)
                if (line := plastic_flow_line(s, point)) is not None:
                    details.append(line)
        if details:
            out += details + [""]
        if s.kind == "strain":
            for point in s.points:
                table = stiffness_table(s, point)
                if table:
                    out += [table, ""]
    figures = figures_section(planned, ("probes",), fig_dir_name, headings=False)
    if figures:
        out += [figures]
    return "\n".join(out).rstrip()


def section(title, body):
    return [] if body is None else [f"## {title}", "", body, ""]


def build_report(run, paper, planned):
    name = os.path.basename(os.path.abspath(run.directory))
    tests = ", ".join(run.test_names) or "none (a preparation only)"
    out = [f"# celldem run report: {name}", "",
           f"Deck: `{run.summary.get('deck', 'n/a')}`. Tests: {tests}. Strains are compression positive and relative "
           "to each test's start.", ""]
    if paper:
        out += ["## Comparison with the paper", "",
                "Paper: *A comparison between true triaxial and plane strain compression by 3D DEM*. The comparisons "
                "between tests use the tests named `ttc` and `psc`. \"Matches qualitatively\" says whether the run "
                "shows what the paper reports, by the criterion in the last column." + uncontrolled_note(run), "",
                paper_table(run), ""]
    out += section("Controls", controls_section(run))
    out += section("Rate check", verify_rate_section(run))
    out += section("Probes", probes_section(run, planned))
    if run.test_names:
        out += ["## Per-test values", "",
                "The peak of σ1/σ3, ε1, b, p, q and the friction angle there, the final values and the end-window "
                f"means are celldem's (summary.json; {end_window_text(run)}); maxima, start values and the final "
                "σ1/σ3 are read from each series.csv.", "",
                peaks_section(run), ""]
    out += section("Energy budget", energy_section(run))
    out += section("Grading", grading_section(run))
    out += section("Preparation", prepared_section(run))
    out += section("Force chains", force_chain_section(planned))
    out += section("Failure surface", failure_surface_section(run))
    out += section("Figures", figures_section(planned) or None)
    study = study_section(run)
    out += section("Run settings", settings_section(run)) + section("Wall times", timing_section(run))
    out += section("Speed–accuracy study", study)
    return "\n".join(out)

