#!/usr/bin/python3
"""bench/mpi/ranks.py's LAMMPS side: what it reads of LAMMPS's output, which runs it interleaves,
the lines it writes under the velocity Verlet table, and, given qbond and a launcher, that LAMMPS
steps the lattice qbond steps and that a small measurement records LAMMPS beside qbond.

Usage: ranks_bench_test.py SOURCE_DIR                       (reading and writing alone)
       ranks_bench_test.py SOURCE_DIR QBOND_EXE WORK_DIR --mpiexec PATH [--mpiexec-flag=F ...]
The second exits 77 (skipped), saying why, where LAMMPS's lmp is not installed.
"""
import argparse
import csv
import json
import os
import re
import shutil
import statistics
import subprocess
import sys

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)
        print("FAIL:", what)


def lammps_output(procs, steps, atoms, bonds, loops=1):
    """What LAMMPS prints of a run, trimmed to the lines ranks.py reads and their neighbours."""
    loop = (f"Loop time of 0.0398 on {procs} procs for {steps} steps with {atoms} atoms\n\n"
            "58.2% CPU use with 1 MPI tasks x 1 OpenMP threads\n")
    return ("LAMMPS (29 Sep 2021 - Update 2)\n  using 1 OpenMP thread(s) per MPI task\nReading data file ...\n"
            f"  reading atoms ...\n  {atoms} atoms\n  scanning bonds ...\n  9 = max bonds/atom\n"
            f"  reading bonds ...\n  {bonds} bonds\nStep \n       0 \n     {steps} \n" + loop * loops)


def reading(ranks):
    n, steps = 10, 20
    bonds = ranks.bond_count(n)
    ms = ranks.lammps_ms_per_step(lammps_output(2, steps, n ** 3, bonds), n, steps, 2)
    check(ms == 1e3 * 0.0398 / steps, f"loop time per step {ms} ms, not {1e3 * 0.0398 / steps}")
    # Each of these is not the run asked for, and must not give a time.
    for what, text, procs in (
            ("one process where two were asked", lammps_output(1, steps, n ** 3, bonds), 2),
            # Copies started apart by a launcher of another MPI: a loop each, on 1 proc.
            ("two copies of one process", lammps_output(1, steps, n ** 3, bonds, loops=2), 1),
            ("fewer steps", lammps_output(2, steps - 1, n ** 3, bonds), 2),
            ("another lattice's quanta", lammps_output(2, steps, 9 ** 3, bonds), 2),
            ("another lattice's bonds", lammps_output(2, steps, n ** 3, bonds - 1), 2),
            ("no loop (a failed run)", lammps_output(2, steps, n ** 3, bonds, loops=0), 2)):
        try:
            ranks.lammps_ms_per_step(text, n, steps, procs)
            check(False, f"a time read from {what}")
        except ValueError:
            pass


def order(ranks):
    """LAMMPS runs beside velocity Verlet alone and over 2 ranks and more, each after qbond's run of
    as many ranks; never beside the implicit integrators, nor when told not to."""
    got = ranks.configs(ranks.VERLET, 3, True)
    want = [("qbond", "alone", 1, 1), ("lammps", "alone", 1, 1), ("qbond", "alone", 1, 2), ("qbond", "ranks", 1, 1),
            ("qbond", "ranks", 2, 1), ("lammps", "ranks", 2, 1), ("qbond", "ranks", 3, 1), ("lammps", "ranks", 3, 1)]
    check(got == want, f"velocity Verlet's runs: {got}")
    for integrator, lammps in (("coupled_implicit", True), (ranks.VERLET, False)):
        got = [c[0] for c in ranks.configs(integrator, 2, lammps)]
        check(got == ["qbond"] * 4, f"{integrator}'s runs (LAMMPS {lammps}): {got}")


def writing(ranks):
    rows = [{"run": "alone", "ranks": 1, "threads": 1, "ms_per_step": 6.0, "repeats_ms": [6.0, 7.0, 5.0]},
            {"run": "alone", "ranks": 1, "threads": 2, "ms_per_step": 3.0, "repeats_ms": [3.0] * 3},
            {"run": "ranks", "ranks": 1, "threads": 1, "ms_per_step": 6.5, "repeats_ms": [6.5] * 3},
            {"run": "ranks", "ranks": 2, "threads": 1, "ms_per_step": 4.0, "repeats_ms": [4.0] * 3}]
    older = {"integrator": ranks.VERLET, "rows": rows}
    lines = ranks.beside_lammps(older)
    check(len(lines) == 2 and "LAMMPS was not run" in lines[1] and not re.search(r"\d", lines[1].split("(")[0]),
          f"results without LAMMPS: {lines}")
    check(ranks.beside_lammps({"integrator": "coupled_implicit", "rows": rows}) == [],
          "a line about LAMMPS under an implicit integrator's table")
    measured = dict(older, lammps={"program": "LAMMPS (29 Sep 2021 - Update 2)", "integrator": "fix nve", "threads": 1,
                                   "rows": [{"run": "alone", "ranks": 1, "threads": 1, "ms_per_step": 5.0,
                                             "repeats_ms": [5.0] * 3},
                                            {"run": "ranks", "ranks": 2, "threads": 1, "ms_per_step": 2.0,
                                             "repeats_ms": [2.0] * 3}]})
    table = [line for line in ranks.beside_lammps(measured) if line.startswith("| ")]
    # qbond's over 2 ranks beside LAMMPS's over 2, each program's speed-up over its own run alone.
    want = ["| ranks | qbond ms per step | qbond speed-up | LAMMPS ms per step | LAMMPS speed-up | qbond / LAMMPS |",
            "| 1 | 6 | 1.00× | 5 | 1.00× | 1.20 |",
            "| 2 | 4 | 1.50× | 2 | 2.50× | 2.00 |"]
    check(table == want, f"side by side: {table}, not {want}")


def same_lattice(ranks, qbond, work):
    """LAMMPS and qbond, both velocity Verlet, on the 6³ lattice without damping (LAMMPS's
    harmonic bonds have none): the same kinetic energy after 100 steps, to 1e-9 of it. The two
    differ only in the order of their sums, a rounding of 1e-16 a step that the stable lattice
    carries along without growth; a mass, stiffness, rest length, anchor or step not the same
    would show at the first digits."""
    n, steps = 6, 100
    script = ranks.lammps_script(n, steps, work, columns="step ke")
    r = subprocess.run(["lmp", "-in", script, "-log", "none", "-nocite"], capture_output=True, text=True, cwd=work,
                       check=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    ke_lammps = float(re.findall(rf"^\s*{steps}\s+(\S+)\s*$", r.stdout, re.M)[-1])
    sc = ranks.scene(n, steps, ranks.VERLET)
    sc["materials"]["bond"]["damping"] = 0.0
    path = os.path.join(work, "lattice.json")
    with open(path, "w") as f:
        json.dump(sc, f)
    out = os.path.join(work, "qbond_out")
    subprocess.run([qbond, "run", path, "-o", out, "--no-vtk"], capture_output=True, check=True)
    with open(os.path.join(out, "diagnostics.csv")) as f:
        last = list(csv.DictReader(f))[-1]
    ke = float(last["kinetic"])
    print(f"kinetic energy after {steps} steps: qbond {ke!r}, LAMMPS {ke_lammps!r}")
    check(int(last["step"]) == steps and ke > 0 and abs(ke - ke_lammps) <= 1e-9 * ke,
          f"kinetic energy after {steps} steps: qbond {ke!r} at step {last['step']}, LAMMPS {ke_lammps!r}")


def measurement(src, qbond, work, mpiexec, flags):
    """A small measurement: LAMMPS's runs recorded beside qbond's, every repeat, and its table."""
    out = os.path.join(work, "ranks.json")
    r = subprocess.run([sys.executable, os.path.join(src, "bench/mpi/ranks.py"), "--qbond", qbond, "--n", "6",
                        "--steps", "10", "--repeats", "2", "--most-ranks", "2", "--mpiexec", mpiexec,
                        *[f"--mpiexec-flag={f}" for f in flags], "--out", out], capture_output=True, text=True)
    check(r.returncode == 0, f"ranks.py: exit {r.returncode}\n{r.stderr}")
    if r.returncode != 0:
        return
    with open(out) as f:
        res = json.load(f)
    lmp = res.get("lammps", {})
    check(lmp.get("program", "").startswith("LAMMPS ("), f"LAMMPS's banner: {lmp.get('program')}")
    got = [(row["run"], row["ranks"], len(row["repeats_ms"])) for row in lmp.get("rows", [])]
    check(got == [("alone", 1, 2), ("ranks", 2, 2)], f"LAMMPS's runs: {got}")
    check(all(row["ms_per_step"] > 0 and row["ms_per_step"] == statistics.median(row["repeats_ms"])
              for row in lmp.get("rows", [])),
          f"LAMMPS's step times: {lmp.get('rows')}")
    check("| 2 | " in r.stdout and "LAMMPS speed-up" in r.stdout, f"no side-by-side table printed:\n{r.stdout}")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("src")
    p.add_argument("qbond", nargs="?")
    p.add_argument("work", nargs="?")
    p.add_argument("--mpiexec", default="mpiexec")
    p.add_argument("--mpiexec-flag", action="append", default=[])
    a = p.parse_args()
    sys.path.insert(0, os.path.join(a.src, "bench", "mpi"))
    import ranks
    reading(ranks)
    order(ranks)
    writing(ranks)
    if a.qbond:
        if shutil.which("lmp") is None:
            print("skipped: LAMMPS's lmp is not installed (bench/peers/packages.txt: apt-get install lammps)")
            return 77
        shutil.rmtree(a.work, ignore_errors=True)
        os.makedirs(a.work)
        same_lattice(ranks, a.qbond, a.work)
        measurement(a.src, a.qbond, a.work, a.mpiexec, a.mpiexec_flag)
    if FAILURES:
        print(f"{len(FAILURES)} failed")
        return 1
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
