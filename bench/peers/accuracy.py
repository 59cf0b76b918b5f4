"""Speed at equal accuracy: each method's largest step that meets an accuracy criterion on the
canonical lattice released from rest under gravity, and its cost per simulated second there.

Two criteria, both measured on the free face's centre of mass r(t) (the mean position of the
quanta at x = (n - 1) a; all masses are equal):
  dynamic: max over the method's samples t <= T_DYNAMIC of |r(t) - r_ref(t)| <= 5% of
           max_t |r_ref(t) - r_ref(0)|, undamped, r_ref from qbond's velocity Verlet at a step
           h_ref (1e-6 s on the 10^3 lattice) whose own error is estimated by Richardson
           against 2 h_ref and recorded;
  settled: |r(t_end) - r_static| <= 1% of |r_static - r(0)| at the first step at or after
           T_SETTLED, r_static from `qbond statics` (Newton on the net force: exact, no step),
           each method damped by its own means, tuned from the first mode's frequency w1
           (the Rayleigh quotient of the static deflection u: w1^2 = g sum(-u_z) / sum |u|^2):
           LAMMPS `fix viscous` with gamma = 2 m w1 (the first mode critically damped: its
           fastest settling), Bullet's kDP = 1 - exp(-2 w1 h) (the same decay per second: Bullet
           scales the velocities by 1 - kDP each step), qbond's axial bond damping
           c = 2 zeta k / w1 (the bonds' damping is k-proportional, C = (c/k) K, so the first
           mode's damping ratio is c w1 / 2k) with the better of zeta = 0.1 and 1 per method.
The search is a bisection in log h between a floor and a ceiling (one step of the whole interval);
a method that fails at the search's floor (1e-5 s on the 10^3 lattice) is reported as never
meeting the criterion at any step above it.
"""
import csv
import json
import math
import os
import re
import subprocess

from workload import A, G, K, MASS, bond_count, lammps_header, lattice
T_DYNAMIC, T_SETTLED = 0.5, 2.0
DYNAMIC_TOL, SETTLED_TOL = 0.05, 0.01
SAMPLE = 1e-4  # seconds between the reference's samples and the small-step runs' samples
ZETAS = (0.1, 1.0)

QBOND_METHODS = {
    "qbond velocity_verlet": ["--integrator", "velocity_verlet"],
    "qbond default": [],
    "qbond hybrid_frozen": ["--integrator", "hybrid_implicit", "--neighbours", "frozen"],
    "qbond bdf2": ["--integrator", "bdf2"],
    "qbond implicit_midpoint": ["--integrator", "implicit_midpoint"],
}


def steps_for(T, h):
    """Steps of h that reach T (the last one at or after T, within rounding)."""
    return max(1, math.ceil(T / h - 1e-9))


def every_for(h):
    """Steps between samples: every step, or about SAMPLE apart for small steps."""
    return max(1, int(round(SAMPLE / h)))


def scene(n, h, steps, damping):
    """The canonical lattice with a probe on its free face (docs/performance.md)."""
    return {
        "name": f"canonical_{n}", "timestep": h, "steps": steps, "gravity": [0, 0, -G],
        "materials": {"bond": {"law": "linear", "stiffness": K, "damping": damping, "damping_model": "axial"}},
        "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                    "size": [n, n, n], "spacing": A, "quanta_mass": MASS, "material": "bond"}],
        "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}],
        "output": {"probes": [{"name": "tip", "select": {"box": [[(n - 1) * A - 1e-9, -1, -1], [1e3, 1e3, 1e3]]}}]},
    }


def start(n):
    """The free face's centre of mass at rest."""
    return ((n - 1) * A, (n - 1) * A / 2, (n - 1) * A / 2)


def read_probe(path):
    """[(t, x, y, z)] of the tip probe in a diagnostics.csv."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return [(float(r["time"]), float(r["tip_x"]), float(r["tip_y"]), float(r["tip_z"])) for r in rows]


def qbond_run(build, work, n, h, T, damping, args, sampled=True):
    """(samples [(t, x, y, z)] or None on a blow-up, seconds per step) of `qbond run` on one thread;
    unsampled: the last step's only (the run's own timing: its step loop and outputs)."""
    d = os.path.join(work, "q")
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, "scene.json")
    steps = steps_for(T, h)
    with open(path, "w") as f:
        json.dump(scene(n, h, steps, damping), f)
    out = os.path.join(d, "out")
    r = subprocess.run([os.path.join(build, "qbond"), "run", path, "-q", "--no-vtk", "-j", "1", "--every",
                        str(every_for(h) if sampled else steps), "--out", out, *args], capture_output=True, text=True)
    if r.returncode == 3:
        return None, math.nan
    if r.returncode != 0:
        raise SystemExit(f"peers: qbond run failed ({r.returncode}): {r.stderr}")
    with open(os.path.join(out, "run.json")) as f:
        run = json.load(f)
    return read_probe(os.path.join(out, "diagnostics.csv")), run["wall_seconds"] / max(1, run["steps_taken"])


def qbond_static(build, work, n):
    """(free face's centre of mass at equilibrium, first mode's w1 [rad/s]) from `qbond statics`."""
    d = os.path.join(work, "s")
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, "scene.json")
    with open(path, "w") as f:
        json.dump(scene(n, 1e-3, 1, 0.0), f)
    out = os.path.join(d, "out")
    subprocess.run([os.path.join(build, "qbond"), "statics", path, "-q", "--no-vtk", "-o", out, "--tolerance", "1e-10"],
                   check=True, capture_output=True)
    r = read_probe(os.path.join(out, "diagnostics.csv"))[-1][1:]
    num = den = 0.0
    with open(os.path.join(out, "quanta.csv")) as f:
        for q in csv.DictReader(f):
            if q["kinematic"] in ("0", "false"):
                u = (float(q["ux"]), float(q["uy"]), float(q["uz"]))
                num += -u[2]
                den += u[0] ** 2 + u[1] ** 2 + u[2] ** 2
    return r, math.sqrt(G * num / den)


def omega_max(n, iterations=200):
    """The highest natural frequency [rad/s] of the lattice at rest (free quanta; K = sum over bonds of
    k e e^T on both ends), by power iteration on M^-1 K with its Rayleigh quotient."""
    sites, bonds = lattice(n)
    free = [x > A / 2 for x, _, _ in sites]
    dirs = []
    for i, j, _ in bonds:
        d = [sites[j][c] - sites[i][c] for c in range(3)]
        length = math.sqrt(sum(v * v for v in d))
        dirs.append((i, j, [v / length for v in d]))
    u = [[(1.0 if (q * 7 + c * 3) % 5 < 3 else -1.0) * free[q] for c in range(3)] for q in range(len(sites))]
    lam = 0.0
    for _ in range(iterations):
        f = [[0.0, 0.0, 0.0] for _ in sites]
        for i, j, e in dirs:
            s = K * sum(e[c] * (u[j][c] - u[i][c]) for c in range(3))
            for c in range(3):
                f[i][c] += s * e[c]
                f[j][c] -= s * e[c]
        f = [[-v * free[q] / MASS for v in f[q]] for q in range(len(sites))]
        lam = sum(u[q][c] * f[q][c] for q in range(len(sites)) for c in range(3)) / \
            sum(u[q][c] ** 2 for q in range(len(sites)) for c in range(3))
        norm = math.sqrt(sum(v * v for r in f for v in r))
        u = [[v / norm for v in r] for r in f]
    return math.sqrt(lam)


def lammps_run(work, n, h, T, gamma, sampled=True):
    """(samples or None when the run fails or diverges, seconds per step) of LAMMPS's velocity Verlet;
    gamma > 0 adds `fix viscous gamma` (a force -gamma v on each free quanta)."""
    steps = steps_for(T, h)
    every = every_for(h) if sampled else steps
    tip = os.path.join(work, "tip.txt")
    script = os.path.join(work, "in.accuracy")
    with open(script, "w") as f:
        f.write(lammps_header(n, work) + f"""region tip block {(n - 1.5) * A} INF INF INF INF INF
group tip region tip
fix move free nve
fix pull free gravity 9.81 vector 0 0 -1
{f"fix drag free viscous {gamma!r}" if gamma > 0 else ""}
compute tipcom tip com
fix out all ave/time {every} 1 {every} c_tipcom[1] c_tipcom[2] c_tipcom[3] file {tip} format " %.12g"
timestep {h!r}
thermo {steps}
run {steps}
""")
    if os.path.exists(tip):
        os.remove(tip)
    r = subprocess.run(["lmp", "-in", script, "-log", "none"], capture_output=True, text=True, cwd=work)
    loop = re.search(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps", r.stdout)
    if r.returncode != 0 or not loop or not os.path.exists(tip):
        return None, math.nan
    samples = []
    with open(tip) as f:
        for line in f:
            if line.startswith("#"):
                continue
            s, x, y, z = line.split()
            samples.append((int(s) * h, float(x), float(y), float(z)))
    if not all(math.isfinite(v) for p in samples for v in p):
        return None, math.nan
    return samples, float(loop.group(1)) / int(loop.group(2))


def bullet_run(exe, n, h, T, kdp, sampled=True):
    """(samples or None when the run diverges, seconds per step) of Bullet's btSoftBody."""
    steps = steps_for(T, h)
    r = subprocess.run([exe, str(n), repr(h), str(steps), "1", repr(kdp), str(every_for(h) if sampled else steps)],
                       capture_output=True, text=True, check=True)
    samples, kv = [], {}
    for line in r.stdout.splitlines():
        if line.startswith("tip "):
            samples.append(tuple(float(v) for v in line.split()[1:]))
        else:
            kv.update(p.split("=") for p in line.split())
    if not samples or not all(math.isfinite(v) for p in samples for v in p) or \
            any(abs(v) > 1e3 for p in samples for v in p[1:]):
        return None, math.nan
    return samples, float(kv["seconds_per_step"])


def dynamic_error(samples, ref, r0):
    """max |r - r_ref| over [0, T_DYNAMIC], over the reference's largest displacement: the method's
    trajectory is its samples joined by straight lines (what a viewer of its steps shows), compared
    at every reference sample, so that a step which skips an oscillation does not pass unseen."""
    pts = [(0.0, *r0)] + [p for p in samples if p[0] > 0]
    worst, j = 0.0, 0
    for k in range(1, len(ref["x"])):
        t = k * ref["sample"]
        if t > T_DYNAMIC + 1e-9:
            break
        while j + 2 < len(pts) and pts[j + 1][0] < t:
            j += 1
        (ta, *ra), (tb, *rb) = pts[j], pts[min(j + 1, len(pts) - 1)]
        w = 0.0 if tb <= ta else min(1.0, max(0.0, (t - ta) / (tb - ta)))
        r = [(1 - w) * x + w * y for x, y in zip(ra, rb)]
        worst = max(worst, math.dist(r, (ref["x"][k], ref["y"][k], ref["z"][k])))
    return worst / ref["largest_displacement"]


def settled_error(samples, static, r0):
    """|r(t_end) - r_static| over |r_static - r(0)|."""
    return math.dist(samples[-1][1:], static) / math.dist(static, r0)


def reference(build, work, n, h_ref):
    """qbond's undamped velocity Verlet at h_ref and 2 h_ref, sampled every SAMPLE seconds, with the
    Richardson estimate of h_ref's own error (second order: |r(h) - r(2h)| / 3)."""
    runs = []
    for h in (h_ref, 2 * h_ref):
        s, t = qbond_run(build, work, n, h, T_DYNAMIC, 0.0, QBOND_METHODS["qbond velocity_verlet"])
        if s is None:
            raise SystemExit(f"peers: the reference (velocity Verlet, h = {h}) blew up on n = {n}")
        runs.append(s)
    fine, coarse = ({round(p[0] / SAMPLE): p[1:] for p in s} for s in runs)
    keys = sorted(k for k in fine if k in coarse)
    r0 = start(n)
    ref = {"n": n, "h": h_ref, "sample": SAMPLE, "x": [r0[0]], "y": [r0[1]], "z": [r0[2]]}
    for k in range(1, keys[-1] + 1):
        for c, v in zip("xyz", fine[k]):
            ref[c].append(float(f"{v:.10g}"))
    ref["largest_displacement"] = max(math.dist(r0, p) for p in fine.values())
    ref["richardson_error"] = max(math.dist(fine[k], coarse[k]) for k in keys) / 3 / ref["largest_displacement"]
    return ref


def search(evaluate, lo, hi, iterations):
    """Bisection in log h for the largest step in [lo, hi] that meets a criterion (hi itself when it
    does; None when lo does not). evaluate(h) -> (meets, error, seconds per step)."""
    tried = []

    def ev(h):
        ok, err, sec = evaluate(h)
        tried.append({"h": h, "meets": ok, "error": err, "seconds_per_step": sec})
        return ok

    found = None
    if ev(hi):
        found = hi
    else:
        for _ in range(iterations):
            mid = math.sqrt(lo * hi)
            if ev(mid):
                lo, found = mid, mid
            else:
                hi = mid
        if found is None and ev(lo):
            found = lo
    best = next((t for t in tried if t["h"] == found), None)
    return {"step": found, "seconds_per_step": best["seconds_per_step"] if best else None,
            "seconds_per_simulated_second": best["seconds_per_step"] / found if best else None,
            "error": best["error"] if best else None, "tried": tried}


def lattice_record(build, work, n, h_ref, floor, iterations, cached=None, log=print):
    """What every method's search on the n^3 lattice is measured against: the reference trajectory
    (`cached`, an earlier run's, when it is of this n and h_ref), the static equilibrium, the first
    and highest frequencies; the JSON record the methods' rows are added to."""
    if cached and cached["n"] == n and cached["h"] == h_ref and cached["sample"] == SAMPLE:
        ref = cached
        log(f"n = {n}: the reference of an earlier run reused")
    else:
        ref = reference(build, work, n, h_ref)
    static, w1 = qbond_static(build, work, n)
    wmax = omega_max(n)
    r0 = start(n)
    log(f"n = {n}: reference h = {h_ref:g} s (Richardson error {ref['richardson_error']:.1e} of the largest "
        f"displacement {ref['largest_displacement'] * 1e3:.4f} mm); static sag {math.dist(static, r0) * 1e3:.4f} mm; "
        f"w1 = {w1:.1f} rad/s, w_max = {wmax:.0f} rad/s")
    return {"n": n, "bonds": bond_count(n), "reference": ref, "static": list(static), "start": list(r0),
            "omega1": w1, "omega_max": wmax, "floor": floor, "iterations": iterations, "rows": []}


def method_rows(build, bullet_exe, work, lat, method, log=print):
    """One method's searches for both criteria on the lattice of `lat` (lattice_record's): its
    dynamic row and its settled row (the damping that allowed the largest step)."""
    n, ref, floor, iterations, w1 = lat["n"], lat["reference"], lat["floor"], lat["iterations"], lat["omega1"]
    static, r0 = tuple(lat["static"]), tuple(lat["start"])

    def judge(run, crit):
        s, sec = run
        if s is None:
            return False, math.inf, sec
        err = dynamic_error(s, ref, r0) if crit == "dynamic" else settled_error(s, static, r0)
        return err <= (DYNAMIC_TOL if crit == "dynamic" else SETTLED_TOL), err, sec

    if method == "LAMMPS":
        name = "LAMMPS (velocity Verlet)"
        dynamic = lambda h, sampled=True: lammps_run(work, n, h, T_DYNAMIC, 0.0, sampled)  # noqa: E731
        settled = [(f"fix viscous, gamma = 2 m w1 = {2 * MASS * w1:.3g} kg/s",
                    lambda h: lammps_run(work, n, h, T_SETTLED, 2 * MASS * w1, False))]
    elif method == "Bullet":
        name = "Bullet (btSoftBody, 1 iteration)"
        dynamic = lambda h, sampled=True: bullet_run(bullet_exe, n, h, T_DYNAMIC, 0.0, sampled)  # noqa: E731
        settled = [("kDP = 1 - exp(-2 w1 h)",
                    lambda h: bullet_run(bullet_exe, n, h, T_SETTLED, 1 - math.exp(-2 * w1 * h), False))]
    else:
        name, args = method, QBOND_METHODS[method]
        dynamic = lambda h, sampled=True: qbond_run(build, work, n, h, T_DYNAMIC, 0.0, args, sampled)  # noqa: E731
        settled = [(f"bonds' c = 2 ζ k / ω₁, ζ = {z:g} (c = {2 * z * K / w1:.3g} N s/m)",
                    lambda h, c=2 * z * K / w1: qbond_run(build, work, n, h, T_SETTLED, c, args, False))
                   for z in ZETAS]
    rows = []
    res = search(lambda h: judge(dynamic(h), "dynamic"), floor, T_DYNAMIC, iterations)
    if res["step"] is not None:
        # The search's runs wrote a sample every SAMPLE seconds; the cost is timed without them.
        sec = dynamic(res["step"], False)[1]
        res.update(seconds_per_step=sec, seconds_per_simulated_second=sec / res["step"])
    rows.append({"method": name, "criterion": "dynamic", "damping": "none", **res})
    log(f"  n = {n} {name:<34} dynamic  {describe(res, floor)}")
    best = None
    for label, run in settled:
        res = search(lambda h: judge(run(h), "settled"), floor, T_SETTLED, iterations)
        cand = {"method": name, "criterion": "settled", "damping": label, **res}
        if best is None or (res["step"] or 0, -(res["seconds_per_simulated_second"] or 0)) > \
                (best["step"] or 0, -(best["seconds_per_simulated_second"] or 0)):
            best = cand
        log(f"  n = {n} {name:<34} settled  {describe(res, floor)}  [{label}]")
    rows.append(best)
    return rows


def describe(res, floor):
    if res["step"] is None:
        return f"never at h >= {floor:g} s"
    return (f"h = {res['step']:.3g} s, error {res['error']:.3g}, {res['seconds_per_step'] * 1e3:.3f} ms/step, "
            f"{res['seconds_per_simulated_second']:.4g} s per simulated second")
