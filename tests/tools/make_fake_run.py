#!/usr/bin/python3
"""Writes a small synthetic celldem run directory for testing the figure and report tools.

Usage: /usr/bin/python3 tests/tools/make_fake_run.py OUT_DIR [--variant alike|diverging] [--only TEST]
       [--drop-columns A,B,...] [--no-prepared] [--no-columns-json] [--reverse-columns]

The curves have the paper's shapes (peak and softening of σ1/σ3, contraction then dilation, falling Z, ...)
and are built so that the numbers the report computes are known exactly; they are written to
OUT_DIR/expected.json. With --variant diverging the PSC test differs from TTC in Z, sliding fraction, the
σ1/σ3–Hs11/Hs33 relation and the peak σ1/σ3, so each of the report's comparisons should say "no".

summary.json holds what celldem would write for these series: `celldem summarize` (solver/run/summary.cpp, the
one definition) of each series, so the built binary must exist (tools/build.sh; $CELLDEM names another). Each
<test>/ also gets series.columns.json (units) unless
--no-columns-json; --reverse-columns writes the series columns in reverse order (the tools read the header).
"""

import argparse
import json
import math
import os
import tempfile

import numpy as np

from celldem import binary

PARTICLES = 8000
S3 = 100e3                      # [Pa] lateral confining stress
E1 = np.linspace(0.0, 0.12, 241)  # axial strain grid, steps of 0.0005: peaks and 10 % fall on grid points

PREPARED_E = 0.583
PREPARED_Z = 5.87
PSC_B_PEAK = 0.412              # b at the PSC stress-ratio peak, by construction
PSC_B_AT_10 = 0.297             # b at ε1 = 10 %, by construction
FABRIC_PEAK = {"ttc": 1.25, "psc": 1.40}   # max H11/H33, reached at ε1 = 6 %
STRONG_SLOPE = 0.45             # Hs11/Hs33 = 1 + STRONG_SLOPE (σ1/σ3 - 1): one macro-micro relation


def rise_and_peak(e1, e_peak):
    """0 at ε1 = 0, exactly 1 at e_peak (a grid point), below 1 elsewhere."""
    x = e1 / e_peak
    return x * np.exp(1.0 - x)


def stress_ratio(e1, peak, e_peak, residual_fraction):
    shape = np.where(e1 <= e_peak, rise_and_peak(e1, e_peak),
                     residual_fraction + (1 - residual_fraction) * np.exp(-((e1 / e_peak - 1) ** 2) / 2.0))
    return 1.0 + (peak - 1.0) * shape


def make_test(name, variant, rng):
    diverging = variant == "diverging" and name == "psc"
    peak, e_peak = {"ttc": (3.9, 0.025), "psc": (3.5 if diverging else 4.6, 0.020)}[name]
    ratio = stress_ratio(E1, peak, e_peak, 0.55 if name == "psc" else 0.7)

    if name == "psc":
        b = np.where(E1 <= e_peak, PSC_B_PEAK * (ratio - 1) / (peak - 1),
                     PSC_B_PEAK + (PSC_B_AT_10 - PSC_B_PEAK) * (E1 - e_peak) / (0.10 - e_peak))
    else:
        b = np.zeros_like(E1)
    s33 = np.full_like(E1, S3)
    s11 = ratio * s33
    s22 = s33 + b * (s11 - s33)
    b[0] = np.nan  # σ1 = σ3 at the start: b is 0/0

    # Slight contraction, then dilation at a rate approaching `dilation`.
    dilation = 0.65 if name == "psc" else 0.60
    ev = (dilation + 0.5) * 0.004 * (1 - np.exp(-E1 / 0.004)) - dilation * E1
    if name == "psc":
        e2 = np.zeros_like(E1)
        e3 = ev - E1 - e2
    else:
        e2 = e3 = (ev - E1) / 2
    di = -np.gradient(ev, E1)
    di[0] = np.nan

    z = 4.55 + (PREPARED_Z - 4.55) * np.exp(-E1 / 0.008) + rng.normal(0, 0.02, E1.size) - (0.6 if diverging else 0)
    zm = z + 0.3
    sliding = np.clip(0.11 * (1 - np.exp(-E1 / 0.003)) - 0.03 * E1 / 0.12 + rng.normal(0, 0.003, E1.size), 0, 1)
    if diverging:
        sliding = sliding * 2

    h_ratio = 1 + (FABRIC_PEAK[name] - 1) * rise_and_peak(E1, 0.06)
    hs_ratio = 1 + (0.8 if diverging else STRONG_SLOPE) * (ratio - 1)
    hw_ratio = 1 - 0.08 * rise_and_peak(E1, 0.01) + (0.18 if name == "psc" else 0.15) * E1 / 0.12

    def components(r):
        h22_over_h33 = 1 + (0.4 * (r - 1) if name == "psc" else 0)
        h33 = 1 / (r + h22_over_h33 + 1)
        return r * h33, h22_over_h33 * h33, h33

    h11, h22, h33 = components(h_ratio)
    hs11, hs22, hs33 = components(hs_ratio)
    hw11, hw22, hw33 = components(hw_ratio)
    n_contacts = np.round(z * PARTICLES / 2)
    q = np.sqrt(0.5 * ((s11 - s22) ** 2 + (s22 - s33) ** 2 + (s33 - s11) ** 2))
    zeros = np.zeros_like(E1)
    return {
        "step": np.arange(E1.size) * 1000, "time": np.arange(E1.size) * 1000 * 1e-6,
        "e1": E1, "e2": e2, "e3": e3, "ev": ev, "s11": s11, "s22": s22, "s33": s33,
        "s12": zeros, "s13": zeros, "s23": zeros, "p": (s11 + s22 + s33) / 3, "q": q,
        "ratio13": ratio, "b": b, "sin_phi": (s11 - s33) / (s11 + s33), "DI": di,
        "void_ratio": (1 + PREPARED_E) * (1 - ev) - 1, "Z": z, "Zm": zm, "sliding_fraction": sliding,
        "n_contacts": n_contacts, "n_strong": np.round(0.4 * n_contacts),
        "H11": h11, "H22": h22, "H33": h33, "H12": zeros, "H13": zeros, "H23": zeros,
        "Hs11": hs11, "Hs22": hs22, "Hs33": hs33, "Hw11": hw11, "Hw22": hw22, "Hw33": hw33,
        "H11_H33": h_ratio, "Hs11_Hs33": hs_ratio, "Hw11_Hw33": hw_ratio,
        "kinetic_energy": 1e-6 * ratio, "unbalanced_force": 1e-3 * np.exp(-E1 / 0.02) + 1e-4,
    }


def fake_test_summary(columns):
    """summary.json["tests"][name] of a series as celldem writes it: `celldem summarize` of the series (every
    column; --drop-columns changes only what the written series shows), and the control and cost entries."""
    fd, path = tempfile.mkstemp(suffix=".csv")
    os.close(fd)
    try:
        write_series(path, columns)
        return dict(binary.summarize(path), servo_max_error=0.001, inertial_number=1.2e-4, controlled=True)
    finally:
        os.remove(path)


def write_columns_json(path, names):
    """series.columns.json as celldem writes it: stresses in Pa, kinetic energy in J, time in s, the rest '-'."""
    units = {"time": "s", "kinetic_energy": "J"}
    units.update({n: "Pa" for n in ("s11", "s22", "s33", "s12", "s13", "s23", "p", "q")})
    with open(path, "w", encoding="utf-8") as f:
        json.dump({"columns": [{"name": n, "unit": units.get(n, "-"), "meaning": f"fake column {n}"}
                               for n in names]}, f, indent=1)


def write_series(path, columns):
    names = list(columns)
    rows = np.column_stack([columns[n] for n in names])
    with open(path, "w", encoding="utf-8") as f:
        f.write(",".join(names) + "\n")
        for row in rows:
            # NaN is written as an empty field, as the solver does for DI at the first rows.
            f.write(",".join("" if math.isnan(v) else repr(float(v)) for v in row) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir")
    parser.add_argument("--variant", choices=("alike", "diverging"), default="alike")
    parser.add_argument("--only", help="write only this test")
    parser.add_argument("--drop-columns", default="", help="comma-separated series columns to leave out")
    parser.add_argument("--no-prepared", action="store_true", help="leave out summary.json 'prepared'")
    parser.add_argument("--no-columns-json", action="store_true", help="no series.columns.json (older runs)")
    parser.add_argument("--reverse-columns", action="store_true", help="series columns in reverse order")
    args = parser.parse_args()

    rng = np.random.default_rng(12345)
    drop = {c for c in args.drop_columns.split(",") if c}
    names = [args.only] if args.only else ["ttc", "psc"]
    tests = {}
    for name in names:
        columns = make_test(name, args.variant, rng)
        # celldem's summary is of every column; --drop-columns changes only what the series shows.
        tests[name] = dict(fake_test_summary(columns), steps=240000, wall_s=120.5, particle_steps_per_s=1.6e7)
        columns = {k: v for k, v in columns.items() if k not in drop}
        if args.reverse_columns:
            columns = dict(reversed(list(columns.items())))
        os.makedirs(os.path.join(args.out_dir, name), exist_ok=True)
        write_series(os.path.join(args.out_dir, name, "series.csv"), columns)
        if not args.no_columns_json:
            write_columns_json(os.path.join(args.out_dir, name, "series.columns.json"), list(columns))

    summary = {
        "celldem_version": "0.1.0", "deck": "inputs/fake.json",
        "settings": {"particles": PARTICLES, "time_step": 1e-6, "kn": 1e6, "kt": 1e6, "density": 2650,
                     "friction": 0.5, "damping_translational": 0.05, "damping_rotational": 0.05, "threads": 2},
        "tests": tests,
    }
    if not args.no_prepared:
        summary["prepared"] = {"void_ratio": PREPARED_E, "Z": PREPARED_Z, "Zm": 6.0, "p": S3, "steps": 123456,
                               "wall_s": 100.0, "particle_steps_per_s": 1.0e7}
    with open(os.path.join(args.out_dir, "summary.json"), "w", encoding="utf-8") as f:
        json.dump(summary, f, indent=1)

    diverging = args.variant == "diverging"
    expected = {
        "prepared_void_ratio": None if args.no_prepared else PREPARED_E,
        "prepared_Z": None if args.no_prepared else PREPARED_Z,
        "psc_b_at_peak": PSC_B_PEAK, "psc_b_at_10": PSC_B_AT_10,
        "peaks": {n: t["peak_ratio13"] for n, t in tests.items()},
        "fabric_peak": FABRIC_PEAK,
        "psc_peak_exceeds_ttc": not diverging, "z_alike": not diverging, "sliding_alike": not diverging,
        "fabric_grows_more_in_psc": True, "macro_micro_unique": not diverging,
    }
    with open(os.path.join(args.out_dir, "expected.json"), "w", encoding="utf-8") as f:
        json.dump(expected, f, indent=1)


if __name__ == "__main__":
    main()
