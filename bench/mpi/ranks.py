#!/usr/bin/python3
"""Step time of a run over MPI ranks against the run alone, on the canonical lattice.

Usage: bench/mpi/ranks.py [--qbond PATH] [--integrator velocity_verlet] [--n 40] [--steps 200]
                          [--repeats 3] [--most-ranks 2] [--mpiexec PATH] [--mpiexec-flag F ...] [--out FILE]
       bench/mpi/ranks.py --check [ROOT]     (the tables of docs/distributed.md against the results)
       bench/mpi/ranks.py --write [ROOT]     (rewrites those tables from the newest results)

Measures `qbond run` of the canonical n³ lattice (samples.hpp's canonical_lattice(n)) stepped by
the integrator (velocity Verlet unless told), without frames: alone on 1 and 2 threads, and over
1 to --most-ranks ranks of 1 thread each (one rank under the launcher is the program alone). The
runs alternate, `repeats` times each, and each configuration's median step time (run.json's
wall_seconds over its steps) is kept with every repeat; for the runs over ranks also each rank's
quanta and ghosts, its CPU time per step stepping its piece and charging its ledger, its wall time
per step and the bytes it sent per step (the lines the run prints); and the machine and its load average (one
minute) before and after. Results go to docs/bench/ranks-DATE.json for velocity Verlet at n = 40,
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
VERLET = "velocity_verlet"
# The tables in docs/distributed.md: (integrator, lattice size); the first of each integrator's
# is named by the integrator alone.
TABLES = [(VERLET, 40), ("coupled_implicit", 20), ("coupled_implicit", 40)]
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
    """canonical_lattice(n) (src/builders/samples.cpp), stepped by `integrator`."""
    return {
        "name": f"canonical_lattice_{n}", "timestep": 1e-4, "steps": steps, "gravity": [0, 0, -9.81],
        "integrator": {"type": integrator},
        "materials": {"bond": {"law": "linear", "stiffness": 1000, "damping": 0.01, "damping_model": "axial"}},
        "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                    "size": [n, n, n], "spacing": 0.01, "quanta_mass": 1e-3, "material": "bond"}],
        "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}],
        "output": {"every": steps, "vtk": False},
    }


def measure(a):
    load_before = os.getloadavg()[0]
    work = tempfile.mkdtemp(prefix="qbond-ranks-")
    path = os.path.join(work, "lattice.json")
    with open(path, "w") as f:
        json.dump(scene(a.n, a.steps, a.integrator), f)
    configs = [("alone", 1, 1), ("alone", 1, 2)] + [("ranks", k, 1) for k in range(1, a.most_ranks + 1)]
    runs = {f"{kind}:{ranks}x{threads}": [] for kind, ranks, threads in configs}
    ranks_seen = {f"{kind}:{ranks}x{threads}": [] for kind, ranks, threads in configs}
    for _ in range(a.repeats):
        for kind, ranks, threads in configs:
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
            key = f"{kind}:{ranks}x{threads}"
            runs[key].append(1e3 * j["wall_seconds"] / j["steps_taken"])
            # Each rank's line: quanta, ghosts, bytes sent, CPU ms stepping and ledger, wall ms, per step.
            per_rank = re.findall(r"rank \d+: (\d+) quanta, (\d+) ghosts, ([0-9.e+]+) bytes sent per step; per step "
                                  r"([0-9.e+]+) ms stepping and ([0-9.e+]+) ms ledger \(CPU\), ([0-9.e+]+) ms", r.stdout)
            if per_rank:
                ranks_seen[key].append([[float(x) for x in rank] for rank in per_rank])
    shutil.rmtree(work, ignore_errors=True)
    rows = []
    for kind, ranks, threads in configs:
        key = f"{kind}:{ranks}x{threads}"
        row = {"run": kind, "ranks": ranks, "threads": threads, "ms_per_step": statistics.median(runs[key]),
               "repeats_ms": runs[key]}
        if ranks_seen[key]:
            # Per rank, the median over the repeats of each figure.
            per = [[statistics.median(rep[r][k] for rep in ranks_seen[key]) for k in range(6)] for r in range(ranks)]
            row["per_rank"] = [{"quanta": int(p[0]), "ghosts": int(p[1]), "bytes_sent_per_step": p[2],
                                "stepping_cpu_ms": p[3], "ledger_cpu_ms": p[4], "wall_ms": p[5]} for p in per]
        rows.append(row)
    return {"workload": f"canonical lattice n={a.n}, {a.integrator}, {a.steps} steps, no frames",
            "integrator": a.integrator,
            "date": datetime.date.today().isoformat(),
            "command": " ".join(["bench/mpi/ranks.py", "--integrator", a.integrator, "--n", str(a.n), "--steps",
                                 str(a.steps), "--repeats", str(a.repeats), "--most-ranks", str(a.most_ranks)]),
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} hardware threads, "
                       "shared with other jobs",
            "load_average": [round(load_before, 2), round(os.getloadavg()[0], 2)],
            "rows": rows}


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
    return "\n".join(lines)


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
    p.add_argument("--out")
    a = p.parse_args()
    if a.check or a.write:
        return render(a.check or a.write, check=bool(a.check))
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
