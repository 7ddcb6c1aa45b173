"""A roofline measurement of celldem's time step on one core (tools/roofline.py): per particle-step and per kernel,
the instructions retired and floating-point operations (callgrind, with every executed instruction classified from
the binary's disassembly), the bytes moved (the compulsory traffic of the data layout, and a cache simulation),
against the core's roofs (clock, vector FMA peak and triad bandwidths, measured by roofline_probe.cpp) and the
throughput the bench achieves natively.

Caveat built into the method: valgrind does not emulate AVX-512, so under it the `target_clones` pair law
(evaluate_chunk) runs its x86-64-v3 (AVX2) clone, natively the x86-64-v4 (AVX-512) one. The law is the same
operation for operation in any lane width (contact/contact_law.hpp), so the flop count holds for both; the
instruction count is the AVX2 clone's.
"""

import hashlib
import json
import os
import re
import shutil
import subprocess
import tempfile
from collections import Counter
from pathlib import Path

from ..files import load_json
from ..reports import plotting
from ..reports.tables import md_table

# Collection is switched on inside the step function: the first of these the binary has (advance_steps runs many
# steps in one parallel region; advance_one_step is the older one-step form). Steps are counted by the calls of
# advance_cell (stage 1 of every step, in its own translation unit), rebuilds by those of rebuild_pairs.
STEP_FUNCTIONS = ("celldem::advance_steps(", "celldem::advance_one_step(")
STEP_COUNTER = "celldem::advance_cell("
REBUILD = "celldem::rebuild_pairs("

# The kernels of a step, in step order, and the function names (callgrind's and perf's) that belong to each; the
# first kernel whose pattern is in a name takes it. `pair_loop` is what the pair loop (pair_loop, or
# evaluate_share in the newer code) does around the three chunk functions (block bounds, zeroing the owners' sums).
KERNELS = (
    ("drift", "drift", ("celldem::drift", "::drift_range")),
    ("neighbour", "neighbour list (check, rebuild)", ("PairSearch", "find_candidates", "rebuild_pairs",
                                                      "pairs_need_rebuild", "Candidate")),
    ("gather_chunk", "gather_chunk, chunk_owners", ("gather_chunk", "chunk_owners")),
    ("evaluate_chunk", "evaluate_chunk (pair law)", ("evaluate_chunk",)),
    ("sum_chunk", "sum_chunk", ("sum_chunk",)),
    ("pair_loop", "pair loop, rest (blocks, zeroing)", ("pair_loop", "evaluate_share", "ContactForceEvaluation")),
    ("gather_and_kick_range", "gather_and_kick_range", ("gather_and_kick", "::kick_range")),
    ("other", "other", ()),
)
KERNEL_KEYS = tuple(k for k, _, _ in KERNELS)

# The arrays a step touches (solver/core/state.hpp, solver/core/model.hpp): name, bytes per element, one element
# per particle or per listed pair, the step's access (R: a value from the last step is read; W: written; "": only
# memory), and each kernel's access (contact/contact_forces.cpp, integrate/leapfrog.cpp, step.cpp). Compulsory
# traffic: each array read once and/or written once, in the step or in a kernel; the pair loop's per-chunk
# scratch (ChunkIn, ChunkOut: a few KiB, in L1) is not memory traffic. The footprint of this table is checked
# against the bench's own count of bytes per particle, so a layout change that it misses is reported.
ARRAYS = (
    ("radius", 8, "particle", "R", {"gather_chunk": "R"}),
    ("scaled", 24, "particle", "RW", {"drift": "RW", "gather_chunk": "R"}),
    ("velocity", 24, "particle", "RW", {"drift": "R", "gather_chunk": "R", "gather_and_kick_range": "RW"}),
    ("spin", 24, "particle", "RW", {"gather_chunk": "R", "gather_and_kick_range": "RW"}),
    ("force", 24, "particle", "W", {"gather_and_kick_range": "W"}),
    ("torque", 24, "particle", "W", {"gather_and_kick_range": "W"}),
    ("pairs.scaled_at_build", 12, "particle", "R", {"drift": "R"}),  # 3 x float
    ("pairs.first", 4, "particle", "R", {"gather_chunk": "R", "gather_and_kick_range": "R"}),  # the owners' rows
    ("pairs.incoming_first", 4, "particle", "R", {"gather_and_kick_range": "R"}),
    ("pairs.incoming_crossing", 4, "particle", "R", {"gather_and_kick_range": "R"}),
    ("model.velocity_keep, velocity_gain, spin_keep, spin_gain", 32, "particle", "R", {"gather_and_kick_range": "R"}),
    ("pairs.neighbor", 4, "pair", "R", {"gather_chunk": "R"}),
    ("pairs.image", 6, "pair", "R", {"gather_chunk": "R"}),  # PairImage: 3 x int16
    ("pairs.tangential", 24, "pair", "RW", {"evaluate_chunk": "RW"}),
    ("pairs.flags", 1, "pair", "W", {"sum_chunk": "W"}),
    # Each pair's force and moments, written by the law and summed into both ends by the kick (each end reads
    # the force: the second read is not counted).
    ("pairs.force", 24, "pair", "W", {"evaluate_chunk": "W", "gather_and_kick_range": "R"}),
    ("pairs.torque_i", 24, "pair", "W", {"evaluate_chunk": "W", "gather_and_kick_range": "R"}),
    ("pairs.torque_j", 24, "pair", "W", {"evaluate_chunk": "W", "gather_and_kick_range": "R"}),
    ("pairs.incoming_pair", 4, "pair", "R", {"gather_and_kick_range": "R"}),
)

CALLGRIND_STEPS = 200     # steps under callgrind (about 20 s with the cache simulation on 8000 spheres)
# Steps before them, run without instrumentation (the bench starts it with callgrind's client request): the list's
# first list, built with the deck's skin, lasts some 5000 steps of the paper's TTC (3.36 listed pairs per particle
# against 2.7-2.8 once the skin has adapted), and the counts must be those of the adapted lists, as a run's are.
CALLGRIND_WARMUP = 10000
BENCH_STEPS, BENCH_WARMUP, BENCH_REPEATS = 5000, 10000, 3
LARGE_COPIES = 8          # the larger sample of the cache simulation: 8 periodic copies (64,000 spheres)
LINE = 64                 # [B] cache line


class RooflineError(RuntimeError):
    """A tool is missing or a measurement failed; the message says which and why."""


def quantity(value, unit, how):
    """A number as roofline.json holds it: with its unit and how it was obtained."""
    return {"value": value, "unit": unit, "how": how}


# ---- running things ----

def require(tools):
    """A clear error naming each of the command-line tools that is not on PATH (and its Debian package)."""
    hints = {"valgrind": "apt-get install valgrind", "objdump": "apt-get install binutils",
             "g++": "apt-get install g++", "perf": "apt-get install linux-perf"}
    missing = [f"{tool} ({hints.get(tool, 'install it')})" for tool in tools if shutil.which(tool) is None]
    if missing:
        raise RooflineError("roofline needs " + ", ".join(missing) + " on PATH")


def run(cmd, what):
    """Runs cmd single-threaded (OMP_NUM_THREADS=1); its stdout, or an error naming `what` and the output's end."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
    r = subprocess.run([str(c) for c in cmd], env=env, text=True, capture_output=True)
    if r.returncode != 0:
        tail = "\n".join(((r.stdout or "") + (r.stderr or "")).strip().splitlines()[-15:])
        raise RooflineError(f"{what} failed (exit {r.returncode}): {' '.join(map(str, cmd))}\n{tail}")
    return r.stdout


def bench_command(celldem, deck, state, out, steps, warmup, repeats, extra=()):
    """`celldem bench` on one thread, writing out/bench.json."""
    return [celldem, "bench", "--deck", deck, "--state", state, "--threads", "1", "--steps", steps,
            "--warmup", warmup, "--repeats", repeats, "--out", out, "--force", *extra]


def callgrind(bench_cmd, out_file, toggle, cache_sim=False, extra=()):
    """The bench under callgrind, collecting only inside `toggle` (a function pattern), one cost per instruction.
    The simulated caches are this core's L1d and L2 (read from sysfs), so LL misses are what comes from beyond L2."""
    cmd = ["valgrind", "--tool=callgrind", "--dump-instr=yes", "--collect-atstart=no",
           f"--toggle-collect={toggle}", f"--callgrind-out-file={out_file}", *extra]
    if cache_sim:
        caches = cache_sizes()
        cmd += ["--cache-sim=yes", "--I1=32768,8,64", f"--D1={caches['L1d']},{caches['L1d_ways']},{LINE}",
                f"--LL={caches['L2']},{caches['L2_ways']},{LINE}"]
    run(cmd + [str(c) for c in bench_cmd], "callgrind")


# ---- callgrind's output ----

class Profile:
    """A callgrind output file: `costs` maps (object, function, instruction address) to its self cost (one count
    per event of `events`), `calls` counts the calls into each function, `summary` is the file's total."""

    def __init__(self, events, summary, costs, calls):
        self.events, self.summary, self.costs, self.calls = events, summary, costs, calls

    def event(self, cost, name):
        k = self.events.index(name)
        return cost[k] if k < len(cost) else 0

    def calls_into(self, prefix):
        return sum(n for fn, n in self.calls.items() if fn.startswith(prefix))


def parse_callgrind(text):
    """Parses callgrind's format (valgrind.org/docs/manual/cl-format.html): name compression "(id) name",
    relative positions ("+3", "-2", "*"), and the cost line after `calls=` (the call's inclusive cost: not self cost)."""
    events, positions, summary = [], ["line"], []
    names = {"ob": {}, "fn": {}}
    share = {"ob": "ob", "cob": "ob", "fn": "fn", "cfn": "fn"}
    current = {"ob": None, "fn": None, "cfn": None}
    costs, calls = {}, Counter()
    last = None
    after_calls = False
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        head = re.match(r"(\w+):\s*(.*)", line)  # "events: Ir ..." (header); body lines are "key=value"
        if head:
            key, value = head.groups()
            if key == "events":
                events = value.split()
            elif key == "positions":
                positions = value.split()
            elif key in ("summary", "totals"):
                summary = [int(v) for v in value.split()]
            continue
        if line[0].isdigit() or line[0] in "+-*":
            if "instr" not in positions:
                raise RooflineError("callgrind output without instruction addresses (run with --dump-instr=yes)")
            parts = line.split()
            pos, values = parts[:len(positions)], [int(v) for v in parts[len(positions):]]
            if last is None:
                last = [0] * len(positions)
            for k, p in enumerate(pos):
                if p == "*":
                    continue
                last[k] = last[k] + int(p, 0) if p[0] in "+-" else int(p, 0)
            if after_calls:  # the inclusive cost of the call just named
                after_calls = False
                continue
            key = (current["ob"], current["fn"], last[positions.index("instr")])
            cost = costs.setdefault(key, [0] * len(events))
            for k, v in enumerate(values):
                cost[k] += v
            continue
        key, _, value = line.partition("=")
        if key == "calls":
            calls[current["cfn"]] += int(value.split()[0])
            after_calls = True
        elif key in share:
            m = re.match(r"\((\d+)\)\s*(.*)", value)
            table = names[share[key]]
            if m and m.group(2):
                table[m.group(1)] = m.group(2)
            name = table.get(m.group(1), m.group(1)) if m else value
            if key in current:
                current[key] = name
    if not events:
        raise RooflineError("not a callgrind output (no events line)")
    return Profile(events, summary, costs, calls)


# ---- floating-point operations from the disassembly ----

# Double-precision arithmetic as Intel's FP_ARITH_INST_RETIRED counts it: add, sub, mul, div, sqrt, min, max (and
# horizontal forms, reciprocal estimates), one flop per lane; FMA two per lane. Compares, blends, logic (abs,
# negation), conversions and moves are not flops.
_ARITH = re.compile(r"v?(add|sub|mul|div|sqrt|min|max|hadd|hsub|addsub|rcp14|rsqrt14)([ps])d$")
_FMA = re.compile(r"vf(n?madd|n?msub|maddsub|msubadd)(132|213|231)?([ps])d$")
_PREFIXES = {"lock", "rep", "repz", "repe", "repnz", "repne", "notrack", "bnd", "data16", "addr32", "{vex}",
             "{vex3}", "{evex}", "cs", "ds", "es", "ss", "fs", "gs"}
_LANES = (("%zmm", 8), ("%ymm", 4), ("%xmm", 2))


def flops_of(mnemonic, operands):
    """(flops, packed, operation) for one execution of a double-precision arithmetic instruction (AT&T syntax, as
    objdump prints it), None for any other. Lanes from the widest register named: zmm 8, ymm 4, xmm 2; scalar (..sd)
    1. A masked AVX-512 operation is counted at full width. operation: "fma", or the arithmetic's name ("add",
    "div", "sqrt", ...): divisions and square roots share one slow, partly pipelined unit."""
    fma = _FMA.match(mnemonic)
    m = fma or _ARITH.match(mnemonic)
    if not m:
        return None
    packed = m.groups()[-1] == "p"
    lanes = next((n for reg, n in _LANES if reg in operands), 1) if packed else 1
    return lanes * (2 if fma else 1), packed, "fma" if fma else m.group(1)


def flop_table(disassembly):
    """{address: flops_of(...)} for the double-precision arithmetic instructions of `objdump -d` output."""
    table = {}
    for line in disassembly.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(.*)", line)
        if not m:
            continue
        tokens = m.group(2).split("#", 1)[0].split()
        while tokens and (tokens[0] in _PREFIXES or tokens[0].startswith("rex")):
            tokens = tokens[1:]
        if tokens:
            f = flops_of(tokens[0], " ".join(tokens[1:]))
            if f:
                table[int(m.group(1), 16)] = f
    return table


def kernel_of(function):
    """The kernel (KERNEL_KEYS) a function name belongs to."""
    for key, _, patterns in KERNELS:
        if any(p in (function or "") for p in patterns):
            return key
    return "other"


def attribute(profile, flops_at, objects):
    """Per kernel: instructions, flops (of the instructions in `objects`, the celldem binary), flops of packed
    instructions, division and square-root lane-operations, instructions without a flop table (other objects: libc,
    libgomp), and with a cache simulation the L1d and LL data misses."""
    out = {k: Counter() for k in KERNEL_KEYS}
    cache = "D1mr" in profile.events
    for (ob, fn, addr), cost in profile.costs.items():
        row = out[kernel_of(fn)]
        executed = profile.event(cost, "Ir")
        row["instructions"] += executed
        if ob in objects:
            f = flops_at.get(addr)
            if f:
                flops, packed, operation = f
                row["flops"] += executed * flops
                row["packed_flops"] += executed * flops if packed else 0
                if operation in ("div", "sqrt"):
                    row[operation + "_lanes"] += executed * flops
        else:
            row["instructions_elsewhere"] += executed
        if cache:
            row["d1_misses"] += profile.event(cost, "D1mr") + profile.event(cost, "D1mw")
            row["ll_misses"] += profile.event(cost, "DLmr") + profile.event(cost, "DLmw")
    total = sum(r["instructions"] for r in out.values())
    if profile.summary and total != profile.summary[0]:
        raise RooflineError(f"callgrind parse: self costs sum to {total} instructions, the file says {profile.summary[0]}")
    return out


# ---- bytes ----

def compulsory_bytes(pairs_per_particle):
    """Bytes per particle-step that each kernel and the whole step must move at least (ARRAYS: a read and a write
    count twice), the bytes of the arrays the step touches (each once: what a cache must bring in, write-backs
    aside) and the footprint of all the arrays, per particle."""
    def size(nbytes, per):
        return nbytes * (pairs_per_particle if per == "pair" else 1.0)
    kernels = Counter()
    step = touched = footprint = 0.0
    for _, nbytes, per, step_access, access in ARRAYS:
        footprint += size(nbytes, per)
        step += size(nbytes, per) * len(step_access)
        touched += size(nbytes, per) if step_access else 0.0
        for kernel, a in access.items():
            kernels[kernel] += size(nbytes, per) * len(a)
    return {"kernels": dict(kernels), "step": step, "touched": touched, "footprint": footprint}


# ---- the machine ----

def cache_sizes():
    """This core's L1d, L2 and L3 sizes [B] and ways (sysfs; Sapphire Rapids values where it says nothing)."""
    sizes = {"L1d": 48 << 10, "L1d_ways": 12, "L2": 2 << 20, "L2_ways": 16, "L3": None}
    base = Path("/sys/devices/system/cpu/cpu0/cache")
    for index in sorted(base.glob("index*")) if base.is_dir() else []:
        try:
            level, kind = (index / "level").read_text().strip(), (index / "type").read_text().strip()
            size = (index / "size").read_text().strip()
            ways = int((index / "ways_of_associativity").read_text().strip() or 0)
        except OSError:
            continue
        nbytes = int(size[:-1]) << {"K": 10, "M": 20}.get(size[-1], 0) if size[-1] in "KM" else int(size)
        name = {("1", "Data"): "L1d", ("2", "Unified"): "L2", ("3", "Unified"): "L3"}.get((level, kind))
        if name:
            sizes[name] = nbytes
            if name in ("L1d", "L2") and ways:
                sizes[name + "_ways"] = ways
    return sizes


def cpu_description():
    """Model name and the vector ISA from /proc/cpuinfo."""
    text = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    model = re.search(r"model name\s*:\s*(.*)", text)
    flags = re.search(r"flags\s*:\s*(.*)", text)
    flags = set(flags.group(1).split()) if flags else set()
    return (model.group(1).strip() if model else "unknown"), flags


def peak_flops_per_cycle(flags):
    """Double-precision flops per cycle of one core from its ISA, assuming two FMA pipes (Intel Xeon Gold/Platinum,
    Skylake-SP and later; AMD Zen): 2 pipes x lanes x 2 flops."""
    if "avx512f" in flags:
        return 32, "AVX-512 (avx512f in /proc/cpuinfo): 2 FMA pipes x 8 lanes x 2 flops; assumed, see the measured FMA rate"
    if "avx2" in flags and "fma" in flags:
        return 16, "AVX2+FMA: 2 FMA pipes x 4 lanes x 2 flops; assumed"
    return 4, "SSE2: an add and a mul pipe x 2 lanes; assumed"


def probe_machine(caches):
    """Compiles (in a temporary folder) and runs roofline_probe.cpp: the clock, the FMA rate and triad bandwidths
    with arrays that fit in L2, sit in L3, and are far beyond every cache (3 x 256 MiB)."""
    sizes = {"L2": int(caches["L2"] * 0.75), "L3": 8 * caches["L2"], "DRAM": 3 * (256 << 20)}
    if caches.get("L3") and sizes["L3"] > caches["L3"] // 2:
        sizes["L3"] = caches["L3"] // 2
    with tempfile.TemporaryDirectory() as tmp:
        exe = Path(tmp) / "roofline_probe"
        # -O3 so that the triad is vectorised (a roof is the best a loop can do); the clock chain is inline asm.
        run(["g++", "-O3", "-march=native", "-std=c++17", "-o", exe, Path(__file__).with_name("roofline_probe.cpp")],
            "compiling roofline_probe.cpp")
        text = run([exe, *sizes.values()], "roofline_probe")
    got, triad = {}, {}
    for line in text.splitlines():
        parts = line.split()
        if parts[0] == "triad_gbs":
            triad[int(parts[1])] = float(parts[2])
        else:
            got[parts[0]] = float(parts[1])
    got["triad_gbs"] = {level: triad[nbytes] for level, nbytes in sizes.items()}
    got["triad_bytes"] = sizes
    return got, text


# ---- the native measurements ----

def native_bench(celldem, deck, state, workdir, steps, warmup, repeats):
    """The bench's median particle-steps/s on one thread, and its bench.json."""
    out = Path(workdir) / "bench-native"
    run(bench_command(celldem, deck, state, out, steps, warmup, repeats), "the native bench")
    report = load_json(out / "bench.json")
    return report["median_particle_steps_per_s"]["celldem-t1"], report


def perf_shares(celldem, deck, state, workdir, steps, warmup):
    """Each kernel's share of the step's CPU time: `perf record -e cpu-clock` on the bench, self samples per symbol
    (perf report --no-children), shares among the step's kernels ('other' holds start-up too, so it is left out
    and the shares sum to 1). None (with the reason) where perf cannot record here."""
    data = Path(workdir) / "perf.data"
    try:
        run(["perf", "record", "-e", "cpu-clock", "-g", "-o", data, "--",
             *bench_command(celldem, deck, state, Path(workdir) / "bench-perf", steps, warmup, 1)], "perf record")
        text = run(["perf", "report", "-i", data, "--no-children", "--stdio", "--sort", "symbol", "-g", "none",
                    "--percent-limit", "0"], "perf report")
    except RooflineError as err:
        return None, str(err).splitlines()[0]
    samples = Counter()
    for line in text.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+\[.\]\s+(.*)", line)
        if m:
            samples[kernel_of(m.group(2))] += float(m.group(1))
    step = sum(v for k, v in samples.items() if k != "other")
    if step <= 0:
        return None, "perf recorded no samples in the step's kernels"
    shares = {k: samples[k] / step for k in KERNEL_KEYS if k != "other"}
    return shares, f"perf: {samples['other']:.1f} % of the samples outside the step's kernels (start-up, kernel)"


# ---- the measurement ----

def step_function(disassembly):
    """The toggle pattern of the first of STEP_FUNCTIONS that the binary defines (objdump's function labels). It
    ends in "(*)" so that it does not also match the function's OpenMP body ("... [clone ._omp_fn.0]"), which runs
    inside it: entering a second toggled function would switch collection off again."""
    for name in STEP_FUNCTIONS:
        if f"<{name}" in disassembly:
            return name + "*)"
    raise RooflineError(f"the binary defines none of {', '.join(n[:-1] for n in STEP_FUNCTIONS)}: "
                        "update STEP_FUNCTIONS in tools/celldem/performance/roofline.py")


def steps_in(profile, what):
    """The steps a callgrind profile collected: the calls of advance_cell."""
    steps = profile.calls_into(STEP_COUNTER)
    if steps <= 0:
        raise RooflineError(f"no call of {STEP_COUNTER[:-1]} in {what}: a celldem built without valgrind's header "
                            "(valgrind/callgrind.h) never starts the instrumentation of its timed steps (install "
                            "valgrind and rebuild), or the step has another name (update STEP_COUNTER in "
                            "tools/celldem/performance/roofline.py)")
    return steps


def totals(per_kernel):
    """The sum of attribute()'s rows: the whole step."""
    whole = Counter()
    for row in per_kernel.values():
        whole.update(row)
    return whole


def rebuild_cost(celldem, deck, state, workdir, flops_at, objects):
    """Instructions and flops of one neighbour-list rebuild: callgrind inside rebuild_pairs on a one-step bench,
    which rebuilds once before its steps (a rebuild within a step runs the same code on the same sample)."""
    path = workdir / "callgrind.rebuild.out"
    callgrind(bench_command(celldem, deck, state, workdir / "bench-rebuild", 1, 0, 1), path, REBUILD + "*)")
    profile = parse_callgrind(path.read_text())
    calls = profile.calls_into(REBUILD)
    if calls <= 0:
        raise RooflineError(f"no call of {REBUILD[:-1]} in {path}: update REBUILD in tools/celldem/performance/roofline.py")
    whole = totals(attribute(profile, flops_at, objects))
    return {"instructions": whole["instructions"] / calls, "flops": whole["flops"] / calls, "calls_measured": calls}


def large_sample(celldem, deck, state, workdir, copies, toggle, flops_at, objects):
    """The cache simulation on `copies` periodic copies of the sample as given (bench --scaling --tile-after 0): per
    particle-step instructions, flops and bytes. The bench first runs one step of the sample itself: --dump-before writes that
    to callgrind.large.out.1 before the copies are made, and callgrind.large.out holds the copies' steps."""
    path, bench = workdir / "callgrind.large.out", workdir / "bench-large"
    callgrind(bench_command(celldem, deck, state, bench, 1, 0, 1, ("--scaling", "--copies", copies, "--tile-after", 0)),
              path, toggle,
              cache_sim=True, extra=("--dump-before=celldem::tile_state*",))
    profile = parse_callgrind(path.read_text())
    row = load_json(bench / "bench.json")["scaling"][0]
    whole = totals(attribute(profile, flops_at, objects))
    steps = steps_in(profile, path)
    particle_steps = steps * row["particles"]
    return {"particles": row["particles"], "steps": steps, "pairs_per_particle": row["pairs_per_particle"],
            "crossings_per_particle": row["crossings_per_particle"],
            "footprint_bytes": row["bytes_per_particle"] * row["particles"],
            "instructions_per_particle_step": whole["instructions"] / particle_steps,
            "flops_per_particle_step": whole["flops"] / particle_steps,
            "compulsory_bytes_per_particle_step": compulsory_bytes(row["pairs_per_particle"])["step"],
            "d1_miss_bytes_per_particle_step": LINE * whole["d1_misses"] / particle_steps,
            "ll_miss_bytes_per_particle_step": LINE * whole["ll_misses"] / particle_steps}


def measure(celldem, deck, state, workdir, callgrind_steps=CALLGRIND_STEPS, bench_steps=BENCH_STEPS,
            bench_warmup=BENCH_WARMUP, bench_repeats=BENCH_REPEATS, copies=LARGE_COPIES, log=print,
            callgrind_warmup=CALLGRIND_WARMUP):
    """Runs every measurement (raw outputs in workdir) and returns what roofline.json holds."""
    require(("valgrind", "objdump", "g++"))
    workdir = Path(workdir)
    m = {"deck": str(deck), "state": str(state), "celldem": str(celldem), "callgrind_steps": callgrind_steps,
         "callgrind_warmup": callgrind_warmup,
         "bench": (bench_steps, bench_warmup, bench_repeats), "load_start": os.getloadavg()[0], "notes": []}
    # Every measurement on one copy of the binary: a rebuild of build/ meanwhile cannot mix two versions.
    celldem = workdir / "celldem"
    shutil.copy2(m["celldem"], celldem)
    m["sha256"] = hashlib.sha256(celldem.read_bytes()).hexdigest()
    m["caches"] = cache_sizes()
    m["cpu"], flags = cpu_description()
    m["peak_per_cycle"] = peak_flops_per_cycle(flags)

    log("1/6 machine: clock, FMA and divider rates, triad bandwidths (roofline_probe.cpp)")
    m["probe"], text = probe_machine(m["caches"])
    (workdir / "probe.txt").write_text(text)

    log("2/6 objdump: the binary's floating-point instructions")
    disassembly = run(["objdump", "-d", "--no-show-raw-insn", "-C", celldem], "objdump")
    flops_at = flop_table(disassembly)
    m["toggle"] = step_function(disassembly)

    log(f"3/6 callgrind with the cache simulation: {callgrind_steps} steps after {callgrind_warmup} uninstrumented, "
        f"collected in {m['toggle']}")
    path, bench = workdir / "callgrind.step.out", workdir / "bench-callgrind"
    callgrind(bench_command(celldem, deck, state, bench, callgrind_steps, callgrind_warmup, 1), path, m["toggle"],
              cache_sim=True, extra=("--instr-atstart=no",))
    profile = parse_callgrind(path.read_text())
    m["sample"] = load_json(bench / "bench.json")
    m["steps"] = steps_in(profile, path)
    if m["steps"] != callgrind_steps:
        m["notes"].append(f"callgrind collected {m['steps']} steps for the bench's {callgrind_steps}: divided by "
                          f"{m['steps']}")
    objects = {ob for ob, _, _ in profile.costs if ob and os.path.realpath(ob) == os.path.realpath(celldem)}
    if not objects:
        raise RooflineError(f"{path} names no object {celldem}: is it the binary that ran?")
    m["per_kernel"] = attribute(profile, flops_at, objects)

    log("4/6 callgrind: one neighbour-list rebuild")
    m["rebuild"] = rebuild_cost(celldem, deck, state, workdir, flops_at, objects)

    m["large"] = None
    if copies > 1:
        log(f"5/6 callgrind with the cache simulation: {copies} periodic copies of the sample")
        m["large"] = large_sample(celldem, deck, state, workdir, copies, m["toggle"], flops_at, objects)
    else:
        log("5/6 (larger sample skipped)")

    log(f"6/6 native bench ({bench_steps} steps after {bench_warmup}, {bench_repeats} repeats) and perf profile")
    m["pss"], m["native"] = native_bench(celldem, deck, state, workdir, bench_steps, bench_warmup, bench_repeats)
    shares, note = perf_shares(celldem, deck, state, workdir, bench_steps, bench_warmup) if shutil.which("perf") \
        else (None, "perf not on PATH: no time shares")
    m["shares"] = shares
    m["notes"].append(note)
    m["load_end"] = os.getloadavg()[0]
    return summarise(m)


def kernel_row(key, label, counts, bytes_ps, share, particle_steps, roofs):
    """One kernel (or the whole step) per particle-step, and natively against the roofs: `counts` from attribute(),
    `share` of the step's time (None without perf)."""
    instr, flops = counts["instructions"] / particle_steps, counts["flops"] / particle_steps
    d1, ll = LINE * counts["d1_misses"] / particle_steps, LINE * counts["ll_misses"] / particle_steps
    t = share * roofs["seconds_per_ps"] if share is not None else None
    rate = flops / t if t else None
    # The least time the divider needs for the kernel's divisions and square roots (they share the unit).
    divider = (counts["div_lanes"] / roofs["div"] + counts["sqrt_lanes"] / roofs["sqrt"]) / particle_steps \
        if roofs["div"] and roofs["sqrt"] else None
    return {"kernel": key, "label": label,
            "instructions_per_particle_step": instr,
            "flops_per_particle_step": flops,
            "packed_flop_fraction": counts["packed_flops"] / counts["flops"] if counts["flops"] else None,
            "div_sqrt_per_particle_step": (counts["div_lanes"] + counts["sqrt_lanes"]) / particle_steps,
            "compulsory_bytes_per_particle_step": bytes_ps,
            "d1_miss_bytes_per_particle_step": d1,
            "ll_miss_bytes_per_particle_step": ll,
            "arithmetic_intensity": flops / bytes_ps if bytes_ps else None,
            "arithmetic_intensity_l2": flops / d1 if d1 else None,
            "time_share": share,
            "seconds_per_particle_step": t,
            "ipc": instr / (roofs["clock"] * t) if t else None,
            "flops_per_second": rate,
            "percent_of_compute_roof": 100 * rate / roofs["peak"] if rate else None,
            "percent_of_bandwidth_roof": 100 * bytes_ps / t / roofs["bw"][roofs["level"]] if t and bytes_ps else None,
            "percent_of_l2_roof": 100 * d1 / t / roofs["bw"]["L2"] if t and d1 else None,
            "percent_divider_bound": 100 * divider / t if t and divider is not None else None}


def summarise(m):
    """roofline.json from measure()'s raw results: per kernel and for the step, per particle-step and against the
    roofs, every number with its unit and how it was obtained."""
    sample, notes = m["sample"], m["notes"]
    particle_steps = m["steps"] * sample["particles"]
    add_rebuild(m)
    compulsory = compulsory_bytes(sample["pairs_per_particle"])
    notes += layout_notes(m, compulsory)
    roofs = machine_roofs(m)
    shares = m["shares"] or {}
    kernels = [kernel_row(key, label, m["per_kernel"][key], compulsory["kernels"].get(key, 0.0), shares.get(key),
                          particle_steps, roofs) for key, label, _ in KERNELS]
    step = kernel_row("step", "whole step", totals(m["per_kernel"]), compulsory["step"], 1.0, particle_steps, roofs)
    law = next(k for k in kernels if k["kernel"] == "evaluate_chunk")
    return {
        "scene": scene_summary(m, roofs),
        "machine": machine_summary(m, roofs),
        "per_particle_step": step_summary(m, step, compulsory),
        "pair_law": pair_law_summary(m, law, roofs),
        "achieved": achieved_summary(m, step, compulsory, roofs),
        "bandwidth_level": roofs["level"],
        "kernels": kernels,
        "step": step,
        "rebuild": m["rebuild"],
        "large_sample": m["large"],
        "definitions": definitions(roofs["level"]),
        "notes": notes,
    }


def add_rebuild(m):
    """The neighbour-list rebuild, measured once, added to the neighbour kernel at the native bench's rate unless
    the callgrind steps had some; notes what it did and what ran outside the binary."""
    per_kernel, steps, sample, native, notes = m["per_kernel"], m["steps"], m["sample"], m["native"], m["notes"]
    particle_steps = steps * sample["particles"]
    rebuild = m["rebuild"]
    rebuild["rebuilds_per_step"] = native.get("rebuilds", 0) / native["steps"]
    if sample.get("rebuilds", 0) == 0:
        for what in ("instructions", "flops"):
            per_kernel["neighbour"][what] += rebuild[what] * rebuild["rebuilds_per_step"] * steps
        notes.append(f"neighbour list: the {steps} callgrind steps had no rebuild; one rebuild "
                     f"({rebuild['instructions']:.3g} instructions, {rebuild['flops']:.3g} flops) is added at the "
                     f"native bench's rate ({native.get('rebuilds', 0)} in {native['steps']} steps)")
    else:
        notes.append(f"neighbour list: the callgrind steps hold {sample['rebuilds']} rebuild(s), counted as measured")
    elsewhere = sum(r["instructions_elsewhere"] for r in per_kernel.values()) / particle_steps
    if elsewhere:
        notes.append(f"{elsewhere:.3g} instructions per particle-step ran outside the celldem binary (libc, libgomp): "
                     "counted as instructions, their flops (if any) not")


def layout_notes(m, compulsory):
    """The notes on the layout table (ARRAYS) against the bench's byte count, and on the simulated L2 misses
    against the bytes the step touches."""
    per_kernel, sample, notes = m["per_kernel"], m["sample"], []
    particles = sample["particles"]
    particle_steps = m["steps"] * particles
    if abs(compulsory["footprint"] - sample["bytes_per_particle"]) > 0.02 * sample["bytes_per_particle"]:
        notes.append(f"WARNING: the layout table (ARRAYS in tools/celldem/performance/roofline.py) holds "
                     f"{compulsory['footprint']:.0f} bytes per particle, the bench counts "
                     f"{sample['bytes_per_particle']:.0f}: the compulsory bytes are out of date")
    # Simulated L2 misses against the touched bytes: about 1 when every array comes from beyond L2 once a step.
    ratios = [f"{totals(per_kernel)['ll_misses'] * LINE / particle_steps / compulsory['touched']:.2f} x on "
              f"{particles} spheres"]
    if m["large"]:
        large = m["large"]
        touched = compulsory_bytes(large["pairs_per_particle"])["touched"]
        ratios.append(f"{large['ll_miss_bytes_per_particle_step'] / touched:.2f} x on {large['particles']}")
    notes.append(f"the simulated L2-miss bytes are {' and '.join(ratios)} the bytes of the arrays the step touches "
                 f"({compulsory['touched']:.0f} B per particle-step, each array once, write-backs aside)")
    return notes


def machine_roofs(m):
    """The roofs the kernels are held against: clock, peak flops, the bandwidth level of the sample's footprint,
    the triad bandwidths and the divider rates, and the native seconds per particle-step."""
    probe, caches, sample = m["probe"], m["caches"], m["sample"]
    footprint = sample["bytes_per_particle"] * sample["particles"]
    level = "L2" if footprint <= caches["L2"] else \
        ("L3" if caches.get("L3") and footprint <= caches["L3"] else "DRAM")
    per_cycle = m["peak_per_cycle"][0]
    clock = probe["clock_ghz"] * 1e9
    return {"clock": clock, "peak": per_cycle * clock, "level": level, "seconds_per_ps": 1.0 / m["pss"],
            "bw": {k: v * 1e9 for k, v in probe["triad_gbs"].items()},
            "div": probe.get("div_glanes", 0) * 1e9, "sqrt": probe.get("sqrt_glanes", 0) * 1e9,
            "footprint": footprint}


HOW_PROBE = "roofline_probe.cpp (g++ -O3 -march=native)"


def scene_summary(m, roofs):
    """roofline.json's scene: the deck, state, binary and the sample's pairs, contacts and footprint."""
    sample, level = m["sample"], roofs["level"]
    return {
        "deck": m["deck"], "state": m["state"], "celldem": m["celldem"], "celldem_sha256": m["sha256"],
        "particles": sample["particles"],
        "pairs_per_particle": quantity(sample["pairs_per_particle"], "listed pairs / particle",
                                       "bench.json of the callgrind run (half list)"),
        "contacts_per_particle": quantity(sample["contacts_per_particle"], "contacts / particle",
                                          "bench.json of the callgrind run"),
        "footprint": quantity(roofs["footprint"], "B", f"bench.json bytes_per_particle x particles: in {level}")}


def machine_summary(m, roofs):
    """roofline.json's machine: the CPU, caches, clock, compute roof, divider and bandwidth roofs, the load."""
    probe, caches, how_probe = m["probe"], m["caches"], HOW_PROBE
    clock, (per_cycle, per_cycle_how) = roofs["clock"], m["peak_per_cycle"]
    return {
        "cpu": m["cpu"],
        "caches": caches,
        "clock": quantity(clock / 1e9, "GHz",
                          f"{how_probe}: a chain of dependent register adds, 1 cycle each, best of 5"),
        "peak_flops_per_cycle": quantity(per_cycle, "flop/cycle", per_cycle_how),
        "peak_flops": quantity(roofs["peak"] / 1e9, "GFlop/s", "peak_flops_per_cycle x clock (the compute roof)"),
        "measured_fma_flops": quantity(probe.get("fma_gflops"), "GFlop/s",
                                       f"{how_probe}: 16 independent {int(probe.get('fma_lanes', 0))}-lane FMA "
                                       "chains, best of 3"),
        "divider": {op: quantity(probe.get(f"{op}_glanes"), "G lane-operations/s",
                                 f"{how_probe}: 16 independent chains of vector {op}, best of 3")
                    for op in ("div", "sqrt")},
        "bandwidth": {k: quantity(v, "GB/s", f"{how_probe}: triad a = b + s c, 3 arrays of "
                                             f"{probe['triad_bytes'][k] / 3 / 2**20:.4g} MiB each, 24 B per "
                                             "element (STREAM's count), best of 7")
                      for k, v in probe["triad_gbs"].items()},
        "load_average": {"start": m["load_start"], "end": m["load_end"],
                         "note": "the machine's 1-minute load average: other jobs share the memory system"}}


def step_summary(m, step, compulsory):
    """roofline.json's per_particle_step: the whole step's instructions, flops, bytes and intensity."""
    pairs, caches, steps = m["sample"]["pairs_per_particle"], m["caches"], m["steps"]
    particles = m["sample"]["particles"]
    how_cg = (f"valgrind --tool=callgrind --dump-instr=yes --instr-atstart=no --toggle-collect={m['toggle']} on "
              f"`celldem bench --threads 1 --steps {m['callgrind_steps']} --warmup {m['callgrind_warmup']}` "
              "(instrumented from the timed steps on: the bench's client request), OMP_NUM_THREADS=1; divided by the steps "
              f"(calls of advance_cell: {steps}) x particles ({particles})")
    how_flops = ("every executed instruction of the celldem binary (callgrind's per-address counts) classified by its "
                 "mnemonic in `objdump -d`: double add/sub/mul/div/sqrt/min/max 1 flop per lane, FMA 2; lanes zmm 8, "
                 "ymm 4, xmm 2, scalar 1 (Intel's FP_ARITH_INST_RETIRED convention)")
    how_bytes = ("each array of the data layout (ARRAYS: solver/core/state.hpp, model.hpp) read once and/or written "
                 f"once per step, pair arrays x {pairs:.4g} listed pairs per particle; no write-allocate, no re-reads")
    how_cache = (f"callgrind --cache-sim=yes with this core's L1d ({caches['L1d'] >> 10} KiB) as D1 and its L2 "
                 f"({caches['L2'] >> 20} MiB) as LL: (misses, read and write) x {LINE} B; LRU, no prefetch, "
                 "write-backs not counted")
    return {
        "instructions": quantity(step["instructions_per_particle_step"], "instructions / particle-step",
                                 how_cg + "; evaluate_chunk is its AVX2 clone under valgrind (natively: AVX-512)"),
        "flops": quantity(step["flops_per_particle_step"], "flop / particle-step", how_flops),
        "compulsory_bytes": quantity(compulsory["step"], "B / particle-step", how_bytes),
        "touched_bytes": quantity(compulsory["touched"], "B / particle-step",
                                  "the arrays the step reads or writes, each counted once (ARRAYS)"),
        "d1_miss_bytes": quantity(step["d1_miss_bytes_per_particle_step"], "B / particle-step", how_cache),
        "ll_miss_bytes": quantity(step["ll_miss_bytes_per_particle_step"], "B / particle-step", how_cache),
        "arithmetic_intensity": quantity(step["arithmetic_intensity"], "flop / B", "flops / compulsory bytes")}


def pair_law_summary(m, law, roofs):
    """roofline.json's pair_law: evaluate_chunk per listed pair and per contact."""
    pairs, sample, clock = m["sample"]["pairs_per_particle"], m["sample"], roofs["clock"]
    return {
        "flops_per_pair": quantity(law["flops_per_particle_step"] / pairs, "flop / listed pair",
                                   "evaluate_chunk's flops / listed pairs (the law runs branch-free on every "
                                   "listed pair)"),
        "flops_per_contact": quantity(law["flops_per_particle_step"] / sample["contacts_per_particle"],
                                      "flop / contact", "evaluate_chunk's flops / touching pairs"),
        "div_sqrt_per_pair": quantity(law["div_sqrt_per_particle_step"] / pairs, "lane-operations / listed pair",
                                      "evaluate_chunk's divisions and square roots / listed pairs"),
        "instructions_per_pair": quantity(law["instructions_per_particle_step"] / pairs,
                                          "instructions / listed pair", "the AVX2 clone, 4 pairs per ymm instruction"),
        "cycles_per_pair": quantity(law["seconds_per_particle_step"] and
                                    law["seconds_per_particle_step"] * clock / pairs, "cycles / listed pair",
                                    "natively: evaluate_chunk's time share x cycles per particle-step / pairs"),
        "divider_cycles_per_pair": quantity(law["percent_divider_bound"] and law["seconds_per_particle_step"] and
                                            law["percent_divider_bound"] / 100 * law["seconds_per_particle_step"]
                                            * clock / pairs, "cycles / listed pair",
                                            "the least time of its divisions and square roots on the measured "
                                            "divider rates")}


def achieved_summary(m, step, compulsory, roofs):
    """roofline.json's achieved: the native rate against the roofs."""
    pss, clock, level = m["pss"], roofs["clock"], roofs["level"]
    bench_steps, bench_warmup, bench_repeats = m["bench"]
    return {
        "particle_steps_per_second": quantity(pss, "particle-steps / s",
                                              f"native `celldem bench --threads 1 --steps {bench_steps} --warmup "
                                              f"{bench_warmup} --repeats {bench_repeats}`, bench.json's median"),
        "cycles_per_particle_step": quantity(clock / pss, "cycles / particle-step",
                                             "clock / particle-steps per second"),
        "flops": quantity(step["flops_per_second"] / 1e9, "GFlop/s", "flops per particle-step x particle-steps/s"),
        "compulsory_bandwidth": quantity(compulsory["step"] * pss / 1e9, "GB/s",
                                         "compulsory bytes x particle-steps/s"),
        "l2_bandwidth": quantity(step["d1_miss_bytes_per_particle_step"] * pss / 1e9, "GB/s",
                                 "simulated L1d-miss bytes x particle-steps/s (traffic between L1 and L2)"),
        "ipc": quantity(step["ipc"], "instructions / cycle",
                        "valgrind's instructions (AVX2 clone of evaluate_chunk) / native cycles (AVX-512 clone): "
                        "mixed, a rough figure"),
        "percent_of_compute_roof": quantity(step["percent_of_compute_roof"], "%", "achieved flops / peak_flops"),
        "percent_of_bandwidth_roof": quantity(step["percent_of_bandwidth_roof"], "%",
                                              f"compulsory bandwidth / the {level} triad roof (the sample's "
                                              f"footprint is in {level})"),
        "percent_of_l2_roof": quantity(step["percent_of_l2_roof"], "%", "L1-L2 bandwidth / the L2 triad roof")}


def definitions(level):
    """What each column of a kernel row means (roofline.json's definitions)."""
    return {
        "instructions_per_particle_step": "callgrind Ir (see per_particle_step.instructions)",
        "flops_per_particle_step": "flop (see per_particle_step.flops)",
        "packed_flop_fraction": "share of the flops done by packed (SIMD) instructions",
        "div_sqrt_per_particle_step": "division and square-root lane-operations (included in the flops)",
        "compulsory_bytes_per_particle_step": "B, each array the kernel touches once (ARRAYS)",
        "d1_miss_bytes_per_particle_step": "B, simulated L1d misses x 64",
        "ll_miss_bytes_per_particle_step": "B, simulated L2 misses x 64",
        "arithmetic_intensity": "flop/B against the compulsory bytes; _l2: against the L1d-miss bytes",
        "time_share": "share of the step's CPU time, perf record -e cpu-clock self samples",
        "seconds_per_particle_step": "s, time_share / native particle-steps per second",
        "ipc": "instructions per cycle (valgrind's instructions / native cycles)",
        "flops_per_second": "flop/s natively",
        "percent_of_compute_roof": "%, of machine.peak_flops",
        "percent_of_bandwidth_roof": f"%, compulsory bytes/s of the {level} triad roof",
        "percent_of_l2_roof": "%, L1d-miss bytes/s of the L2 triad roof",
        "percent_divider_bound": "%, the least time the divider needs for the divisions and square roots "
                                 "(machine.divider rates) of the kernel's time"}


# ---- the report ----

def _f(value, spec=".3g"):
    return "n/a" if value is None else format(value, spec)


def markdown(r):
    """roofline.md: the machine, the per-kernel table, the whole step against the roofs, and the caveats."""
    lines = machine_lines(r) + [kernel_table(r), ""] + [
        "† Instructions under valgrind, where evaluate_chunk runs its AVX2 (x86-64-v3) clone; natively it runs the "
        "AVX-512 clone (fewer instructions, the same flops). IPC divides these by the native cycles.", "",
        "## The whole step", "", whole_step_table(r), ""]
    lines += large_sample_lines(r) + note_lines(r)
    return "\n".join(lines)


def kernel_table(r):
    """The per-kernel table (and the whole step's row) against the roofs."""
    level = r["bandwidth_level"]

    def packed(k):  # (not for a handful of flops)
        return 100 * k["packed_flop_fraction"] if k["flops_per_particle_step"] >= 1 else None
    rows = [(k["label"], _f(k["instructions_per_particle_step"], ".0f"), _f(k["flops_per_particle_step"], ".0f"),
             _f(packed(k), ".0f"), _f(k["div_sqrt_per_particle_step"], ".1f"),
             _f(k["time_share"] and 100 * k["time_share"], ".1f"), _f(k["compulsory_bytes_per_particle_step"], ".0f"),
             _f(k["d1_miss_bytes_per_particle_step"], ".0f"), _f(k["arithmetic_intensity"], ".2f"), _f(k["ipc"], ".2f"),
             _f(k["flops_per_second"] and k["flops_per_second"] / 1e9, ".2f"), _f(k["percent_of_compute_roof"], ".1f"),
             _f(k["percent_of_bandwidth_roof"], ".1f"), _f(k["percent_of_l2_roof"], ".1f"),
             _f(k["percent_divider_bound"], ".0f"))
            for k in r["kernels"] + [r["step"]]]
    return md_table(("kernel", "instructions / p-step †", "flops / p-step", "packed flops %", "div+sqrt / p-step",
                     "time % (perf)", "compulsory B / p-step", "L1-miss B / p-step (sim.)", "AI [flop/B]", "IPC †",
                     "GFlop/s", "% compute roof", f"% {level} roof (compulsory B)", "% L2 roof (L1-miss B)",
                     "divider-bound % of time"),
                    rows, align="lrrrrrrrrrrrrrr")


def machine_lines(r):
    """The heading, the scene and the machine's roofs."""
    m, s, level = r["machine"], r["scene"], r["bandwidth_level"]
    return [
        "# Roofline of the time step (one core)", "",
        f"Scene: {s['deck']}, {s['particles']} spheres from {s['state']}; {s['pairs_per_particle']['value']:.3g} listed "
        f"pairs and {s['contacts_per_particle']['value']:.3g} contacts per particle; footprint "
        f"{s['footprint']['value'] / 2**20:.3g} MiB (in {level}). p-step: particle-step. Method and units: roofline.json.", "",
        f"Machine: {m['cpu']}; clock {m['clock']['value']:.3g} GHz (measured); compute roof "
        f"{m['peak_flops']['value']:.4g} GFlop/s ({m['peak_flops_per_cycle']['value']} flop/cycle, assumed from the ISA; "
        f"measured FMA rate {_f(m['measured_fma_flops']['value'], '.4g')} GFlop/s); divider "
        f"{_f(m['divider']['div']['value'])} G divisions/s, {_f(m['divider']['sqrt']['value'])} G square roots/s "
        "(lane-operations); triad bandwidth "
        + ", ".join(f"{k} {v['value']:.3g} GB/s" for k, v in m["bandwidth"].items()) + ".", ""]


def whole_step_table(r):
    """The whole step's numbers: rates, counts per particle-step and per listed pair, and the share of each roof."""
    a, level = r["achieved"], r["bandwidth_level"]
    return md_table(("quantity", "value"), [
        ("particle-steps/s (native, median)", f"{a['particle_steps_per_second']['value']:.4g}"),
        ("cycles / particle-step", f"{a['cycles_per_particle_step']['value']:.0f}"),
        ("instructions / particle-step †", f"{r['per_particle_step']['instructions']['value']:.0f}"),
        ("flops / particle-step", f"{r['per_particle_step']['flops']['value']:.0f}"),
        ("flops / listed pair (pair law)", f"{r['pair_law']['flops_per_pair']['value']:.0f}"),
        ("divisions + square roots / listed pair (pair law)", f"{r['pair_law']['div_sqrt_per_pair']['value']:.1f}"),
        ("instructions / listed pair (pair law, AVX2 clone)", f"{r['pair_law']['instructions_per_pair']['value']:.0f}"),
        ("cycles / listed pair (pair law, native; of which the divider's floor)",
         f"{_f(r['pair_law']['cycles_per_pair']['value'], '.1f')} "
         f"({_f(r['pair_law']['divider_cycles_per_pair']['value'], '.1f')})"),
        ("compulsory bytes / particle-step", f"{r['per_particle_step']['compulsory_bytes']['value']:.0f}"),
        ("touched bytes / particle-step (each array once)", f"{r['per_particle_step']['touched_bytes']['value']:.0f}"),
        ("L1-miss bytes / particle-step (simulated)", f"{r['per_particle_step']['d1_miss_bytes']['value']:.0f}"),
        ("L2-miss bytes / particle-step (simulated)", f"{r['per_particle_step']['ll_miss_bytes']['value']:.0f}"),
        ("arithmetic intensity (compulsory)", f"{r['per_particle_step']['arithmetic_intensity']['value']:.2f} flop/B"),
        ("achieved", f"{a['flops']['value']:.3g} GFlop/s, {a['compulsory_bandwidth']['value']:.3g} GB/s compulsory, "
                     f"{a['l2_bandwidth']['value']:.3g} GB/s L1-L2, IPC {a['ipc']['value']:.2f} †"),
        ("of the compute roof", f"{a['percent_of_compute_roof']['value']:.1f} %"),
        (f"of the {level} bandwidth roof (compulsory bytes)", f"{a['percent_of_bandwidth_roof']['value']:.1f} %"),
        ("of the L2 bandwidth roof (L1-miss bytes)", f"{a['percent_of_l2_roof']['value']:.1f} %"),
    ], align="lr")


def large_sample_lines(r):
    """The larger sample's counts, when it was measured."""
    if not r.get("large_sample"):
        return []
    g = r["large_sample"]
    return [f"Larger sample ({g['particles']} spheres, {g['steps']} steps under callgrind, footprint "
            f"{g['footprint_bytes'] / 2**20:.3g} MiB): {g['instructions_per_particle_step']:.0f} instructions, "
            f"{g['flops_per_particle_step']:.0f} flops, {g['compulsory_bytes_per_particle_step']:.0f} compulsory B, "
            f"{g['d1_miss_bytes_per_particle_step']:.0f} L1-miss B and {g['ll_miss_bytes_per_particle_step']:.0f} "
            "L2-miss B per particle-step (simulated).", ""]


def note_lines(r):
    """## Notes: the run's notes and the method's caveats."""
    return ["## Notes", ""] + [f"- {n}" for n in r["notes"]] + [
        "- Under valgrind evaluate_chunk is the AVX2 clone (valgrind does not emulate AVX-512); the flop count "
        "(lane-operations) is the same for the AVX-512 clone that runs natively, the instruction count is not.",
        "- Compulsory bytes assume every array moves once per step; the L1-/L2-miss bytes come from valgrind's cache "
        "model (LRU, no hardware prefetch, write-backs not counted), a guide to the traffic, not a measurement.",
        "- Per-kernel compulsory bytes count every array the kernel touches, also where the kernel before has just "
        "brought it into cache (sum_chunk and the kick read the pair forces evaluate_chunk wrote): they add up to "
        "more than the step's, which counts each array once.",
        "- Time shares are perf's self samples among the step's kernels ('other', mostly start-up, left out); the "
        "neighbour list's share includes the bench's initial rebuild.",
        "- The divider-bound column is the least time the kernel's divisions and square roots take on the measured "
        "divider rates (they share one unit): a floor under the kernel's time that FMA throughput does not show.",
        "- The roofs are single-core triad, FMA and divider rates on a shared virtual machine; the compute roof "
        "assumes two AVX-512 FMA pipes (the measured FMA rate checks it).", ""]


def plot(r, path):
    """Log-log roofline: the compute roof (and the measured FMA rate), the L2/L3/DRAM triad roofs, the pair law's
    divider ceiling, the step and the pair law (filled: against compulsory bytes; hollow: against the simulated
    L1-miss bytes)."""
    import numpy as np
    plt = plotting.pyplot()
    m = r["machine"]
    peak = m["peak_flops"]["value"]
    fig, ax = plt.subplots(figsize=(7, 4.8))
    ai = np.logspace(-2, 2, 200)
    ax.plot(ai, np.full_like(ai, peak), "k-", lw=2)
    ax.annotate(f"compute roof {peak:.0f} GFlop/s (AVX-512, 2 FMA)", (ai[0], peak), xytext=(4, 4),
                textcoords="offset points", fontsize=8)
    fma = m["measured_fma_flops"]["value"]
    if fma:
        ax.plot(ai, np.full_like(ai, fma), "k:", lw=1, label=f"measured FMA rate {fma:.3g} GFlop/s")
    law = next(x for x in r["kernels"] if x["kernel"] == "evaluate_chunk")
    if law["percent_divider_bound"]:  # the pair law's flops in the time its divisions and square roots need
        ceiling = law["flops_per_second"] / 1e9 / (law["percent_divider_bound"] / 100)
        ax.plot(ai, np.full_like(ai, ceiling), color="tab:green", ls=":", lw=1.5,
                label=f"pair law's divider ceiling {ceiling:.3g} GFlop/s")
    for (level, bw), style in zip(m["bandwidth"].items(), ("-", "--", "-.")):
        gbs = bw["value"]
        ax.plot(ai, np.minimum(peak, ai * gbs), color="tab:blue", ls=style, lw=1.5, label=f"{level} triad {gbs:.3g} GB/s")
    for k, color in ((r["step"], "tab:red"), (law, "tab:green")):
        if k["flops_per_second"] is None:
            continue
        gf = k["flops_per_second"] / 1e9
        ax.plot(k["arithmetic_intensity"], gf, "o", color=color, ms=8, label=f"{k['label']}: {gf:.3g} GFlop/s")
        if k["arithmetic_intensity_l2"]:
            ax.plot(k["arithmetic_intensity_l2"], gf, "o", mfc="none", color=color, ms=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("arithmetic intensity [flop/B]  (filled: compulsory bytes; hollow: simulated L1-miss bytes)")
    ax.set_ylabel("GFlop/s (one core)")
    s = r["scene"]
    ax.set_title(f"celldem step, {s['particles']} spheres, 1 thread")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return plotting.save(fig, path)


def write(out, result):
    """roofline.json, roofline.md and roofline.png in out; returns their paths."""
    out = Path(out)
    (out / "roofline.json").write_text(json.dumps(result, indent=2) + "\n")
    (out / "roofline.md").write_text(markdown(result))
    return out / "roofline.json", out / "roofline.md", plot(result, out / "roofline.png")


def measure_into(out, celldem, deck, state, **options):
    """Measures, with the raw outputs (callgrind files, benches, perf data, probe output) in out/raw, then writes
    the report; returns the paths written."""
    raw = Path(out) / "raw"
    if raw.exists():
        shutil.rmtree(raw)
    raw.mkdir(parents=True)
    return write(out, measure(celldem, deck, state, raw, **options))
