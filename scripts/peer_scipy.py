#!/usr/bin/python3
"""The SciPy half of the peer comparison (scripts/bench-peer).

Reads the problems written by `fit_peer --out DIR` (core/fit/peer_export.cc),
fits each colour channel of our extended Phong model with
scipy.optimize.least_squares, and writes a JSON report with our and SciPy's
time and final cost side by side.

The model, re-implemented from core/fit/phong_fit.cc and phong_cost.h (not
exported pre-applied, so that this is a check of the C++ too):

  g' = g if finite and > 0 else 0;  h' = min(h, 1) if g' > 0 and h finite > 0 else 0
  per channel c, over the lights k of the mask:
    w_k = I_kc / I_max,  G_i = sum_k w_k g'_ik,  r_scale = sqrt(mean r_ic^2)
    x = (a, b, t):  kd = a r_scale / I_max,  ks = b r_scale / I_max,  ke = e^t
    S_i = sum_{k: h'>0} w_k exp(ke ln h'_ik + ln a_ik)      (a_ik the fall-off, 1 without)
    rho_i = r_ic / r_scale - (a G_i + b S_i)
    J = [-G_i, -S_i, -b ke sum_k w_k exp(.) ln h'_ik]
  bounds [0, kd_max / to_orig], [0, ks_max / to_orig], [ln ke_min, ln ke_max]
  x0: where our LM started (FitPhong's start after its grid over ke, exported
      per channel); without it, ks, ke from the options, a by least squares
      with b = 0, clamped.
  cost (original units) = 0.5 sum_i (r_ic - f_ic)^2 = r_scale^2 * 0.5 sum rho_i^2  (Ceres's convention)

Runs per channel: 'trf' with the bounds and the analytic Jacobian, 'trf' with
a 2-point numeric Jacobian, and 'lm' (MINPACK, no bounds) with the analytic
Jacobian; an 'lm' solution outside the bounds is marked infeasible. All with
ftol = xtol = gtol = 1e-10 (Ceres: function and parameter tolerance 1e-10,
gradient tolerance 1e-10 by default; the definitions differ in detail) and
SciPy's default evaluation cap. Times are time.perf_counter around
least_squares (residuals and Jacobian included, data preparation excluded and
reported apart), summed over the 3 channels, median of --repeats. BLAS
threads are pinned to 1, as Ceres runs with num_threads = 1.

Usage: /usr/bin/python3 scripts/peer_scipy.py DIR [--out FILE] [--repeats 3]
"""
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

# Our final cost, re-evaluated here, must match the reported one to this.
CHECK_RELATIVE_TOLERANCE = 1e-6
# Costs closer than this (relative) count as equal in the verdict column.
EQUAL_COST_RELATIVE = 1e-9
# ke = e^t is capped at e^700 so that an unbounded 'lm' step cannot overflow.
MAX_LOG_KE = 700.0


def load(directory, name, shape):
    values = np.fromfile(os.path.join(directory, name), dtype="<f8")
    return values.reshape(shape)


class Channel:
    """One channel's normalised problem, built like phong_fit.cc's FitChannel."""

    def __init__(self, refl_c, g, log_h, log_a, valid, intensity_c, opts):
        i_max = float(intensity_c.max()) if intensity_c.size else 0.0
        self.w = intensity_c / i_max if i_max > 0.0 else intensity_c.copy()
        n = refl_c.size
        self.G = g @ self.w
        r_scale = math.sqrt(float(np.dot(refl_c, refl_c)) / n) if n > 0 else 1.0
        if not (r_scale > 0.0) or not math.isfinite(r_scale):
            r_scale = 1.0
        self.r_scale = r_scale
        self.r = refl_c / r_scale
        self.to_original = r_scale / i_max if i_max > 0.0 else 1.0
        # exp(ke * LH + LA): LH = ln h' where valid (0 elsewhere), LA = ln a
        # where valid (-inf elsewhere, which zeroes the term like kNoHighlight).
        self.LH = np.where(valid, log_h, 0.0)
        self.LA = np.where(valid, log_a, -np.inf)
        log_highlight = math.log(opts["highlight_cosine"]) if opts["highlight_cosine"] > 0 else -np.inf
        diffuse_samples = int(np.count_nonzero(self.G > opts["min_cosine"]))
        highlight = valid & (log_h > log_highlight) & (self.w[None, :] > 0.0)
        highlight_samples = int(np.count_nonzero(highlight.any(axis=1)))
        self.free = (diffuse_samples > 0, highlight_samples >= max(opts["min_highlight_samples"], 1))
        self.lower = np.array([0.0, 0.0, math.log(opts["ke_min"])])
        self.upper = np.array(
            [opts["kd_max"] / self.to_original, opts["ks_max"] / self.to_original, math.log(opts["ke_max"])]
        )
        kd0, ks0, ke0 = opts["initial"]
        x = np.array(
            [
                kd0 / self.to_original,
                ks0 / self.to_original,
                math.log(min(max(ke0, opts["ke_min"]), opts["ke_max"])),
            ]
        )
        s_gg = float(np.dot(self.G, self.G))
        if self.free[0] and opts["initialise_kd_from_data"] and s_gg > 0.0:
            x[0] = float(np.dot(self.r, self.G)) / s_gg
        self.x0 = np.clip(x, self.lower, self.upper)
        self._t = None

    def _sums(self, t):
        if self._t != t:
            ke = math.exp(min(t, MAX_LOG_KE))
            p = np.exp(ke * self.LH + self.LA) * self.w
            self._S = p.sum(axis=1)
            self._D = (p * self.LH).sum(axis=1)
            self._ke = ke
            self._t = t
        return self._S, self._D, self._ke

    def residuals(self, x):
        S, _, _ = self._sums(float(x[2]))
        return self.r - (x[0] * self.G + x[1] * S)

    def jacobian(self, x):
        S, D, ke = self._sums(float(x[2]))
        return np.column_stack((-self.G, -S, -x[1] * D * ke))

    def cost_original(self, x):
        rho = self.residuals(x)
        return 0.5 * float(np.dot(rho, rho)) * self.r_scale**2

    def x_of(self, kd, ks, ke):
        return np.array([kd / self.to_original, ks / self.to_original, math.log(ke)])

    def params_of(self, x):
        return [x[0] * self.to_original, x[1] * self.to_original, math.exp(min(x[2], MAX_LOG_KE))]


def prepare(directory, problem, opts):
    n, L = problem["samples"], problem["lights"]
    refl = load(directory, "reflectance.f64", (n, 3))
    g_raw = load(directory, "g.f64", (n, L))
    h_raw = load(directory, "h.f64", (n, L))
    intensity = load(directory, "intensity.f64", (L, 3))
    a_raw = load(directory, "falloff.f64", (n, L)) if problem["falloff"] else np.ones((n, L))
    lights = [k for k in range(L) if problem["mask"] >> k & 1]
    g_raw, h_raw, a_raw, intensity = g_raw[:, lights], h_raw[:, lights], a_raw[:, lights], intensity[lights]
    finite = np.isfinite(refl).all(axis=1) & np.isfinite(g_raw).all(axis=1) & np.isfinite(h_raw).all(axis=1)
    refl, g_raw, h_raw, a_raw = refl[finite], g_raw[finite], h_raw[finite], a_raw[finite]
    g = np.where(g_raw > 0.0, g_raw, 0.0)
    h = np.where((g > 0.0) & (h_raw > 0.0), np.minimum(h_raw, 1.0), 0.0)
    valid = h > 0.0
    with np.errstate(divide="ignore"):
        log_h = np.where(valid, np.log(np.where(valid, h, 1.0)), -np.inf)
        a_ok = (a_raw > 0.0) & np.isfinite(a_raw)
        log_a = np.where(a_ok, np.log(np.where(a_ok, a_raw, 1.0)), -np.inf)
    return [Channel(refl[:, c], g, log_h, log_a, valid, intensity[:, c], opts) for c in range(3)]


def run_scipy(channels, method, jac, repeats):
    """Fits the 3 channels; returns seconds (median over repeats), cost, params, nfev."""
    runs = []
    for _ in range(repeats):
        seconds, results = 0.0, []
        for ch in channels:
            if not all(ch.free):
                raise SystemExit("peer_scipy: a problem with a parameter held constant is not supported")
            kwargs = dict(method=method, ftol=1e-10, xtol=1e-10, gtol=1e-10)
            if method != "lm":
                kwargs["bounds"] = (ch.lower, ch.upper)
            ch._t = None
            start = time.perf_counter()
            res = least_squares(ch.residuals, ch.x0, jac=ch.jacobian if jac == "analytic" else "2-point", **kwargs)
            seconds += time.perf_counter() - start
            results.append(res)
        runs.append((seconds, results))
    seconds = statistics.median(r[0] for r in runs)
    results = runs[-1][1]
    out = {"seconds": seconds, "seconds_all": [r[0] for r in runs], "channels": []}
    feasible = True
    for ch, res in zip(channels, results):
        inside = bool(np.all(res.x >= ch.lower - 1e-12) and np.all(res.x <= ch.upper + 1e-12))
        feasible = feasible and inside
        out["channels"].append(
            {
                "cost": ch.cost_original(res.x),
                "scipy_cost": float(res.cost) * ch.r_scale**2,
                "params": ch.params_of(res.x),
                "nfev": int(res.nfev),
                "njev": int(res.njev) if res.njev is not None else None,
                "status": int(res.status),
                "feasible": inside,
            }
        )
    out["cost"] = sum(c["cost"] for c in out["channels"])
    out["feasible"] = feasible
    out["nfev"] = sum(c["nfev"] for c in out["channels"])
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir")
    parser.add_argument("--out", default="out/bench/peer.json")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    manifest = json.load(open(os.path.join(args.dir, "manifest.json")))
    opts = manifest["options"]
    rows, warnings = [], []
    for problem in manifest["problems"]:
        start = time.perf_counter()
        channels = prepare(os.path.join(args.dir, problem["dir"]), problem, opts)
        prepare_seconds = time.perf_counter() - start
        # SciPy starts where our LM started: FitPhong's initial grid over ke
        # (phong_fit.cc InitialSpecular) is part of our time, not of SciPy's.
        for ch, summary in zip(channels, problem["ours"]["lm"]["channels"]):
            if "start" in summary:
                ch.x0 = np.clip(ch.x_of(*summary["start"]), ch.lower, ch.upper)
        # One residual + Jacobian evaluation of channel 0 at x0 (exp() once):
        # the peer's per-evaluation cost, beside BM_PhongResidualBlocks's.
        evals = []
        for _ in range(7):
            channels[0]._t = None
            t0 = time.perf_counter()
            channels[0].residuals(channels[0].x0)
            channels[0].jacobian(channels[0].x0)
            evals.append(time.perf_counter() - t0)
        row = {"name": problem["name"], "description": problem["description"], "samples": problem["samples"],
               "python_prepare_seconds": prepare_seconds,
               "numpy_residual_jacobian_seconds": statistics.median(evals), "ours": {}, "scipy": {}, "check": {}}
        # Our results, and our costs re-evaluated with this file's model.
        for solver in ("lm", "powell"):
            ours = problem["ours"][solver]
            recomputed, initial, worst = [], [], 0.0
            for ch, params, summary in zip(channels, ours["params"], ours["channels"]):
                cost = ch.cost_original(ch.x_of(*params))
                recomputed.append(cost)
                initial.append(ch.cost_original(ch.x0))
                for mine, theirs in ((cost, summary["final_cost"]), (initial[-1], summary["initial_cost"])):
                    worst = max(worst, abs(mine - theirs) / max(abs(theirs), 1e-300))
            ok = worst <= CHECK_RELATIVE_TOLERANCE
            row["check"][solver] = {"max_relative_difference": worst, "ok": ok}
            if not ok:
                warnings.append(f"{problem['name']} {solver}: our reported cost and the Python model differ by "
                                f"{worst:.3g} (relative) — the peer's model is not ours")
            row["ours"][solver] = {
                "seconds": ours["seconds"],
                "cost": sum(c["final_cost"] for c in ours["channels"]),
                "cost_recomputed": sum(recomputed),
                "iterations": sum(c["iterations"] for c in ours["channels"]),
                "flags": [c["flags"] for c in ours["channels"]],
                "channel_costs": [c["final_cost"] for c in ours["channels"]],
                "params": ours["params"],
            }
        # Where our LM's time goes (fit_peer's copy of the Ceres problem), and
        # the same without Ceres's projected line search (an experiment).
        for key, diag in (("ceres", problem.get("ceres_lm_diagnostics")),
                          ("ceres_no_line_search", problem.get("ceres_lm_no_line_search_diagnostics"))):
            if not diag:
                continue
            lm = row["ours"]["lm"]
            lm[key] = {
                "iterations": sum(c["iterations"] for c in diag),
                "residual_evaluations": sum(c["residual_evaluations"] for c in diag),
                "jacobian_evaluations": sum(c["jacobian_evaluations"] for c in diag),
                "residual_seconds": sum(c["residual_seconds"] for c in diag),
                "jacobian_seconds": sum(c["jacobian_seconds"] for c in diag),
                "linear_solver_seconds": sum(c["linear_solver_seconds"] for c in diag),
                "total_seconds": sum(c["total_seconds"] for c in diag),
                "cost": sum(c["final_cost"] for c in diag),
                "channels": diag,
            }
            drift = max(abs(c["final_cost"] - f) / max(abs(f), 1e-300) for c, f in zip(diag, lm["channel_costs"]))
            lm[key]["max_relative_cost_difference_to_fitphong"] = drift
            if key == "ceres" and drift > CHECK_RELATIVE_TOLERANCE:
                warnings.append(f"{problem['name']}: fit_peer's Ceres diagnostics copy ends at a cost {drift:.3g} "
                                "(relative) away from FitPhong's: the copy has drifted from phong_fit.cc")
        for key, method, jac in (("trf", "trf", "analytic"), ("trf_2point", "trf", "2-point"),
                                 ("lm", "lm", "analytic")):
            result = run_scipy(channels, method, jac, args.repeats)
            result["channel_costs"] = [c["cost"] for c in result["channels"]]
            ref = row["ours"]["lm"]
            result["cost_ratio_vs_ours_lm"] = result["cost"] / ref["cost"]
            result["time_ratio_vs_ours_lm"] = result["seconds"] / ref["seconds"]
            result["time_ratio_vs_ours_powell"] = result["seconds"] / row["ours"]["powell"]["seconds"]
            # Per channel: does SciPy reach a lower cost than both our solvers?
            best_ours = [min(a, b) for a, b in zip(ref["channel_costs"], row["ours"]["powell"]["channel_costs"])]
            result["lower_than_ours"] = [
                c["feasible"] and c["cost"] < b * (1 - EQUAL_COST_RELATIVE)
                for c, b in zip(result["channels"], best_ours)
            ]
            if any(result["lower_than_ours"]):
                gain = [(b - c["cost"]) / b for c, b in zip(result["channels"], best_ours)]
                warnings.append(f"{problem['name']} scipy {key}: lower cost than ours on channel(s) "
                                f"{[i for i, x in enumerate(result['lower_than_ours']) if x]}, relative gain "
                                f"{', '.join(f'{x:.3g}' for x in gain)}")
            row["scipy"][key] = result
        row["cost_ratio_ours_powell_vs_lm"] = row["ours"]["powell"]["cost"] / row["ours"]["lm"]["cost"]
        rows.append(row)
        print(f"peer_scipy: {problem['name']} done", file=sys.stderr)
    report = {"format": "mvbrdf.bench_peer.v1", "numpy": np.__version__, "scipy": scipy.__version__,
              "repeats": args.repeats, "tolerances": {"ftol": 1e-10, "xtol": 1e-10, "gtol": 1e-10},
              "check_relative_tolerance": CHECK_RELATIVE_TOLERANCE, "problems": rows, "warnings": warnings}
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(report, f, indent=1)
    print_table(report)


def print_table(report):
    head = (f"{'problem':<14} {'n':>7} | {'ours LM s':>9} {'Powell s':>9} {'scipy trf':>9} {'trf 2pt':>9} "
            f"{'scipy lm':>9} | {'LM cost':>12} {'Powell':>9} {'trf':>9} {'trf 2pt':>9} {'lm':>10} | check")
    print(head)
    print("-" * len(head))
    for r in report["problems"]:
        s, o = r["scipy"], r["ours"]
        lm_mark = "" if s["lm"]["feasible"] else "*"
        check = "ok" if all(c["ok"] for c in r["check"].values()) else "WARNING"
        print(f"{r['name']:<14} {r['samples']:>7} | {o['lm']['seconds']:>9.4f} {o['powell']['seconds']:>9.4f} "
              f"{s['trf']['seconds']:>9.4f} {s['trf_2point']['seconds']:>9.4f} {s['lm']['seconds']:>9.4f} | "
              f"{o['lm']['cost']:>12.6g} {r['cost_ratio_ours_powell_vs_lm'] - 1:>9.1e} "
              f"{s['trf']['cost_ratio_vs_ours_lm'] - 1:>9.1e} {s['trf_2point']['cost_ratio_vs_ours_lm'] - 1:>9.1e} "
              f"{s['lm']['cost_ratio_vs_ours_lm'] - 1:>9.1e}{lm_mark or ' '} | {check}")
    print("seconds: RGB (3 channel fits), median of repeats. LM cost: 0.5 sum of squared residuals over RGB, "
          "original units;\nPowell, trf, trf 2pt, lm: cost / our LM cost - 1 (< 0: lower than ours); "
          "* lm solution outside the bounds; check: our costs re-evaluated by the Python model")
    print()
    head = (f"{'problem':<14} | {'LM iter':>7} {'res ev':>6} {'jac ev':>6} {'eval s':>7} {'linsol s':>8} "
            f"{'ceres s':>7} | {'ours ev ms':>10} {'numpy ev ms':>11} | {'trf nfev/njev':>13} {'lm nfev/njev':>12} | "
            f"{'noLS res/jac':>12} {'noLS s':>7} {'noLS cost':>9}")
    print(head)
    print("-" * len(head))
    for r in report["problems"]:
        c = r["ours"]["lm"].get("ceres")
        if not c:
            continue
        evals = c["residual_evaluations"] + c["jacobian_evaluations"]
        ours_ms = 1e3 * (c["residual_seconds"] + c["jacobian_seconds"]) / max(evals, 1)
        s = r["scipy"]
        trf = f"{s['trf']['nfev']}/{sum(x['njev'] for x in s['trf']['channels'])}"
        lm = f"{s['lm']['nfev']}/{sum(x['njev'] for x in s['lm']['channels'])}"
        print(f"{r['name']:<14} | {c['iterations']:>7} {c['residual_evaluations']:>6} {c['jacobian_evaluations']:>6} "
              f"{c['residual_seconds'] + c['jacobian_seconds']:>7.4f} {c['linear_solver_seconds']:>8.4f} "
              f"{c['total_seconds']:>7.4f} | {ours_ms:>10.3f} {1e3 * r['numpy_residual_jacobian_seconds']:>11.3f} | "
              f"{trf:>13} {lm:>12} | ", end="")
        n = r["ours"]["lm"].get("ceres_no_line_search")
        if n:
            evs = f"{n['residual_evaluations']}/{n['jacobian_evaluations']}"
            print(f"{evs:>12} {n['total_seconds']:>7.4f} {n['cost'] / r['ours']['lm']['cost'] - 1:>9.1e}")
        else:
            print()
    print("Ceres's LM over RGB (FitPhong's solver before phong_lm.h), from its summary: iterations, residual-only and residual+Jacobian evaluations (each "
          "over all samples, exp() every time),\ntheir time, the linear solver's, Ceres's total; ms per evaluation, "
          "ours and numpy's (residual + Jacobian of one channel, exp() once); SciPy's evaluation counts over RGB;\n"
          "noLS: the same Ceres solve with its projected line search off (max_num_line_search_step_size_iterations = 0):"
          " evaluations, Ceres seconds, cost / our LM cost - 1")
    for w in report["warnings"]:
        print("WARNING:", w)


if __name__ == "__main__":
    main()
