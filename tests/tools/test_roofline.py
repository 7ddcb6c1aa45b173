"""tools/roofline.py (tools/celldem/performance/roofline.py): the flop classifier on a synthetic objdump listing, the
callgrind parser on a synthetic profile (name compression, relative positions, the inclusive cost after calls=),
exact flop, division and step counts from the two together, the compulsory-bytes table, the command line's
refusals; then, where valgrind, objdump and g++ are installed and the paper's prepared sample exists, a short real
run (5 steps under callgrind, a 50-step bench: about 20 s) whose counts must be plausible."""

import json
import os
import shutil

import pytest

from celldem.performance import roofline as rl
from checking import ROOT, check, tool

# One instruction per line as `objdump -d --no-show-raw-insn -C` prints it; flops per execution beside.
LISTING = """
0000000000001000 <celldem::(anonymous namespace)::evaluate_chunk<Law>(double*) [clone .arch_x86_64_v4]>:
    1000:	vfmadd231pd %zmm1,%zmm2,%zmm3
    1006:	vaddsd %xmm1,%xmm2,%xmm3
    100a:	vmulpd %ymm1,%ymm2,%ymm3
    100e:	vdivpd 0x40(%rax),%xmm1,%xmm2
    1013:	vsqrtpd %zmm4,%zmm5{%k1}{z}
    1019:	vcmppd $0x1,%ymm1,%ymm2,%ymm3
    101e:	vxorpd %xmm0,%xmm0,%xmm0
    1022:	vmovapd %zmm0,(%rdi)
    1028:	addsd  %xmm1,%xmm0
    102c:	vfnmadd213sd %xmm1,%xmm2,%xmm3
    1031:	vmaxpd 0x8(%rip){1to8},%zmm2,%zmm3        # 2000 <kConstant>
    1037:	vaddps %ymm1,%ymm2,%ymm3
    103b:	vpaddq %zmm1,%zmm2,%zmm3
    1041:	vcvtsi2sd %eax,%xmm1,%xmm1
    1045:	ret

0000000000002000 <celldem::advance_cell(celldem::Model const&)>:
    2000:	vsubsd %xmm1,%xmm2,%xmm3
    2004:	ret
"""


# A callgrind profile of those addresses: name compression "(id) name", relative positions, and a call whose
# inclusive cost (the line after calls=) must not count as the caller's own.
PROFILE = """# callgrind format
version: 1
creator: test
positions: instr line
events: Ir
summary: 57

ob=(1) /fake/celldem
fl=(1) ???
fn=(1) celldem::(anonymous namespace)::evaluate_chunk<Law>(double*) [clone .arch_x86_64_v3]
0x1000 0 10
+6 0 3
+4 0 5
+4 0 2
+5 0 1
* 0 1
+6 0 4
+24 0 7
-49 0 6
cfn=(2) celldem::advance_cell(celldem::Model const&)
calls=7 0x2000 0
* 0 14
fn=(2)
0x2000 0 7
+4 0 7
ob=(2) /usr/lib/libc.so.6
fn=(3) memcpy
0x500 0 4
"""


def test_flop_classifier():
    table = rl.flop_table(LISTING)
    want = {0x1000: (16, True, "fma"), 0x1006: (1, False, "add"), 0x100a: (4, True, "mul"), 0x100e: (2, True, "div"),
            0x1013: (8, True, "sqrt"), 0x1028: (1, False, "add"), 0x102c: (2, False, "fma"), 0x1031: (8, True, "max"),
            0x2000: (1, False, "sub")}
    check("flop table", table, want)
    check("one zmm FMA", rl.flops_of("vfmadd231pd", "%zmm1,%zmm2,%zmm3"), (16, True, "fma"))
    one = rl.parse_callgrind("positions: instr line\nevents: Ir\nsummary: 10\nob=(1) /fake/celldem\nfn=(1) f\n0x1000 0 10\n")
    check("one zmm FMA executed 10 times", rl.attribute(one, table, {"/fake/celldem"})["other"]["flops"], 160)
    check("single precision is not counted", rl.flops_of("vfmadd231ps", "%zmm1,%zmm2,%zmm3"), None)


def test_callgrind_profile_counts():
    table = rl.flop_table(LISTING)
    profile_text = PROFILE
    p = rl.parse_callgrind(profile_text)
    check("steps (calls of advance_cell)", p.calls_into(rl.STEP_COUNTER), 7)
    per = rl.attribute(p, table, {"/fake/celldem"})
    law, other = per["evaluate_chunk"], per["other"]
    # Positions: 0x1000, 0x1006, 0x100a, 0x100e, 0x1013 twice, 0x1019 (compare: no flop), 0x1031, 0x1000 again.
    check("evaluate_chunk flops", law["flops"], 16 * 16 + 3 * 1 + 5 * 4 + 2 * 2 + 2 * 8 + 7 * 8)
    check("evaluate_chunk instructions", law["instructions"], 10 + 3 + 5 + 2 + 1 + 1 + 4 + 7 + 6)
    check("division lanes", law["div_lanes"], 4)
    check("square-root lanes", law["sqrt_lanes"], 16)
    check("packed flops", law["packed_flops"], 16 * 16 + 5 * 4 + 2 * 2 + 2 * 8 + 7 * 8)
    check("advance_cell: own cost only, its flops", (other["instructions"], other["flops"]), (14 + 4, 7))
    check("libc: instructions, not flops", other["instructions_elsewhere"], 4)
    # A profile whose self costs do not sum to its summary is refused.
    with pytest.raises(rl.RooflineError):
        rl.attribute(rl.parse_callgrind(profile_text.replace("summary: 57", "summary: 58")), table, {"/fake/celldem"})


def test_kernels_by_name():
    # Kernels by name, callgrind's and perf's spellings.
    for name, kernel in (("celldem::drift_share(celldem::Model const&)", "drift"),
                         ("celldem::(anonymous namespace)::drift_range(Eigen::Matrix<...> const&, ...)", "drift"),
                         ("celldem::(anonymous namespace)::kick_range(double const*, ...)", "gather_and_kick_range"),
                         ("celldem::(anonymous namespace)::gather_chunk", "gather_chunk"),
                         ("void celldem::(anonymous namespace)::evaluate_share<Law, true>(...)", "pair_loop"),
                         ("celldem::gather_and_kick_range(celldem::Model const&, ...)", "gather_and_kick_range"),
                         ("celldem::(anonymous namespace)::find_candidates(...)", "neighbour"),
                         ("celldem::PairSearch::search_share()", "neighbour"),
                         ("GOMP_parallel", "other")):
        check(f"kernel of {name}", rl.kernel_of(name), kernel)


def test_layout_table():
    # The layout table: 184 B per particle and 111 per pair of memory (the bench's count; a pair image is 3 x int16,
    # the build positions 3 x float; no owner per pair; each pair's force and both moments); 256 + 135 moved per
    # step, 184 + 111 touched.
    b = rl.compulsory_bytes(1.0)
    check("footprint, one pair per particle", b["footprint"], 295.0)
    check("compulsory bytes, one pair per particle", b["step"], 391.0)
    check("touched bytes, one pair per particle", b["touched"], 295.0)
    check("evaluate_chunk's compulsory bytes per pair", rl.compulsory_bytes(2.0)["kernels"]["evaluate_chunk"], 240.0)
    check("the kick's bytes per pair", rl.compulsory_bytes(1.0)["kernels"]["gather_and_kick_range"]
          - rl.compulsory_bytes(0.0)["kernels"]["gather_and_kick_range"], 76.0)


def test_refuses_to_overwrite_without_force(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "roofline.json").write_text("{}\n")
    r = tool("roofline", "--out", out, "--celldem", "/bin/true", "--deck", out / "roofline.json",
             "--state", out / "roofline.json", check=False)
    assert r.returncode != 0, "overwrote roofline.json without --force"
    assert "exists (give --force" in r.stderr, f"no clear message for an existing roofline.json: {r.stderr}"


def test_refuses_to_run_without_valgrind(tmp_path):
    out, empty = tmp_path / "out", tmp_path / "bin"
    out.mkdir()
    empty.mkdir()
    (out / "roofline.json").write_text("{}\n")
    r = tool("roofline", "--out", out, "--force", "--celldem", "/bin/true", "--deck", out / "roofline.json",
             "--state", out / "roofline.json", check=False, env=dict(os.environ, PATH=str(empty)))
    assert r.returncode != 0, "ran without valgrind"
    assert "roofline needs valgrind" in r.stderr, f"no clear message without valgrind: {r.stderr}"


STATE = os.path.join(ROOT, "results", "paper", "prepared.state")


def test_short_real_run(tmp_path):
    """Where valgrind, objdump and g++ are installed and tools/paper.sh has prepared the paper's sample."""
    missing = [t for t in ("valgrind", "objdump", "g++") if shutil.which(t) is None]
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed")
    celldem = os.environ.get("CELLDEM") or os.path.join(ROOT, "build", "celldem")
    if not os.access(celldem, os.X_OK) or not os.path.isfile(STATE):
        pytest.skip(f"no {celldem} or no {STATE} (tools/paper.sh prepares it)")
    real = tmp_path / "real"
    tool("roofline", "--out", real, "--celldem", celldem, "--state", STATE, "--callgrind-steps", 5,
         "--bench-steps", 50, "--bench-warmup", 5, "--bench-repeats", 1, "--copies", 0)
    for f in ("roofline.json", "roofline.md", "roofline.png"):
        assert (real / f).is_file() and (real / f).stat().st_size > 0, f"no {f}"
    r = json.load(open(real / "roofline.json"))
    law = r["pair_law"]["flops_per_pair"]["value"]
    assert 100 <= law <= 250, f"the linear law's flops per listed pair: {law:.1f}, expected 100 to 250"
    step = r["per_particle_step"]
    assert step["flops"]["value"] < step["instructions"]["value"] < 3000, \
        f"instructions per particle-step {step['instructions']['value']:.0f}, flops {step['flops']['value']:.0f}"
    assert not any("layout table" in n for n in r["notes"]), \
        "the layout table disagrees with the bench's bytes per particle: " + str(r["notes"])
    check("kernels", [k["kernel"] for k in r["kernels"]][:4], ["drift", "neighbour", "gather_chunk", "evaluate_chunk"])
    check("every instruction attributed", round(sum(k["instructions_per_particle_step"] for k in r["kernels"]), 6),
          round(step["instructions"]["value"], 6))
