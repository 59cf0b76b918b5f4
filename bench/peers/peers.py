#!/usr/bin/python3
"""qbond, LAMMPS and Bullet side by side on the canonical workload (docs/performance.md).

Usage: bench/peers/peers.py BUILD_DIR BULLET_EXE [--n 10,20,40] [--steps 200] [--rounds 3]
                            [--accuracy-n 10,20] [--iterations 7] [--methods LAMMPS,Bullet,default,...]
                            [--cap 600] [--reference FILE] [--append FILE] [--quick] [--json FILE]
Run by bench/peers/run, which installs LAMMPS and Bullet (Debian packages) and builds
BULLET_EXE. Prints, for each n, ns per bond per step of each engine measured in this run; then
qbond's velocity Verlet against LAMMPS's in `rounds` alternating runs (the shared host's load
moves both by 20% and more within minutes: each round's ratio sets two runs a few seconds apart
side by side); then, on each of the accuracy-n lattices, each method's largest step that meets
the dynamic and the settled accuracy criteria and its cost per simulated second there
(bench/peers/accuracy.py). --quick runs it all on the 4^3 lattice with a shorter search (the
ctest test peers.accuracy_quick), so the machinery cannot rot. --append FILE runs only the accuracy
searches (e.g. of a larger lattice, for fewer methods) and adds them to an earlier run's JSON; a
lattice it already holds keeps its rows of the methods not searched again.

The workload: n^3 simple-cubic lattice, spacing 0.01 m, 1 g quanta, bonds to nearest and
face-diagonal neighbours (k = 1000 N/m), the x = 0 face anchored, gravity -9.81 m/s^2 along z.
LAMMPS: bond_style harmonic with K = k/2 (its energy is K (r - r0)^2), fix nve (velocity Verlet),
fix setforce/zero velocity on the anchored face; no bond damping (harmonic has none).
Bullet: btSoftBody links (position constraints, kLST = 1, one iteration): same topology, masses,
anchors and step, Bullet's own material law. qbond: `qbond bench` (its default integrator, the
paper's hybrid and velocity Verlet), and `qbond run` (one thread) for the accuracy search.
"""
import argparse
import concurrent.futures
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import accuracy
from workload import MASS, bond_count, lammps_header

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from ab import cpu_model  # noqa: E402  (bench/ab.py)


def lammps(n, h, steps, work):
    """(seconds per step, stable) of LAMMPS's velocity-Verlet run of the workload."""
    script = os.path.join(work, "in.canonical")
    with open(script, "w") as f:
        f.write(lammps_header(n, work) + f"""fix move free nve
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


def machine():
    """The processor's name and this machine's core count (an appended run's machine may not be
    the first run's)."""
    return f"{cpu_model()} ({os.cpu_count()} cores)"


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


def accuracy_setup(a, n, cached):
    """(lattice record, printed lines): what the n^3 lattice's searches are measured against."""
    lines = []
    work = tempfile.mkdtemp(prefix=f"qbond_peers_{n}_")
    # The reference's step is the largest whose own error estimate is far below the tolerance
    # (accuracy.reference); the floor is 1e-5 s on every lattice, the cap on an evaluation's CPU
    # seconds saying when a step that small costs too much.
    return accuracy.lattice_record(a.build, work, n, 1e-5, a.iterations, a.cap, cached, log=lines.append), lines


def accuracy_method(a, lat, method):
    """(rows, printed lines) of one method's searches, in a work folder of its own."""
    lines = []
    work = tempfile.mkdtemp(prefix=f"qbond_peers_{lat['n']}_")
    return accuracy.method_rows(a.build, a.bullet, work, lat, method, log=lines.append), lines


def accuracy_methods(a):
    methods = [m if m in ("LAMMPS", "Bullet") else "qbond " + m for m in a.methods.split(",")]
    unknown = [m for m in methods if m not in ("LAMMPS", "Bullet", *accuracy.QBOND_METHODS)]
    if unknown:
        sys.exit(f"peers: unknown --methods {unknown}")
    return methods


def accuracy_all(a, pool, setups, save):
    """The accuracy records of every --accuracy-n: each method's searches a job of the pool (two
    processes: the machine's cores), `save(records)` called as each finishes, so that a run cut
    short keeps what it measured."""
    records = []
    for job in setups:
        lat, lines = job.result()
        print("\n".join(lines), flush=True)
        records.append(lat)
    jobs = [(lat, pool.submit(accuracy_method, a, lat, m)) for lat in records for m in accuracy_methods(a)]
    order = {id(job): i for i, (_, job) in enumerate(jobs)}
    done = []
    for job in concurrent.futures.as_completed([j for _, j in jobs]):
        rows, lines = job.result()
        print("\n".join(lines), flush=True)
        done.append((order[id(job)], rows))
        for lat in records:
            lat["rows"] = [r for i, rows_i in sorted(done) if jobs[i][0] is lat for r in rows_i]
        save(records)
    return records


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("bullet")
    ap.add_argument("--n", default="10,20,40")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--accuracy-n", default="10,20")
    ap.add_argument("--iterations", type=int, default=7, help="bisection steps of each accuracy search")
    ap.add_argument("--cap", type=float, default=600,
                    help="CPU seconds an accuracy evaluation's run may take: a longer one is stopped and its step "
                         "reported as over the cap (default: 600)")
    ap.add_argument("--quick", action="store_true", help="the 4^3 lattice only, a short search (a test)")
    ap.add_argument("--reference", help="an earlier run's JSON whose accuracy references (trajectory, static "
                                        "solution) to reuse where they meet this run's tolerances")
    ap.add_argument("--methods", default="LAMMPS,Bullet," + ",".join(m.removeprefix("qbond ") for m in accuracy.QBOND_METHODS),
                    help="the accuracy searches' methods: LAMMPS, Bullet and qbond's integrators")
    ap.add_argument("--append", help="only the accuracy searches, their records added to this earlier run's JSON "
                                     "(a lattice searched again keeps its rows of the methods not in --methods)")
    ap.add_argument("--json")
    a = ap.parse_args()
    cached = {}
    if a.reference:
        with open(a.reference) as f:
            cached = {r["n"]: r for r in json.load(f).get("accuracy", [])}
    if a.quick:
        a.n, a.accuracy_n, a.steps, a.rounds, a.iterations = "4", "4", 20, 1, 3
    command = "bench/peers/run " + " ".join(sys.argv[3:])
    pool = concurrent.futures.ProcessPoolExecutor(max_workers=2)
    # The lattices' references first, in the pool, while this process times the steps.
    setups = [pool.submit(accuracy_setup, a, int(n), cached.get(int(n))) for n in a.accuracy_n.split(",")]

    if a.append:
        with open(a.append) as f:
            doc = json.load(f)
        ns = {int(n) for n in a.accuracy_n.split(",")}
        kept = [r for r in doc["accuracy"] if r["n"] not in ns]
        # A lattice searched again keeps its earlier rows of the methods not run this time.
        earlier = {r["n"]: r for r in doc["accuracy"] if r["n"] in ns}
        rerun = accuracy_methods(a)

        def merged(rec):
            old = [r for r in earlier.get(rec["n"], {}).get("rows", [])
                   if not any(r["method"] == m or r["method"].startswith(m + " (") for m in rerun)]
            return {**rec, "rows": old + rec["rows"]}
        appended = {"command": command, "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                    "machine": machine(), "nice": os.nice(0), "load_average": [os.getloadavg()[0]] * 2,
                    "accuracy_n": sorted(ns), "finished": False}
        doc.setdefault("appended", []).append(appended)

        def save_appended(records):
            doc["accuracy"] = sorted(kept + [merged(r) for r in records], key=lambda r: r["n"])
            appended["load_average"][1] = os.getloadavg()[0]
            write_json(a.append, doc)
        records = accuracy_all(a, pool, setups, save_appended)
        appended["finished"] = True
        save_appended(records)
        pool.shutdown()
        return
    n_list = [int(x) for x in a.n.split(",")]
    work = tempfile.mkdtemp(prefix="qbond_peers_")
    load_start = os.getloadavg()[0]
    integrators = ["default", "hybrid_frozen", "hybrid_sweep", "velocity_verlet"]
    q, qdoc = qbond_bench(a.build, n_list, integrators)
    rows = []
    print("ns per bond per step, h = 1e-4 s, one thread, measured in this run")
    print(f"{'n':>4} {'bonds':>8} {'LAMMPS':>9} {'Bullet':>9} " + " ".join(f"{'qbond ' + i:>22}" for i in integrators))
    for n in n_list:
        nb = bond_count(n)
        steps = max(20, a.steps * 1000 // n ** 3) if n > 10 else a.steps
        t_l, _ = lammps(n, 1e-4, steps, work)
        t_b, links, _ = bullet(a.bullet, n, 1e-4, steps)
        if links != nb:
            sys.exit(f"peers: Bullet built {links} links, the workload has {nb} bonds")
        row = {"n": n, "bonds": nb, "lammps": t_l, "bullet": t_b, **{f"qbond_{i}": q[(i, n)] for i in integrators}}
        rows.append(row)
        print(f"{n:>4} {nb:>8} {t_l / nb * 1e9:>9.2f} {t_b / nb * 1e9:>9.2f} " +
              " ".join(f"{q[(i, n)] / nb * 1e9:>22.2f}" for i in integrators), flush=True)

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
                        for l_t, q_t in pairs), flush=True)

    def save(records, finished=False):
        if a.json:
            write_json(a.json, {"bandwidth": qdoc["triad_bytes_per_second"], "machine": qdoc["machine"],
                                "date": qdoc["date"], "per_step": rows, "quick": a.quick, "accuracy": records,
                                "finished": finished, "nice": os.nice(0),
                                "load_average": [load_start, os.getloadavg()[0]], "command": command})
    save([])
    save(accuracy_all(a, pool, setups, save), finished=True)
    pool.shutdown()


def write_json(path, doc):
    with open(path + ".tmp", "w") as f:
        json.dump(doc, f, indent=1)
    os.replace(path + ".tmp", path)


if __name__ == "__main__":
    main()
