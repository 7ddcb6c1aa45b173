"""ENSEMBLE_DIR/report.md (tools/report.py on a folder with ensemble.json and seed-<k>/): the tests over the seeds,
the differences between tests on the same samples, the preparation, for the paper's deck each of the paper's
findings judged statistically, and the figures with their bands.

Every summary.json quantity and every paired difference comes from celldem's ensemble.json (mean, std, sem and
95 % interval over the seeds); what the paper's findings measure on curves is measured on each seed's series
(report.py's functions) and described by stats.describe, the same statistics. A difference is called only when
the 95 % interval excludes the compared value (Student t; stats.py), else it is "not distinguishable at N seeds".
The intervals printed are unadjusted while the verdicts are Holm-adjusted over their table: a row whose value lies
outside its unadjusted interval but is not rejected after the adjustment says so.
"""

import math
import os

from .. import metrics, stats
from . import figures, report
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


ALPHA = 0.05  # the family-wise error rate of each table's verdicts (Holm)


def uncontrolled_seeds(ens, test):
    """Seeds whose run of `test` failed a control (summary.json "controlled": false)."""
    return [seed_of(run) for run in ens.runs if run.test_summary(test) and not run.controlled(test)]


def seed_of(run):
    name = os.path.basename(os.path.normpath(run.directory))
    return name[len("seed-"):] if name.startswith("seed-") else name


def controls_section(ens):
    """Per seed and test: the largest servo error, each leg's control errors, whether the controls held and a peak
    was reached (summary.json's)."""
    rows = []
    for run in ens.runs:
        for test in ens.test_names:
            info = run.test_summary(test)
            if not info:
                continue
            servo = info.get("servo_max_error")
            legs = "; ".join(f"leg {leg.get('leg', k)}: {report.leg_errors_text(leg.get('control_errors'))}"
                             for k, leg in enumerate(info.get("legs") or []) if isinstance(leg, dict)) or "—"
            rows.append((seed_of(run), test, report.control_state(run, test),
                         report.percent_text(servo), report.over_tolerance_text(info), legs,
                         "yes" if run.peak_reached(test) else "**no**"))
    if not rows:
        return None
    excluded = (ens.stats.get("excluded") or {}).get("rule")
    return ((f"ensemble.json: {excluded}.\n\n" if excluded else
             "This ensemble.json predates celldem's exclusion of uncontrolled tests: pairs with an uncontrolled "
             "test get no verdict.\n\n")
            + md_table(("Seed", "Test", "Controls", "Largest stress or p error", "Worst error / tolerance",
                        "Control errors per leg", "Peak reached"), rows))


def excluded_by_celldem(ens):
    """True when ensemble.json left the uncontrolled tests out itself (celldem with "excluded")."""
    return isinstance(ens.stats.get("excluded"), dict) and "kept" not in str(ens.stats["excluded"].get("rule", ""))


def paired_section(ens):
    """Each pair of tests of ensemble.json's "paired" (B - A on the same seed): difference, paired t, Holm over the
    table, verdict. No verdict on a pair whose statistics may hold a test whose control failed."""
    rows, pvals = [], []
    for pair in (ens.stats.get("paired") or {}):
        b, a = pair.split("-", 1)
        bad = sorted(set(uncontrolled_seeds(ens, a)) | set(uncontrolled_seeds(ens, b)))
        refuse = bad and not excluded_by_celldem(ens)
        for key, label, scale, digits in TEST_QUANTITIES:
            stat = ens.statistic("paired", pair, key)
            if stat is None or key in ("servo_max_error", "inertial_number"):
                continue
            p = None if refuse else stats.one_sample_p(stat)
            rows.append([label, f"{b} − {a}", spread(stat, scale, digits), stats.t_text(stat), stat, b, a, refuse])
            pvals.append(p)
    if not rows:
        return None
    adjusted, rejected = stats.holm(pvals, ALPHA)
    table = []
    for (label, pair, sp, t, stat, b, a, refuse), p, adj, rej in zip(rows, pvals, adjusted, rejected):
        if refuse:
            verdict = "not judged: uncontrolled runs in the pair"
        elif p is None:
            verdict = "n/a"
        elif rej:
            verdict = f"{b} {'higher' if stat['mean'] > 0 else 'lower'} than {a}"
        else:
            verdict = stats.not_distinguishable(stat) + (ADJUSTED_NOTE.format("0", "95 % interval")
                                                         if stats.lost_to_adjustment(p, adj, ALPHA) else "")
        table.append((label, pair, sp, f"{t}; {stats.p_text(p, adj)}", verdict))
    return ("Per seed, the difference B − A of the two tests on the same sample (ensemble.json `paired`; tests whose "
            "control failed are left out by celldem). Test: paired t over the seeds, two-sided; the "
            f"{sum(p is not None for p in pvals)} tests of the table are one family, Holm-adjusted to a family-wise "
            f"error rate of {ALPHA * 100:g} %: a difference is called when its Holm-adjusted p ≤ {ALPHA:g}. The 95 % "
            "interval shown is the unadjusted one: a row whose interval excludes 0 without a call says so.\n\n"
            + md_table(("Quantity", "Pair", "Difference: mean ± std [95 % interval]", "Paired t", "Verdict"), table))


def prepared_section(ens):
    return table_of(PREPARED_QUANTITIES, [("over the seeds", lambda key: ens.statistic("prepared", key))])


# --- the paper's findings, judged over the seeds ------------------------------------------------------------

def per_seed(ens, measure, tests=("ttc", "psc")):
    """stats.describe of measure(run) over the seeds' runs, leaving out the runs in which one of `tests` failed a
    control."""
    return stats.describe([measure(run) for run in ens.runs if all(run.controlled(t) for t in tests)])


def both(ens):
    return all(ens.test(t) is not None for t in ("ttc", "psc"))


# Sameness claims ("alike" in the paper) are judged by equivalence (TOST) against these margins, on the paired
# per-seed difference psc − ttc averaged over ε1 bins: (margin, unit, why that size).
ALIKE_MARGINS = {
    "Z": (0.1, "contacts per particle",
          "about 1/15 of Z's fall during a test (5.9 to 4.3) and 2 % of Z: below what the paper's Z figure resolves"),
    "sliding_fraction": (0.01, "fraction of contacts",
                         "one contact in a hundred, a line's width on the paper's sliding-fraction axis"),
    "DI": (0.05, "(–)", "a tenth of the dilatancy index's largest values (about 0.5), a line's width in the paper"),
    "macro_micro": (0.05, "relative", "5 % of σ1/σ3 at the same Hs11/Hs33, the scatter of one run's curve"),
}

ONE_SAMPLE = "one-sample t vs {}"
FISHER = "one-sample t of the seeds' Fisher z = artanh(r) vs artanh({})"
# Appended to a verdict not called after Holm's adjustment whose compared value lies outside the printed
# (unadjusted) interval: ({compared value}, {interval name}).
ADJUSTED_NOTE = " ({} lies outside the unadjusted {}, but is not rejected after Holm's adjustment)"
PREDICTION = "prediction interval of one more seed vs the paper's single sample"
PAIRED = "paired t (both tests on each seed's sample)"


class Claim:
    """A finding judged over the seeds: its statistic, the hypotheses it tests (p-values, adjusted together with
    every other claim's by Holm) and how its verdict reads them."""

    def __init__(self, label, paper_text, stat, scale, digits, kind, test, against=0.0, expected=None, below=None,
                 margin=None):
        """kind: "value" (the paper's single value vs one more seed), "alike" (TOST and paired t), "sign", "threshold"
        (one-sample t vs `against`), "correlation" (a threshold on Pearson r, `stat` over the seeds' Fisher z and
        `against` an r) or "construction" (true by the test's prescription: shown, `against` the tolerance the
        seeds' values must stay below, not tested and outside the Holm family)."""
        self.label, self.paper_text, self.stat, self.scale, self.digits = label, paper_text, stat, scale, digits
        self.kind, self.test, self.against, self.expected, self.below, self.margin = \
            kind, test, against, expected, below, margin
        if kind == "construction":
            self.p = []
        elif kind == "correlation":
            self.p = [stats.one_sample_p(stat, stats.fisher_z(against))]
        elif kind == "value":
            self.p = [stats.prediction_p(stat, against)]
        elif kind == "alike":
            self.tost = stats.tost(stat, margin[0])
            self.p = [stats.one_sample_p(stat), self.tost and self.tost["p"]]
        else:
            self.p = [stats.one_sample_p(stat, against)]
        self.adjusted = [None] * len(self.p)

    def interval_text(self):
        s, f, d = self.stat, self.scale, self.digits
        if self.kind == "construction":
            return f"{fmt(s['mean'] * f, d)} ± {fmt(s['std'] * f, d)}; largest seed {fmt(max(s['values']) * f, d)}"
        if self.kind == "correlation":  # back from z to r: tanh of the mean z and of its interval's ends
            lo, hi = s["ci95"]
            return (f"r = {fmt(math.tanh(s['mean']), d)} (tanh of the mean z {fmt(s['mean'], d)} ± "
                    f"{fmt(s['std'], d)}); CI95 [{fmt(math.tanh(lo), d)}, {fmt(math.tanh(hi), d)}]")
        if self.kind == "value":
            lo, hi = s["pi95"] if "pi95" in s else stats.prediction_interval(s)
            return f"{fmt(s['mean'] * f, d)} ± {fmt(s['std'] * f, d)}; PI95 [{fmt(lo * f, d)}, {fmt(hi * f, d)}]"
        if self.kind == "alike":
            lo, hi = self.tost["interval"]
            return (f"{fmt(s['mean'] * f, d)} ± {fmt(s['std'] * f, d)}; 90 % CI [{fmt(lo * f, d)}, {fmt(hi * f, d)}] "
                    f"vs margin ±{fmt(self.margin[0] * f, d)}")
        lo, hi = s["ci95"]
        return f"{fmt(s['mean'] * f, d)} ± {fmt(s['std'] * f, d)}; CI95 [{fmt(lo * f, d)}, {fmt(hi * f, d)}]"

    def verdict(self):
        n = self.stat["n"]
        if self.kind == "construction":
            worst = max(self.stat["values"])
            return (f"by construction (every seed ≤ {fmt(self.against * self.scale, 4)})" if worst <= self.against
                    else f"**no**: a seed reaches {fmt(worst * self.scale, 4)} > {fmt(self.against * self.scale, 4)}")
        lost = [stats.lost_to_adjustment(p, a, ALPHA) for p, a in zip(self.p, self.adjusted)]
        sig = [a is not None and a <= ALPHA for a in self.adjusted]
        against = stats.fisher_z(self.against) if self.kind == "correlation" else self.against
        side = 1 if self.stat["mean"] > against else -1
        if self.kind == "value":
            return f"no: {'above' if side > 0 else 'below'} the paper" if sig[0] else \
                "consistent (the paper's value is a plausible seed)" + \
                (ADJUSTED_NOTE.format("the paper's value", "PI95") if lost[0] else "")
        if self.kind == "alike":
            v = stats.equivalence_verdict(self.adjusted[0], self.adjusted[1], n, ALPHA)
            if v != "equivalent" and lost[1]:
                v += " (the 90 % CI lies inside the margin, but TOST is not rejected after Holm's adjustment)"
            elif v.startswith("undecided") and lost[0]:
                v += ADJUSTED_NOTE.format("0", "95 % interval")
            return v
        if not sig[0]:
            return (f"not distinguishable at {n} seeds" +
                    (f" from {self.against:g}" if self.kind in ("threshold", "correlation") else "") +
                    (ADJUSTED_NOTE.format(f"{self.against:g}" if self.kind != "sign" else "0", "CI95")
                     if lost[0] else ""))
        if self.kind == "sign":
            return "yes" if side == self.expected else "no: the opposite"
        return "yes" if (side < 0) == self.below else "no"

    def test_text(self):
        if self.kind == "construction":
            return f"{self.test}: not tested, outside the Holm family"
        p = "; ".join(stats.p_text(p, a) for p, a in zip(self.p, self.adjusted))
        if self.kind == "alike":
            return (f"TOST, margin ±{self.margin[0]:g} {self.margin[1]}, and paired t; p (difference), p (TOST): {p}")
        return f"{self.test}; {p}"


def paper_claims(ens):
    """The Claims of the paper's findings the ensemble can judge, Holm-adjusted together."""
    claims = []

    def add(*args, **kw):
        if args[2] is not None and args[2].get("n", 0) >= 2:
            claims.append(Claim(*args, **kw))

    for section in (prepared_claims, psc_claims, ttc_claims, pair_claims, per_test_claims):
        section(ens, add)
    flat = [p for c in claims for p in c.p]
    adjusted, _ = stats.holm(flat, ALPHA)
    k = 0
    for c in claims:
        c.adjusted = adjusted[k:k + len(c.p)]
        k += len(c.p)
    return claims


def prepared_claims(ens, add):
    """The prepared sample's void ratio and coordination number against the paper's."""
    for key, label, value, digits in (("void_ratio", "Prepared void ratio e", report.PAPER_VOID_RATIO, 3),
                                      ("Z", "Prepared coordination number Z", report.PAPER_Z, 2)):
        add(label, fmt(value, digits), ens.statistic("prepared", key), 1.0, digits, "value", PREDICTION,
            against=value)


def psc_claims(ens, add):
    """PSC: b at the peak and at 10 %, b falling after the peak, ε2 held at 0."""
    if ens.test("psc") is None:
        return
    add("PSC b at peak σ1/σ3", fmt(report.PAPER_B_AT_PEAK), ens.statistic("tests", "psc", "b_at_peak"), 1.0, 3,
        "value", PREDICTION, against=report.PAPER_B_AT_PEAK)
    add("PSC b at ε1 = 10 %", fmt(report.PAPER_B_AT_10), per_seed(ens, report.psc_b_at_10, ("psc",)), 1.0, 3,
        "value", PREDICTION, against=report.PAPER_B_AT_10)

    def b_fall(run):
        b10, peak = report.psc_b_at_10(run), run.quantity("psc", "b_at_peak")
        return None if b10 is None or peak is None or not run.peak_reached("psc") else b10 - peak
    add("PSC b falls after the peak (b at 10 % − b at peak)", "yes", per_seed(ens, b_fall, ("psc",)), 1.0, 3,
        "sign", ONE_SAMPLE.format(0), expected=-1)
    add("PSC ε2 stays 0 (max |ε2|, %)", "yes", per_seed(ens, report.psc_max_e2, ("psc",)), PERCENT, 4,
        "construction", "by construction (plane strain prescribes ε2 = 0)", against=report.ZERO_STRAIN_TOL)


def ttc_claims(ens, add):
    """TTC: b held at 0."""
    if ens.test("ttc") is None:
        return
    add("TTC b stays 0 (max |b| for ε1 ≥ 0.1 %)", "yes", per_seed(ens, report.ttc_max_b, ("ttc",)), 1.0, 3,
        "construction", "by construction (the triaxial test holds σ2 = σ3)", against=report.ZERO_B_TOL)


def pair_claims(ens, add):
    """TTC against PSC: the peaks, Z, sliding and DI alike, fabric growing more in PSC, one macro-micro curve."""
    if not both(ens):
        return
    # ensemble.json's pairs are named B-A with B after A alphabetically: "ttc-psc" is ttc − psc.
    add("PSC peak σ1/σ3 exceeds TTC's (ttc − psc)", "yes", ens.statistic("paired", "ttc-psc", "peak_ratio13"),
        1.0, 3, "sign", PAIRED, expected=-1)
    for name, label in (("Z", "Z"), ("sliding_fraction", "Sliding fraction"), ("DI", "DI")):
        stat = per_seed(ens, lambda run, c=name: metrics.mean_difference(
            run.column("ttc", "e1"), run.column("ttc", c), run.column("psc", "e1"), run.column("psc", c),
            bins=report.CURVE_BINS))
        add(f"{label} evolves alike in TTC and PSC (mean psc − ttc over ε1 bins)", "yes", stat, 1.0, 3, "alike",
            PAIRED, margin=ALIKE_MARGINS[name])
    for name in ("H11_H33", "Hs11_Hs33", "Hw11_Hw33"):
        stat = per_seed(ens, lambda run, c=name: None if metrics.max_of(run.column("psc", c)) is None
                        or metrics.max_of(run.column("ttc", c)) is None
                        else metrics.max_of(run.column("psc", c)) - metrics.max_of(run.column("ttc", c)))
        label = name.replace("_", "/")
        add(f"{label} grows more in PSC (max psc − max ttc)", "yes", stat, 1.0, 3, "sign", PAIRED, expected=1)

    def macro_micro(run):
        return metrics.mean_difference(*report.macro_micro_relation(run, "ttc"),
                                       *report.macro_micro_relation(run, "psc"),
                                       bins=report.MACRO_MICRO_BINS, relative=True)
    add("σ1/σ3 vs Hs11/Hs33 (ε1 ≤ 1 %) is one curve (mean relative psc − ttc)", "yes",
        per_seed(ens, macro_micro), 1.0, 3, "alike", PAIRED, margin=ALIKE_MARGINS["macro_micro"])


def per_test_claims(ens, add):
    """Each test: the fabric peak after the stress ratio's, Hs11/Hs33 (and PSC's b) tracking σ1/σ3."""
    for test in ("ttc", "psc"):
        if ens.test(test) is None:
            continue
        add(f"{test}: H11/H33 peaks after σ1/σ3 (ε1 lag, %)", "yes",
            per_seed(ens, lambda run, t=test: report.fabric_peak_lag(run, t) if run.peak_reached(t) else None,
                     (test,)), PERCENT, 2, "sign", ONE_SAMPLE.format(0), expected=1)
        for name, label in (("Hs11_Hs33", "Hs11/Hs33"), ("b", "b")):
            if name == "b" and test != "psc":
                continue
            add(f"{test}: {label} tracks σ1/σ3 (Pearson r)", "yes",
                per_seed(ens, lambda run, t=test, c=name: stats.fisher_z(report.tracks_r(run, t, c)), (test,)), 1.0,
                2, "correlation", FISHER.format(report.TRACKS_MIN_R), against=report.TRACKS_MIN_R, below=False)


def paper_section(ens):
    claims = paper_claims(ens)
    rows = [(c.label, c.paper_text, c.interval_text(), c.test_text(), c.verdict()) for c in claims]
    margins = [f"{k}: ±{m:g} {unit} ({why})" for k, (m, unit, why) in ALIKE_MARGINS.items()]
    bad = {t: uncontrolled_seeds(ens, t) for t in ("ttc", "psc")}
    bad_text = "; ".join(f"{t} on seeds {', '.join(map(str, s))}" for t, s in bad.items() if s)
    if not rows:
        return "No finding of the paper can be judged on these tests (they need tests named ttc and psc)."
    return "\n".join([
        "Paper: *A comparison between true triaxial and plane strain compression by 3D DEM*. Each finding is judged "
        f"over the {len(ens.runs)} seeds, each by the test named in its row, two-sided; all "
        f"{sum(p is not None for c in claims for p in c.p)} hypotheses of the table are one family, Holm-adjusted "
        f"to a family-wise error rate of {ALPHA * 100:g} % (a verdict is called when its Holm-adjusted p ≤ {ALPHA:g}). "
        "A value of the paper comes from one sample, so it is compared with the prediction interval of one more "
        "seed, mean ± t(0.975, n − 1) s √(1 + 1/n) (PI95), not with the interval of the mean: \"consistent\" "
        "means the paper's sample could be one more of ours. A sameness (\"alike\") is judged by equivalence: two "
        "one-sided t-tests (TOST) that the paired difference lies within a stated margin: \"equivalent\" (TOST "
        "rejects a difference as large as the margin: the 90 % interval lies inside it), \"different\" (not "
        "equivalent, and the paired t-test rejects no difference) or \"undecided at N seeds\". Margins: "
        + "; ".join(margins) + ". Other differences (from 0, from a threshold) are one-sample or paired t-tests "
        "with their 95 % interval of the mean (CI95); a correlation r is tested on the seeds' Fisher z = artanh(r) "
        "and shown back as r. The intervals printed are unadjusted: a row whose compared value lies outside its "
        "interval but is not rejected after Holm's adjustment says so in its verdict. Rows true by construction "
        "(the test prescribes them) are shown as \"by construction\", checked against their tolerance but not "
        "tested, and take no place in the Holm family. "
        + (f"Runs whose control failed are left out of every verdict ({bad_text}). " if bad_text else "")
        + "Summary quantities and paired differences are celldem's (ensemble.json); the rest is measured on each "
        "seed's series as in a single run's report.", "",
        md_table(("Finding", "Paper", "Ensemble: mean ± std; interval", "Test; p (Holm-adjusted)",
                  "Matches the paper"), rows)])


def build_report(ens, paper, planned):
    name = os.path.basename(os.path.abspath(ens.directory))
    seeds = ", ".join(str(s) for s in ens.seeds)
    first = ens.runs[0]
    out = [f"# celldem ensemble report: {name}", "",
           f"Deck: `{first.summary.get('deck', 'n/a')}`. Seeds: {seeds} ({len(ens.runs)} runs, `seed-<k>/`). Tests: "
           f"{', '.join(ens.test_names) or 'none'}. Statistics: {ens.stats.get('statistics', 'n/a')} "
           "(celldem's ensemble.json). Figures: " + figures.BAND_TEXT + ".", ""]
    if paper:
        out += report.section("Comparison with the paper", paper_section(ens))
    out += report.section("Controls of each seed", controls_section(ens))
    out += report.section("Probes (first seed)", report.probes_section(first, planned))
    out += report.section("Per-test values over the seeds", tests_section(ens))
    out += report.section("Differences between tests", paired_section(ens))
    out += report.section("Preparation over the seeds", prepared_section(ens))
    out += report.section("Force chains", report.force_chain_section(planned))
    out += report.section("Figures", report.figures_section(planned) or None)
    out += report.section("Run settings (first seed)", report.settings_section(first))
    return "\n".join(out)
