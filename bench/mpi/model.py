#!/usr/bin/python3
"""A model of a step over many ranks, checked against bench/mpi/ranks.py's measurements.

Usage: bench/mpi/model.py            (prints the check and the prediction)
       bench/mpi/model.py --check [ROOT]   (docs/distributed.md's model table against the results)
       bench/mpi/model.py --write [ROOT]   (rewrites that table from the newest results)

The canonical n³ lattice (cubic, face-diagonal bonds: 18 neighbours a quanta) split by the
recursive coordinate bisection of src/distributed/partition.cpp gives boxes of whole lattice
planes. For a box the model counts, exactly, what a rank owns, its ghosts (quanta outside its box
bonded to one inside: the box grown by one plane a side less the points beyond a corner, which no
bond of 18 reaches) and what it sends each neighbour (its quanta in the neighbour's grown box).
A step of velocity Verlet sends 72 bytes a ghost (position, velocity and bond force) and one
all-gather of 10 numbers a rank, and the run starts with one exchange of the positions (24 bytes
a ghost); a step of coupled_implicit sends 48 bytes a ghost and, per CG
iteration, 24 bytes a ghost and two sums over the ranks. The step time is

    T(P) = max over ranks of c · Q_r  +  m_r α + B_r β  +  ⌈log₂ P⌉ α + 80 P β,

c a quanta's CPU time a step (stepping and ledger), Q_r the rank's quanta, m_r its neighbours,
B_r the bytes it sends, α a message's latency and β the time a byte takes on the network.

Checked against the newest docs/bench/ranks-*.json (velocity Verlet on n = 40): the model must
give each rank's quanta, ghosts and bytes sent a step (the start-up exchange spread over the
run's steps) exactly, or this exits 1; the CPU time a quanta
(c) is taken from the run over 2 ranks and predicts the runs over 3. The prediction for a 10⁹
quanta lattice on 1 000 ranks (weak scaling: 10⁶ quanta a rank) takes c from those runs scaled
by the single-thread bench's ratio of n = 100 to n = 40 (docs/bench/qbond-*.json: a larger
body's arrays leave the caches), and α, β of a cluster's network (ALPHA, BETA below: assumptions,
not measured here). The table sits between `<!-- ranks:model -->` and `<!-- /ranks:model -->` in
docs/distributed.md.
"""
import argparse
import json
import math
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ALPHA = 2e-6  # s a message: an InfiniBand network's MPI latency (assumed)
BETA = 1 / 10e9  # s a byte: 10 GB/s a rank (assumed)
BYTES_A_GHOST = {"velocity_verlet": 72, "coupled_implicit": 48}
START_BYTES_A_GHOST = {"velocity_verlet": 24, "coupled_implicit": 0}
CG_BYTES_A_GHOST = 24
BEGIN, END = "<!-- ranks:model -->", "<!-- /ranks:model -->"


def bisect(lo, hi, parts, first=0):
    """Boxes [lo, hi) of lattice planes per part, as partition.cpp cuts an n³ lattice's points."""
    if parts == 1:
        return {first: (lo, hi)}
    left = parts // 2
    ext = [hi[a] - lo[a] for a in range(3)]
    count = math.prod(ext)
    target = count * left // parts
    axes = sorted(range(3), key=lambda a: -ext[a])  # stable: the lowest axis of equal sides first
    for a in axes:
        if ext[a] < 2:
            continue
        plane = count // ext[a]
        # The cut between planes k − 1 and k nearest the target count (the first of equal ones).
        best = min(range(1, ext[a]), key=lambda k: (abs(k * plane - target), k))
        l_hi = list(hi)
        l_hi[a] = lo[a] + best
        r_lo = list(lo)
        r_lo[a] = lo[a] + best
        boxes = bisect(lo, tuple(l_hi), left, first)
        boxes.update(bisect(tuple(r_lo), hi, parts - left, first + left))
        return boxes
    raise SystemExit("model.py: a box of one point cannot be cut")


def size(box):
    lo, hi = box
    return math.prod(max(0, hi[a] - lo[a]) for a in range(3))


def reached(box, other, n):
    """Points of `other` bonded to a point of `box` and outside it (18 neighbours, in an n³ lattice)."""
    lo, hi = box
    grown = (tuple(max(0, lo[a] - 1) for a in range(3)), tuple(min(n, hi[a] + 1) for a in range(3)))
    inter = tuple(zip(*[(max(grown[0][a], other[0][a]), min(grown[1][a], other[1][a])) for a in range(3)]))
    count = size(inter)
    if count == 0:
        return 0
    # The grown box's corners outside `box` in all three axes: no bond of 18 reaches them.
    for corner in [(x, y, z) for x in (lo[0] - 1, hi[0]) for y in (lo[1] - 1, hi[1]) for z in (lo[2] - 1, hi[2])]:
        if all(inter[0][a] <= corner[a] < inter[1][a] for a in range(3)):
            count -= 1
    return count


def halo(n, parts):
    """Per rank: quanta, ghosts, quanta sent a step (to all neighbours), neighbours."""
    boxes = bisect((0, 0, 0), (n, n, n), parts)
    rows = []
    for r in range(parts):
        ghosts = sum(reached(boxes[r], boxes[s], n) for s in range(parts) if s != r)
        sent = [reached(boxes[s], boxes[r], n) for s in range(parts) if s != r]
        rows.append({"quanta": size(boxes[r]), "ghosts": ghosts, "sent": sum(sent),
                     "neighbours": sum(1 for k in sent if k)})
    return rows


def latest(root, pattern):
    bench = os.path.join(root, "docs", "bench")
    found = sorted((m[1], len(m[2]), m[2], name) for name in os.listdir(bench) if (m := re.match(pattern, name)))
    if not found:
        raise SystemExit(f"model.py: no docs/bench file matching {pattern}")
    name = found[-1][3]
    with open(os.path.join(bench, name)) as f:
        return name, json.load(f)


def n_of(res):
    return int(re.search(r"n=(\d+)", res["workload"]).group(1))


def steps_of(res):
    return int(re.search(r"(\d+) steps", res["workload"]).group(1))


def check_halo(res, integrator):
    """Each measured rank's quanta, ghosts and bytes against the model; the lines of the check."""
    n, steps = n_of(res), steps_of(res)
    lines, bad = [], []
    for row in res["rows"]:
        if "per_rank" not in row or "quanta" not in row["per_rank"][0]:
            continue
        for r, (m, p) in enumerate(zip(halo(n, row["ranks"]), row["per_rank"])):
            bytes_model = (BYTES_A_GHOST[integrator] + START_BYTES_A_GHOST[integrator] / steps) * m["sent"]
            # The run prints its bytes a step rounded to a whole byte.
            ok = (m["quanta"] == p["quanta"] and m["ghosts"] == p["ghosts"]
                  and abs(p["bytes_sent_per_step"] - bytes_model) <= 0.5 + 1e-9)
            lines.append((row["ranks"], r, m, p, bytes_model, ok))
            if not ok:
                bad.append(f"{row['ranks']} ranks, rank {r}: model {m['quanta']} quanta, {m['ghosts']} ghosts, "
                           f"{bytes_model:.1f} bytes; measured {p['quanta']}, {p['ghosts']}, {p['bytes_sent_per_step']:g}")
    if bad:
        raise SystemExit("model.py: the model does not give the measured halo:\n  " + "\n  ".join(bad))
    return lines


def cpu_a_quanta(row):
    """Seconds of CPU a quanta a step over the ranks of a measured row (stepping and ledger)."""
    total = sum(p["stepping_cpu_ms"] + p["ledger_cpu_ms"] for p in row["per_rank"]) * 1e-3
    return total / sum(p["quanta"] for p in row["per_rank"])


def comm(rank, parts, bytes_a_ghost):
    """Seconds a step of one rank's exchange and sums on the assumed network."""
    log_p = math.ceil(math.log2(parts)) if parts > 1 else 0
    return rank["neighbours"] * ALPHA + bytes_a_ghost * rank["sent"] * BETA + log_p * ALPHA + 80 * parts * BETA


def predict(n, parts, c, bytes_a_ghost):
    rows = halo(n, parts) if parts <= 64 else None
    # Beyond 64 ranks, a grid of k³ equal cubes (the bisection's boxes differ a little in shape):
    # the interior rank, with the most neighbours, is the slowest.
    if rows is None:
        k = round(parts ** (1 / 3))
        side = n // k
        rows = [{"quanta": side ** 3, "ghosts": 6 * side ** 2 + 12 * side, "sent": 6 * side ** 2 + 12 * side,
                 "neighbours": 18}]
    worst = max(rows, key=lambda r: c * r["quanta"] + comm(r, parts, bytes_a_ghost))
    compute = c * worst["quanta"]
    talk = comm(worst, parts, bytes_a_ghost)
    return worst, compute, talk


def report(root):
    name, res = latest(root, r"^ranks-(\d{4}-\d\d-\d\d)([a-z]*)\.json$")
    verlet = "velocity_verlet"
    lines = check_halo(res, verlet)
    if not lines:
        raise SystemExit(f"model.py: {name} has no rank's quanta and ghosts (measure with bench/mpi/ranks.py "
                         "--most-ranks 3)")
    rows = {r["ranks"]: r for r in res["rows"] if r["run"] == "ranks" and "per_rank" in r}
    c2 = cpu_a_quanta(rows[2])
    qname, q = latest(root, r"^qbond-(\d{4}-\d\d-\d\d)([a-z]*)\.json$")
    ns = {r["workload"]: r["ns_per_quanta_step"] for r in q["rows"]
          if r["integrator"] == verlet and r["threads"] == 1 and not r.get("as_run")}
    big = ns["lattice n=100"] / ns["lattice n=40"]
    out = [f"Checked against [docs/bench/{name}](bench/{name}) (measured {res['date']}; "
           f"{res['workload']}; load average {res['load_average'][0]:g} before and {res['load_average'][1]:g} after) "
           f"and [docs/bench/{qname}](bench/{qname}): `bench/mpi/model.py`.", "",
           "| ranks | rank | quanta (model, measured) | ghosts (model, measured) | bytes sent a step (model, measured) "
           "| CPU ms a step (model, measured) |", "|---|---|---|---|---|---|"]
    for ranks, r, m, p, b, _ in lines:
        cpu = p["stepping_cpu_ms"] + p["ledger_cpu_ms"]
        out.append(f"| {ranks} | {r} | {m['quanta']}, {p['quanta']} | {m['ghosts']}, {p['ghosts']} | "
                   f"{b:.0f}, {p['bytes_sent_per_step']:.0f} | {1e3 * c2 * m['quanta']:.3g}, {cpu:.3g} |")
    out += ["", f"CPU time a quanta a step, c, from the run over 2 ranks: {1e9 * c2:.0f} ns (velocity Verlet, "
            f"stepping and ledger); at n = 100 the single-thread bench takes {big:.2f}× a quanta's time at n = 40.",
            "", "Predicted on a cluster (α = {:g} µs a message, β = 1/({:g} GB/s) a byte; one thread a rank; the "
            "slowest rank):".format(ALPHA * 1e6, 1 / BETA / 1e9), "",
            "| lattice | ranks | quanta a rank | ghosts | neighbours | compute ms | exchange and sums ms | "
            "step ms | parallel efficiency |", "|---|---|---|---|---|---|---|---|---|"]
    for n, parts, scale in [(40, 2, 1.0), (100, 8, big), (1000, 1000, big)]:
        worst, compute, talk = predict(n, parts, c2 * scale, BYTES_A_GHOST[verlet])
        out.append(f"| {n}³ | {parts} | {worst['quanta']} | {worst['ghosts']} | {worst['neighbours']} | "
                   f"{1e3 * compute:.3g} | {1e3 * talk:.3g} | {1e3 * (compute + talk):.3g} | "
                   f"{compute / (compute + talk):.3f} |")
    return "\n".join(out)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--check", nargs="?", const=ROOT)
    p.add_argument("--write", nargs="?", const=ROOT)
    a = p.parse_args()
    root = a.check or a.write or ROOT
    text = report(root)
    if not (a.check or a.write):
        print(text)
        return
    doc = os.path.join(root, "docs", "distributed.md")
    with open(doc) as f:
        old = f.read()
    if BEGIN not in old or END not in old:
        sys.exit(f"{doc}: no {BEGIN} ... {END}")
    head, rest = old.split(BEGIN, 1)
    new = head + BEGIN + "\n" + text + "\n" + END + rest.split(END, 1)[1]
    if a.check:
        if new != old:
            sys.exit(f"{doc}: the model table is not what the newest results give (bench/mpi/model.py --write)")
        return
    with open(doc, "w") as f:
        f.write(new)


if __name__ == "__main__":
    main()
