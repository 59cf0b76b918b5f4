#!/usr/bin/python3
"""bench/peers/peers.py --quick: the equal-accuracy comparison with LAMMPS and Bullet on the 4^3
lattice, so that the benchmark cannot rot. Exits 77 (skipped), saying why, without LAMMPS or Bullet.

Usage: peers_accuracy_test.py QBOND_EXE SOURCE_DIR WORK_DIR

Checks what the search must give whatever the machine: every step reported meets its criterion
and a step just above it (one bisection interval) was tried and failed, unless it is the ceiling;
the reference's Richardson error is far below the dynamic tolerance, at the largest step of its
halving that is; the search's cost cap, on a criterion of known answer: a step below the cap's
reach is reported as over the cap, never as failing; LAMMPS and qbond, both
velocity Verlet on the same harmonic bonds, make the same dynamic errors at every step both
tried below their stability limit; backward Euler (qbond's default) settles to the static
solution in steps far beyond any explicit method's limit.
"""
import json
import math
import os
import shutil
import subprocess
import sys


def search_with_a_cap(accuracy, check):
    """accuracy.search on a criterion met at h <= 1e-3 whose runs take over the cap below 1e-4 and
    2e-3: the first finds 1e-3 within a bisection interval; the second reports over the cap."""
    for cap_below, want in ((1e-4, 1e-3), (2e-3, None)):
        res = accuracy.search(lambda h: (None, None, None) if h < cap_below else (h <= 1e-3, 0.0, 1.0),
                              1e-6, 1.0, 8)
        ratio = (1.0 / 1e-6) ** (0.5 ** 8)
        if want is None:
            check(res["step"] is None and res["over_cap_below"] is not None and
                  1e-3 < res["over_cap_below"] < cap_below and
                  all(t["meets"] is False for t in res["tried"] if t["h"] >= cap_below),
                  f"search over the cap below {cap_below}: {res}")
        else:
            check(res["step"] is not None and want / ratio <= res["step"] <= want and res["over_cap_below"] is None,
                  f"search with runs over the cap below {cap_below}: {res}")
        check(all(t["meets"] is None for t in res["tried"] if t["h"] < cap_below),
              f"a run below the cap's reach counted as met or failed: {res['tried']}")


def main():
    qbond, src, work = sys.argv[1:4]
    if shutil.which("lmp") is None:
        print("skipped: LAMMPS's lmp is not installed (bench/peers/packages.txt: apt-get install lammps)")
        return 77
    if subprocess.run(["pkg-config", "--exists", "bullet"]).returncode != 0:
        print("skipped: Bullet is not installed (bench/peers/packages.txt: apt-get install libbullet-dev pkg-config)")
        return 77
    os.makedirs(work, exist_ok=True)
    bullet = os.path.join(work, "bullet_canonical")
    flags = subprocess.run(["pkg-config", "--cflags", "--libs", "bullet"], capture_output=True, text=True,
                           check=True).stdout.split()
    subprocess.run(["g++", "-std=c++20", "-O2", "-o", bullet, os.path.join(src, "bench/peers/bullet_canonical.cpp"),
                    *flags], check=True)
    out = os.path.join(work, "quick.json")
    subprocess.run([sys.executable, os.path.join(src, "bench/peers/peers.py"), os.path.dirname(qbond), bullet,
                    "--quick", "--json", out], check=True)
    with open(out) as f:
        doc = json.load(f)

    sys.path.insert(0, os.path.join(src, "bench/peers"))
    import accuracy
    failures = []

    def check(ok, what):
        if not ok:
            failures.append(what)

    search_with_a_cap(accuracy, check)
    for p in doc["per_step"]:
        for k in ("lammps", "bullet", "qbond_velocity_verlet", "qbond_default"):
            check(math.isfinite(p[k]) and p[k] > 0, f"per step n = {p['n']}: {k} = {p[k]}")
    (acc,) = doc["accuracy"]
    iterations, floor = acc["iterations"], acc["floor"]
    ref = acc["reference"]
    check(ref["richardson_error"] < 1e-3 * accuracy.DYNAMIC_TOL, f"reference's Richardson error {ref['richardson_error']}")
    halving = ref["halving"]
    check(halving[-1]["h"] == ref["h"] and halving[-1]["richardson_error"] == ref["richardson_error"] and
          all(x["richardson_error"] > accuracy.REFERENCE_TOL for x in halving[:-1]) and
          all(y["h"] == x["h"] / 2 for x, y in zip(halving, halving[1:])) and halving[0]["h"] == accuracy.SAMPLE / 2,
          f"the reference's step is not the largest of its halving below the tolerance: {halving}")
    check(acc["static_solve"]["residual"] <= accuracy.STATIC_TOL, f"static solve {acc['static_solve']}")
    rows = {(r["method"], r["criterion"]): r for r in acc["rows"]}
    check(len(rows) == 2 * (2 + len(accuracy.QBOND_METHODS)), f"rows: {sorted(rows)}")
    for (m, c), r in rows.items():
        tol = accuracy.DYNAMIC_TOL if c == "dynamic" else accuracy.SETTLED_TOL
        ceiling = accuracy.T_DYNAMIC if c == "dynamic" else accuracy.T_SETTLED
        ratio = (ceiling / floor) ** (0.5 ** iterations)
        if r["step"] is None:
            check(any(t["h"] == floor and t["meets"] is False for t in r["tried"]) or
                  any(t["h"] == r["over_cap_below"] and t["meets"] is None for t in r["tried"]),
                  f"{m} {c}: never, neither the floor tried nor a run over the cap")
            continue
        check(r["error"] <= tol, f"{m} {c}: error {r['error']} at the step found, tolerance {tol}")
        check(r["step"] == ceiling or any(r["step"] < t["h"] <= r["step"] * ratio * 1.000001 and not t["meets"]
                                          for t in r["tried"]), f"{m} {c}: no failure just above {r['step']}")
        check(r["seconds_per_simulated_second"] > 0, f"{m} {c}: cost {r['seconds_per_simulated_second']}")
    lam = {t["h"]: t for t in rows[("LAMMPS (velocity Verlet)", "dynamic")]["tried"]}
    vv = {t["h"]: t for t in rows[("qbond velocity_verlet", "dynamic")]["tried"]}
    common = [h for h in lam if h in vv and math.isfinite(lam[h]["error"]) and math.isfinite(vv[h]["error"])]
    check(len(common) >= 1, "LAMMPS and qbond's velocity Verlet share no stable step")
    for h in common:
        check(abs(lam[h]["error"] - vv[h]["error"]) <= 1e-3, f"h = {h}: LAMMPS's error {lam[h]['error']}, "
              f"qbond velocity Verlet's {vv[h]['error']}")
    # Without the ledger velocity Verlet steps the same bits: the same steps tried, the same errors.
    def tried(method, c):
        return [(t["h"], repr(t["error"])) for t in rows[(method, c)]["tried"]]
    for c in ("dynamic", "settled"):
        check(tried("qbond velocity_verlet_no_ledger", c) == tried("qbond velocity_verlet", c),
              f"{c}: velocity Verlet's searches with and without the ledger differ")
    be = rows[("qbond default", "settled")]["step"]
    vv_settled = rows[("qbond velocity_verlet", "settled")]["step"]
    check(be is not None and be >= 0.1, f"backward Euler settled only at h = {be}")
    check(vv_settled is not None and vv_settled < 0.01, f"velocity Verlet settled at h = {vv_settled}")
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print(f"peers --quick: {len(rows)} searches consistent; LAMMPS and qbond velocity Verlet agree at "
              f"{len(common)} steps")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
