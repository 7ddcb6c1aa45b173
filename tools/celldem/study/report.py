"""The study's charts (figures/pareto.png, stability.png, reference.png) and study.md, from the dict that
study_analysis.analyse returns (tools/study.py analyse); study.md includes the model-sufficiency tables
(tools/sufficiency.py) found beside the study root."""

import math
import os

import numpy as np

from ..reports import plotting
from . import sufficiency
from .analysis import pareto_front
from .scene import (END_STRAIN, KE_UNSTABLE, DRIFT_FLOORS, MODELLING_QUANTITIES, PAPER_DT, QUANTITIES,
                          QUANTITY_LABELS, SCENE_COUNT, SERVO_INC, SERVO_OUTPUT_INTERVAL,
                          SERVO_STRAIN, SERVO_STD_LIMIT, STABILITY_STRAIN, quasi_static_inertial_number)
from ..reports.tables import fmt, fmt_spec, md_table, scaled

GROUP_STYLE = {
    "reference": ("k", "*", "reference (paper settings)"),
    "null": ("0.4", "p", "round-off only (dt × (1 + 1e-9))"),
    "strain_increment": ("C0", "o", "strain increment per step"),
    "time_step": ("C1", "s", "time step (at the paper's rate)"),
    "density": ("C2", "^", "density scaling"),
    "combined": ("C3", "D", "larger dt and rate together"),
    "damping": ("C4", "v", "damping fraction"),
    "output_interval": ("C5", "P", "output interval"),
    "count": ("C6", "X", "particle count"),
    "prepare_dt": ("C7", "h", "sample prepared at larger dt"),
}


# Below this a score is drawn at FLOOR_Y (the reference's own errors are 0), above 1e3 at 1e3.
FLOOR_Y = 1e-2


def draw_charts(study, fig_dir):
    """figures/pareto.png and figures/stability.png; returns {"pareto": path, "stability": path}."""
    plt = plotting.pyplot()
    os.makedirs(fig_dir, exist_ok=True)
    paths = {"pareto": draw_pareto(plt, study, fig_dir)}
    st = study["stability"]
    fig, axes = plt.subplots(2, 2, figsize=(12, 9.5))
    draw_dt_damping(axes[0, 0], st)
    draw_rate(axes[0, 1], study)
    draw_servo_gains(fig, axes[1, 0], st)
    draw_kinetic_energy(axes[1, 1], st)
    paths["stability"] = plotting.save(fig, os.path.join(fig_dir, "stability.png"))
    return paths


def draw_pareto(plt, study, fig_dir):
    """Error against cost, with the Pareto front and the inertial number of each point: all quantities, and the
    stress-ratio quantities alone (figures/pareto.png; returns its path)."""
    rows = [r for r in study["rows"] if r["cost"] is not None and r["score"] is not None]
    fig, axes = plt.subplots(1, 2, figsize=(16, 7), sharex=True)
    preset_keys = {p["row"]: name for name, p in study["presets"].items()}
    null = next((r for r in rows if r["group"] == "null"), None)
    for ax, key, title in ((axes[0], "score", "all compared quantities"),
                           (axes[1], "score_stress", "stress-ratio quantities: peak σ1/σ3, ε1 at peak, b")):
        seen = set()
        panel = [r for r in rows if r.get(key) is not None]
        ys = [min(max(r[key], FLOOR_Y), 1e3) for r in panel]
        front = set(pareto_front([(r["cost"], y) for r, y in zip(panel, ys)]))
        for i, (r, y) in enumerate(zip(panel, ys)):
            color, marker, label = GROUP_STYLE.get(r["group"], ("0.5", "o", r["group"]))
            ax.scatter(r["cost"], y, color=color, marker=marker, s=60 if i in front else 35,
                       edgecolor="k" if i in front else "none", label=None if r["group"] in seen else label, zorder=3)
            seen.add(r["group"])
            ax.annotate(f"I={fmt_spec(r['inertial_number'], '.1e', 'n/a')}", (r["cost"], y),
                        textcoords="offset points", xytext=(4, 3),
                        fontsize=6.5, color=color)
            if r["key"] in preset_keys:
                ax.scatter(r["cost"], y, s=260, facecolor="none", edgecolor="m", linewidth=1.5, zorder=4)
                ax.annotate(preset_keys[r["key"]], (r["cost"], y), textcoords="offset points", xytext=(-10, -16),
                            fontsize=8, color="m")
        pts = sorted((panel[i]["cost"], ys[i]) for i in front)
        if pts:
            ax.step([c for c, _ in pts], [y for _, y in pts], where="post", color="k", linewidth=1, linestyle="--",
                    label="Pareto front", zorder=2)
        ax.axhline(1.0, color="r", linewidth=1, label="noise floor (seed-to-seed std)")
        if null is not None and null.get(key) is not None:
            ax.axhline(null[key], color="0.4", linewidth=0.8, linestyle=":",
                       label="round-off only: what an exact setting scores")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"run time of the tests to ε1 = {END_STRAIN:.0%}, {SCENE_COUNT} spheres (single-thread CPU s)")
        ax.set_ylabel("largest |error| / noise floor (–)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7.5, loc="lower left")
    fig.suptitle("celldem speed against accuracy on the reduced scene (error: mean over seeds of the paired "
                 "difference from the reference; reference drawn at 0.01; magenta rings: presets)", fontsize=10)
    return plotting.save(fig, os.path.join(fig_dir, "pareto.png"))


def draw_dt_damping(ax, st):
    """The stability map's time step × damping panel: each run's state and its largest kinetic energy."""
    colors = {"stable": "tab:green", "drift": "tab:orange", "unstable": "tab:red", "blow-up": "darkred",
              "failed": "k"}
    for state, color in colors.items():
        pts = [r for r in st["dt"] if r["state"] == state]
        if pts:
            ax.scatter([r["dt_over_tc"] for r in pts], [r["damping"] for r in pts], color=color, s=90, label=state,
                       marker="x" if state == "failed" else "o")
    for r in st["dt"]:
        txt = "fail" if r["state"] == "failed" else f"KE {r.get('ke_max', math.nan):.0e}"
        ax.annotate(txt, (r["dt_over_tc"], r["damping"]), textcoords="offset points", rotation=60,
                    xytext=(-4, 8), fontsize=6)
    ax.set_xlabel("time step / sqrt(m_min/kn) (–)")
    ax.set_ylabel("damping fraction (–)")
    ax.set_ylim(-0.006, 0.064)
    ax.set_title(f"time step × damping (TTC to ε1 = {STABILITY_STRAIN:.0%}, paper's rate)\n"
                 "KE: max kinetic energy / (p V)", fontsize=10)
    ax.legend(fontsize=8, loc="center right")
    ax.grid(True, alpha=0.3)


def draw_rate(ax, study):
    """The loading rate panel: the score of each rate setting against its inertial number and the solver's
    quasi-static limit."""
    rate_rows = [r for r in study["rows"] if r["group"] in ("reference", "strain_increment", "time_step", "density",
                                                             "combined") and r["score"] is not None
                 and r.get("dt_within_warning") and r["inertial_number"]]
    for r in rate_rows:
        color, marker, _ = GROUP_STYLE.get(r["group"], ("0.5", "o", ""))
        ax.scatter(r["inertial_number"], min(max(r["score"], FLOOR_Y), 1e3), color=color, marker=marker)
    ax.axhline(1.0, color="r", linewidth=1)
    limit = quasi_static_inertial_number()
    ax.axvline(limit, color="0.4", linestyle="--", linewidth=1)
    ax.text(limit, ax.get_ylim()[1] if ax.get_ylim()[1] < 1e3 else 1e2, f" I = {limit:g}", fontsize=8, va="top")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("inertial number I = ε̇ d sqrt(ρ/p) (–)")
    ax.set_ylabel("largest error / noise floor (–)")
    ax.set_title("loading rate against the quasi-static limit\n(settings below celldem's time-step warning)",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)


def draw_servo_gains(fig, ax, st):
    """The servo panel: the std of the stress error per gain and integral gain, as a map."""
    servo = [r for r in st["servo"] if r.get("std") is not None]
    if servo:
        gains = sorted({r["gain"] for r in st["servo"]})
        igains = sorted({r["integral_gain"] for r in st["servo"]})
        grid = np.full((len(igains), len(gains)), np.nan)
        for r in servo:
            grid[igains.index(r["integral_gain"]), gains.index(r["gain"])] = r["std"] * 100
        im = ax.imshow(np.log10(np.clip(grid, 1e-3, None)), origin="lower", cmap="viridis", aspect="auto")
        for r in st["servo"]:
            i, j = igains.index(r["integral_gain"]), gains.index(r["gain"])
            txt = "fail" if r.get("std") is None else (f"{r['std'] * 100:.2g}%" + (
                f"\nbias {r['bias'] * 100:.2g}%" if r["bias"] > 1e-4 else "") + ("" if r.get("holds") else " ✗"))
            ax.text(j, i, txt, ha="center", va="center", fontsize=7, color="w")
        ax.set_xticks(range(len(gains)), [f"{g:g}" for g in gains])
        ax.set_yticks(range(len(igains)), [f"{g:g}" for g in igains])
        fig.colorbar(im, ax=ax, label="log10(std of σ22, σ33 error, %)")
    ax.set_xlabel("servo gain (–)")
    ax.set_ylabel("servo integral_gain (–)")
    ax.set_title(f"servo: std of (σ/100 kPa − 1) of x2, x3; ✗: std or bias above {SERVO_STD_LIMIT:.1%}")


def draw_kinetic_energy(ax, st):
    """The kinetic energy against the time step, one curve per damping."""
    for alpha in sorted({r["damping"] for r in st["dt"]}):
        pts = sorted((r for r in st["dt"] if r["damping"] == alpha and r.get("ke_max") is not None),
                     key=lambda r: r["dt_over_tc"])
        if pts:
            ax.plot([r["dt_over_tc"] for r in pts], [min(max(r["ke_max"], 1e-12), 1e6) for r in pts], "o-",
                    label=f"damping {alpha:g}")
    ax.axhline(KE_UNSTABLE, color="r", linewidth=1, label="unstable above")
    ax.set_yscale("log")
    ax.set_xlabel("time step / sqrt(m_min/kn) (–)")
    ax.set_ylabel("max kinetic energy / (p V) (–)")
    ax.set_title("kinetic energy against time step, per damping")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)


def draw_reference_curves(results, fig_dir):
    plt = plotting.pyplot()

    refs = sorted((e for e in results.values() if e["spec"].get("role") == "reference"
                   and e["outcome"].get("rc") == 0), key=lambda e: e["spec"]["seed"])
    if not refs:
        return None
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for e in refs:
        for k, test in enumerate(("ttc", "psc")):
            s = e["series"].get(test)
            if s is None:
                continue
            style = dict(color=f"C{e['spec']['seed'] - 1}", linestyle="-" if test == "ttc" else "--", linewidth=1)
            axes[0].plot(s["e1"] * 100, s["ratio13"], label=f"{test} seed {e['spec']['seed']}", **style)
            axes[1].plot(s["e1"] * 100, s["ev"] * 100, **style)
            axes[2].plot(s["e1"] * 100, s["Z"], **style)
    for ax, label in zip(axes, ("σ1/σ3 (–)", "εv (%)", "Z (–)")):
        ax.set_xlabel("ε1 (%)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"reference runs: paper settings, {SCENE_COUNT} spheres, four seeds (TTC solid, PSC dashed)")
    return plotting.save(fig, os.path.join(fig_dir, "reference.png"))


PERCENT_QUANTITIES = ("e1_peak", "ev_end")


def in_display_units(value, quantity):
    """A strain quantity in %, others as they are."""
    return None if value is None else value * (100.0 if quantity in PERCENT_QUANTITIES else 1.0)


def err_cell(errors, key, scale=1.0):
    v = errors.get(key)
    if v is None:
        return "n/a"
    e, n = v
    mark = "" if n is None or n <= 1.0 else " ✗"
    return f"{fmt(e * scale)} ({fmt(n, 2)}){mark}"


def scene_section(study):
    """study.md's title and its first paragraphs: the reduced scene, the binaries, the reference peaks."""
    sc = study["scene"]
    window = sc.get("end_window")
    end_window_from = "n/a" if window is None else f"{(sc['end_strain'] - window) * 100:g}"
    out = ["# celldem speed–accuracy and stability study",
           "",
           f"Reduced scene: **{sc['count']} spheres** (the paper's sizes, density, contact law, damping and "
           f"preparation; sample.count changed only), tests to **ε1 = {sc['end_strain']:.0%}** (the paper: 8000 "
           f"spheres to 10 %). εv and Z \"at the end\" are their means over ε1 = "
           f"{end_window_from}–{sc['end_strain'] * 100:g} % (summary.json end_window; the issue's 5 % is beyond the "
           f"reduced tests' end). Critical step "
           f"t_c = sqrt(m_min/kn) = {fmt_spec(sc['t_c'], '.3e', 'n/a')} s; the paper's dt = {PAPER_DT:g} s is "
           f"{fmt_spec(sc['paper_dt_over_tc'], '.3f', 'n/a')} t_c; its inertial number I = ε̇·d·sqrt(ρ/p) = "
           f"{fmt_spec(sc['paper_inertial_number'], '.2e', 'n/a')} "
           f"(d = {fmt_spec(scaled(sc['d_mean'], 1e3), '.3g', 'n/a')} mm "
           f"mean diameter, p = 100 kPa). Run times are single-thread CPU seconds (celldem --threads 1), one run "
           f"at a time, on {', '.join(sc['hosts']) or 'n/a'}; wall times are in study.json.",
           "",
           "celldem binaries used: " + ("; ".join(f"`{b.get('path')}` sha256 {str(b.get('sha256'))[:12]}…, built "
                                                  f"{b.get('built')}" + (f" ({b['note']})" if b.get("note") else "")
                                                  for b in study.get("binaries") or []) or "n/a") + ".",
           "",
           f"Reference ε1 at peak σ1/σ3 per seed: TTC {', '.join(fmt(x * 100 if x is not None else None, 2) for x in sc['reference_e1_at_peak']['ttc'])} %, "
           f"PSC {', '.join(fmt(x * 100 if x is not None else None, 2) for x in sc['reference_e1_at_peak']['psc'])} %: "
           + _peak_margin(sc),
           ""]
    return out


def noise_floor_section(study):
    """## Noise floor: the reference samples' mean and seed-to-seed std of each compared quantity."""
    floor = study["noise_floor"]
    sc = study["scene"]
    return ["## Noise floor",
            "",
            f"Mean and seed-to-seed standard deviation over the reference samples (seeds "
            f"{', '.join(str(s) for s in sc['reference_seeds'])}, paper settings). An error below the standard "
            f"deviation is not an error.",
            "",
            md_table(("quantity", "mean", "std (noise floor)"),
                     [(f"{t.upper()} {QUANTITY_LABELS[q]}" + (" (%)" if q in PERCENT_QUANTITIES else ""),
                       fmt(in_display_units(floor[f'{t}.{q}'][0], q)), fmt(in_display_units(floor[f'{t}.{q}'][1], q)))
                      for t, q in QUANTITIES]),
            ""]


def speed_section(study, root, fig_paths):
    """## Speed against accuracy: the chart, each setting's errors, and its run-time health."""
    out = ["## Speed against accuracy",
           "",
           f"![error against run time]({os.path.relpath(fig_paths['pareto'], root)})",
           "",
           "Each setting changes one knob from the paper's settings (\"combined\": dt and rate together). Errors are "
           "differences from the reference on the same sample (mean over the seeds run), in parentheses divided by "
           "the noise floor; ✗ marks a quantity outside the floor. Score: the largest normalised error. "
           "Particle count runs are different samples, compared with the reference mean.",
           ""]
    headers = ("setting", "seeds", "dt/t_c", "Δε1/step", "I", "CPU s", "wall s", "score", "Pareto",
               "TTC peak σ1/σ3", "TTC ε1 peak (%)", "TTC εv end (%)", "TTC Z end", "PSC peak σ1/σ3",
               "PSC ε1 peak (%)", "PSC εv end (%)", "PSC Z end", "PSC b peak")
    table = []
    for r in study["rows"]:
        e = r["errors"]
        table.append((r["label"], ",".join(str(s) for s in r["seeds"]) + (f" ({r['failed']} failed)" if r["failed"] else ""),
                      fmt(r["dt_over_tc"], 3), fmt(r["strain_increment"]), fmt(r["inertial_number"]),
                      fmt(r["cost"], 1), fmt(r["wall"], 1), fmt(r["score"], 2), "yes" if r["pareto"] else "",
                      err_cell(e, "ttc.peak_ratio"), err_cell(e, "ttc.e1_peak", 100), err_cell(e, "ttc.ev_end", 100),
                      err_cell(e, "ttc.Z_end"), err_cell(e, "psc.peak_ratio"), err_cell(e, "psc.e1_peak", 100),
                      err_cell(e, "psc.ev_end", 100), err_cell(e, "psc.Z_end"), err_cell(e, "psc.b_peak")))
    out += [md_table(headers, table), ""]
    out += ["Run-time health of the same settings: the largest kinetic energy / (p V) after the first row (V from "
            "the void ratio and the mean sphere volume), and the largest relative error of a stress-controlled axis "
            "that celldem reports (summary.json servo_max_error, rows after the first 2 %), against the score.", ""]
    out += [md_table(("setting", "I", "dt/t_c", "max KE/(pV)", "servo max error (%)", "score"),
                     [(r["label"], fmt(r["inertial_number"]), fmt(r["dt_over_tc"], 3), fmt(r.get("ke_max")),
                       fmt(r.get("servo_max_error") and r["servo_max_error"] * 100), fmt(r["score"], 2))
                      for r in study["rows"]]), ""]
    return out


def presets_section(study):
    """## Presets: each preset's rule and setting, and the samples prepared at larger dt it avoids."""
    out = []
    out += ["## Presets", ""]
    if study["presets"]:
        prow = []
        for name, p in study["presets"].items():
            prow.append((f"inputs/{name}.json", p["rule"], p["label"], p["preparation"],
                         ",".join(str(x) for x in p["seeds"]),
                         fmt(p["time_step"]), fmt(p["dt_over_tc"], 3), fmt(p["strain_increment"]),
                         fmt(p["servo_max_strain_increment"]), fmt(p["inertial_number"]), fmt(p["score_stress"], 2),
                         fmt(p["score_volume"], 2), f"{fmt(p['test_steps_speedup'], 1)}×",
                         f"{p['measured_speedup']:.1f}×" if p.get("measured_speedup") else "n/a"))
        out += [md_table(("preset", "rule", "setting", "preparation", "seeds", "time_step (s)", "dt/t_c", "Δε1/step",
                          "servo.max_strain_increment", "I", "stress-ratio errors / floor (max)",
                          "εv, Z errors / floor (max)", "speed-up of the tests (steps)",
                          "measured speed-up (reduced scene, CPU)"), prow),
                "",
                "A preset is the cheapest setting, run on at least two seeds, whose errors meet its rule; it is written "
                "as the paper deck (8000 spheres, ε1 to 10 %) with only time_step, the axial strain increment, the "
                "servo's cap on the strain per step (5 × Δε1, the paper's own ratio) and the output interval (a row "
                "every 2e-4 of ε1, as the paper deck) changed. inputs/paper.json remains paper fidelity. The deck's "
                "time step and servo cap also apply to its preparation; samples prepared with a larger dt or cap and "
                "then run with the paper's tests (below) differ from the reference by more than the noise floor "
                "(the TTC peak drops by about 0.1 in all four samples prepared with a larger cap), so such a preset "
                "starts from the paper deck's prepared sample (\"initial_state\", column preparation = paper), "
                "exactly as the study's runs did:", ""]
        for r in study["rows"]:
            if r["group"] == "prepare_dt":
                out += [f"- {r['label']} (seeds {','.join(str(x) for x in r['seeds'])}), then the paper's tests: "
                        f"stress-ratio errors {fmt(r['score_stress'], 2)} floors, εv and Z {fmt(r['score_volume'], 2)} "
                        "floors against the reference mean (a different packing, so unpaired)."]
        out += [""]
    else:
        out += ["No setting meets a preset's rule (or no reference yet).", ""]
    return out


def samples_section(study):
    """## Samples: each prepared sample's void ratio, Z, steps and cost."""
    out = []
    out += ["## Samples", ""]
    srows = []
    for n, s in sorted(study["samples"].items()):
        p = s.get("prepared") or {}
        srows.append((n, s["spec"]["label"], fmt(p.get("void_ratio")), fmt(p.get("Z"), 3), fmt(p.get("steps")),
                      fmt(s.get("cpu_s"), 1), "ok" if s["outcome_rc"] == 0 else f"rc {s['outcome_rc']}"))
    out += [md_table(("sample", "what", "void ratio e", "Z", "preparation steps", "CPU s", "state"), srows), ""]
    return out


def stability_section(study, root, fig_paths):
    """## Stability map: the chart and the time step × damping runs."""
    out = []
    out += ["## Stability map", "", f"![stability map]({os.path.relpath(fig_paths['stability'], root)})", "",
            f"Time step × damping: TTC from the seed-1 sample to ε1 = {STABILITY_STRAIN:.0%} at the paper's strain "
            "rate 0.2/s. blow-up: non-finite values; unstable: max kinetic energy above "
            f"{KE_UNSTABLE:g} p·V (quasi-static runs stay near 1e-6 p·V); drift: σ1/σ3 over the last "
            f"fifth of the run differs from the same damping's run at the paper's dt by more than {DRIFT_FLOORS:g} TTC "
            "peak noise floors (round-off alone moves it by about one).", ""]
    drows = [(fmt(r["dt_over_tc"], 3), fmt(r["damping"]), r["state"], fmt(r.get("ke_max")),
              fmt(r.get("ratio_drift"), 2), fmt(r.get("curve_diff_ratio")), fmt(r.get("curve_diff_ev")))
             for r in study["stability"]["dt"]]
    out += [md_table(("dt/t_c", "damping", "state", "max KE/(pV)", "σ1/σ3 drift / floor",
                      "σ1/σ3 curve diff / range", "εv curve diff / range"), drows), ""]
    return out


def servo_cap_lines(study):
    """The servo cap's paragraph and table (part of the stability map)."""
    out = []
    out += ["Servo cap: the first pass of the strain-increment, time-step, density and combined settings, run with "
            "celldem's default servo.max_strain_increment = 1e-6 (the stress servo moves an axis by at most that "
            "much per step). PSC's free axis dilates at about 2 × Δε1 per step, so once Δε1 exceeds about half the "
            "cap the servo cannot follow and σ3 runs away; errors: the largest relative error of a stress-controlled "
            "axis that celldem reports (summary.json servo_max_error).", ""]
    crow = [(r["label"], fmt(r["strain_increment"]),
             fmt(r["strain_increment"] / r["servo_max_strain_increment"] if r["servo_max_strain_increment"]
                 else None, 2),
             fmt(r["inertial_number"]), fmt((r["servo_max_error_by_test"].get("ttc") or 0) * 100, 3),
             fmt((r["servo_max_error_by_test"].get("psc") or 0) * 100, 3), fmt(r["score"], 2))
            for r in sorted(study.get("servo_cap_rows", []), key=lambda r: r["strain_increment"])]
    out += [md_table(("setting", "Δε1/step", "Δε1 / cap", "I", "TTC servo max error (%)", "PSC servo max error (%)",
                      "score"), crow), ""]
    return out


def servo_gain_lines(study):
    """The servo gains' paragraph and table (part of the stability map)."""
    sc = study["scene"]
    out = []
    out += [f"Servo gains: TTC to ε1 = {SERVO_STRAIN:.1%} at Δε1 = {SERVO_INC:g}/step (I = "
            f"{fmt_spec(sc.get('servo_inertial_number'), '.1e', 'n/a')}), a row every "
            f"{SERVO_OUTPUT_INTERVAL} steps; error of σ22 and σ33 against 100 kPa after the first 10 % of rows.", ""]
    srows = [(fmt(r["gain"]), fmt(r["integral_gain"]), fmt(r.get("std") and r["std"] * 100, 3),
              fmt(r.get("bias") and r["bias"] * 100, 3), fmt(r.get("max") and r["max"] * 100, 3),
              fmt(r.get("peak_ratio")), "yes" if r.get("holds") else ("no" if r.get("rc") == 0 else f"rc {r.get('rc')}"))
             for r in study["stability"]["servo"]]
    out += [md_table(("gain", "integral_gain", "error std (%)", "|mean error| (%)", "max error (%)", "TTC peak σ1/σ3",
                      "holds (std and bias ≤ 0.5 %)"), srows), ""]
    return out


def thresholds_section(study):
    """## Where the scheme fails: the measured thresholds for run-time detection."""
    out = []
    t = study.get("thresholds") or {}
    out += ["## Where the scheme fails: thresholds for run-time detection", "",
            md_table(("what", "measured"), [
                ("time step (damping 0.05; damping 0, 0.01 alike)",
                 f"results unchanged up to dt = {fmt(t.get('dt_stable_max'), 2)} t_c; σ1/σ3 drifts at "
                 f"{', '.join(fmt(x, 2) for x in t.get('dt_drift') or []) or 'none'} t_c; unstable from "
                 f"{fmt(t.get('dt_unstable_min'), 2)} t_c (finite, but the kinetic energy is 100 times the "
                 "quasi-static level and the results are wrong)"),
                ("kinetic energy / (p V)",
                 f"quasi-static settings ≤ {fmt(t.get('ke_quasi_static_max'))}; short stable runs ≤ "
                 f"{fmt(t.get('ke_stable_max'))}; unstable runs ≥ {fmt(t.get('ke_unstable_min'))}"),
                ("inertial number I (dt below celldem's time-step warning, `celldem plan`)",
                 f"stress-ratio results inside the noise floor up to I = {fmt(t.get('I_stress_ok_max'))}, outside from "
                 f"{fmt(t.get('I_stress_bad_min'))}; εv and Z within 2 floors up to I = {fmt(t.get('I_volume_ok_max'))}"),
                ("servo cap: Δε1 / servo.max_strain_increment",
                 f"the servo holds (max error ≤ 0.5 %) up to {fmt(t.get('cap_ratio_ok_max'), 2)}, fails from "
                 f"{fmt(t.get('cap_ratio_bad_min'), 2)}; the paper's settings: max error "
                 f"{fmt((t.get('servo_max_error_reference') or 0) * 100, 3)} %"),
                ("servo gains (gain ≤ 1 by deck validation)",
                 "no oscillation at any gain; failing (std or bias > 0.5 %): " + (", ".join(
                     f"gain {g:g} / integral {i:g} (bias {b * 100:.2g} %)" for g, i, _, b in t.get("servo_failing", []))
                     or "none") + f"; holding settings: error std ≤ {fmt((t.get('servo_std_max_holding') or 0) * 100, 3)} %"),
            ]), ""]
    return out


def modelling_section(study):
    """## Modelling choices: the reduced TTC with one choice changed, against the reference."""
    out = []
    out += ["## Modelling choices", "",
            "The reduced TTC with one modelling choice changed, against the reference on the same samples (mean "
            "signed difference over the seeds run; in parentheses divided by the noise floor; ✗: outside it).", ""]
    mrows = []
    for m in study["modelling"]:
        cells = []
        for t, q in MODELLING_QUANTITIES:
            v = m.get(f"{t}.{q}")
            scale = 100 if q == "ev_end" else 1
            cells.append("n/a" if v is None else f"{fmt(v[0] * scale)} ({fmt(v[1], 2)})" + (" ✗" if v[1] and v[1] > 1 else ""))
        changes = [QUANTITY_LABELS[q] for (t, q) in MODELLING_QUANTITIES
                   if m.get(f"{t}.{q}") and m[f"{t}.{q}"][1] and m[f"{t}.{q}"][1] > 1]
        mrows.append((m["label"], m["seeds"], *cells, ", ".join(changes) or "none beyond the noise floor"))
    out += [md_table(("choice (paper: rotate, contact_point, rot. damping 0.05, affine)", "seeds",
                      "Δ peak σ1/σ3", "Δ εv at end (%)", "Δ Z at end", "changes"), mrows), ""]
    return out


def write_markdown(study, root, fig_paths, ref_fig):
    """Writes root/study.md from the analysed study, section by section; returns its path."""
    out = scene_section(study) + noise_floor_section(study) + speed_section(study, root, fig_paths)
    out += presets_section(study) + samples_section(study)
    out += stability_section(study, root, fig_paths) + servo_cap_lines(study) + servo_gain_lines(study)
    out += thresholds_section(study) + modelling_section(study)
    out += sufficiency.study_section(root)  # sufficiency*/sufficiency.md beside the study root, when present
    if ref_fig:
        out += ["## Reference curves", "", f"![reference]({os.path.relpath(ref_fig, root)})", ""]
    path = os.path.join(root, "study.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out))
    return path


def jsonable(x):
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if isinstance(x, (np.floating,)):
        return jsonable(float(x))
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def _peak_margin(sc):
    """Where the reference seeds' peaks lie against the tests' end, as measured (not assumed inside it)."""
    e1 = [x for t in ("ttc", "psc") for x in sc["reference_e1_at_peak"][t]]
    missing = sum(x is None for x in e1)
    found = [x for x in e1 if x is not None]
    words = (f"the latest at ε1 = {max(found) * 100:.2f} % of the tests' {sc['end_strain']:.0%}" if found
             else "no seed reached a peak")
    return words + (f"; {missing} seed-tests reached no peak (largest σ1/σ3 at the end)." if missing else ".")
