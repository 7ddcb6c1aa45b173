"""The failure surface of a constant-b run (tools/failure_surface.py): peak friction angle against b and the
peak states in the pi-plane, with Mohr-Coulomb, Matsuoka-Nakai and Lade-Duncan fitted. Reads only summary.json
(celldem's peak_state: the principal stresses on the row of the largest s11/s33).

Fits (each criterion has one constant, fitted by least squares on the peak friction angle):
  Mohr-Coulomb     (s1 - s3)/(s1 + s3) = sin(phi)           : the same phi at every b
  Matsuoka-Nakai   I1 I2 / I3 = k_MN
  Lade-Duncan      I1^3 / I3 = k_LD
For a given b and constant, the principal stress ratio R = s1/s3 on the surface is found by bisection with
s3 = 1, s2 = 1 + b (R - 1), s1 = R; phi = asin((R - 1)/(R + 1)).
"""

import math
import os

import numpy as np

from . import plotting
from .tables import md_table


PARAMETERS = 1  # each criterion's fitted constants; a fit needs at least PARAMETERS + 1 points


def left_out(summary, tests=None):
    """[(name, reason)] of the tests (of `tests`, default all) kept out of the fits: a control failed (summary.json
    "controlled": false) or no peak was reached ("peak_reached": false: the largest s11/s33 is the test's last
    row). A summary from before these keys counts as controlled with a peak."""
    out = []
    for name, t in summary.get("tests", {}).items():
        if tests is not None and name not in tests or not isinstance(t, dict):
            continue
        reasons = []
        if t.get("controlled", True) is False:
            failures = "; ".join(str(f) for f in t.get("control_failures") or [])
            reasons.append("its control failed" + (f" ({failures})" if failures else ""))
        if t.get("peak_reached", True) is False:
            reasons.append("no peak reached (the largest σ1/σ3 is its last row)")
        if reasons:
            out.append((name, " and ".join(reasons)))
    return out


def peaks(summary, tests=None):
    """(name, s1, s2, s3) at each test's peak (of `tests`, default all), from summary.json's peak_state; tests
    left_out() names are not among them."""
    out = []
    skip = {name for name, _ in left_out(summary, tests)}
    for name, t in summary.get("tests", {}).items():
        if tests is not None and name not in tests or name in skip:
            continue
        ps = t.get("peak_state") or {}
        if all(ps.get(k) is not None for k in ("sigma1", "sigma2", "sigma3")):
            out.append((name, ps["sigma1"], ps["sigma2"], ps["sigma3"]))
    return sorted(out, key=lambda p: b_of(*p[1:]))


def b_of(s1, s2, s3):
    return (s2 - s3) / (s1 - s3)


def phi_of(s1, s3):
    return math.degrees(math.asin((s1 - s3) / (s1 + s3)))


def invariants(s1, s2, s3):
    return s1 + s2 + s3, s1 * s2 + s2 * s3 + s3 * s1, s1 * s2 * s3


CRITERIA = {
    "Mohr-Coulomb": lambda s1, s2, s3: (s1 - s3) / (s1 + s3),
    "Matsuoka-Nakai": lambda s1, s2, s3: invariants(s1, s2, s3)[0] * invariants(s1, s2, s3)[1] / invariants(s1, s2, s3)[2],
    "Lade-Duncan": lambda s1, s2, s3: invariants(s1, s2, s3)[0] ** 3 / invariants(s1, s2, s3)[2],
}


def ratio_on_surface(criterion, constant, b):
    """s1/s3 where the criterion reaches `constant` at this b (each criterion grows with R at fixed b)."""
    f = CRITERIA[criterion]
    lo, hi = 1.0 + 1e-12, 1e3
    value = lambda r: f(r, 1.0 + b * (r - 1.0), 1.0) - constant
    if value(hi) < 0:
        return float("nan")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if value(mid) < 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def predicted_phi(criterion, constant, b):
    r = ratio_on_surface(criterion, constant, b)
    return math.degrees(math.asin((r - 1.0) / (r + 1.0))) if math.isfinite(r) else float("nan")


def fit(criterion, points):
    """The constant that minimises the RMS error of the predicted peak friction angle; (constant, rms)."""
    values = [CRITERIA[criterion](s1, s2, s3) for _, s1, s2, s3 in points]
    lo, hi = min(values) * 0.8, max(values) * 1.2

    def rms(c):
        errs = [predicted_phi(criterion, c, b_of(s1, s2, s3)) - phi_of(s1, s3) for _, s1, s2, s3 in points]
        return math.sqrt(sum(e * e for e in errs) / len(errs))

    for _ in range(100):  # golden section: rms is unimodal in the constant
        a, c = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        if rms(a) < rms(c):
            hi = c
        else:
            lo = a
    best = 0.5 * (lo + hi)
    return best, rms(best)


def pi_plane(s1, s2, s3):
    """Deviatoric coordinates / p, s1 up, s2 lower left, s3 lower right (sqrt(2/3) |s'| is the radius)."""
    p = (s1 + s2 + s3) / 3.0
    k = math.sqrt(2.0 / 3.0)
    x = k * (math.sqrt(3) / 2) * (s3 - s2)
    y = k * (s1 - 0.5 * (s2 + s3))
    return x / p, y / p


def surface_curve(criterion, constant):
    """The criterion's trace in the pi-plane (normalised by p), all six sextants."""
    pts = []
    for b in np.linspace(0.0, 1.0, 61):
        r = ratio_on_surface(criterion, constant, b)
        s1, s2, s3 = r, 1.0 + b * (r - 1.0), 1.0
        pts.append((s1, s2, s3))
    curve = []
    orders = [(0, 1, 2), (1, 0, 2), (1, 2, 0), (2, 1, 0), (2, 0, 1), (0, 2, 1)]
    for k, order in enumerate(orders):
        seq = pts if k % 2 == 0 else pts[::-1]
        for s in seq:
            a = (s[order.index(0)], s[order.index(1)], s[order.index(2)])
            curve.append(pi_plane(*a))
    curve.append(curve[0])
    return np.array(curve)


def analyse(run_dir, points, extra=()):
    """Fits the criteria to the peaks of the run (`points`) and of a paper run (`extra`), draws the two figures
    into RUN_DIR/figures; returns (Markdown lines: the peak table, the fits, the best; path of the φ-b figure,
    path of the π-plane figure). tools/report.py puts these in a run's report."""
    if len(points) < PARAMETERS + 1:
        raise ValueError(f"{run_dir}/summary.json has {len(points)} test(s) with a peak and held controls; a fit of "
                         f"{PARAMETERS} constant needs at least {PARAMETERS + 1}: no fit")
    plt = plotting.pyplot()

    fits = {c: fit(c, points) for c in CRITERIA}
    best = min(fits, key=lambda c: fits[c][1])

    fig_dir = os.path.join(run_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    bs = np.linspace(0.0, 1.0, 101)
    styles = {"Mohr-Coulomb": "--", "Matsuoka-Nakai": "-", "Lade-Duncan": ":"}

    fig, ax = plt.subplots(figsize=(5.5, 4.0))
    for c, (k, r) in fits.items():
        ax.plot(bs, [predicted_phi(c, k, b) for b in bs], styles[c], label=f"{c} (RMS {r:.2f}°)")
    ax.plot([b_of(*p[1:]) for p in points], [phi_of(p[1], p[3]) for p in points], "ko", label="constant b, p")
    for name, s1, s2, s3 in extra:
        ax.plot(b_of(s1, s2, s3), phi_of(s1, s3), "s", ms=8, label=f"paper run: {name}")
    ax.set_xlabel("b = (σ2 − σ3)/(σ1 − σ3) at peak (principal)")
    ax.set_ylabel("peak friction angle φ (°)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    phi_png = plotting.save(fig, os.path.join(fig_dir, "failure_surface_phi_b.png"))

    fig, ax = plt.subplots(figsize=(5.0, 5.0))
    for c, (k, _) in fits.items():
        curve = surface_curve(c, k)
        ax.plot(curve[:, 0], curve[:, 1], styles[c], label=c)
    ax.plot(*zip(*[pi_plane(*p[1:]) for p in points]), "ko", label="constant b, p")
    for name, s1, s2, s3 in extra:
        ax.plot(*pi_plane(s1, s2, s3), "s", ms=8, label=f"paper run: {name}")
    for k, label in enumerate(("σ1", "σ2", "σ3")):
        angle = math.pi / 2 + k * 2 * math.pi / 3
        ax.plot([0, 1.2 * math.cos(angle)], [0, 1.2 * math.sin(angle)], color="0.7", lw=0.8)
        ax.text(1.28 * math.cos(angle), 1.28 * math.sin(angle), label, ha="center", va="center")
    ax.set_aspect("equal")
    ax.set_title("peak states in the π-plane (deviator / p)")
    ax.legend(fontsize=8, loc="lower center")
    ax.axis("off")
    pi_png = plotting.save(fig, os.path.join(fig_dir, "failure_surface_pi_plane.png"))

    lines = [md_table(("test", "σ1 (kPa)", "σ2 (kPa)", "σ3 (kPa)", "b (principal, plotted)", "φ (°)"),
                      [(name, f"{s1 / 1e3:.1f}", f"{s2 / 1e3:.1f}", f"{s3 / 1e3:.1f}", f"{b_of(s1, s2, s3):.3f}",
                        f"{phi_of(s1, s3):.2f}") for name, s1, s2, s3 in list(points) + list(extra)], align="lrrrrr"),
             "",
             md_table(("criterion", "constant", "RMS error of φ (°)"),
                      [(c, f"sin φ = {k:.4f} (φ = {math.degrees(math.asin(k)):.2f}°)" if c == "Mohr-Coulomb"
                        else f"{k:.3f}", f"{r:.2f}") for c, (k, r) in fits.items()], align="lrr"),
             "", f"Best fit: **{best}**."]
    for name, s1, s2, s3 in extra:
        b = b_of(s1, s2, s3)
        on_curve = predicted_phi(best, fits[best][0], b)
        lines.append(f"- paper run `{name}`: φ = {phi_of(s1, s3):.2f}° at b = {b:.3f}; the {best} fit to the "
                     f"constant-b tests gives {on_curve:.2f}° there ({phi_of(s1, s3) - on_curve:+.2f}°).")
    return lines, phi_png, pi_png


HOW = ("Peaks are celldem's (`summary.json`, `peak_state`: the row of the largest σ11/σ33); b and φ from the "
       "principal stresses there (b_principal), beside the axis b from the stresses on the cell's axes. Shear strains "
       "are held at zero, so shear stresses are free: near b = 1 they split σ1 from σ2 and the principal b falls "
       "below the axis b that the servo holds (a 300-sphere test held axis b at 1.0004 while b_principal was 0.859 "
       "at the peak; 0.977 on 8000 spheres). The principal b is what a failure criterion sees, so it is plotted; "
       "control of zero shear stresses, which would make the two agree, is left to the full-tensor control. Tests "
       "whose control failed or that reached no peak are kept out of the fits.")


def left_out_text(excluded):
    """'2 tests kept out of the fits: b05 (no peak reached ...); ...' or ''."""
    if not excluded:
        return ""
    return (f"{len(excluded)} test{'s' if len(excluded) > 1 else ''} kept out of the fits: "
            + "; ".join(f"{name} ({why})" for name, why in excluded) + ".")


def write(run_dir, points, extra=(), excluded=()):
    """analyse(), then RUN_DIR/failure_surface.md; returns the paths of failure_surface.md and the two figures,
    and the text to print."""
    body, phi_png, pi_png = analyse(run_dir, points, extra)
    note = left_out_text(excluded)
    lines = ["# Failure surface", "", f"Run: `{run_dir}`. {HOW}", ""] + ([note, ""] if note else []) + body
    out = os.path.join(run_dir, "failure_surface.md")
    with open(out, "w", encoding="utf-8") as f:
        f.write("\n".join(lines + ["", f"![φ against b](figures/{os.path.basename(phi_png)})",
                                   f"![π-plane](figures/{os.path.basename(pi_png)})", ""]))
    return out, phi_png, pi_png, "\n".join(lines)
