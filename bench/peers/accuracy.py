"""Speed at equal accuracy: each method's largest step that meets an accuracy criterion on the
canonical lattice released from rest under gravity, and its cost per simulated second there.

Two criteria, both measured on the free face's centre of mass r(t) (the mean position of the
quanta at x = (n - 1) a; all masses are equal):
  dynamic: max over the method's samples t <= T_DYNAMIC of |r(t) - r_ref(t)| <= 5% of
           max_t |r_ref(t) - r_ref(0)|, undamped, r_ref from qbond's velocity Verlet at the
           largest step h_ref of SAMPLE, SAMPLE/2, SAMPLE/4, ... whose own error, estimated by
           Richardson against 2 h_ref, is below REFERENCE_TOL (every halving's estimate is
           recorded: they fall 4x a halving when the runs are in velocity Verlet's second-order
           regime, which is what makes the estimate trustworthy);
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
a method that fails at the search's floor is reported as never meeting the criterion at any step
above it. Each evaluation runs for at most `cap` CPU seconds: one that takes longer is stopped
and recorded as over the cap, and the search goes on above that step only (every smaller step
costs more), so a method whose passing step would cost more than the cap says so.
"""
import csv
import json
import math
import os
import re
import resource
import signal
import subprocess
import time

from workload import A, G, K, MASS, bond_count, lammps_header, lattice
T_DYNAMIC, T_SETTLED = 0.5, 2.0
DYNAMIC_TOL, SETTLED_TOL = 0.05, 0.01
SAMPLE = 1e-4  # seconds between the reference's samples and the small-step runs' samples
# The reference's own error, a fraction of the largest displacement: far below DYNAMIC_TOL, so
# that it moves no method's error across the tolerance.
REFERENCE_TOL = 1e-3 * DYNAMIC_TOL
# The net force at which `qbond statics` stops, relative to the weight: the sag it gives is then
# exact to about this fraction (the stiffness is far from singular), far below SETTLED_TOL.
STATIC_TOL = 1e-8
ZETAS = (0.1, 1.0)

QBOND_METHODS = {
    "qbond velocity_verlet": ["--integrator", "velocity_verlet"],
    # The same steps without the energy ledger's pass over the bonds, which LAMMPS has no match for.
    "qbond velocity_verlet_no_ledger": ["--integrator", "velocity_verlet", "--no-ledger"],
    "qbond default": [],
    "qbond hybrid_frozen": ["--integrator", "hybrid_implicit", "--neighbours", "frozen"],
    "qbond bdf2": ["--integrator", "bdf2"],
    "qbond implicit_midpoint": ["--integrator", "implicit_midpoint"],
}


class OverCap(Exception):
    """An evaluation stopped at the search's cap on CPU seconds."""


def timed(cmd, cap, **kw):
    """subprocess.run(cmd) stopped after `cap` seconds of CPU time (None: no cap), raising OverCap
    then. CPU time, not wall time: on a shared host a run's wall time moves with the others' load."""
    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (math.ceil(cap), math.ceil(cap) + 5))

    r = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit if cap else None, **kw)
    if cap and r.returncode in (-signal.SIGXCPU, -signal.SIGKILL):
        raise OverCap
    return r


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


def qbond_run(build, work, n, h, T, damping, args, sampled=True, cap=None):
    """(samples [(t, x, y, z)] or None on a blow-up, seconds per step) of `qbond run` on one thread;
    unsampled: the last step's only (the run's own timing: its step loop and outputs). OverCap
    after `cap` wall seconds."""
    d = os.path.join(work, "q")
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, "scene.json")
    steps = steps_for(T, h)
    with open(path, "w") as f:
        json.dump(scene(n, h, steps, damping), f)
    out = os.path.join(d, "out")
    r = timed([os.path.join(build, "qbond"), "run", path, "-q", "--no-vtk", "-j", "1", "--every",
               str(every_for(h) if sampled else steps), "--out", out, *args], cap)
    if r.returncode == 3:
        return None, math.nan
    if r.returncode != 0:
        raise SystemExit(f"peers: qbond run failed ({r.returncode}): {r.stderr}")
    with open(os.path.join(out, "run.json")) as f:
        run = json.load(f)
    return read_probe(os.path.join(out, "diagnostics.csv")), run["wall_seconds"] / max(1, run["steps_taken"])


def qbond_static(build, work, n):
    """(free face's centre of mass at equilibrium, first mode's w1 [rad/s], the solve's record:
    Newton iterations, residual, wall seconds) from `qbond statics`."""
    d = os.path.join(work, "s")
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, "scene.json")
    with open(path, "w") as f:
        json.dump(scene(n, 1e-3, 1, 0.0), f)
    out = os.path.join(d, "out")
    began = time.monotonic()
    subprocess.run([os.path.join(build, "qbond"), "statics", path, "-q", "--no-vtk", "-o", out, "--tolerance",
                    repr(STATIC_TOL)], check=True, capture_output=True)
    wall = time.monotonic() - began
    with open(os.path.join(out, "statics.json")) as f:
        st = json.load(f)
    solve = {"iterations": st["iterations"], "residual": st["residual"], "tolerance": STATIC_TOL, "wall_seconds": wall}
    r = read_probe(os.path.join(out, "diagnostics.csv"))[-1][1:]
    num = den = 0.0
    with open(os.path.join(out, "quanta.csv")) as f:
        for q in csv.DictReader(f):
            if q["kinematic"] in ("0", "false"):
                u = (float(q["ux"]), float(q["uy"]), float(q["uz"]))
                num += -u[2]
                den += u[0] ** 2 + u[1] ** 2 + u[2] ** 2
    return r, math.sqrt(G * num / den), solve


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


def lammps_run(work, n, h, T, gamma, sampled=True, cap=None):
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
    r = timed(["lmp", "-in", script, "-log", "none"], cap, cwd=work)
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


def bullet_run(exe, n, h, T, kdp, sampled=True, cap=None):
    """(samples or None when the run diverges, seconds per step) of Bullet's btSoftBody."""
    steps = steps_for(T, h)
    r = timed([exe, str(n), repr(h), str(steps), "1", repr(kdp), str(every_for(h) if sampled else steps)], cap)
    if r.returncode != 0:
        raise SystemExit(f"peers: {exe} failed ({r.returncode}): {r.stderr}")
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


def reference(build, work, n, finest=SAMPLE / 2 ** 8):
    """qbond's undamped velocity Verlet sampled every SAMPLE seconds at the largest of the steps
    SAMPLE, SAMPLE/2, SAMPLE/4, ... (down to `finest`) whose Richardson estimate of its own error
    against twice its step (second order: max_t |r(h) - r(2h)| / 3, over the largest displacement)
    is below REFERENCE_TOL; every halving's estimate is recorded."""
    r0 = start(n)

    def run(h):
        s, _ = qbond_run(build, work, n, h, T_DYNAMIC, 0.0, QBOND_METHODS["qbond velocity_verlet"])
        if s is None:
            raise SystemExit(f"peers: the reference (velocity Verlet, h = {h}) blew up on n = {n}")
        return {round(p[0] / SAMPLE): p[1:] for p in s}

    h, coarse, halving = SAMPLE, None, []
    coarse = run(h)
    while True:
        h /= 2
        fine = run(h)
        keys = sorted(k for k in fine if k in coarse)
        largest = max(math.dist(r0, p) for p in fine.values())
        estimate = max(math.dist(fine[k], coarse[k]) for k in keys) / 3 / largest
        halving.append({"h": h, "richardson_error": estimate})
        if estimate <= REFERENCE_TOL or h / 2 < finest:
            break
        coarse = fine
    ref = {"n": n, "h": h, "sample": SAMPLE, "x": [r0[0]], "y": [r0[1]], "z": [r0[2]]}
    for k in range(1, keys[-1] + 1):
        for c, v in zip("xyz", fine[k]):
            ref[c].append(float(f"{v:.10g}"))
    ref["largest_displacement"] = largest
    ref["richardson_error"] = estimate
    ref["halving"] = halving
    if estimate > REFERENCE_TOL:
        raise SystemExit(f"peers: no reference step down to {h:g} s has an error estimate below {REFERENCE_TOL:g} "
                         f"on n = {n}: {halving}")
    return ref


def search(evaluate, lo, hi, iterations):
    """Bisection in log h for the largest step in [lo, hi] that meets a criterion (hi itself when it
    does; None when lo does not). evaluate(h) -> (meets, error, seconds per step), meets None when
    the evaluation was stopped at the cost cap: every smaller step costs more, so the search goes
    on above it and `over_cap_below` says where it stopped."""
    tried = []
    capped = None

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
            ok = ev(mid)
            if ok is None:
                lo = capped = mid
            elif ok:
                lo, found = mid, mid
            else:
                hi = mid
        if found is None and capped is None:
            if ev(lo) is None:
                capped = lo
            elif tried[-1]["meets"]:
                found = lo
    best = next((t for t in tried if t["h"] == found), None)
    return {"step": found, "seconds_per_step": best["seconds_per_step"] if best else None,
            "seconds_per_simulated_second": best["seconds_per_step"] / found if best else None,
            "error": best["error"] if best else None, "over_cap_below": capped if found is None else None,
            "tried": tried}


def lattice_record(build, work, n, floor, iterations, cap, cached=None, log=print):
    """What every method's search on the n^3 lattice is measured against: the reference trajectory
    and the static equilibrium (`cached`'s, an earlier run's record of this n, when they meet this
    run's tolerances), the first and highest frequencies; the JSON record the methods' rows are
    added to."""
    old = cached["reference"] if cached and cached["n"] == n else None
    if old and old["sample"] == SAMPLE and old["richardson_error"] <= REFERENCE_TOL:
        ref = old
        log(f"n = {n}: the reference of an earlier run reused")
    else:
        began = time.monotonic()
        ref = reference(build, work, n)
        ref["wall_seconds"] = time.monotonic() - began
    if old and cached.get("static_solve", {}).get("residual", math.inf) <= STATIC_TOL:
        static, w1, solve = cached["static"], cached["omega1"], cached["static_solve"]
        log(f"n = {n}: the static solution of an earlier run reused")
    else:
        static, w1, solve = qbond_static(build, work, n)
    wmax = omega_max(n)
    r0 = start(n)
    halving = ", ".join(f"{x['h']:.3g} s: {x['richardson_error']:.1e}" for x in ref.get("halving", []))
    log(f"n = {n}: reference h = {ref['h']:g} s (Richardson error {ref['richardson_error']:.1e} of the largest "
        f"displacement {ref['largest_displacement'] * 1e3:.4f} mm; halving {halving}); static sag "
        f"{math.dist(static, r0) * 1e3:.4f} mm ({solve['iterations']} Newton iterations, {solve['wall_seconds']:.0f} s); "
        f"w1 = {w1:.1f} rad/s, w_max = {wmax:.0f} rad/s")
    return {"n": n, "bonds": bond_count(n), "reference": ref, "static": list(static), "static_solve": solve,
            "start": list(r0), "omega1": w1, "omega_max": wmax, "floor": floor, "iterations": iterations,
            "cap_seconds": cap, "rows": []}


def method_rows(build, bullet_exe, work, lat, method, log=print):
    """One method's searches for both criteria on the lattice of `lat` (lattice_record's): its
    dynamic row and its settled row (the damping that allowed the largest step)."""
    n, ref, floor, iterations, w1 = lat["n"], lat["reference"], lat["floor"], lat["iterations"], lat["omega1"]
    static, r0, cap = tuple(lat["static"]), tuple(lat["start"]), lat.get("cap_seconds")

    def judge(run, crit):
        try:
            s, sec = run()
        except OverCap:
            return None, None, None
        if s is None:
            return False, math.inf, sec
        err = dynamic_error(s, ref, r0) if crit == "dynamic" else settled_error(s, static, r0)
        return err <= (DYNAMIC_TOL if crit == "dynamic" else SETTLED_TOL), err, sec

    if method == "LAMMPS":
        name = "LAMMPS (velocity Verlet)"
        dynamic = lambda h, sampled=True: lammps_run(work, n, h, T_DYNAMIC, 0.0, sampled, cap)  # noqa: E731
        settled = [(f"fix viscous, gamma = 2 m w1 = {2 * MASS * w1:.3g} kg/s",
                    lambda h: lammps_run(work, n, h, T_SETTLED, 2 * MASS * w1, False, cap))]
    elif method == "Bullet":
        name = "Bullet (btSoftBody, 1 iteration)"
        dynamic = lambda h, sampled=True: bullet_run(bullet_exe, n, h, T_DYNAMIC, 0.0, sampled, cap)  # noqa: E731
        settled = [("kDP = 1 - exp(-2 w1 h)",
                    lambda h: bullet_run(bullet_exe, n, h, T_SETTLED, 1 - math.exp(-2 * w1 * h), False, cap))]
    else:
        name, args = method, QBOND_METHODS[method]
        dynamic = lambda h, sampled=True: qbond_run(build, work, n, h, T_DYNAMIC, 0.0, args, sampled, cap)  # noqa: E731
        settled = [(f"bonds' c = 2 ζ k / ω₁, ζ = {z:g} (c = {2 * z * K / w1:.3g} N s/m)",
                    lambda h, c=2 * z * K / w1: qbond_run(build, work, n, h, T_SETTLED, c, args, False, cap))
                   for z in ZETAS]
    rows = []
    res = search(lambda h: judge(lambda: dynamic(h), "dynamic"), floor, T_DYNAMIC, iterations)
    if res["step"] is not None:
        # The search's runs wrote a sample every SAMPLE seconds; the cost is timed without them
        # (a run that passed within the cap with its samples takes about as long without them).
        try:
            sec = dynamic(res["step"], False)[1]
            res.update(seconds_per_step=sec, seconds_per_simulated_second=sec / res["step"])
        except OverCap:
            pass
    rows.append({"method": name, "criterion": "dynamic", "damping": "none", **res})
    log(f"  n = {n} {name:<34} dynamic  {describe(res, floor)}")
    best = None
    for label, run in settled:
        res = search(lambda h, run=run: judge(lambda: run(h), "settled"), floor, T_SETTLED, iterations)
        cand = {"method": name, "criterion": "settled", "damping": label, **res}
        if best is None or (res["step"] or 0, -(res["seconds_per_simulated_second"] or 0)) > \
                (best["step"] or 0, -(best["seconds_per_simulated_second"] or 0)):
            best = cand
        log(f"  n = {n} {name:<34} settled  {describe(res, floor)}  [{label}]")
    rows.append(best)
    return rows


def describe(res, floor):
    if res["step"] is None and res.get("over_cap_below"):
        return f"never at h > {res['over_cap_below']:.3g} s; smaller steps cost more than the cap"
    if res["step"] is None:
        return f"never at h >= {floor:g} s"
    return (f"h = {res['step']:.3g} s, error {res['error']:.3g}, {res['seconds_per_step'] * 1e3:.3f} ms/step, "
            f"{res['seconds_per_simulated_second']:.4g} s per simulated second")
