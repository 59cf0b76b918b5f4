#!/usr/bin/python3
"""Step time of a run over MPI ranks against the run alone, on the canonical lattice.

Usage: bench/mpi/ranks.py [--qbond PATH] [--integrator velocity_verlet] [--n 40] [--steps 200]
                          [--repeats 3] [--most-ranks 2] [--mpiexec PATH] [--mpiexec-flag F ...]
                          [--lmp PATH | --no-lammps] [--out FILE]
       bench/mpi/ranks.py --check [ROOT]     (the tables of docs/distributed.md against the results)
       bench/mpi/ranks.py --write [ROOT]     (rewrites those tables from the newest results)

Measures `qbond run` of the canonical n³ lattice (samples.hpp's canonical_lattice(n)) stepped by
the integrator (velocity Verlet unless told), without frames: alone on 1 and 2 threads, and over
1 to --most-ranks ranks of 1 thread each (one rank under the launcher is the program alone). The
runs alternate, `repeats` times each, and each configuration's median step time (run.json's
wall_seconds over its steps) is kept with every repeat; for the runs over ranks also each rank's
quanta and ghosts, its CPU time per step stepping its piece and charging its ledger, its wall time
per step and the bytes it sent per step (the lines the run prints); and the machine and its load average (one
minute) before and after. With velocity Verlet, LAMMPS (`lmp`, unless --no-lammps) steps the same
lattice (bench/peers/workload.py's lammps_header: the same quanta, masses, bonds, stiffness,
anchored face, gravity and step) by its velocity Verlet (`fix nve`, output at the run's ends
alone), alone and under the same launcher over 2 to --most-ranks ranks, in the same repeats, each
run placed beside qbond's over as many ranks; its step time is its own loop time ("Loop time of X
on P procs for S steps") over the steps. LAMMPS has no implicit integrator to set beside the others.
Results go to docs/bench/ranks-DATE.json for velocity Verlet at n = 40,
docs/bench/ranks-INTEGRATOR-DATE.json for coupled_implicit at n = 20, and
docs/bench/ranks-INTEGRATOR-nN-DATE.json for the other tables of TABLES; each table sits between
`<!-- ranks:step -->` and `<!-- /ranks:step -->` (velocity Verlet), `<!-- ranks:step:INTEGRATOR -->`
and `<!-- /ranks:step:INTEGRATOR -->`, or `<!-- ranks:step:INTEGRATOR:nN -->` and its end, in
docs/distributed.md; --check exits 1 when one is not what the newest results of its table give.
"""
import argparse
import datetime
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench", "peers"))
from workload import A, G, K, MASS, bond_count, lammps_header  # noqa: E402

VERLET = "velocity_verlet"
STEP = 1e-4  # s, qbond's and LAMMPS's
# The tables in docs/distributed.md: (integrator, lattice size); the first of each integrator's
# is named by the integrator alone.
TABLES = [(VERLET, 40), (VERLET, 100), ("coupled_implicit", 20), ("coupled_implicit", 40), ("coupled_implicit", 100)]
PLAIN = {VERLET: 40, "coupled_implicit": 20}


def name_part(integrator, n):
    """What names a table's results and markers besides `ranks`: '', 'INTEGRATOR' or 'INTEGRATOR-nN'."""
    if integrator == VERLET and n == PLAIN[VERLET]:
        return ""
    return integrator if PLAIN.get(integrator) == n else f"{integrator}-n{n}"


def markers(integrator, n):
    part = name_part(integrator, n).replace("-", ":")
    tag = "ranks:step" + (f":{part}" if part else "")
    return f"<!-- {tag} -->", f"<!-- /{tag} -->"


def name_pattern(integrator, n):
    part = name_part(integrator, n)
    mid = re.escape(part) + "-" if part else ""
    return re.compile(rf"^ranks-{mid}(\d{{4}}-\d\d-\d\d)([a-z]*)\.json$")


def scene(n, steps, integrator):
    """canonical_lattice(n) (src/builders/samples.cpp), stepped by `integrator`: the workload of
    bench/peers/workload.py, which LAMMPS reads too, with the bonds' axial damping."""
    return {
        "name": f"canonical_lattice_{n}", "timestep": STEP, "steps": steps, "gravity": [0, 0, -G],
        "integrator": {"type": integrator},
        "materials": {"bond": {"law": "linear", "stiffness": K, "damping": 0.01, "damping_model": "axial"}},
        "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                    "size": [n, n, n], "spacing": A, "quanta_mass": MASS, "material": "bond"}],
        "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}],
        "output": {"every": steps, "vtk": False},
    }


LOOP = re.compile(r"^Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", re.M)
BONDS = re.compile(r"^\s*(\d+) bonds\s*$", re.M)


def lammps_script(n, steps, work, columns="step"):
    """LAMMPS's input of the lattice stepped by velocity Verlet (`fix nve` on the free quanta, the
    anchored face not integrated) under gravity, printing `columns` at the run's two ends alone."""
    path = os.path.join(work, "in.ranks")
    with open(path, "w") as f:
        f.write(lammps_header(n, work) + f"""fix move free nve
fix pull free gravity {G} vector 0 0 -1
timestep {STEP}
thermo_style custom {columns}
thermo_modify format float %.17g
thermo 0
run {steps}
""")
    return path


def lammps_ms_per_step(stdout, n, steps, ranks):
    """LAMMPS's loop time per step (ms) from what it printed, once that says it read the n³
    lattice's bonds and stepped its quanta `steps` times as one job of `ranks` processes (copies
    of it started apart by a launcher of another MPI print a loop each); ValueError otherwise."""
    loops = LOOP.findall(stdout)
    if len(loops) != 1:
        raise ValueError(f"LAMMPS printed {len(loops)} 'Loop time of ... on P procs for S steps' lines, not one")
    seconds, procs, took, atoms = loops[0]
    got = {"procs": int(procs), "steps": int(took), "atoms": int(atoms),
           "bonds": [int(b) for b in BONDS.findall(stdout)]}
    want = {"procs": ranks, "steps": steps, "atoms": n ** 3, "bonds": [bond_count(n)]}
    if got != want:
        raise ValueError(f"LAMMPS ran {got}, not the lattice's {want}")
    return 1e3 * float(seconds) / steps


def run_lammps(a, script, work, ranks, alone):
    """LAMMPS's ms per step stepping `script` alone or over `ranks` ranks under the launcher, and its banner."""
    cmd = [a.lmp, "-in", script, "-log", "none", "-nocite"]
    if not alone:
        cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", str(ranks)] + cmd
    # One OpenMP thread a process, as qbond's runs over ranks.
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env={**os.environ, "OMP_NUM_THREADS": "1"})
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    try:
        ms = lammps_ms_per_step(r.stdout, a.n, a.steps, ranks)
    except ValueError as e:
        sys.exit(f"{' '.join(cmd)}: {e}")
    return ms, r.stdout.splitlines()[0].strip()


def configs(integrator, most_ranks, lammps):
    """(program, run, ranks, threads) in the order each repeat runs them: qbond alone on 1 and 2
    threads and over 1 to most_ranks ranks; with velocity Verlet and `lammps`, LAMMPS alone after
    qbond alone and over k >= 2 ranks after qbond over k, each pair seconds apart."""
    beside = {("alone", 1)} | {("ranks", k) for k in range(2, most_ranks + 1)}
    out = []
    for run, ranks, threads in [("alone", 1, 1), ("alone", 1, 2)] + [("ranks", k, 1) for k in range(1, most_ranks + 1)]:
        out.append(("qbond", run, ranks, threads))
        if lammps and integrator == VERLET and threads == 1 and (run, ranks) in beside:
            out.append(("lammps", run, ranks, 1))
    return out


def measure(a):
    load_before = os.getloadavg()[0]
    work = tempfile.mkdtemp(prefix="qbond-ranks-")
    path = os.path.join(work, "lattice.json")
    with open(path, "w") as f:
        json.dump(scene(a.n, a.steps, a.integrator), f)
    order = configs(a.integrator, a.most_ranks, not a.no_lammps)
    script = lammps_script(a.n, a.steps, work) if any(c[0] == "lammps" for c in order) else None
    key = lambda program, run, ranks, threads: f"{program}:{run}:{ranks}x{threads}"  # noqa: E731
    runs = {key(*c): [] for c in order}
    ranks_seen = {key(*c): [] for c in order}
    banner = None
    for _ in range(a.repeats):
        for program, kind, ranks, threads in order:
            if program == "lammps":
                ms, banner = run_lammps(a, script, work, ranks, alone=kind == "alone")
                runs[key(program, kind, ranks, threads)].append(ms)
                continue
            out = os.path.join(work, "out")
            shutil.rmtree(out, ignore_errors=True)
            cmd = [a.qbond, "run", path, "-o", out, "--threads", str(threads), "--no-vtk"]
            if kind == "ranks":
                cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", str(ranks)] + cmd
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stderr}")
            with open(os.path.join(out, "run.json")) as f:
                j = json.load(f)
            k = key(program, kind, ranks, threads)
            runs[k].append(1e3 * j["wall_seconds"] / j["steps_taken"])
            # Each rank's line: quanta, ghosts, bytes sent, CPU ms stepping and ledger, wall ms, per step.
            per_rank = re.findall(r"rank \d+: (\d+) quanta, (\d+) ghosts, ([0-9.e+]+) bytes sent per step; per step "
                                  r"([0-9.e+]+) ms stepping and ([0-9.e+]+) ms ledger \(CPU\), ([0-9.e+]+) ms", r.stdout)
            if per_rank:
                ranks_seen[k].append([[float(x) for x in rank] for rank in per_rank])
    shutil.rmtree(work, ignore_errors=True)
    rows, lammps_rows = [], []
    for program, kind, ranks, threads in order:
        k = key(program, kind, ranks, threads)
        row = {"run": kind, "ranks": ranks, "threads": threads, "ms_per_step": statistics.median(runs[k]),
               "repeats_ms": runs[k]}
        if ranks_seen[k]:
            # Per rank, the median over the repeats of each figure.
            per = [[statistics.median(rep[r][i] for rep in ranks_seen[k]) for i in range(6)] for r in range(ranks)]
            row["per_rank"] = [{"quanta": int(p[0]), "ghosts": int(p[1]), "bytes_sent_per_step": p[2],
                                "stepping_cpu_ms": p[3], "ledger_cpu_ms": p[4], "wall_ms": p[5]} for p in per]
        (lammps_rows if program == "lammps" else rows).append(row)
    res = {"workload": f"canonical lattice n={a.n}, {a.integrator}, {a.steps} steps, no frames",
           "integrator": a.integrator,
           "date": datetime.date.today().isoformat(),
           "command": " ".join(["bench/mpi/ranks.py", "--integrator", a.integrator, "--n", str(a.n), "--steps",
                                str(a.steps), "--repeats", str(a.repeats), "--most-ranks", str(a.most_ranks)] +
                               (["--no-lammps"] if a.no_lammps and a.integrator == VERLET else [])),
           "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} hardware threads, "
                      "shared with other jobs",
           "load_average": [round(load_before, 2), round(os.getloadavg()[0], 2)],
           "rows": rows}
    if lammps_rows:
        # Its loop time over the steps: from the first step to the last, its output at the end included.
        res["lammps"] = {"program": banner, "integrator": "fix nve", "threads": 1, "rows": lammps_rows}
    return res


def latest(root, integrator, n):
    bench = os.path.join(root, "docs", "bench")
    pattern = name_pattern(integrator, n)
    found = sorted((m[1], len(m[2]), m[2], name) for name in os.listdir(bench) if (m := pattern.match(name)))
    if not found:
        sys.exit(f"ranks.py: no docs/bench/ranks-*.json of {integrator} at n={n}")
    name = found[-1][3]
    with open(os.path.join(bench, name)) as f:
        return name, json.load(f)


def table(name, res):
    base = res["rows"][0]["ms_per_step"]
    load = res["load_average"]
    command = f"`{res['command']}`" if "command" in res else "`bench/mpi/ranks.py`"
    on = f" on {res['date']}" if "command" in res else ""
    lines = [f"Measured{on} by {command} ({res['workload']}; {res['machine']}, load average "
             f"{load[0]:g} before and {load[1]:g} after; [docs/bench/{name}](bench/{name})), "
             f"median of {len(res['rows'][0]['repeats_ms'])} runs each:", "",
             "| run | ranks × threads | ms per step | speed-up | per rank: stepping, ledger (CPU ms per step) | "
             "bytes sent per step, per rank |",
             "|---|---|---|---|---|---|"]
    for r in res["rows"]:
        per = r.get("per_rank", [])
        cpu = "; ".join(f"{p['stepping_cpu_ms']:.3g}, {p['ledger_cpu_ms']:.3g}" for p in per) or "—"
        sent = ", ".join(f"{p['bytes_sent_per_step']:.0f}" for p in per) or "—"
        lines.append(f"| {r['run']} | {r['ranks']} × {r['threads']} | {r['ms_per_step']:.3g} | "
                     f"{base / r['ms_per_step']:.2f}× | {cpu} | {sent} |")
    return "\n".join(lines + beside_lammps(res))


def beside_lammps(res):
    """The lines under a velocity Verlet table: LAMMPS's step times beside qbond's, each program's
    speed-up over its own run alone, or that LAMMPS was not run. None under the other integrators'."""
    if res.get("integrator") != VERLET:
        return []
    if "lammps" not in res:
        return ["", "LAMMPS was not run in this measurement: it has no step times here to set beside qbond's "
                "([performance.md](performance.md#side-by-side-with-lammps-and-bullet) sets one thread of each "
                "side by side)."]
    lmp = res["lammps"]
    qbond = {r["ranks"]: r["ms_per_step"] for r in res["rows"] if r["run"] == "ranks" and r["ranks"] > 1}
    qbond[1] = next(r["ms_per_step"] for r in res["rows"] if r["run"] == "alone" and r["threads"] == 1)
    alone = {"qbond": qbond[1], "lammps": lmp["rows"][0]["ms_per_step"]}
    lines = ["", f"Beside {lmp['program']}, its velocity Verlet (`{lmp['integrator']}`) run in the same repeats, "
             f"median of {len(lmp['rows'][0]['repeats_ms'])} runs each; one rank is each program alone, more are "
             f"under the launcher, {lmp['threads']} thread a process:", "",
             "| ranks | qbond ms per step | qbond speed-up | LAMMPS ms per step | LAMMPS speed-up | qbond / LAMMPS |",
             "|---|---|---|---|---|---|"]
    for r in lmp["rows"]:
        q, m = qbond[r["ranks"]], r["ms_per_step"]
        lines.append(f"| {r['ranks']} | {q:.3g} | {alone['qbond'] / q:.2f}× | {m:.3g} | {alone['lammps'] / m:.2f}× | "
                     f"{q / m:.2f} |")
    return lines + ["", "Both step the same lattice (quanta, masses, bonds, stiffness, anchored face, gravity, step) "
                    "by velocity Verlet, each timed by its own clock over its loop of steps: the cost of a step, "
                    "not accuracy. qbond's bonds carry their axial damping, LAMMPS's harmonic bonds none."]


def render(root, check):
    doc = os.path.join(root, "docs", "distributed.md")
    with open(doc) as f:
        text = f.read()
    new = text
    for integrator, n in TABLES:
        begin, end = markers(integrator, n)
        if begin not in new or end not in new:
            sys.exit(f"{doc}: no {begin} ... {end}")
        head, rest = new.split(begin, 1)
        _, tail = rest.split(end, 1)
        new = head + begin + "\n" + table(*latest(root, integrator, n)) + "\n" + end + tail
    if check:
        if new != text:
            sys.exit(f"{doc}: the ranks table is not what the newest docs/bench/ranks-*.json gives "
                     "(bench/mpi/ranks.py --write)")
        return
    with open(doc, "w") as f:
        f.write(new)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--check", nargs="?", const=ROOT)
    p.add_argument("--write", nargs="?", const=ROOT)
    p.add_argument("--qbond", default=os.path.join(ROOT, "build", "qbond"))
    p.add_argument("--integrator", default=VERLET)
    p.add_argument("--n", type=int, default=40)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--most-ranks", type=int, default=2, help="runs over 1 to this many ranks (default: 2)")
    p.add_argument("--mpiexec", default="mpiexec")
    p.add_argument("--mpiexec-flag", action="append", default=[])
    p.add_argument("--lmp", default="lmp", help="LAMMPS's program, run beside velocity Verlet (default: lmp)")
    p.add_argument("--no-lammps", action="store_true", help="velocity Verlet without LAMMPS beside it")
    p.add_argument("--out")
    a = p.parse_args()
    if a.check or a.write:
        return render(a.check or a.write, check=bool(a.check))
    if a.integrator == VERLET and not a.no_lammps and shutil.which(a.lmp) is None:
        sys.exit(f"ranks.py: LAMMPS's {a.lmp} is not found (bench/peers/packages.txt: apt-get install lammps); "
                 "--lmp PATH, or --no-lammps to measure qbond alone")
    res = measure(a)
    part = name_part(a.integrator, a.n)
    mid = f"{part}-" if part else ""
    out = a.out or os.path.join(ROOT, "docs", "bench", f"ranks-{mid}{res['date']}.json")
    with open(out, "w") as f:
        json.dump(res, f, indent=1)
        f.write("\n")
    print(table(os.path.basename(out), res))


if __name__ == "__main__":
    main()
