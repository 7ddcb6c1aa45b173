#!/usr/bin/python3
"""Cross-code verification: celldem against LAMMPS and LIGGGHTS on the same prepared state.

usage: run_crosscheck.py DECK [--state FILE] [--codes lammps,liggghts] [--np 1] --out DIR [options]

For each target code this
  1. derives a deck from DECK that matches the code's contact model (initial_state = the state,
     "kinematics": "lammps", "tangential_rotation": "project", "moment_arm": "radius" for LAMMPS or
     "contact_point" for LIGGGHTS, and damping.rotational 0 for LIGGGHTS, which has no rotational damping),
  2. runs celldem on it, translates it with `celldem translate` (warnings kept in DIR/<code>/warnings.txt),
  3. runs the code on the translated scripts (mpirun -np N when --np > 1),
  4. compares s11, s22, s33, ev and Z against e1.
Two kinds of scene:
  (a) fully strain-controlled ("strain", added unless --strain-end 0): x1 strained like the deck's first test,
      x2 and x3 by --strain-lateral times as much (default -0.5: a constant-volume shear). Pass: relative
      stress difference < --tol-stress (1e-3) for every row up to e1 = --hold-e1 (0.2 % for LAMMPS, 0.1 % for
      LIGGGHTS, whose dynamics without rotational damping are chaotic; "lammps=X,liggghts=Y" or one value).
  (b) mixed control (the deck's tests, TTC/PSC-like), in the quantities of celldem's summary.json (celldem's
      own; for the other code computed from its series by the same definitions, `celldem summarize`):
      peak s11/s33 within --tol-peak (relative); e1 at the peak (e1_at_peak_centre: the centre of the strain
      range where s11/s33 is within 1 % of its peak) within --tol-e1-peak; ev at the end of the test
      (ev_final) within --tol-ev; Z averaged over the end window (the last 0.5 % of e1) within --tol-z.
      --at-e1 X ends the tests at e1 = X (as --end-strain; the smaller wins), so that the end values are
      those at X. Ratios use the stresses each code actually held (its own s33, servo lag included).
--variants affine,rotate,contact_point,no_rotational_damping,native adds celldem runs with one model choice
changed from the LAMMPS-matched deck (or the deck's own settings), to measure how much each choice matters.
Writes DIR/report.md, DIR/report.json and one overlay plot DIR/<test>.png per test; exit code 1 when a
check fails. Tolerances and the measured differences are discussed in crosscheck/README.md; the work is in
tools/celldem/crosscheck.py.
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
# The one script outside tools/ that users run by hand: it finds the package as the entry scripts in tools/ do
# (there, Python's own first path entry is the script's folder; here it is added).
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from celldem import binary, crosscheck  # noqa: E402


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1], formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("deck")
    p.add_argument("--state", help="prepared state (default: the deck's initial_state)")
    p.add_argument("--codes", default="lammps,liggghts")
    p.add_argument("--np", type=int, default=1, help="MPI ranks for the target codes")
    p.add_argument("--out", required=True)
    p.add_argument("--celldem", default=None, help="celldem binary (default: $CELLDEM, ROOT/build/celldem, else PATH)")
    p.add_argument("--threads", type=int, default=0, help="celldem threads (default: OpenMP default)")
    p.add_argument("--tests", help="comma-separated subset of the deck's tests")
    p.add_argument("--end-strain", type=float, default=0.0, help="override the end strain of the deck's tests")
    p.add_argument("--output-interval", type=int, default=0, help="override the deck's output intervals")
    p.add_argument("--strain-end", type=float, default=0.005, help="e1 of the strain-controlled scene (0: none)")
    p.add_argument("--strain-lateral", type=float, default=-0.5,
                   help="strain scene: lateral increment / axial increment (-0.5: constant volume, 0: oedometric)")
    p.add_argument("--variants", default="",
                   help="extra celldem runs, each with one choice changed from the LAMMPS-matched deck: "
                        "affine, rotate, contact_point, no_rotational_damping; or native (the deck's own settings)")
    p.add_argument("--noise", action="store_true",
                   help="also run each code on another rank count and report that difference (not a check)")
    p.add_argument("--reuse", action="store_true", help="keep runs already complete in --out")
    p.add_argument("--tol-stress", type=float, default=1e-3)
    p.add_argument("--hold-e1", default="lammps=0.002,liggghts=0.001",
                   help="e1 up to which kind (a) must hold --tol-stress: one value or lammps=X,liggghts=Y")
    p.add_argument("--tol-peak", type=float, default=0.03)
    p.add_argument("--tol-e1-peak", type=float, default=0.01)
    p.add_argument("--at-e1", type=float, default=0.0,
                   help="end the deck's tests at this e1 (as --end-strain), so that the end values are there")
    p.add_argument("--tol-ev", type=float, default=1e-3, help="ev at the end (absolute)")
    p.add_argument("--tol-z", type=float, default=0.05, help="Z over the end window (absolute)")
    args = p.parse_args(argv)
    if "=" in args.hold_e1:
        args.hold_e1 = {k: float(v) for k, v in (kv.split("=") for kv in args.hold_e1.split(","))}
    else:
        args.hold_e1 = {code: float(args.hold_e1) for code in crosscheck.EXE}
    args.celldem = binary.find(args.celldem)
    return args


def main(argv=None):
    """Runs the cross-check: 0 when every check passes; 1 when one fails or the check cannot go on (the
    reason printed as 'run_crosscheck: ...' on stderr)."""
    try:
        return crosscheck.run(parse_args(argv))
    except crosscheck.CrosscheckError as err:
        print("run_crosscheck: %s" % err, file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
