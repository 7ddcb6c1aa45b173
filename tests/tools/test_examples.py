"""The worked example docs/examples/stress_path_and_probes.py runs as a user runs it (300 spheres, one thread)
and writes what it says: the run, whose probes held their controls and reached the increments asked for, and
its two figures."""

import os

import pandas as pd

from checking import ROOT, is_png, run_script

EXAMPLE = os.path.join(ROOT, "docs", "examples", "stress_path_and_probes.py")


def test_the_worked_example_runs_and_plots(celldem, tmp_path):
    out = tmp_path / "example"
    r = run_script(EXAMPLE, "--out", out, "--count", "300", "--threads", "1")
    assert "wrote" in r.stdout
    assert is_png(str(out / "stress_path.png")) and is_png(str(out / "probe_responses.png"))
    table = pd.read_csv(out / "run" / "ttc" / "probes" / "probes.csv")
    assert len(table) == 4 and table["controlled"].all(), table
    # Each probe's stress increment is the one asked for (M d, within 2 % of M before the peak).
    for _, row in table.iterrows():
        for c in ("11", "22", "33"):
            assert abs(row["ds" + c] - row["magnitude"] * row["d" + c]) <= 0.02 * row["magnitude"], row
