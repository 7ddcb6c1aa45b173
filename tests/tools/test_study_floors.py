"""tools/study.py floors (tools/celldem/study/floors.py), the evidence for --tolerance's floor model, without running a
simulation: the scene's deck at a count, per-seed values read from an ensemble.json as celldem writes it, and the
fitted exponent and its bootstrap interval on synthetic ensembles whose true exponent is known (-0.5, and 0: a
floor that does not shrink must not pass for 1/sqrt(N))."""

import json

import numpy as np
import pytest

from celldem import decks
from celldem.study import floors, scene


def synthetic(exponent, seeds, counts=(500, 1000, 2000), rng_seed=3):
    """Per-seed values at each count whose standard deviation is 0.1 (N / 1000)^exponent."""
    rng = np.random.default_rng(rng_seed)
    return {n: {q: list(1.0 + rng.normal(0.0, 0.1 * (n / 1000) ** exponent, seeds)) for q in floors.QUANTITIES}
            for n in counts}


def test_deck_is_the_paper_scene_at_the_count():
    paper = decks.load()
    deck = floors.floor_deck(paper, 500)
    assert deck["sample"]["count"] == 500 and paper["sample"]["count"] == 8000
    assert all(t["end"]["strain"] == scene.END_STRAIN for t in deck["tests"])
    assert deck["contact"] == paper["contact"] and deck["prepare"] == paper["prepare"]


def test_values_are_read_from_the_ensemble(tmp_path):
    ensemble = {"seeds": [1, 2, 3],
                "prepared": {"void_ratio": {"n": 3, "std": 0.01, "values": [0.6, 0.61, 0.62]}},
                "tests": {"ttc": {"end_window.ev": {"n": 3, "std": 0.001, "values": [-0.01, -0.011, -0.012]},
                                  "peak_ratio13": {"n": 2, "std": 0.1, "values": [2.9, 3.0]}}}}
    (tmp_path / "ensemble.json").write_text(json.dumps(ensemble))
    values = floors.read_values(str(tmp_path))
    assert values == {"prepared.void_ratio": [0.6, 0.61, 0.62], "ttc.end_window.ev": [-0.01, -0.011, -0.012]}


def test_exponent_of_exact_power_laws():
    counts = [500, 1000, 2000, 4000]
    stds = np.array([[2.0 * n ** -0.5, 7.0 * n ** -0.5] for n in counts])
    assert floors.exponent_of(stds, counts) == pytest.approx(-0.5, abs=1e-12)


def test_inverse_sqrt_is_found_inside_and_a_flat_floor_outside():
    inside = floors.fit(synthetic(-0.5, 8), resamples=1000)
    assert inside["inverse_sqrt_inside"], inside["interval"]
    assert inside["interval"][0] < inside["exponent"] < inside["interval"][1]
    flat = floors.fit(synthetic(0.0, 32), resamples=1000)
    assert not flat["inverse_sqrt_inside"] and flat["interval"][0] > -0.5, flat["interval"]
    text = floors.markdown(inside)
    assert "1/sqrt(N) lies inside it" in text and "| ttc.peak_ratio13 |" in text


def test_a_run_of_another_deck_is_refused(tmp_path, monkeypatch):
    # A folder whose deck.json differs from the one the scene gives now (the paper deck edited since): its
    # ensemble is not reused, and nothing is run over it.
    paper = decks.load()
    folder = tmp_path / "n500"
    (folder / "run").mkdir(parents=True)
    (folder / "deck.json").write_text(json.dumps(floors.floor_deck(paper, 400), indent=2))
    (folder / "run" / "ensemble.json").write_text("{}")
    monkeypatch.setattr(floors.subprocess, "run", lambda *a, **k: pytest.fail("ran celldem over another deck's run"))
    with pytest.raises(floors.FloorsError, match="another deck"):
        floors.run_count(str(tmp_path), paper, 500, "1-2", "celldem")
    same = floors.floor_deck(paper, 500)
    (folder / "deck.json").write_text(json.dumps(same, indent=2))
    assert floors.run_count(str(tmp_path), paper, 500, "1-2", "celldem") == str(folder / "run")


def test_one_count_is_refused():
    with pytest.raises(floors.FloorsError):
        floors.fit({1000: synthetic(-0.5, 8)[1000]})
