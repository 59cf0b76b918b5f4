#!/usr/bin/python3
"""Draws the plots of an experiment from its CSVs: experiments/plot.py NAME DIR.

Run by `qbond experiment`; uses Debian's python3-matplotlib.
"""
import csv
import math
import os
import sys
from collections import defaultdict

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def series(path, x, y, key="method"):
    """Rows of a CSV grouped by `key`: {key: (xs, ys)}."""
    out = defaultdict(lambda: ([], []))
    with open(path) as f:
        for r in csv.DictReader(f):
            xs, ys = out[r[key]]
            xs.append(float(r[x]))
            ys.append(float(r[y]))
    return out


def numbers(path):
    """Every row of an all-numeric CSV as a dict of floats."""
    with open(path) as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def save(fig, d, name):
    fig.tight_layout()
    fig.savefig(os.path.join(d, name), dpi=110)
    plt.close(fig)


def fig4_5(d):
    for fig_no, title in (("4", "small timestep (h = 1 ms)"), ("5", "large timestep (h = 0.25 s)")):
        data = series(os.path.join(d, f"fig{fig_no}_velocity.csv"), "time", "relative_velocity")
        exact = [(r["time"], r["relative_velocity"]) for r in numbers(os.path.join(d, f"fig{fig_no}_exact.csv"))]
        fig, ax = plt.subplots(figsize=(8, 4.5))
        ax.plot([t for t, _ in exact], [e for _, e in exact], "k-", lw=2.5, alpha=0.35, label="exact")
        amp = max(abs(e) for _, e in exact)
        sparse = fig_no == "5"  # a few steps per period: mark the samples
        for m, (t, w) in data.items():
            ax.plot(t, w, "o-" if sparse else "-", ms=3, lw=1, label=m)
        ax.set_ylim(-2.5 * amp, 2.5 * amp)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("relative velocity [m/s]")
        ax.set_title(f"Figure {fig_no}: two bonded quanta, {title}")
        ax.legend(fontsize=8, loc="upper right")
        save(fig, d, f"fig{fig_no}.png")


def fig6_7(d):
    for fig_no, title in (("6", "small timestep (h = 1 ms)"), ("7", "large timestep (h = 0.1 s)")):
        data = series(os.path.join(d, f"fig{fig_no}_energy.csv"), "time", "total_energy")
        fig, ax = plt.subplots(figsize=(8, 4.5))
        e0 = next(iter(data.values()))[1][0]
        for m, (t, e) in data.items():
            ax.plot(t, e, lw=1, label=m)
        ax.set_ylim(0, 1.6 * e0)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("total energy [J]")
        ax.set_title(f"Figure {fig_no}: four bonded quanta, {title}")
        ax.legend(fontsize=8, loc="upper right")
        save(fig, d, f"fig{fig_no}.png")


def eq14_15(d):
    rows = numbers(os.path.join(d, "dynamics.csv"))
    t = [r["time"] for r in rows]
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t, [1e3 * r["full_end"] for r in rows], lw=3, alpha=0.4, label="chain of 5 bonds (full)")
    ax.plot(t, [1e3 * r["reduced_end"] for r in rows], "k--", lw=1, label="one bond, Eq. 14 + Rayleigh end mass")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("end displacement [mm]")
    ax.set_title("Eq. 14: a series chain and the one bond that replaces it, free vibration")
    ax.legend(fontsize=8)
    save(fig, d, "eq14_15.png")


def cantilever(d):
    rows = numbers(os.path.join(d, "deflection.csv"))
    n = [r["quanta_across"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(n, [1e6 * r["lattice"] for r in rows], "o-", label="lattice (exact static, K u = f)")
    ax.axhline(1e6 * rows[0]["timoshenko"], color="k", ls="--", lw=1, label="Timoshenko")
    ax.axhline(1e6 * rows[0]["euler_bernoulli"], color="gray", ls=":", lw=1, label="Euler-Bernoulli")
    ax.set_xlabel("quanta across the section")
    ax.set_ylabel("tip deflection [µm]")
    ax.set_title("Cantilever: calibrated steel lattice vs beam theory")
    ax.legend(fontsize=8)
    save(fig, d, "cantilever.png")


def drag(d):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for ax, (name, title, ylabel) in zip(axes[:2], (("fall", "free fall under gravity", "downward velocity [m/s]"),
                                                    ("thrown", "thrown sideways at 1 m/s", "velocity [m/s]"))):
        data = series(os.path.join(d, f"{name}.csv"), "time", "velocity")
        for m, (t, v) in data.items():
            ax.plot(t, v, lw=1.5 if m == "hybrid_frozen" else 1, ls="-" if m != "velocity_verlet" else "--", label=m)
        if name == "fall":
            t = next(iter(data.values()))[0]
            ax.plot(t, [9.81 * x for x in t], "k:", lw=1, label="g t")
        ax.set_title(title)
        ax.set_xlabel("time [s]")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=7)
    ax = axes[2]
    with open(os.path.join(d, "pendulum.csv")) as f:
        rows = list(csv.DictReader(f))
    for key in sorted({(r["method"], r["timestep"]) for r in rows}, key=lambda k: (float(k[1]), k[0])):
        pts = [(float(r["time"]), float(r["energy_fraction"])) for r in rows if (r["method"], r["timestep"]) == key]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], lw=1, ls="-" if float(key[1]) < 1e-3 else "--",
                label=f"{key[0]}, h = {float(key[1]):.3g} s")
    ax.set_ylim(0, 1.3)
    ax.set_title("pendulum: swing energy left")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("E / E(0)")
    ax.legend(fontsize=7)
    save(fig, d, "drag.png")


def fig10(d):
    x = series(os.path.join(d, "trajectory.csv"), "time", "cube_x")
    ln = series(os.path.join(d, "trajectory.csv"), "time", "rope_length")
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for m in x:
        a.plot(*x[m], lw=1, label=m)
        b.plot(*ln[m], lw=1, label=m)
    a.set_ylabel("cube x [m]")
    a.set_title("Figure 10: the pendulum swinging, then tugged down (scripted force)")
    b.set_ylabel("pivot-cube distance [m]")
    b.set_xlabel("time [s]")
    a.legend(fontsize=8)
    save(fig, d, "fig10.png")


def fig9(d):
    pts = numbers(os.path.join(d, "midplane.csv"))
    bend = numbers(os.path.join(d, "bending.csv"))
    fig, (a, b) = plt.subplots(2, 1, figsize=(10, 6.5), gridspec_kw={"height_ratios": [1, 2]})
    sc = a.scatter([p["x"] for p in pts], [p["z"] for p in pts], c=[p["von_mises"] / 1e6 for p in pts],
                   cmap="jet", s=12, marker="s")
    fig.colorbar(sc, ax=a, label="von Mises [MPa]", orientation="horizontal", pad=0.35, aspect=50)
    a.set_aspect("equal")
    a.set_title("Figure 9: von Mises stress on the mid-plane (clamped at x = 0, pushed down at x = L)")
    a.set_xlabel("x [m]")
    a.set_ylabel("z [m]")
    b.plot([r["x"] for r in bend], [r["lattice_sxx"] / 1e6 for r in bend], "o", ms=3, label="lattice (second layer from top)")
    b.plot([r["x"] for r in bend], [r["beam_theory"] / 1e6 for r in bend], "k-", lw=1, label="beam theory M z / I")
    b.set_xlabel("x [m]")
    b.set_ylabel("sigma_xx [MPa]")
    b.legend(fontsize=8)
    save(fig, d, "fig9.png")


def fig11(d):
    def rows(name):
        return numbers(os.path.join(d, name))
    fem = rows("getfem.csv")[-1]["torque"]
    theta = 0.01
    ta, ref = rows("torque_angle.csv"), rows("refinement.csv")
    site, at = rows("lattice_displacement.csv"), rows("getfem_at_sites.csv")
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(15, 4.2))
    a.plot([r["theta"] for r in ta], [r["lattice_torque"] for r in ta], "o-", label="lattice (finest)")
    a.plot([0, ta[-1]["theta"]], [0, fem / theta * ta[-1]["theta"]], "k--", lw=1, label="GetFEM (linear elasticity)")
    a.set_xlabel("twist angle [rad]")
    a.set_ylabel("torque [N m]")
    a.set_title("Figure 11: torque against twist")
    a.legend(fontsize=8)
    n = [r["quanta_across"] for r in ref]
    b.loglog(n, [abs(r["lattice_stiffness"] / (fem / theta) - 1) for r in ref], "o-", label="|T_lattice / T_GetFEM - 1|")
    e0 = abs(ref[0]["lattice_stiffness"] / (fem / theta) - 1)
    b.loglog(n, [e0 * n[0] / x for x in n], "k:", lw=1, label="slope 1/n")
    b.set_xlabel("quanta across")
    b.set_ylabel("relative torque error")
    b.set_title("refinement")
    b.legend(fontsize=8)
    # The end section's displacement (quanta at the largest x), lattice arrows over GetFEM's.
    xmax = max(r["x"] for r in site)
    for s_, f_ in zip(site, at):
        if abs(s_["x"] - 0.5 * xmax) < 1e-9 or abs(s_["x"] - xmax / 2) < (xmax / 100):
            c.arrow(s_["y"], s_["z"], 20 * f_["uy"], 20 * f_["uz"], color="0.6", width=1e-5, head_width=4e-4)
            c.arrow(s_["y"], s_["z"], 20 * s_["uy"], 20 * s_["uz"], color="C0", width=4e-6, head_width=2e-4)
    c.set_aspect("equal")
    c.set_title("mid-length section, displacement x20\n(blue: lattice, grey: GetFEM)", fontsize=10)
    c.set_xlabel("y [m]")
    c.set_ylabel("z [m]")
    save(fig, d, "fig11.png")


def fig3(d):
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, name, title in ((axes[0], "chain", "chain grown by 2 quanta (the paper's run)"),
                            (axes[1], "lattice", "3D lattices")):
        for m, (n, t) in series(os.path.join(d, f"{name}.csv"), "quanta", "seconds_per_step").items():
            ax.loglog(n, [1e3 * x for x in t], "o-", ms=3, lw=1, label=m)
        ax.set_xlabel("quanta")
        ax.set_ylabel("time per step [ms]")
        ax.set_title(f"Figure 3: {title}")
        ax.legend(fontsize=8)
    save(fig, d, "fig3.png")


def fig12(d):
    from matplotlib.collections import LineCollection
    segs = defaultdict(list)
    with open(os.path.join(d, "torn_bonds.csv")) as f:
        for r in csv.DictReader(f):
            segs[r["layout"]].append(((float(r["x0"]), float(r["y0"])), (float(r["x1"]), float(r["y1"]))))
    fig, axes = plt.subplots(1, len(segs), figsize=(3.2 * len(segs), 6.5))
    for ax, (name, s) in zip(axes, segs.items()):
        ax.add_collection(LineCollection(s, lw=0.5, colors="k"))
        ax.autoscale()
        ax.set_aspect("equal")
        kind, phi = name.split("_")
        ax.set_title(f"{kind} lattice turned {phi} deg" if kind == "square" else "Poisson-disk packing", fontsize=9)
        ax.tick_params(labelsize=6)
    with open(os.path.join(d, "cracks.csv")) as f:
        rows = list(csv.DictReader(f))
    fig.suptitle("Figure 12: strips pulled down until they tear (seed 1 of each; alive bonds)", fontsize=10)
    save(fig, d, "fig12.png")
    fig, ax = plt.subplots(figsize=(7, 4))
    for key in dict.fromkeys((r["layout"], r["phi_degrees"]) for r in rows):
        a = [float(r["crack_angle_degrees"]) for r in rows if (r["layout"], r["phi_degrees"]) == key and r["torn"] == "1"]
        label = f"square, turned {float(key[1]):g} deg" if key[0] == "square" else "Poisson-disk packing"
        ax.hist(a, bins=range(-90, 91, 5), alpha=0.5, label=label)
    ax.set_xlabel("crack angle from the horizontal [deg]")
    ax.set_ylabel("seeds")
    ax.legend(fontsize=8)
    save(fig, d, "fig12_angles.png")


def energy_momentum(d):
    data = series(os.path.join(d, "energy.csv"), "time", "relative_energy", key="case")
    with open(os.path.join(d, "energy.csv")) as f:
        rows = list(csv.DictReader(f))
    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey=True)
    for ax, case in zip(axes.flat, cases):
        for method in dict.fromkeys(r["method"] for r in rows):
            pts = [(float(r["time"]), abs(float(r["relative_energy"]) - 1)) for r in rows
                   if r["case"] == case and r["method"] == method]
            ax.plot([t for t, _ in pts], [max(e, 1e-17) for _, e in pts], lw=1, label=method)
        system, homega = case.rsplit("_h", 1)
        ax.set_yscale("log")
        ax.set_ylim(1e-17, 10)
        ax.set_title(f"{system}, h*omega_max = {homega}", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("|E/E(0) - 1|")
        ax.legend(fontsize=7)
    del data
    fig.suptitle("Energy error: energy-momentum vs the hybrid vs backward Euler (undamped)", fontsize=10)
    save(fig, d, "energy_momentum.png")
    # Angular momentum of the two energy-momentum runs: polished to round-off, and stopped at the
    # Newton tolerance (the other methods drift by 1e-2 to 1, off this scale).
    if "angular_drift" not in rows[0]:
        return
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey=True)
    for ax, case in zip(axes.flat, cases):
        for method in dict.fromkeys(r["method"] for r in rows):
            if not method.startswith("energy_momentum"):
                continue
            pts = [(float(r["time"]), float(r["angular_drift"])) for r in rows
                   if r["case"] == case and r["method"] == method]
            ax.plot([t for t, _ in pts], [max(e, 1e-17) for _, e in pts], lw=1, label=method)
        system, homega = case.rsplit("_h", 1)
        ax.set_yscale("log")
        ax.set_ylim(1e-17, 1e-7)
        ax.set_title(f"{system}, h*omega_max = {homega}", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("|L - L(0)| / sum m|x||v|")
        ax.legend(fontsize=7)
    fig.suptitle("Angular momentum error of energy-momentum: polished to round-off vs stopped at the tolerance",
                 fontsize=10)
    save(fig, d, "energy_momentum_angular.png")


def integrators(d):
    with open(os.path.join(d, "integrators.csv")) as f:
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(8, 5))
    floor = 1e-16  # a closed budget shows at round-off, not at zero, on a log axis
    pts = [(float(r["ms_per_step"]), max(float(r["relative_error"]), floor)) for r in rows]
    for k, (r, (x, y)) in enumerate(zip(rows, pts)):
        ax.scatter(x, y, s=30)
        # Neighbours in cost often share an error level: of two points within 15% in cost and a
        # decade in error, the higher is labelled above and the lower below; others alternate.
        near = [q for j, q in enumerate(pts)
                if j != k and abs(math.log(x / q[0])) < 0.15 and abs(math.log10(y / q[1])) < 1]
        above = y >= near[0][1] if near else k % 2 == 1
        ax.annotate(r["method"], (x, y), textcoords="offset points", xytext=(5, 4 if above else -11), fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ms per step (1 thread)")
    ax.set_ylabel("|numerical energy| / work of gravity")
    ax.set_title("Every integrator on the canonical lattice: cost vs energy error", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    save(fig, d, "integrators.png")


def gas(d):
    p = numbers(os.path.join(d, "pressure.csv"))
    fig, ax = plt.subplots(figsize=(6, 4.2))
    eta = [r["eta"] for r in p]
    ax.errorbar(eta, [r["Z"] for r in p], yerr=[r["Z_err"] for r in p], fmt="o", label="measured: wall impulse")
    top = max(eta) * 1.1
    grid = [top * k / 200 for k in range(201)]
    ax.plot(grid, [(1 + e + e * e - e ** 3) / (1 - e) ** 3 for e in grid], label="Carnahan-Starling")
    ax.axhline(1, color="gray", lw=1, ls="--", label="ideal gas pV = NkT")
    ax.set_xlabel("packing fraction eta = N pi sigma^3 / 6V")
    ax.set_ylabel("pV / (N kT)")
    ax.legend(fontsize=8)
    ax.set_title("Gas in a closed box: pressure from the walls' impulse", fontsize=10)
    save(fig, d, "gas_pressure.png")

    sp = numbers(os.path.join(d, "speeds.csv"))
    rel = numbers(os.path.join(d, "relaxation.csv"))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    v = [r["speed"] for r in sp]
    width = v[1] - v[0]
    a1.bar(v, [r["density_start"] for r in sp], width=width, alpha=0.3, label="start: all speeds equal")
    a1.bar(v, [r["density_end"] for r in sp], width=width, alpha=0.6, label="end")
    a1.plot(v, [r["maxwell_boltzmann"] for r in sp], "k", label="Maxwell-Boltzmann")
    a1.set_ylim(0, 1.3 * max(r["maxwell_boltzmann"] for r in sp))
    a1.set_xlabel("speed [m/s]")
    a1.set_ylabel("probability density [s/m]")
    a1.legend(fontsize=8)
    c = [r["collisions_per_quanta"] for r in rel]
    a2.plot(c, [r["kurtosis_ratio"] for r in rel], label="<v^4>/<v^2>^2")
    a2.axhline(5 / 3, color="gray", ls="--", lw=1, label="Maxwell-Boltzmann 5/3")
    a2.plot(c, [r["ks_D"] for r in rel], label="Kolmogorov-Smirnov D")
    a2.set_xlabel("collision times")
    a2.legend(fontsize=8)
    a2.set_title("relaxation from equal speeds", fontsize=10)
    save(fig, d, "gas_speeds.png")


if __name__ == "__main__":
    name, d = sys.argv[1], sys.argv[2]
    globals()[name](d)
