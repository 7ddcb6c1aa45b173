"""The rate ladder's analysis: per quantity the law Q = Q0_seed + C r^p over the rungs (0.25x-8x of the paper's
rate, 1000 spheres, TTC to e1 = 5 %), its exponent with a 95 % interval; the same against the cell's actual
inertial number; and the 1x test's three-rate Richardson distance (rungs 1, 0.5, 0.25) against the law's."""
import csv, json, math, os, sys
import numpy as np
from scipy import optimize, stats

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "results", "ladder")
FACTORS = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]
SEEDS = [int(s) for s in sys.argv[1:] if s.isdigit()] or [1, 2]
WINDOW = 0.02
FLOORS = {"peak_robust.ratio13": 0.0952, "peak_ratio13": 0.0952, "end_span.ev": 0.00106, "end_span.Z": 0.0259}


def folder(seed, f):
    if f == 1.0:
        return os.path.join(HERE, f"prep/seed-{seed}" if seed <= 2 else f"prep_s{seed}/seed-{seed}")
    return os.path.join(HERE, f"r_s{seed}_{f:g}")


def values(seed, f):
    d = folder(seed, f)
    s = json.load(open(os.path.join(d, "summary.json")))["tests"]["ttc"]
    rows = list(csv.DictReader(open(os.path.join(d, "ttc", "series.csv"))))
    e1 = np.array([float(r["e1"]) for r in rows])
    span = np.abs(e1 - e1[-1]) <= WINDOW
    ev = np.array([float(r["ev"]) for r in rows])
    Z = np.array([float(r["Z"]) for r in rows])
    return {"peak_robust.ratio13": s["peak_robust"]["ratio13"], "peak_ratio13": s["peak_ratio13"],
            "end_span.ev": float(ev[span].mean()), "end_span.Z": float(Z[span].mean()),
            "I": s["inertial_number"], "I_imposed": s["imposed_inertial_number"],
            "peak_reached": s.get("peak_reached", True), "wall_s": s.get("wall_s")}


def pooled_fit(x, q, seed_index, nseeds):
    """Q = Q0_seed + C x^p: (params, covariance, dof); params = [Q0_1..Q0_n, C, p]."""
    def resid(th):
        return q - th[seed_index] - th[nseeds] * x ** th[nseeds + 1]
    best = None
    for p0 in (0.3, 0.6, 1.0, 1.5):
        c0 = np.polyfit(x ** p0, q, 1)[0]
        th0 = np.r_[[q[seed_index == k].mean() for k in range(nseeds)], c0, p0]
        r = optimize.least_squares(resid, th0, bounds=(np.r_[[-np.inf] * (nseeds + 1), 0.05], np.r_[[np.inf] * (nseeds + 1), 5.0]))
        if best is None or r.cost < best.cost:
            best = r
    dof = len(q) - len(best.x)
    s2 = 2 * best.cost / dof
    cov = np.linalg.pinv(best.jac.T @ best.jac) * s2
    return best.x, cov, dof


def richardson3(rates, q):
    """The ladder's three-rate fit (the code's, measure/richardson.hpp): p within [0.25, 3]."""
    r = np.asarray(rates); q = np.asarray(q)
    def lin(p):
        x = r ** p
        c, q0 = np.polyfit(x, q, 1)
        return q0, c, float(np.sum((q - q0 - c * x) ** 2))
    g = np.linspace(np.log(0.25), np.log(3.0), 400)
    k = int(np.argmin([lin(np.exp(v))[2] for v in g]))
    res = optimize.minimize_scalar(lambda v: lin(np.exp(v))[2], bounds=(g[max(k - 1, 0)], g[min(k + 1, 399)]), method="bounded")
    q0, c, _ = lin(np.exp(res.x))
    return q0, c, float(np.exp(res.x))


def main():
    data = {(s, f): values(s, f) for s in SEEDS for f in FACTORS
            if os.path.exists(os.path.join(folder(s, f), "summary.json"))}
    twins = {(s, f): values(s, f) for s in SEEDS for f in (1.001, 1.002) if os.path.exists(folder(s, f))}
    out = {"seeds": SEEDS, "factors": FACTORS, "window_strain": WINDOW, "floors": FLOORS, "quantities": {}}
    print("I (actual) / I (imposed):", {f: round(np.mean([data[s, f]["I"] / data[s, f]["I_imposed"] for s in SEEDS if (s, f) in data]), 3) for f in FACTORS})
    print("runs:", len(data), "I imposed at 1x:", np.mean([data[s, 1.0]["I_imposed"] for s in SEEDS]))
    print("peak reached:", {k: v["peak_reached"] for k, v in data.items() if not v["peak_reached"]})
    for q in FLOORS:
        rows = [(k, f, data[s, f][q], data[s, f]["I_imposed"]) for k, s in enumerate(SEEDS) for f in FACTORS if (s, f) in data]
        idx = np.array([r[0] for r in rows]); rate = np.array([r[1] for r in rows]); val = np.array([r[2] for r in rows])
        I = np.array([r[3] for r in rows])
        res = {}
        for name, x in (("rate", rate), ("I", I / 1e-4)):
            th, cov, dof = pooled_fit(x, val, idx, len(SEEDS))
            t = stats.t.ppf(0.975, dof)
            p, sp = th[-1], math.sqrt(cov[-1, -1])
            C, sC = th[-2], math.sqrt(cov[-2, -2])
            res[name] = {"order": p, "order_ci95": [p - t * sp, p + t * sp], "C": C, "C_ci95": [C - t * sC, C + t * sC],
                         "Q0": list(th[:-2]), "dof": dof,
                         # (ln |C|, p): the delta method
                         "log_cov": [cov[-2, -2] / C ** 2, cov[-2, -1] / C, cov[-1, -1]]}
        # the 1x test's ladder (rungs 0.5, 0.25) per seed, against the law's distance at r = 1 (C of the rate fit)
        ladder = []
        for s in SEEDS:
            if (s, 0.25) not in data:
                continue
            qs = [data[s, 1.0][q], data[s, 0.5][q], data[s, 0.25][q]]
            q0, c, p = richardson3([1.0, 0.5, 0.25], qs)
            tw = [data[s, 1.0][q]] + [twins[s, f][q] for f in (1.001, 1.002) if (s, f) in twins]
            sd = float(np.std(tw, ddof=1)) if len(tw) > 1 else float("nan")
            ladder.append({"seed": s, "distance": c, "order": p, "linear": (qs[0] - qs[1]) / 0.5, "chaos_sd": sd,
                           "distance_floors": c / FLOORS[q], "law_distance_floors": res["rate"]["C"] / FLOORS[q]})
        res["ladder_1x"] = ladder
        # the 8x test's distance by the law, in floors
        res["law_distance_floors_at"] = {f: res["rate"]["C"] * f ** res["rate"]["order"] / FLOORS[q] for f in FACTORS + [10.0]}
        out["quantities"][q] = res
        r = res["rate"]
        print(f"{q:22s} p = {r['order']:.3f} [{r['order_ci95'][0]:.3f}, {r['order_ci95'][1]:.3f}]  C = {r['C']:.4g} "
              f"[{r['C_ci95'][0]:.4g}, {r['C_ci95'][1]:.4g}] ({r['C'] / FLOORS[q]:+.2f} floors at 1x; vs I: p = "
              f"{res['I']['order']:.3f} [{res['I']['order_ci95'][0]:.3f}, {res['I']['order_ci95'][1]:.3f}])")
        print(f"{'':22s} vs imposed I/1e-4: C = {res['I']['C']:.4g}, p = {res['I']['order']:.3f}, cov(lnC, p) = {res['I']['log_cov']}")
        for l in ladder:
            print(f"    seed {l['seed']}: 1x ladder distance {l['distance_floors']:+.2f} floors (order {l['order']:.2f}), "
                  f"linear {l['linear'] / FLOORS[q]:+.2f}, chaos sd {l['chaos_sd'] / FLOORS[q]:.2f} floors")
    json.dump(out, open(os.path.join(HERE, "ladder_fit.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
