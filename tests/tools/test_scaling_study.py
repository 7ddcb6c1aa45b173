"""The thread-scaling study: the scaling table of `celldem bench --scaling` (tools/celldem/performance/bench.py),
whose speed-up and parallel efficiency of each row over the same sample's one-thread row are checked against values
worked out by hand, and tools/thread_scaling.sh's refusals."""

from celldem.performance.bench import parallel_efficiency, scaling_markdown


def row(particles, copies, threads, rate):
    return {"particles": particles, "copies": copies, "threads": threads, "steps": 100,
            "particle_steps_per_s": rate, "bytes_per_particle": 500.0}


def test_efficiency_is_the_rate_over_threads_times_the_same_samples_one_thread_rate():
    rows = [row(8000, 1, 1, 10e6), row(8000, 1, 4, 30e6), row(128000, 16, 1, 8e6), row(128000, 16, 16, 64e6),
            row(1000, 0, 2, 5e6)]  # an extra sample timed on two threads only: no one-thread rate to compare with
    got = parallel_efficiency(rows)
    assert got[0] == (1.0, 1.0)
    assert got[1][0] == 3.0 and got[1][1] == 0.75
    assert got[3][0] == 8.0 and got[3][1] == 0.5  # against 128,000's own one-thread rate, not 8000's
    assert got[4] == (None, None)
    table = scaling_markdown({"scaling": rows})
    assert "parallel efficiency" in table.splitlines()[0]
    line = next(l for l in table.splitlines() if l.startswith("| 128000") and "| 16 |" in l)
    assert "| 8.00 | 0.50 |" in line

    # Two extra samples of one size (copies 0 both) are told apart by their source; a repeated one-thread row
    # does not replace the first as the baseline.
    a, b = row(1000, 0, 1, 4e6), row(1000, 0, 2, 6e6)
    c, d = row(1000, 0, 1, 8e6), row(1000, 0, 2, 10e6)
    for r, source in ((a, "a.state"), (b, "a.state"), (c, "b.state"), (d, "b.state")):
        r["source"] = source
    again = dict(a, particle_steps_per_s=5e6)
    got = parallel_efficiency([a, b, c, d, again])
    assert got[1] == (1.5, 0.75) and got[3] == (1.25, 0.625) and got[4] == (1.25, 1.25)


def test_thread_scaling_refuses_bad_arguments_before_measuring(tmp_path, celldem):
    """tools/thread_scaling.sh: no arguments, a missing state or deck, a missing binary and a folder that already
    holds results each stop it with exit 2 and a message naming the problem, before anything is timed."""
    import os
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    script = str(root / "tools" / "thread_scaling.sh")
    env = dict(os.environ, CELLDEM=celldem)

    def run(*args, **extra):
        return subprocess.run(["bash", script, *map(str, args)], capture_output=True, text=True,
                              env=dict(env, **extra), timeout=60)

    r = run()
    assert r.returncode == 2 and "usage" in r.stderr
    r = run(tmp_path / "out", tmp_path / "missing.state")
    assert r.returncode == 2 and "no state file" in r.stderr
    state = tmp_path / "a.state"
    state.write_text("not read before the checks pass")
    r = run(tmp_path / "out", state, tmp_path / "missing.json")
    assert r.returncode == 2 and "no deck" in r.stderr
    r = run(tmp_path / "out", state, CELLDEM=str(tmp_path / "no-binary"))
    assert r.returncode == 2 and "no celldem binary" in r.stderr
    (tmp_path / "done" / "bench").mkdir(parents=True)
    (tmp_path / "done" / "bench" / "bench.json").write_text("{}")
    r = run(tmp_path / "done", state)
    assert r.returncode == 2 and "already holds results" in r.stderr
    assert (tmp_path / "done" / "bench" / "bench.json").read_text() == "{}"
    assert not (tmp_path / "out").exists()


def test_the_scaling_bench_tiles_the_adapted_sample_and_the_table_reads_it(tmp_path, celldem):
    """`celldem bench --scaling` on the small deck's prepared sample: the copies are tiled after 10,000 steps with
    the skin the sample adapted to, so the sample and its 2 and 4 copies list about as many pairs per particle,
    fewer than the same sample timed from its file (--extra-state, the deck's skin); --tile-after 0 keeps the
    skin as given, a negative count is refused; plot_bench's table gives the rows' efficiencies."""
    import json
    import os
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    deck = root / "tests" / "run" / "small_run.json"
    run = tmp_path / "small"
    subprocess.run([celldem, "run", str(deck), "--out", str(run), "--threads", "1"], check=True, capture_output=True)
    out = tmp_path / "bench"
    state = str(run / "prepared.state")
    bench = [celldem, "bench", "--deck", str(deck), "--state", state, "--scaling", "--threads", "1", "--steps", "400",
             "--warmup", "20", "--repeats", "1"]
    done = subprocess.run(bench + ["--copies", "1,2,4", "--extra-state", state, "--out", str(out)], check=True,
                          capture_output=True, text=True, timeout=300)
    rows = json.loads((out / "bench.json").read_text())["scaling"]
    assert [r["copies"] for r in rows] == [0, 1, 2, 4]  # the extra sample first, as it is read
    assert [r["tiled_after_steps"] for r in rows] == [0, 10000, 10000, 10000]
    assert rows[0]["source"] == state and rows[2]["source"] == "copies 2"
    skin = float(done.stdout.split("list skin ")[1].split()[0])  # (the copies' list skin, of the deck's)
    assert 0 < skin < 1, done.stdout  # the premise: the sample's skin adapted in its 10,000 steps
    pairs = [r["pairs_per_particle"] for r in rows]
    assert max(pairs[1:]) / min(pairs[1:]) < 1.1, pairs  # the copies list alike
    assert max(pairs[1:]) < pairs[0], pairs  # and fewer pairs apart than the sample on the deck's skin
    # --tile-after 0 tiles the state as given; a negative count is refused, naming the option.
    done = subprocess.run(bench + ["--copies", "2", "--tile-after", "0", "--out", str(tmp_path / "as-given")],
                          check=True, capture_output=True, text=True, timeout=300)
    assert "list skin 1 of the deck's" in done.stdout
    done = subprocess.run(bench + ["--copies", "2", "--tile-after", "-1", "--out", str(tmp_path / "bad")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0 and "--tile-after" in done.stderr
    subprocess.run(["/usr/bin/python3", str(root / "tools" / "plot_bench.py"), str(out)], check=True,
                   capture_output=True, env=dict(os.environ))
    table = (out / "scaling.md").read_text()
    assert "parallel efficiency" in table and "| 1.00 | 1.00 |" in table
