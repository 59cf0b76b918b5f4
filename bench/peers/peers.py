#!/usr/bin/python3
"""qbond, LAMMPS and Bullet side by side on the canonical workload (docs/performance.md).

Usage: bench/peers/peers.py BUILD_DIR BULLET_EXE [--n 10,20,40] [--steps 200] [--rounds 3] [--json FILE]
Run by bench/peers/run, which installs LAMMPS and Bullet (Debian packages) and builds
BULLET_EXE. Prints, for each n, ns per bond per step of each engine measured in this run; then
qbond's velocity Verlet against LAMMPS's in `rounds` alternating runs (the shared host's load
moves both by 20% and more within minutes: each round's ratio sets two runs a few seconds apart
side by side); then each method's largest stable timestep (bisection on the 10^3 lattice) and
its cost per simulated second at that step on the largest n.

The workload: n^3 simple-cubic lattice, spacing 0.01 m, 1 g quanta, bonds to nearest and
face-diagonal neighbours (k = 1000 N/m), the x = 0 face anchored, gravity -9.81 m/s^2 along z.
LAMMPS: bond_style harmonic with K = k/2 (its energy is K (r - r0)^2), fix nve (velocity Verlet),
fix setforce/zero velocity on the anchored face; no bond damping (harmonic has none).
Bullet: btSoftBody links (position constraints, kLST = 1, one iteration): same topology, masses,
anchors and step, Bullet's own material law. qbond: `qbond bench` (its default integrator, the
paper's hybrid and velocity Verlet), and `qbond run` for the stability search.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile

A, MASS, K = 0.01, 1e-3, 1000.0


def lattice(n):
    """Sites, bonds (i, j, type 1 = axis, 2 = diagonal) of the canonical lattice, 0-based."""
    def idx(i, j, k):
        return (k * n + j) * n + i
    sites = [(i * A, j * A, k * A) for k in range(n) for j in range(n) for i in range(n)]
    bonds = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                p = idx(i, j, k)
                if i + 1 < n: bonds.append((p, idx(i + 1, j, k), 1))
                if j + 1 < n: bonds.append((p, idx(i, j + 1, k), 1))
                if k + 1 < n: bonds.append((p, idx(i, j, k + 1), 1))
                if i + 1 < n and j + 1 < n:
                    bonds += [(p, idx(i + 1, j + 1, k), 2), (idx(i + 1, j, k), idx(i, j + 1, k), 2)]
                if i + 1 < n and k + 1 < n:
                    bonds += [(p, idx(i + 1, j, k + 1), 2), (idx(i + 1, j, k), idx(i, j, k + 1), 2)]
                if j + 1 < n and k + 1 < n:
                    bonds += [(p, idx(i, j + 1, k + 1), 2), (idx(i, j + 1, k), idx(i, j, k + 1), 2)]
    return sites, bonds


def lammps(n, h, steps, work):
    """(seconds per step, stable) of LAMMPS's velocity-Verlet run of the workload."""
    data = os.path.join(work, f"canonical_{n}.data")
    if not os.path.exists(data):
        sites, bonds = lattice(n)
        hi = (n - 1) * A
        with open(data, "w") as f:
            f.write(f"canonical lattice n = {n}\n\n{len(sites)} atoms\n{len(bonds)} bonds\n1 atom types\n2 bond types\n\n")
            f.write(f"-0.005 {hi + 0.005} xlo xhi\n-0.005 {hi + 0.005} ylo yhi\n-0.005 {hi + 0.005} zlo zhi\n\n")
            f.write(f"Masses\n\n1 {MASS}\n\nAtoms # bond\n\n")
            f.writelines(f"{q + 1} 1 1 {x} {y} {z}\n" for q, (x, y, z) in enumerate(sites))
            f.write("\nBonds\n\n")
            f.writelines(f"{b + 1} {t} {i + 1} {j + 1}\n" for b, (i, j, t) in enumerate(bonds))
    script = os.path.join(work, "in.canonical")
    with open(script, "w") as f:
        f.write(f"""units si
atom_style bond
boundary s s s
read_data {data}
pair_style none
bond_style harmonic
bond_coeff 1 {K / 2} {A}
bond_coeff 2 {K / 2} {A * math.sqrt(2)}
comm_modify cutoff {3 * A}
region face block INF {0.5 * A} INF INF INF INF
group face region face
group free subtract all face
fix move free nve
fix pull free gravity 9.81 vector 0 0 -1
timestep {h}
thermo_style custom step ke
thermo {steps}
run {steps}
""")
    r = subprocess.run(["lmp", "-in", script, "-log", "none"], capture_output=True, text=True, cwd=work)
    if r.returncode != 0:
        return math.inf, False
    loop = re.search(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps", r.stdout)
    ke = re.findall(r"^\s*" + str(steps) + r"\s+(\S+)\s*$", r.stdout, re.M)
    if not loop:
        sys.exit("peers: LAMMPS printed no loop time:\n" + r.stdout[-2000:])
    ke_end = float(ke[-1]) if ke else math.inf
    # Stable: the kinetic energy stays of the order gravity can give (v well under 10 m/s).
    stable = math.isfinite(ke_end) and ke_end < 0.5 * MASS * n ** 3 * 10 ** 2
    return float(loop.group(1)) / int(loop.group(2)), stable


def bullet(exe, n, h, steps):
    r = subprocess.run([exe, str(n), repr(h), str(steps)], capture_output=True, text=True, check=True)
    kv = dict(p.split("=") for p in r.stdout.split())
    vmax = float(kv["max_speed"])
    return float(kv["seconds_per_step"]), int(kv["links"]), math.isfinite(vmax) and vmax < 10


def qbond_bench(build, n_list, integrators, dt=None):
    """{(integrator, n): seconds per step} from `qbond bench`."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "b.json")
        cmd = [os.path.join(build, "qbond"), "bench", "-n", ",".join(map(str, n_list)), "--integrators",
               ",".join(integrators), "--repetitions", "3", "--json", out]
        if dt:
            cmd += ["--dt", repr(dt)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        doc = json.load(open(out))
    return {(r["integrator"], int(round(r["quanta"] ** (1 / 3)))): r["seconds_per_step"] for r in doc["rows"]}, doc


def verlet_against_lammps(build, n, rounds, steps, work):
    """[(LAMMPS's, qbond's velocity Verlet's seconds per step)] of `rounds` alternating runs."""
    pairs = []
    for _ in range(rounds):
        t_l, _ = lammps(n, 1e-4, steps, work)
        t_q = qbond_bench(build, [n], ["velocity_verlet"])[0][("velocity_verlet", n)]
        pairs.append((t_l, t_q))
    return pairs


def qbond_stable(build, integrator_args, h, work):
    """Whether `qbond run` of the 10^3 workload at step h finishes 0.05 s without a blow-up."""
    scene = {
        "name": "canonical_10", "timestep": h, "duration": max(0.05, 20 * h), "gravity": [0, 0, -9.81],
        "materials": {"bond": {"law": "linear", "stiffness": K, "damping": 0.01, "damping_model": "axial"}},
        "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                    "size": [10, 10, 10], "spacing": A, "quanta_mass": MASS, "material": "bond"}],
        "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}],
    }
    path = os.path.join(work, "canonical_10.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    r = subprocess.run([os.path.join(build, "qbond"), "run", path, "-q", "--no-vtk", "--every", "1000000", "--out",
                        os.path.join(work, "qrun"), *integrator_args], capture_output=True, text=True)
    if r.returncode not in (0, 3):
        sys.exit(f"peers: qbond run failed ({r.returncode}): {r.stderr}")
    return r.returncode == 0


def largest_stable(stable, lo=1e-6, hi=0.1):
    """Bisection (in log h) for the largest stable step in [lo, hi]; hi itself when stable there."""
    if stable(hi):
        return hi
    for _ in range(12):
        mid = math.sqrt(lo * hi)
        if stable(mid):
            lo = mid
        else:
            hi = mid
    return lo


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("bullet")
    ap.add_argument("--n", default="10,20,40")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json")
    a = ap.parse_args()
    n_list = [int(x) for x in a.n.split(",")]
    work = tempfile.mkdtemp(prefix="qbond_peers_")
    integrators = ["default", "hybrid_frozen", "hybrid_sweep", "velocity_verlet"]
    q, qdoc = qbond_bench(a.build, n_list, integrators)
    rows = []
    print("ns per bond per step, h = 1e-4 s, one thread, measured in this run")
    print(f"{'n':>4} {'bonds':>8} {'LAMMPS':>9} {'Bullet':>9} " + " ".join(f"{'qbond ' + i:>22}" for i in integrators))
    for n in n_list:
        nb = 3 * n * n * (n - 1) + 6 * n * (n - 1) ** 2
        steps = max(20, a.steps * 1000 // n ** 3) if n > 10 else a.steps
        t_l, _ = lammps(n, 1e-4, steps, work)
        t_b, links, _ = bullet(a.bullet, n, 1e-4, steps)
        if links != nb:
            sys.exit(f"peers: Bullet built {links} links, the workload has {nb} bonds")
        row = {"n": n, "bonds": nb, "lammps": t_l, "bullet": t_b, **{f"qbond_{i}": q[(i, n)] for i in integrators}}
        rows.append(row)
        print(f"{n:>4} {nb:>8} {t_l / nb * 1e9:>9.2f} {t_b / nb * 1e9:>9.2f} " +
              " ".join(f"{q[(i, n)] / nb * 1e9:>22.2f}" for i in integrators))

    print(f"\nqbond's velocity Verlet / LAMMPS, per step, {a.rounds} alternating rounds (h = 1e-4 s, one thread)")
    for row in rows:
        n = row["n"]
        # At least ~0.5 s of LAMMPS's loop a round at n = 40, as qbond's benchmark times its own.
        steps = max(100, a.steps * 1000 // n ** 3)
        pairs = verlet_against_lammps(a.build, n, a.rounds, steps, work)
        ratios = sorted(q_t / l_t for l_t, q_t in pairs)
        row["verlet_against_lammps"] = [{"lammps": l_t, "qbond_velocity_verlet": q_t} for l_t, q_t in pairs]
        row["verlet_over_lammps_median"] = ratios[len(ratios) // 2]
        print(f"{n:>4}  median {row['verlet_over_lammps_median']:.2f}  rounds " +
              "  ".join(f"{q_t / l_t:.2f} ({q_t / row['bonds'] * 1e9:.2f} / {l_t / row['bonds'] * 1e9:.2f} ns)"
                        for l_t, q_t in pairs))

    print("\nlargest stable step (10^3 lattice, bisection), and cost per simulated second on n =", n_list[-1])
    n = n_list[-1]
    nb = rows[-1]["bonds"]
    steps_big = max(20, a.steps * 1000 // n ** 3)
    stability = {
        "LAMMPS (velocity Verlet)": largest_stable(lambda h: lammps(10, h, max(50, int(0.02 / h)), work)[1]),
        "Bullet (btSoftBody, 1 iteration)": largest_stable(lambda h: bullet(a.bullet, 10, h, max(50, int(0.02 / h)))[2]),
        "qbond default": largest_stable(lambda h: qbond_stable(a.build, [], h, work)),
        "qbond hybrid_frozen": largest_stable(
            lambda h: qbond_stable(a.build, ["--integrator", "hybrid_implicit", "--neighbours", "frozen"], h, work)),
        "qbond velocity_verlet": largest_stable(
            lambda h: qbond_stable(a.build, ["--integrator", "velocity_verlet"], h, work)),
    }
    cost = {}
    for name, h in stability.items():
        if name.startswith("LAMMPS"):
            t = lammps(n, h, steps_big, work)[0]
        elif name.startswith("Bullet"):
            t = bullet(a.bullet, n, h, steps_big)[0]
        else:
            # The step found on 10^3 can be just past the limit on the larger lattice (its highest
            # frequency is a little higher), where qbond's blow-up check stops the benchmark, while
            # LAMMPS would go on computing a diverging run at full speed: back off by 5% until it runs.
            integ = name.split()[-1]
            for _ in range(10):
                try:
                    t = qbond_bench(a.build, [n], [integ], dt=h)[0][(integ, n)]
                    break
                except subprocess.CalledProcessError:
                    print(f"  ({name}: blew up at h = {h:.3g} on n = {n}; trying {0.95 * h:.3g})")
                    h *= 0.95
            else:
                sys.exit(f"peers: {name} blew up on n = {n} at every step tried")
        cost[name] = {"largest_stable_step": h, "seconds_per_step": t, "seconds_per_simulated_second": t / h}
        print(f"  {name:<34} h = {h:<10.3g} {t * 1e3:9.3f} ms/step  {t / h:10.3f} s per simulated second")
    if a.json:
        with open(a.json + ".tmp", "w") as f:
            json.dump({"bandwidth": qdoc["triad_bytes_per_second"], "machine": qdoc["machine"], "date": qdoc["date"],
                       "per_step": rows, "per_simulated_second": cost}, f, indent=1)
        os.replace(a.json + ".tmp", a.json)


if __name__ == "__main__":
    main()
