"""ENSEMBLE_DIR/report.md (tools/report.py on a folder with ensemble.json and seed-<k>/): the tests over the seeds,
the differences between tests on the same samples, the preparation, for the paper's deck each of the paper's
findings judged statistically, and the figures with their bands.

Every summary.json quantity and every paired difference comes from celldem's ensemble.json (mean, std, sem and
95 % interval over the seeds); what the paper's findings measure on curves is measured on each seed's series
(report.py's functions) and described by stats.describe, the same statistics. A difference is called only when
the 95 % interval excludes the compared value (Student t; stats.py), else it is "not distinguishable at N seeds".
"""

import os

from . import metrics, report, stats
from .tables import fmt, md_table

PERCENT = 100.0

# The per-test quantities shown, (ensemble.json key, label, scale, digits); those no test has are left out.
TEST_QUANTITIES = (
    ("peak_ratio13", "peak σ1/σ3 (–)", 1.0, 3),
    ("peak_robust.ratio13", "robust peak σ1/σ3, smoothed (–)", 1.0, 3),
    ("e1_at_peak", "ε1 at peak σ1/σ3 (%)", PERCENT, 3),
    ("b_at_peak", "b at peak σ1/σ3 (–)", 1.0, 3),
    ("b_principal_at_peak", "b of the principal stresses at peak (–)", 1.0, 3),
    ("peak_state.p", "p at peak (kPa)", 1e-3, 1),
    ("peak_state.q", "q at peak (kPa)", 1e-3, 1),
    ("peak_state.sin_phi", "sin φ at peak (–)", 1.0, 3),
    ("ev_final", "final εv (%)", PERCENT, 3),
    ("end_window.ev", "εv over the end window (%)", PERCENT, 3),
    ("end_window.Z", "Z over the end window (–)", 1.0, 2),
    ("Z_final", "final Z (–)", 1.0, 2),
    ("servo_max_error", "largest servo error (–)", 1.0, 3),
    ("inertial_number", "inertial number (–)", 1.0, 3),
)
PREPARED_QUANTITIES = (("void_ratio", "void ratio e (–)", 1.0, 4), ("Z", "coordination number Z (–)", 1.0, 3),
                       ("Zm", "mechanical coordination number Zm (–)", 1.0, 3), ("p", "mean stress p (kPa)", 1e-3, 2))


def spread(stat, scale=1.0, digits=3):
    """'0.568 ± 0.003 [0.561, 0.576]': mean ± std [95 % interval], scaled."""
    if stat is None:
        return "n/a"
    lo, hi = stat["ci95"]
    return (f"{fmt(stat['mean'] * scale, digits)} ± {fmt(stat['std'] * scale, digits)} "
            f"[{fmt(lo * scale, digits)}, {fmt(hi * scale, digits)}]")


def table_of(rows, columns):
    """Rows (key, label, scale, digits) × columns (header, function key -> statistic); rows no column has left out."""
    out = []
    for key, label, scale, digits in rows:
        cells = [spread(get(key), scale, digits) for _, get in columns]
        if any(c != "n/a" for c in cells):
            out.append((label, *cells))
    return md_table(("Quantity", *(h for h, _ in columns)), out) if out else None


def tests_section(ens):
    columns = [(t, lambda key, t=t: ens.statistic("tests", t, key)) for t in ens.test_names]
    return table_of(TEST_QUANTITIES, columns)


def paired_section(ens):
    """Each pair of tests of ensemble.json's "paired" (B - A on the same seed): difference, paired t, verdict."""
    rows = []
    for pair in (ens.stats.get("paired") or {}):
        for key, label, scale, digits in TEST_QUANTITIES:
            stat = ens.statistic("paired", pair, key)
            if stat is None or key in ("servo_max_error", "inertial_number"):
                continue
            side = stats.compare(stat)
            b, a = pair.split("-", 1)
            verdict = (stats.not_distinguishable(stat) if side == 0 else "n/a" if side is None
                       else f"{b} {'higher' if side > 0 else 'lower'} than {a}")
            rows.append((label, f"{b} − {a}", spread(stat, scale, digits), stats.t_text(stat), verdict))
    if not rows:
        return None
    return ("Per seed, the difference B − A of the two tests on the same sample (ensemble.json `paired`); test: "
            "paired t over the seeds, two-sided at 5 % (a difference is called when its 95 % interval excludes 0).\n\n"
            + md_table(("Quantity", "Pair", "Difference: mean ± std [95 % interval]", "Paired t", "Verdict"), rows))


def prepared_section(ens):
    return table_of(PREPARED_QUANTITIES, [("over the seeds", lambda key: ens.statistic("prepared", key))])


# --- the paper's findings, judged over the seeds ------------------------------------------------------------

def per_seed(ens, measure):
    """stats.describe of measure(run) over the seeds' runs."""
    return stats.describe([measure(run) for run in ens.runs])


def both(ens):
    return all(ens.test(t) is not None for t in ("ttc", "psc"))


def vs_value(stat, value, digits=3):
    """Verdict of a mean against the paper's value (one-sample t)."""
    side = stats.compare(stat, value)
    if side is None:
        return None
    return stats.not_distinguishable(stat) + " (consistent)" if side == 0 else \
        f"no: {'above' if side > 0 else 'below'} the paper"


def sign_verdict(stat, expected):
    """Verdict of a difference whose sign the paper states (+1 or -1)."""
    side = stats.compare(stat)
    if side is None:
        return None
    return stats.not_distinguishable(stat) if side == 0 else ("yes" if side == expected else "no: the opposite")


def alike_verdict(stat):
    """Verdict of a difference the paper says is absent."""
    side = stats.compare(stat)
    if side is None:
        return None
    return stats.not_distinguishable(stat) + " (alike)" if side == 0 else "no: they differ"


def threshold_verdict(stat, threshold, below):
    """Verdict of a quantity the paper's criterion wants below (or above) a threshold."""
    side = stats.compare(stat, threshold)
    if side is None:
        return None
    if side == 0:
        return stats.not_distinguishable(stat) + f" from {threshold:g}"
    return "yes" if (side < 0) == below else "no"


ONE_SAMPLE = "one-sample t vs the paper's value"
PAIRED = "paired t (both tests on each seed's sample)"


def paper_claims(ens):
    """(claim, paper, statistic, scale, digits, test, verdict) of each finding the ensemble can judge."""
    claims = []

    def add(label, paper_text, stat, scale, digits, test, verdict, against=0.0):
        if stat is not None and verdict is not None:
            claims.append((label, paper_text, spread(stat, scale, digits), f"{test}; {stats.t_text(stat, against)}",
                           verdict))

    for key, label, value, digits in (("void_ratio", "Prepared void ratio e", report.PAPER_VOID_RATIO, 3),
                                      ("Z", "Prepared coordination number Z", report.PAPER_Z, 2)):
        stat = ens.statistic("prepared", key)
        add(label, fmt(value, digits), stat, 1.0, digits, ONE_SAMPLE, vs_value(stat, value), value)
    if ens.test("psc") is not None:
        stat = ens.statistic("tests", "psc", "b_at_peak")
        add("PSC b at peak σ1/σ3", fmt(report.PAPER_B_AT_PEAK), stat, 1.0, 3, ONE_SAMPLE,
            vs_value(stat, report.PAPER_B_AT_PEAK), report.PAPER_B_AT_PEAK)
        stat = per_seed(ens, report.psc_b_at_10)
        add("PSC b at ε1 = 10 %", fmt(report.PAPER_B_AT_10), stat, 1.0, 3, ONE_SAMPLE,
            vs_value(stat, report.PAPER_B_AT_10), report.PAPER_B_AT_10)

        def b_fall(run):
            b10, peak = report.psc_b_at_10(run), run.quantity("psc", "b_at_peak")
            return None if b10 is None or peak is None else b10 - peak
        stat = per_seed(ens, b_fall)
        add("PSC b falls after the peak (b at 10 % − b at peak)", "yes", stat, 1.0, 3,
            "one-sample t vs 0", sign_verdict(stat, -1))
        stat = per_seed(ens, report.psc_max_e2)
        add("PSC ε2 stays 0 (max |ε2|, %)", "yes", stat, PERCENT, 4,
            f"one-sample t vs {report.ZERO_STRAIN_TOL * PERCENT:g} %",
            threshold_verdict(stat, report.ZERO_STRAIN_TOL, below=True), report.ZERO_STRAIN_TOL)
    if ens.test("ttc") is not None:
        stat = per_seed(ens, report.ttc_max_b)
        add("TTC b stays 0 (max |b| for ε1 ≥ 0.1 %)", "yes", stat, 1.0, 3, f"one-sample t vs {report.ZERO_B_TOL}",
            threshold_verdict(stat, report.ZERO_B_TOL, below=True), report.ZERO_B_TOL)
    if both(ens):
        # ensemble.json's pairs are named B-A with B after A alphabetically: "ttc-psc" is ttc − psc.
        stat = ens.statistic("paired", "ttc-psc", "peak_ratio13")
        add("PSC peak σ1/σ3 exceeds TTC's (ttc − psc)", "yes", stat, 1.0, 3, PAIRED, sign_verdict(stat, -1))
        for name, label in (("Z", "Z"), ("sliding_fraction", "Sliding fraction"), ("DI", "DI")):
            stat = per_seed(ens, lambda run, c=name: metrics.mean_difference(
                run.column("ttc", "e1"), run.column("ttc", c), run.column("psc", "e1"), run.column("psc", c),
                bins=report.CURVE_BINS))
            add(f"{label} evolves alike in TTC and PSC (mean psc − ttc over ε1 bins)", "yes", stat, 1.0, 3, PAIRED,
                alike_verdict(stat))
        for name in ("H11_H33", "Hs11_Hs33", "Hw11_Hw33"):
            stat = per_seed(ens, lambda run, c=name: None if metrics.max_of(run.column("psc", c)) is None
                            or metrics.max_of(run.column("ttc", c)) is None
                            else metrics.max_of(run.column("psc", c)) - metrics.max_of(run.column("ttc", c)))
            label = name.replace("_", "/")
            add(f"{label} grows more in PSC (max psc − max ttc)", "yes", stat, 1.0, 3, PAIRED, sign_verdict(stat, 1))

        def macro_micro(run):
            return metrics.mean_difference(*report.macro_micro_relation(run, "ttc"),
                                           *report.macro_micro_relation(run, "psc"),
                                           bins=report.MACRO_MICRO_BINS, relative=True)
        stat = per_seed(ens, macro_micro)
        add("σ1/σ3 vs Hs11/Hs33 (ε1 ≤ 1 %) is one curve (mean relative psc − ttc)", "yes", stat, 1.0, 3, PAIRED,
            alike_verdict(stat))
    for test in ("ttc", "psc"):
        if ens.test(test) is None:
            continue
        stat = per_seed(ens, lambda run, t=test: report.fabric_peak_lag(run, t))
        add(f"{test}: H11/H33 peaks after σ1/σ3 (ε1 lag, %)", "yes", stat, PERCENT, 2, "one-sample t vs 0",
            sign_verdict(stat, 1))
        for name, label in (("Hs11_Hs33", "Hs11/Hs33"), ("b", "b")):
            if name == "b" and test != "psc":
                continue
            stat = per_seed(ens, lambda run, t=test, c=name: report.tracks_r(run, t, c))
            add(f"{test}: {label} tracks σ1/σ3 (Pearson r)", "yes", stat, 1.0, 2,
                f"one-sample t vs r = {report.TRACKS_MIN_R}", threshold_verdict(stat, report.TRACKS_MIN_R, False),
                report.TRACKS_MIN_R)
    return claims


def paper_section(ens):
    rows = paper_claims(ens)
    if not rows:
        return "No finding of the paper can be judged on these tests (they need tests named ttc and psc)."
    return "\n".join([
        "Paper: *A comparison between true triaxial and plane strain compression by 3D DEM*. Each finding is judged "
        f"over the {len(ens.runs)} seeds: the run's value is the mean ± standard deviation [95 % interval of the "
        "mean]; a difference (from the paper's value, from 0, from a threshold) is called only when that interval "
        "excludes it (Student t, two-sided, 5 %), else the finding is \"not distinguishable at N seeds\". "
        "Summary quantities and paired differences are celldem's (ensemble.json); the rest is measured on each "
        "seed's series as in a single run's report.", "",
        md_table(("Finding", "Paper", "Ensemble: mean ± std [95 % interval]", "Test", "Matches the paper"), rows)])


def build_report(ens, paper, planned):
    name = os.path.basename(os.path.abspath(ens.directory))
    seeds = ", ".join(str(s) for s in ens.seeds)
    first = ens.runs[0]
    out = [f"# celldem ensemble report: {name}", "",
           f"Deck: `{first.summary.get('deck', 'n/a')}`. Seeds: {seeds} ({len(ens.runs)} runs, `seed-<k>/`). Tests: "
           f"{', '.join(ens.test_names) or 'none'}. Statistics: {ens.stats.get('statistics', 'n/a')} "
           "(celldem's ensemble.json). Figures: " + report.figures.BAND_TEXT + ".", ""]
    if paper:
        out += report.section("Comparison with the paper", paper_section(ens))
    out += report.section("Per-test values over the seeds", tests_section(ens))
    out += report.section("Differences between tests", paired_section(ens))
    out += report.section("Preparation over the seeds", prepared_section(ens))
    out += report.section("Force chains", report.force_chain_section(planned))
    out += report.section("Figures", report.figures_section(planned) or None)
    out += report.section("Run settings (first seed)", report.settings_section(first))
    return "\n".join(out)
