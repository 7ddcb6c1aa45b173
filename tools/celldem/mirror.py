"""summary.json's per-test quantities for a series that has no summary.json.

A LAMMPS or LIGGGHTS run of a translated deck writes a series only. To compare it with celldem, the
cross-check needs the quantities celldem writes into summary.json for its own run, by exactly the same
definitions. summary_of_series is the one Python copy of those definitions (solver/run/summary.cpp,
summarize_test); any run that has a summary.json is read, never recomputed. Keep the two in step: a change
in summary.cpp must be made here too (tests/tools/test_tools.sh checks this copy against the synthetic run's
summary, and the ctest crosscheck_reduced checks it against a real celldem run).
"""

import math

# solver/run/summary.hpp
PEAK_PLATEAU = 0.01        # kPeakPlateau: the e1 range where s11/s33 stays within 1 % of its peak
END_WINDOW_STRAIN = 0.005  # kEndWindowStrain: end values are means over the last 0.5 % of the end axis's strain

AXIS_STRAIN = {"x1": "e1", "x2": "e2", "x3": "e3"}


def _finite_or_none(x):
    return float(x) if x is not None and math.isfinite(x) else None


def summary_of_series(series, end_axis="x1"):
    """The scalars of summary.json["tests"][name] that a series determines, as celldem defines them:

    peak_ratio13       ratio13 (s11/s33) on the first row of its largest value (a NaN first row stays the peak,
                       as in C++, where no comparison with NaN is true)
    e1_at_peak         e1 on that row; b_at_peak: b there (when the series has a b column)
    e1_peak_range      [lo, hi]: the smallest and largest e1 over the rows with ratio13 >= 0.99 peak_ratio13
    e1_at_peak_centre  (lo + hi) / 2
    final_e1, ev_final, Z_final, b_final   the last row
    end_window         {"strain": 0.005, "ev", "Z"}: means over the rows whose end-axis strain lies within 0.005
                       of the last row's

    `series` maps column names to arrays (ratio13 falls back to s11/s33, the columns of a translated script);
    `end_axis` is the axis of the test's last end condition ("x1" for TTC and PSC). Non-finite values are None,
    as summary.json writes null.
    """
    e1 = [float(v) for v in series["e1"]]
    ratio = series.get("ratio13")
    if ratio is None:
        ratio = [s11 / s33 if s33 != 0 else math.nan for s11, s33 in zip(series["s11"], series["s33"])]
    ratio = [float(v) for v in ratio]
    n = len(e1)
    peak = 0
    for r in range(n):
        if ratio[r] > ratio[peak]:
            peak = r
    lo = hi = e1[peak]
    for r in range(n):
        if ratio[r] >= (1.0 - PEAK_PLATEAU) * ratio[peak]:
            lo, hi = min(lo, e1[r]), max(hi, e1[r])

    strain = [float(v) for v in series[AXIS_STRAIN[end_axis]]]
    ev_sum = z_sum = 0.0
    count = 0
    for r in range(n):
        if abs(strain[r] - strain[-1]) <= END_WINDOW_STRAIN:
            ev_sum += float(series["ev"][r])
            z_sum += float(series["Z"][r])
            count += 1

    out = {"peak_ratio13": _finite_or_none(ratio[peak]),
           "e1_at_peak": _finite_or_none(e1[peak]),
           "e1_peak_range": [_finite_or_none(lo), _finite_or_none(hi)],
           "e1_at_peak_centre": _finite_or_none(0.5 * (lo + hi)),
           "final_e1": _finite_or_none(e1[-1]),
           "ev_final": _finite_or_none(float(series["ev"][-1])),
           "Z_final": _finite_or_none(float(series["Z"][-1])),
           "end_window": {"strain": END_WINDOW_STRAIN, "ev": _finite_or_none(ev_sum / count),
                          "Z": _finite_or_none(z_sum / count)}}
    if "b" in series:
        out["b_at_peak"] = _finite_or_none(float(series["b"][peak]))
        out["b_final"] = _finite_or_none(float(series["b"][-1]))
    return out
