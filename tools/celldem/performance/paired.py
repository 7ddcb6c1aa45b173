"""Two celldem binaries timed against each other in concurrent pairs: a round runs `celldem bench` (one thread) of
both at once, each pinned to a core of its own, then again with the cores swapped; the round's ratio is new over
old in particle-steps/s, the geometric mean of its two halves.

Why: on the project's 2-core host the speed of each core changes from time to time by up to 30 % for a minute or
more (a binary run after run gave 14-15 M and 19-20 M particle-steps/s), which sequential alternation turns into
bimodal noise. Two runs at the same moment see the same machine, and a round's two halves, seconds apart, see
each binary on both cores, so a difference between the cores cancels: with c0 and c1 the cores' speed factors,
(new c1 / old c0) (new c0 / old c1) has neither. Each run has its core to itself (the kernel runs out of the
private caches: the paper's 8000 spheres take about 3 MB).

The verdict: a one-sample t-test on the rounds' log ratios (SciPy), its two-sided 95 % interval turned back into
a ratio; "faster" or "slower" when the interval excludes 1 (5 % error rate), "within noise" otherwise, and
whether the interval's lower end clears a bar (the performance issue's 5 % for a structural change).
"""

from __future__ import annotations

import math
import os
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

from scipy import stats

from ..files import load_json

CONFIDENCE = 0.95
BAR = 1.05  # a structural change lands only if it buys at least 5 %


class PairedError(RuntimeError):
    """A round could not be run (a bench failed, fewer than two cores); the message says which and why."""


@dataclass
class Verdict:
    """What the rounds say of new against old."""

    ratios: List[float]
    median: float
    mean: float  # geometric mean of the ratios
    low: float  # the interval's ends, as ratios
    high: float
    verdict: str  # "faster", "slower" or "within noise"
    clears_bar: bool  # the interval's lower end at or above bar
    bar: float
    test: str = "one-sample t-test on log(new/old), two-sided 95 % interval (5 % error rate), SciPy"
    extra: Dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> Dict[str, object]:
        return {"ratios": self.ratios, "median": self.median, "geometric_mean": self.mean,
                "interval_95": [self.low, self.high], "verdict": self.verdict, "bar": self.bar,
                "clears_bar": self.clears_bar, "test": self.test, "rounds": len(self.ratios)}

    def text(self) -> str:
        bar = f"{(self.bar - 1) * 100:.0f} %"
        return (f"new/old over {len(self.ratios)} rounds: median {self.median:.3f}, geometric mean {self.mean:.3f}, "
                f"95 % interval [{self.low:.3f}, {self.high:.3f}] ({self.test}): {self.verdict}; "
                f"{'clears' if self.clears_bar else 'does not clear'} the {bar} bar")


def judge(ratios: Sequence[float], bar: float = BAR) -> Verdict:
    """The verdict of the rounds' ratios (new/old, each > 0; at least two rounds)."""
    if len(ratios) < 2:
        raise ValueError("a verdict needs at least two rounds")
    if any(not (r > 0 and math.isfinite(r)) for r in ratios):
        raise ValueError(f"every ratio must be finite and positive: {list(ratios)}")
    logs = [math.log(r) for r in ratios]
    mean = sum(logs) / len(logs)
    spread = max(logs) - min(logs)
    if spread == 0.0:  # identical rounds: the interval is the point itself
        low = high = mean
    else:
        result = stats.ttest_1samp(logs, 0.0)
        interval = result.confidence_interval(CONFIDENCE)
        low, high = float(interval.low), float(interval.high)
    verdict = "faster" if low > 0 else "slower" if high < 0 else "within noise"
    ordered = sorted(ratios)
    n = len(ordered)
    median = ordered[n // 2] if n % 2 else 0.5 * (ordered[n // 2 - 1] + ordered[n // 2])
    return Verdict(ratios=list(ratios), median=median, mean=math.exp(mean), low=math.exp(low), high=math.exp(high),
                   verdict=verdict, clears_bar=math.exp(low) >= bar, bar=bar)


def two_cores() -> List[int]:
    """Two cores this process may run on (the first two of its affinity set)."""
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2:
        raise PairedError(f"paired rounds need two cores; this process may run on {len(cores)}")
    return cores[:2]


def bench_command(binary: str, deck: str, state: str, steps: int, warmup: int, out: str) -> List[str]:
    return [binary, "bench", "--deck", deck, "--state", state, "--threads", "1", "--steps", str(steps),
            "--warmup", str(warmup), "--repeats", "1", "--out", out, "--force"]


def run_command(binary: str, deck: str, out: str) -> List[str]:
    return [binary, "run", deck, "--out", out, "--threads", "1", "--fixed-threads"]


def run_half(old: str, new: str, deck: str, state: Optional[str], steps: int, warmup: int, cores: Sequence[int],
             scratch: Optional[str] = None) -> Dict[str, float]:
    """Both binaries at once, old on cores[0] and new on cores[1]: their benches (state given; particle-steps/s),
    or with state None whole `celldem run` processes of the deck (1 / wall seconds). Returns the rate of each."""
    with tempfile.TemporaryDirectory(dir=scratch) as tmp:
        procs = {}
        for (name, binary), core in zip((("old", old), ("new", new)), cores):
            out = os.path.join(tmp, name)
            command = (bench_command(binary, deck, state, steps, warmup, out) if state is not None
                       else run_command(binary, deck, out))
            log = open(os.path.join(tmp, name + ".log"), "w+")  # (a file, not a pipe: nobody waits on a full pipe)
            procs[name] = (subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, text=True,
                                            preexec_fn=lambda c=core: os.sched_setaffinity(0, {c})),
                           out, log, time.monotonic())
        seconds: Dict[str, float] = {}
        while len(seconds) < len(procs):  # each one's own wall time, whichever ends first
            for name, (proc, _, _, start) in procs.items():
                if name not in seconds and proc.poll() is not None:
                    seconds[name] = time.monotonic() - start
            time.sleep(0.005)
        rates = {}
        for name, (proc, out, log, _) in procs.items():
            log.seek(0)
            output = log.read()
            log.close()
            if proc.returncode != 0:
                what = "bench" if state is not None else "run"
                raise PairedError(f"the {name} binary's {what} failed (exit {proc.returncode}):\n{output.strip()[-2000:]}")
            if state is None:
                rates[name] = 1.0 / seconds[name]
                continue
            rates[name] = float(load_json(os.path.join(out, "bench.json"))["median_particle_steps_per_s"]["celldem-t1"])
        return rates


def run_round(old: str, new: str, deck: str, state: Optional[str], steps: int, warmup: int,
              scratch: Optional[str] = None) -> Dict[str, float]:
    """One round: both halves. Returns each binary's rate over the halves, each half's ratio and the round's."""
    cores = two_cores()
    first = run_half(old, new, deck, state, steps, warmup, cores, scratch)
    second = run_half(old, new, deck, state, steps, warmup, cores[::-1], scratch)
    ratio = math.sqrt(first["new"] / first["old"] * second["new"] / second["old"])
    return {"old": math.sqrt(first["old"] * second["old"]), "new": math.sqrt(first["new"] * second["new"]),
            "ratio": ratio, "first_half": first["new"] / first["old"], "second_half": second["new"] / second["old"]}
