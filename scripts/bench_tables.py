#!/usr/bin/python3
"""Renders the measured tables of docs/performance.md, docs/integrators.md, docs/running.md, docs/api.md
and docs/heuristics.md from docs/bench/.

Usage: scripts/bench_tables.py [--check] [ROOT]   (ROOT: the repository, default: this script's parent)

Each table sits between `<!-- bench:KIND ... -->` and `<!-- /bench:KIND -->` in
docs/performance.md, docs/integrators.md or docs/running.md; the opening marker may carry
`machine="..."`, which the provenance line quotes. KIND is one of step, asrun, solve, multigrid,
peers, peers_rounds, peers_accuracy, peers_frequencies, memory, runmemory, fuzz, soak, killresume, ab,
realtime, damping, targets, python (docs/api.md: bench/python_overhead.py's), contact
(docs/heuristics.md: `qbond bench --contact`'s);
each reads the latest docs/bench/PREFIX-DATE[SUFFIX][-N].json of its kind. The script rewrites
the text between the markers; with --check it rewrites nothing and exits 1 when the file differs
from what the results give (a ctest test), so the tables cannot drift from the results.
"""
import json
import math
import os
import re
import sys
from collections import defaultdict

# A result file's name: PREFIX-YYYY-MM-DD, an optional letter suffix (a second run that day), an
# optional -N (a run's number).
NAME = re.compile(r"^(?P<prefix>[a-z]+)-(?P<date>\d{4}-\d\d-\d\d)(?P<suffix>[a-z]*)(?:-(?P<run>\d+))?\.json$")

PREFIX = {"step": "qbond", "asrun": "asrun", "solve": "solve", "multigrid": "multigrid", "peers": "peers",
          "peers_rounds": "peers", "peers_accuracy": "peers",
          "peers_frequencies": "peers", "memory": "memory", "runmemory": "runmemory",
          "fuzz": "fuzz", "soak": "soak", "killresume": "killresume", "ab": "ab", "realtime": "realtime",
          "damping": "damping", "python": "python", "contact": "contact"}
INTEGRATORS = ["velocity_verlet", "hybrid_frozen", "hybrid_sweep", "default"]
# The work below this many quanta runs on one thread whatever -j asks (kParallelMin).
PARALLEL_MIN = 4096


def latest(bench_dir, prefix):
    """The newest result of one kind: by date, then letter suffix, then run number."""
    found = []
    for name in os.listdir(bench_dir):
        m = NAME.match(name)
        if m and m["prefix"] == prefix:
            found.append(((m["date"], len(m["suffix"]), m["suffix"], int(m["run"] or 0)), name))
    if not found:
        raise SystemExit(f"bench_tables: no docs/bench/{prefix}-DATE.json")
    name = max(found)[1]
    with open(os.path.join(bench_dir, name)) as f:
        return name, json.load(f)


def sig(x, digits=3):
    """x to `digits` significant figures, without exponent for the magnitudes these tables hold."""
    if x == 0 or not math.isfinite(x):
        return str(x)
    decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
    return f"{x:.{decimals}f}"


def n_of(row):
    return int(row["workload"].split("n=")[1])


def sizes(rows):
    return sorted({n_of(r) for r in rows})


def date_of(data):
    return data["date"][:10]


def provenance(name, data, machine, command):
    where = f"{machine} ({data['machine']})" if machine else data["machine"]
    # A run at a lower priority (the machine shared) names it: `nice -n N` before the command.
    if data.get("nice", 0) > 0 and not command.startswith("nice"):
        command = f"nice -n {data['nice']} {command}"
    return f"Measured {date_of(data)} on {where} with `{command}`; results: `docs/bench/{name}`."


def bench_command(data, name, extra=""):
    rows = data["rows"]
    ints = []
    for r in rows:
        i = r["integrator"].removesuffix("+run")
        if i not in ints:
            ints.append(i)
    threads = sorted({r["threads"] for r in rows})
    cmd = f"build/qbond bench{extra} -n {','.join(map(str, sizes(rows)))} -j {','.join(map(str, threads))}"
    if sorted(ints) != sorted(INTEGRATORS):
        cmd += " --integrators " + ",".join(ints)
    if data["repetitions"] != 3:
        cmd += f" --repetitions {data['repetitions']}"
    return cmd + f" --json docs/bench/{name}"


def triads(data):
    by = data["triad_bytes_per_second_by_threads"]
    parts = [f"{by[t] / 1e9:.2f} GB/s on {t} thread{'s' if t != '1' else ''}" for t in sorted(by, key=int)]
    return "STREAM triad " + ", ".join(parts)


def slopes(data):
    """Least-squares slope of log(time) against log(bonds), one thread, per integrator."""
    pts = defaultdict(list)
    for r in data["rows"]:
        if r["threads"] == 1:
            pts[r["integrator"].removesuffix("+run")].append((math.log(r["bonds"]), math.log(r["seconds_per_step"])))
    out = {}
    for k, v in pts.items():
        if len(v) < 2:
            continue
        mx = sum(a for a, _ in v) / len(v)
        my = sum(b for _, b in v) / len(v)
        out[k] = sum((a - mx) * (b - my) for a, b in v) / sum((a - mx) ** 2 for a, _ in v)
    return out


def shown(rows):
    """Rows worth a line: not the two-thread rows of worlds that step on one thread anyway."""
    order = {k: i for i, k in enumerate(INTEGRATORS)}
    keep = [r for r in rows if r["threads"] == 1 or r["quanta"] >= PARALLEL_MIN]
    return sorted(keep, key=lambda r: (order.get(r["integrator"].removesuffix("+run"), 9), n_of(r), r["threads"]))


def step_table(name, data, machine, extra=""):
    lines = [provenance(name, data, machine, bench_command(data, name, extra)) + f" {triads(data)}.", "",
             "| n | integrator | threads | ms/step | ns/bond | × bound | vs 1T |", "|---|---|---|---|---|---|---|"]
    for r in shown(data["rows"]):
        s = r["speedup_over_one_thread"]
        vs = f"{s:.2f}" if r["threads"] > 1 and s is not None else ""
        lines.append(f"| {n_of(r)} | {r['integrator']} | {r['threads']} | {sig(r['seconds_per_step'] * 1e3)} | "
                     f"{sig(r['ns_per_bond_step'])} | {r['ratio_to_bandwidth_bound']:.2f} | {vs} |")
    sl = slopes(data)
    if len(sizes(data["rows"])) > 2:
        lines += ["", f"Slopes of time against bonds, n = {sizes(data['rows'])[0]} → {sizes(data['rows'])[-1]} "
                  "(least squares on log–log, one thread): "
                  + ", ".join(f"{k} {v:.2f}" for k, v in sl.items()) + "."]
    return lines


SOLVERS = ["qbond_cg", "qbond_mg", "eigen_cg", "eigen_cholesky", "petsc_gamg", "petsc_boomeramg"]


def solve_table(name, data, machine):
    reps = f" --repetitions {data['repetitions']}" if data["repetitions"] != 3 else ""
    cmd = f"build/qbond bench --solve -n {','.join(map(str, sizes(data['rows'])))}{reps} --json docs/bench/{name}"
    # The timing thread's CPU time, when the results have it (a loaded host: wall time over it).
    has_cpu = all("cpu_seconds" in r for r in data["rows"])
    lines = [provenance(name, data, machine, cmd), "",
             "| n | solver | iterations | ms |" + (" CPU ms |" if has_cpu else "") +
             " set-up ms | CG ms | true relative residual | time / qbond's CG |" +
             (" CPU time / qbond's CG's |" if has_cpu else ""),
             "|---|---|---|---|---|---|---|---|" + ("---|---|" if has_cpu else "")]
    cg_cpu = {n_of(r): r.get("cpu_seconds") for r in data["rows"] if r["solver"] == "qbond_cg"}
    for r in sorted(data["rows"], key=lambda r: (n_of(r), SOLVERS.index(r["solver"]))):
        it = f"{r['iterations']:.0f}" if r["iterations"] else "direct"
        setup = sig(r["setup_seconds"] * 1e3) if "setup_seconds" in r else ""
        cg = sig(r["solve_seconds"] * 1e3) if "solve_seconds" in r else ""
        cpu = f" {sig(r['cpu_seconds'] * 1e3)} |" if has_cpu else ""
        lines.append(f"| {n_of(r)} | {r['solver']} | {it} | {sig(r['seconds'] * 1e3)} |{cpu} {setup} | {cg} | "
                     f"{r['relative_residual']:.1e} | {sig(r['ratio_to_qbond_cg'])} |" +
                     (f" {sig(r['cpu_seconds'] / cg_cpu[n_of(r)])} |" if has_cpu else ""))
    return lines


def multigrid_table(name, data, machine):
    """docs/integrators.md's: block-Jacobi and multigrid CG side by side, from the solve results."""
    # A run of the two CG rows alone (the benchmark binary filtered) records its command.
    cmd = data.get("command") or f"build/qbond bench --solve -n {','.join(map(str, sizes(data['rows'])))} --json docs/bench/{name}"
    # With the timing thread's CPU times (a shared host: wall time also counts the other tenants'
    # time slices), the times and ratios are those; otherwise wall times.
    cpu = all("cpu_seconds" in r for r in data["rows"]) and \
        all("setup_cpu_seconds" in r for r in data["rows"] if r["solver"] == "qbond_mg")
    unit = "CPU ms" if cpu else "ms"
    lines = [provenance(name, data, machine, cmd), "",
             f"| n | quanta | block Jacobi: iterations | {unit} | multigrid: iterations | levels | set-up {unit} | "
             f"CG {unit} | true residual | multigrid CG / block-Jacobi time | set-up / block-Jacobi time |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    by = defaultdict(dict)
    for r in data["rows"]:
        by[n_of(r)][r["solver"]] = r
    for n in sorted(by):
        bj, mg = by[n].get("qbond_cg"), by[n].get("qbond_mg")
        if not bj or not mg:
            continue
        t_bj = bj["cpu_seconds"] if cpu else bj["seconds"]
        t_setup = mg["setup_cpu_seconds"] if cpu else mg["setup_seconds"]
        t_cg = mg["solve_cpu_seconds"] if cpu else mg["solve_seconds"]
        lines.append(f"| {n} | {mg['quanta']} | {bj['iterations']:.0f} | {sig(t_bj * 1e3)} | "
                     f"{mg['iterations']:.0f} | {mg['levels']} | {sig(t_setup * 1e3)} | "
                     f"{sig(t_cg * 1e3)} | {mg['relative_residual']:.1e} | "
                     f"{sig(t_cg / t_bj)} | {sig(t_setup / t_bj)} |")
    return lines


def peers_command(name, data):
    if "command" in data:
        return "`; then `".join([data["command"]] + [x["command"] for x in data.get("appended", [])])
    return f"bench/peers/run --n {','.join(str(p['n']) for p in data['per_step'])} --json docs/bench/{name}"


def peers_load(data):
    """The host's load during a peers run, when it recorded it."""
    if "load_average" not in data:
        return ""
    return (f" Host load average {data['load_average'][0]:.1f} at the start, {data['load_average'][1]:.1f} at the end "
            "(runnable processes on the machine's cores): single timings move with it, read the rounds' ratios.")


def peers_table(name, data, machine):
    lines = [provenance(name, data, machine, peers_command(name, data)) + peers_load(data), "",
             "| n | bonds | LAMMPS | Bullet | qbond velocity_verlet | qbond hybrid_frozen | qbond hybrid_sweep "
             "| qbond default |", "|---|---|---|---|---|---|---|---|"]
    keys = ["lammps", "bullet", "qbond_velocity_verlet", "qbond_hybrid_frozen", "qbond_hybrid_sweep", "qbond_default"]
    for p in data["per_step"]:
        cells = " | ".join(sig(p[k] / p["bonds"] * 1e9) for k in keys)
        lines.append(f"| {p['n']} | {p['bonds']} | {cells} |")
    return lines


def ab_table(name, data, machine):
    """bench/ab.py's interleaved rounds: each step row's medians and the median of the rounds' ratios."""
    lines = [provenance(name, data, machine, data["command"]) +
             f" Base: {data['base']}; new: {data['new']}; {data['rounds']} interleaved rounds.", "",
             "| integrator | n | threads | base ms (median) | new ms (median) | new / base (median of rounds) | within 3% |",
             "|---|---|---|---|---|---|---|"]
    worst = 0.0
    for r in data["rows"]:
        parts = r["name"].split("/")
        if parts[0] != "step":
            continue
        ratio = median([y / x for x, y in zip(r["base"], r["new"])])
        worst = max(worst, ratio)
        lines.append(f"| {parts[1]} | {parts[2].removeprefix('n:')} | {parts[3].removeprefix('threads:')} | "
                     f"{sig(median(r['base']))} | {sig(median(r['new']))} | {ratio:.3f} | "
                     f"{'yes' if ratio <= 1.03 else 'no'} |")
    lines += ["", f"Largest ratio: {worst:.3f}."]
    return lines


def median(xs):
    xs = sorted(xs)
    m = len(xs) // 2
    return xs[m] if len(xs) % 2 else (xs[m - 1] + xs[m]) / 2


def peers_rounds(name, data, machine):
    rounds = max(len(p["verlet_against_lammps"]) for p in data["per_step"])
    head = "| n | " + " | ".join(f"round {i + 1}" for i in range(rounds)) + " | median |"
    lines = [provenance(name, data, machine, peers_command(name, data)) + peers_load(data), "", head,
             "|---" * (rounds + 2) + "|"]
    for p in data["per_step"]:
        cells = []
        for r in p["verlet_against_lammps"]:
            q, l = r["qbond_velocity_verlet"], r["lammps"]
            cells.append(f"{q / l:.2f} ({sig(q / p['bonds'] * 1e9)} / {sig(l / p['bonds'] * 1e9)})")
        med = median([r["qbond_velocity_verlet"] / r["lammps"] for r in p["verlet_against_lammps"]])
        lines.append(f"| {p['n']} | " + " | ".join(cells) + f" | **{med:.2f}** |")
    return lines


def peers_accuracy(name, data, machine):
    """Each method's largest step meeting each accuracy criterion and its cost per simulated second there."""
    note = ""
    if "load_average" in data:
        note += (f" Host load average {data['load_average'][0]:.1f} at the start, {data['load_average'][1]:.1f} at "
                 "the end (runnable processes on the machine's cores; the searches ran two at a time).")
    for x in data.get("appended", []):
        if "accuracy_n" in x:
            where = f" on {x['machine']}" if "machine" in x else ""
            note += (f" The searches of n = {', '.join(map(str, x['accuracy_n']))} were run {x['date'][:10]}{where} "
                     f"at nice {x['nice']}, host load average {x['load_average'][0]:.1f} at the start, "
                     f"{x['load_average'][1]:.1f} at the end" +
                     ("." if x.get("finished", True) else "; that run was cut short: these are the searches it finished."))
    if not data.get("finished", True):
        note += " The run was cut short: these are the searches it finished."
    lines = [provenance(name, data, machine, peers_command(name, data)) + note, "",
             "| n | criterion | method | damping | largest step meeting it [s] | error there | s per step | "
             "s per simulated second | × qbond's best |", "|---|---|---|---|---|---|---|---|---|"]
    for acc in data["accuracy"]:
        for crit in ("dynamic", "settled"):
            rows = [r for r in acc["rows"] if r["criterion"] == crit]
            costs = [r["seconds_per_simulated_second"] for r in rows
                     if r["step"] is not None and r["method"].startswith("qbond")]
            best = min(costs) if costs else None
            for r in sorted(rows, key=lambda r: (r["step"] is None, r["seconds_per_simulated_second"] or 0)):
                if r["step"] is None:
                    never = (f"never at h > {r['over_cap_below']:.2g}; a smaller step's run takes over the "
                             f"cap of {acc['cap_seconds']:g} CPU seconds" if r.get("over_cap_below")
                             else f"never at h ≥ {min(t['h'] for t in r['tried']):.0e}")
                    lines.append(f"| {acc['n']} | {crit} | {r['method']} | {r['damping']} | {never} | – | – | – | – |")
                    continue
                c = r["seconds_per_simulated_second"]
                lines.append(f"| {acc['n']} | {crit} | {r['method']} | {r['damping']} | {r['step']:.3g} | "
                             f"{r['error']:.2g} | {r['seconds_per_step']:.3g} | {c:.3g} | "
                             f"{sig(c / best) if best else '–'} |")
    return lines


# The accuracy searches' explicit qbond methods: velocity Verlet with and without the energy ledger.
EXPLICIT = ("qbond velocity_verlet", "qbond velocity_verlet_no_ledger")


def implicit(method):
    """Whether an accuracy search's method is one of qbond's implicit integrators."""
    return method.startswith("qbond") and method not in EXPLICIT


def accuracy_finished(data, n):
    """Whether the accuracy searches of the n^3 lattice in a peers result all finished."""
    runs = [x for x in data.get("appended", []) if n in x.get("accuracy_n", [])]
    return runs[-1].get("finished", True) if runs else data.get("finished", True)


def peers_frequencies(name, data, machine):
    """The lattices' lowest and highest natural frequencies beside the steps the criteria allowed."""
    lines = [provenance(name, data, machine, peers_command(name, data)), "",
             "| n | ω₁ [rad/s] | ω_max [rad/s] | ω_max / ω₁ | explicit limit 2/ω_max [s] | "
             "reference step [s] (Richardson error; the same at twice the step) | static sag [mm] | dynamic: velocity Verlet's step [s] | "
             "dynamic: best implicit step [s] (integrator, ω₁h) | its cost / velocity Verlet's |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for acc in data["accuracy"]:
        sag = math.dist(acc["static"], acc["start"]) * 1e3
        ref = acc["reference"]
        tried = {r["method"] for r in acc["rows"] if r["criterion"] == "dynamic"}
        dyn = {r["method"]: r for r in acc["rows"] if r["criterion"] == "dynamic" and r["step"] is not None}
        vv = dyn.get("qbond velocity_verlet")
        imp = [r for m, r in dyn.items() if implicit(m)]
        im = max(imp, key=lambda r: r["step"]) if imp else None
        vv_text = f"{vv['step']:.3g}" if vv else "never" if "qbond velocity_verlet" in tried else "not measured"
        implicit_tried = any(implicit(m) for m in tried)
        im_text = (f"{im['step']:.3g} ({im['method'].removeprefix('qbond ')}, {acc['omega1'] * im['step']:.2g})"
                   if im else "never" if implicit_tried else "not measured")
        ratio = (sig(im["seconds_per_simulated_second"] / vv["seconds_per_simulated_second"])
                 if im and vv else "–")
        # The halving that chose the reference's step: the estimate at twice the step beside it
        # (a fall of 4x a halving is velocity Verlet's second order, which the estimate relies on).
        halving = ref.get("halving", [])
        before = f"; at {halving[-2]['h']:.3g}: {halving[-2]['richardson_error']:.1e}" if len(halving) > 1 else ""
        lines.append(f"| {acc['n']} | {sig(acc['omega1'])} | {sig(acc['omega_max'])} | "
                     f"{sig(acc['omega_max'] / acc['omega1'])} | {2 / acc['omega_max']:.3g} | "
                     f"{ref['h']:.3g} ({ref['richardson_error']:.1e}{before}) | {sig(sag)} | {vv_text} | {im_text} | {ratio} |")
    return lines


def memory_table(name, data, machine):
    lines = [provenance(name, data, machine, data["command"]), "",
             "| integrator | peak resident memory [KiB] | [GB] |", "|---|---|---|"]
    for r in data["rows"]:
        lines.append(f"| {r['integrator']} | {r['max_rss_kib']} | {r['max_rss_kib'] * 1024 / 1e9:.2f} |")
    return lines


def runmemory_table(name, data, machine):
    lines = [provenance(name, data, machine, data["command"]), "",
             "| n | neighbours | integrator | heuristics | quanta | bonds | peak resident [GB] | estimate |",
             "|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        lines.append(f"| {r['n']} | {r['neighbors']} | {r['integrator']} | {r.get('heuristics', 'none')} | "
                     f"{r['quanta']} | {r['bonds']} | "
                     f"{r['max_rss_kib'] * 1024 / 1e9:.3g} | {r['estimate']} |")
    return lines


def fuzz_table(name, data, machine):
    lines = [provenance(name, data, machine, data["command"]), "",
             "| target | inputs run | seconds | peak resident [MB] | result |", "|---|---|---|---|---|"]
    for r in data["rows"]:
        lines.append(f"| {r['target']} | {r['runs']} | {r['seconds'] if r['seconds'] is not None else '–'} | {r['peak_rss_mb']} | {r['result']} |")
    return lines


def python_table(name, data, machine):
    """What stepping from Python adds to the C++ step (bench/python_overhead.py)."""
    rows = {r["config"]: r for r in data["rows"]}
    over = rows["Python"]["percent_over_cpp"]
    lines = [provenance(name, data, machine, data["command"]) +
             f" Canonical lattice n = {data['n']} ({data['quanta']} quanta), default integrator, one thread; "
             f"per configuration the median of {data['steps']} steps, then of {data['rounds']} interleaved rounds.",
             "",
             "| stepped | ms per step | rounds [ms] | over the C++ step | per quanta |", "|---|---|---|---|---|"]
    for r in data["rows"]:
        spread = f"{min(r['rounds_ms']):.3f}–{max(r['rounds_ms']):.3f}"
        if r["config"] == "C++":
            lines.append(f"| C++ (qbond_step_times) | {r['ms_per_step']:.3f} | {spread} | – | – |")
            continue
        percent, per = r["percent_over_cpp"], r["ns_per_quanta_over_cpp"]
        lines.append(f"| {r['config']} | {r['ms_per_step']:.3f} | {spread} | {percent:+.2f} % | {per:+.1f} ns |")
    # A negative difference is the host's noise (the rounds' spread shows its size), not a gain.
    lines += ["", f"Stepping from Python costs {over:+.2f} % over the C++ step: "
              f"{'within' if over <= 2 else 'beyond'} the target of at most 2 % more."]
    return lines


def killresume_table(name, data, machine):
    """scripts/soak's kill/resume loop: a run killed and resumed against the uninterrupted run."""
    k = data["kill_resume"]
    same = ", ".join(f"{what} ({size})" for what, size in k.get("identical", {}).items())
    return [provenance(name, data, machine, data["command"]), "",
            "| steps | uninterrupted [s] | SIGKILLs | resumes | byte for byte against the uninterrupted run | result |",
            "|---|---|---|---|---|---|",
            f"| {k['steps']} | {k.get('uninterrupted_seconds', '–')} | {k.get('killed', 0)} (seed {k['seed']}) | "
            f"{k.get('resumed', 0)} | {same or '–'} | {'; '.join(k['failures']) or 'identical'} |"]


def soak_table(name, data, machine):
    """scripts/soak's long run: steps, speed, bond events and the resident memory's trend."""
    s = data["soak"]
    mib = lambda kib: f"{kib / 1024:.1f}"
    lines = [provenance(name, data, machine, data["command"]), "",
             "| steps (asked) | status | wall [s] | steps/s | bonds broken or formed | memory samples | "
             "resident, second half's mean / peak [MiB] | growth over the second half [KiB] | bound [KiB] | result |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    if "rss_peak_kib" in s:
        memory = (f"{mib(s['rss_second_half_mean_kib'])} / {mib(s['rss_peak_kib'])} | {s['rss_second_half_growth_kib']} | "
                  f"{s['rss_flat_bound_kib']}")
    else:
        memory = "– | – | –"
    lines.append(f"| {s['steps']} ({s['steps_asked']}) | {s['status']} | {s['seconds']} | {s['steps_per_second']} | "
                 f"{s['bond_events']} | {s['samples']} | {memory} | "
                 f"{'; '.join(s['failures']) or 'no sanitizer report, memory flat'} |")
    return lines


def targets(bench_dir, machines):
    sname, step = latest(bench_dir, "qbond")
    vname, solve = latest(bench_dir, "solve")
    pname, peers = latest(bench_dir, "peers")
    mname, mem = latest(bench_dir, "memory")
    rows = []

    frozen = [r for r in step["rows"] if r["integrator"] == "hybrid_frozen" and n_of(r) == 40 and r["threads"] == 1]
    x = frozen[0]["ratio_to_bandwidth_bound"]
    rows.append(("hybrid_frozen, n = 40, one thread: ≤ 2× the bandwidth bound", f"{x:.2f}×", x <= 2, sname))

    by = defaultdict(dict)
    for r in solve["rows"]:
        by[n_of(r)][r["solver"]] = r["ratio_to_qbond_cg"]
    cg = " / ".join(f"{by[n]['eigen_cg']:.2f}×" for n in sorted(by))
    ch = " / ".join(f"{by[n]['eigen_cholesky']:.0f}×" for n in sorted(by) if "eigen_cholesky" in by[n])
    chn = " / ".join(str(n) for n in sorted(by) if "eigen_cholesky" in by[n])
    ok = all(v > 1 for d in by.values() for k, v in d.items() if k.startswith("eigen"))
    rows.append(("default solve at h = 1/60 s faster than Eigen's CG and sparse Cholesky (residual 1e-6)",
                 f"Eigen's CG takes {cg} qbond's time at n = {' / '.join(map(str, sorted(by)))}; "
                 f"Cholesky {ch} at n = {chn}", ok, vname))

    mg = {n_of(r): r for r in solve["rows"] if r["solver"] == "qbond_mg"}
    if mg:
        ns = sorted(mg)
        its = [mg[n]["iterations"] for n in ns]
        growth = its[-1] / its[0]
        rows.append(("multigrid CG at h = 1/60 s to a relative residual of 1e-6: ≤ 25 iterations, growing at most "
                     "1.5× from n = 10 to n = 60",
                     ", ".join(f"{i:.0f}" for i in its) + f" at n = {' / '.join(map(str, ns))} ({growth:.2f}×)",
                     (ns[0] == 10 and max(its) <= 25 and growth <= 1.5) if ns[-1] >= 60 else "not measured at n = 60",
                     vname))
    at40 = {r["solver"]: r for r in solve["rows"] if n_of(r) == 40}
    if "qbond_mg" in at40 and "qbond_cg" in at40:
        m, c = at40["qbond_mg"], at40["qbond_cg"]
        rows.append(("time to the solution at n = 40 (set-up included): multigrid ≥ 10× faster than block-Jacobi CG",
                     f"{c['seconds'] / m['seconds']:.2f}× (set-up {sig(m['setup_seconds'] * 1e3)} ms, "
                     f"CG {sig(m['solve_seconds'] * 1e3)} ms; block Jacobi {sig(c['seconds'] * 1e3)} ms)",
                     c["seconds"] / m["seconds"] >= 10, vname))
        rows.append(("n = 40: multigrid's set-up cheaper than one block-Jacobi solve",
                     f"{sig(m['setup_seconds'] * 1e3)} ms against {sig(c['seconds'] * 1e3)} ms",
                     m["setup_seconds"] < c["seconds"], vname))
        if "petsc_gamg" in at40:
            g = at40["petsc_gamg"]
            rows.append(("n = 40: multigrid's CG ≥ 3× faster than PETSc GAMG's solve phase",
                         f"{g['solve_seconds'] / m['solve_seconds']:.2f}×", g["solve_seconds"] / m["solve_seconds"] >= 3,
                         vname))

    sp = [(r["integrator"], n_of(r), r["speedup_over_one_thread"]) for r in step["rows"]
          if r["threads"] == 2 and r["quanta"] >= PARALLEL_MIN and r["integrator"] != "hybrid_sweep"]
    met = sum(s >= 1.7 for _, _, s in sp)
    text = "; ".join(f"{i} " + ", ".join(f"{s:.2f}" for j, _, s in sp if j == i)
                     for i in ["velocity_verlet", "hybrid_frozen", "default"])
    rows.append(("two threads ≥ 1.7× one thread, n ≥ 20, same bits",
                 f"{text} (n = {', '.join(str(n) for n in sorted({n for _, n, _ in sp}))})",
                 "yes" if met == len(sp) else f"{met} of {len(sp)} rows", sname))

    meds = [median([r["qbond_velocity_verlet"] / r["lammps"] for r in p["verlet_against_lammps"]])
            for p in peers["per_step"]]
    rows.append(("velocity_verlet's step faster than LAMMPS's",
                 "qbond / LAMMPS " + " / ".join(f"{m:.2f}" for m in meds)
                 + f" at n = {' / '.join(str(p['n']) for p in peers['per_step'])} (medians of alternating rounds)",
                 all(m < 1 for m in meds), pname))

    # The largest lattice whose searches all finished: a run cut short lacks methods, and "qbond's
    # best" must be over all of them.
    acc = max((a for a in peers["accuracy"] if accuracy_finished(peers, a["n"])), key=lambda a: a["n"])
    n = acc["n"]

    def cost(crit, pick):
        rows = [r for r in acc["rows"] if r["criterion"] == crit and pick(r["method"]) and r["step"] is not None]
        return min(rows, key=lambda r: r["seconds_per_simulated_second"]) if rows else None

    def versus(q, peer):
        row = cost(crit, lambda m: m.startswith(peer))
        if row is None and not any(r["criterion"] == crit and r["method"].startswith(peer) for r in acc["rows"]):
            return f"{peer} not measured", math.nan
        if row is None:
            return f"{peer} never meets it", math.inf
        x = row["seconds_per_simulated_second"] / q["seconds_per_simulated_second"]
        return f"{peer} costs {sig(x)}× as much", x

    for crit, need, why in (("settled", 10, "≥ 10× cheaper than LAMMPS and Bullet"),
                            ("dynamic", 1, "cheaper than LAMMPS")):
        q = cost(crit, lambda m: m.startswith("qbond"))
        if q is None:
            rows.append((f"{crit} criterion, n = {n}: qbond's best method {why}", "qbond never meets it", False, pname))
            continue
        peers_text = [versus(q, p) for p in (("LAMMPS", "Bullet") if crit == "settled" else ("LAMMPS",))]
        rows.append((f"{crit} criterion, n = {n}: a simulated second with qbond's best method {why}",
                     f"{q['method'].removeprefix('qbond ')} at h = {q['step']:.3g} s: " +
                     ", ".join(t for t, _ in peers_text), all(x >= need for _, x in peers_text), pname))
    vv = cost("dynamic", lambda m: m == "qbond velocity_verlet")
    im = cost("dynamic", implicit)
    if vv and im:
        rows.append((f"dynamic criterion, n = {n}: an implicit qbond integrator cheaper than qbond's velocity Verlet",
                     f"{im['method'].removeprefix('qbond ')} {sig(im['seconds_per_simulated_second'])} s, velocity Verlet "
                     f"{sig(vv['seconds_per_simulated_second'])} s per simulated second",
                     im["seconds_per_simulated_second"] < vv["seconds_per_simulated_second"], pname))

    sl = slopes(step)
    three = ["velocity_verlet", "hybrid_frozen", "default"]
    rows.append((f"cost linear in bonds, n = {sizes(step['rows'])[0]} → {sizes(step['rows'])[-1]}: slope 1.0 ± 0.1",
                 ", ".join(f"{k} {sl[k]:.2f}" for k in three), all(abs(sl[k] - 1) <= 0.1 for k in three), sname))

    rname, realtime = latest(bench_dir, "realtime")
    frames = realtime_targets(realtime)
    if frames:
        rows.append(("canonical lattice at h = 1/60 s, tolerance 1e-4, 2 threads, settling then pulled: n = 20 at "
                     "≥ 60 frames a second, n = 40 at ≥ 30",
                     ", ".join(f"n = {n}: {sig(1 / t)}" for n, _, t in frames) + " frames a second (mean frame)",
                     len(frames) == 2 and all(1 / t >= rate for _, rate, t in frames), rname))

    peak = max(r["max_rss_kib"] for r in mem["rows"]) * 1024 / 1e9
    ints = ", ".join(r["integrator"] for r in mem["rows"])
    rows.append(("n = 100 under 2 GB resident", f"at most {peak:.2f} GB ({ints})", peak < 2, mname))

    lines = ["| target | measured | met? | results |", "|---|---|---|---|"]
    for t, m, ok, f in rows:
        okt = ok if isinstance(ok, str) else ("yes" if ok else "no")
        lines.append(f"| {t} | {m} | {okt} | `{f}` |")
    return lines


def realtime_targets(data):
    """The real-time targets as (n, frames a second asked, mean frame seconds) for the canonical
    lattice rows at tolerance 1e-4 on 2 threads that a `--realtime` file holds: the mean frame is
    the run's throughput (files without it give the median)."""
    out = []
    for n, rate in ((20, 60), (40, 30)):
        row = [r for r in data["rows"] if r["workload"] == f"lattice n={n} tol=1e-4" and r["threads"] == 2]
        seconds = row[0].get("mean_frame_seconds", row[0]["median_frame_seconds"]) if row else None
        if seconds is not None:
            out.append((n, rate, seconds))
    return out


def realtime_table(name, data, machine):
    """`qbond bench --realtime`: a 1/60 s frame's wall time per workload and thread count, and the
    viewer's own real-time factor where bench/viewer_realtime.py measured it."""
    viewer = data.get("viewer")
    viewer_note = ""
    if viewer:
        viewer_note = (f" The viewer's column: `{viewer['command']}`, {viewer['date'][:10]}, {viewer['frames']} headless "
                       f"frames of 1/60 s a scene with its panel (Xvfb, {viewer['gl_renderer']}), "
                       f"{viewer['threads']} threads" + (f", at nice {viewer['nice']}" if viewer.get("nice") else "") +
                       f", host load average {viewer['load_average'][0]:.1f} at the start, "
                       f"{viewer['load_average'][1]:.1f} at the end: simulated over wall seconds, drawing included.")
    lines = [provenance(name, data, machine, data["command"]) +
             f" Median and mean of up to {data['max_frames']} frames after {data['warmup_frames']} warm-up frames, "
             f"at most {data['budget_seconds']:g} s measured a row." +
             (f" The canonical lattice runs {data['lattice_frames']} frames: it settles under gravity, then from "
              f"frame {data['lattice_settle_frames']} its free face is pulled up by {data['lattice_pull_weights']:g} "
              "times the body's weight; its rows named tol=1e-4 stop CG at a relative residual of 1e-4 instead of "
              "the default 1e-6." if "lattice_frames" in data else "") +
             (f" Host load average {data['load_average'][0]:.1f} at the start, {data['load_average'][1]:.1f} at the end "
              "(runnable processes; the machine's cores are in its name): wall time over CPU time shows what the "
              "other work took." if "load_average" in data else "") +
             (" Before each row the bench times a fixed arithmetic loop on each core: a row on one thread runs "
              "on the fastest, and a row whose slowest core ran below 0.9 of the fastest (a shared host's "
              "neighbours) says so." if any("core_speeds" in r for r in data["rows"]) else "") + viewer_note, "",
             "| workload | quanta | bonds | integrator | h [s] | steps a frame | threads | frame ms (median) | "
             "frame ms (mean) | CPU ms a frame | × real time | keeps up with 60 Hz |" +
             (" viewer × real time |" if viewer else "") + " note |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|" + ("---|" if viewer else "") + "---|"]
    for r in data["rows"]:
        note = []
        if r["failure"]:
            note.append("blew up: " + r["failure"])
        if r.get("warmup_only"):
            note.append("cut off by the budget: one warm-up frame measured")
        elif r["cut_off"]:
            note.append(f"cut off by the budget after {r['frames']} frame{'s' if r['frames'] != 1 else ''}")
        if r["adaptive"]:
            note.append("adaptive steps")
        if r["kind"] == "scene" and r["quanta"] > 10000:
            note.append("over 10 000 quanta")
        speeds = r.get("core_speeds", {}).get("speed") or [1]
        if min(speeds) < 0.9:
            note.append(f"slowest core at {min(speeds):.2f} of the fastest")
        frame = sig(r["median_frame_seconds"] * 1e3) if r["median_frame_seconds"] is not None else "–"
        mean = sig(r["mean_frame_seconds"] * 1e3) if r.get("mean_frame_seconds") is not None else "–"
        factor = sig(r["real_time_factor"]) if r["real_time_factor"] is not None else "–"
        cpu = sig(r["median_frame_cpu_seconds"] * 1e3) if r["median_frame_cpu_seconds"] is not None else "–"
        seen = ""
        if viewer:
            v = r.get("viewer")
            seen = (" " + sig(v["real_time_factor"]) + (" (blew up)" if v["blowup"] else "") if v else " –") + " |"
        lines.append(f"| {r['workload']} | {r['quanta']} | {r['bonds']} | {r['integrator']} | {r['timestep']:.3g} | "
                     f"{r['steps_per_frame']} | {r['threads']} | {frame} | {mean} | {cpu} | {factor} | "
                     f"{'yes' if r['keeps_up'] else 'no'} |{seen} {'; '.join(note)} |")
    keep = [r for r in data["rows"] if r["kind"] == "scene" and r["quanta"] <= 10000 and r["threads"] == 2]
    ok = sum(r["keeps_up"] for r in keep)
    one = [r for r in data["rows"] if r["kind"] == "scene" and r["quanta"] <= 10000 and r["threads"] == 1]
    cpu_ok = sum(r["median_frame_cpu_seconds"] is not None and r["median_frame_cpu_seconds"] <= data["frame_seconds"]
                 for r in one)
    targets = [f"n = {n}: {sig(seconds * 1e3)} ms a frame on average, {sig(1 / seconds)} frames a second "
               f"({'at least' if 1 / seconds >= rate else 'below'} the {rate} a second the real-time target asks for)"
               for n, rate, seconds in realtime_targets(data)]
    if targets:
        lines += ["", "The canonical lattice at tolerance 1e-4 on 2 threads, over its whole run: " +
                  "; ".join(targets) + "."]
    lines += ["", f"Scenes of at most 10 000 quanta keeping up with 60 Hz on 2 threads: {ok} of {len(keep)}; "
              f"whose frame's CPU time on one thread is within 1/60 s: {cpu_ok} of {len(one)}."]
    seen = [r["viewer"]["real_time_factor"] for r in keep if r.get("viewer")]
    if seen:
        lines[-1] += f" In the viewer, drawing included: {sum(f >= 1 for f in seen)} of {len(seen)}."
    return lines


def damping_table(name, data, machine):
    """The first modes' numerical damping by integrator and step, beside backward Euler's."""
    lines = [provenance(name, data, machine, data["command"]) +
             f" Structure: {data['structure']}; each mode started alone at rest, "
             f"{data['amplitude']:g} m at most, run {data['periods']:g} of its periods (at least one step).", "",
             "| integrator | h [s] | mode | ω [rad/s] | ωh | steps | measured \\|λ\\| | backward Euler \\|λ\\| | "
             "measured ζ | backward Euler ζ |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        if r["stable"]:
            amp, zeta = f"{r['amplification']:.6f}", f"{r['damping_ratio']:.3g}"
        else:
            amp, zeta = "unstable", "–"
        lines.append(f"| {r['integrator']} | {r['h']:.3g} | {r['mode']} | {sig(r['omega'])} | {sig(r['omega_h'])} | "
                     f"{r['steps']} | {amp} | {r['backward_euler_amplification']:.6f} | {zeta} | "
                     f"{r['backward_euler_damping_ratio']:.3g} |")
    lines += ["", "The method on a single spring (two 1 g quanta, k = 1000 N/m, the default integrator), where "
              "backward Euler's value is exact:", "",
              "| h [s] | ωh | measured \\|λ\\| | backward Euler \\|λ\\| | relative difference |", "|---|---|---|---|---|"]
    for r in data["single_spring"]:
        a, b = r["amplification"], r["backward_euler_amplification"]
        lines.append(f"| {r['h']:.3g} | {sig(r['omega_h'])} | {a:.9f} | {b:.9f} | {abs(a - b) / b:.1e} |")
    return lines


def contact_table(name, data, machine):
    """`qbond bench --contact`: a step with contact inside the implicit step, by projection and without."""
    lines = [provenance(name, data, machine, data["command"]) +
             f" One thread; each scene stepped {data['warmup_seconds']:g} s of simulated time first, then "
             f"{data['rounds']} interleaved rounds of {data['steps']} steps a variant; a variant's time is the "
             "median of its steps, a ratio the median of the rounds' ratios.", "",
             "| scene | quanta | bonds | h [s] | implicit ms | projection ms | no contact ms | implicit / no contact | "
             "implicit / projection | note |", "|---|---|---|---|---|---|---|---|---|---|"]

    def ms(v):
        return sig(v["median_ms"]) if v["median_ms"] is not None else "–"

    def ratio(x):
        return f"{x:.2f}" if x is not None else "–"

    for r in data["rows"]:
        note = "; ".join(f"{v} blew up: {r[v]['failure']}" for v in ("implicit", "projection", "none") if r[v]["failure"])
        lines.append(f"| {r['scene']} | {r['quanta']} | {r['bonds']} | {r['timestep']:.3g} | {ms(r['implicit'])} | "
                     f"{ms(r['projection'])} | {ms(r['none'])} | {ratio(r['implicit_over_none'])} | "
                     f"{ratio(r['implicit_over_projection'])} | {note} |")
    mesh = [r for r in data["rows"] if r["scene"] == "mesh_drop" and r["implicit_over_none"] is not None]
    if mesh:
        extra = mesh[0]["implicit_over_none"] - 1
        cost = f"adds {extra:.0%} to" if extra >= 0 else f"costs {-extra:.0%} less than"
        lines += ["", f"mesh_drop at h = {mesh[0]['timestep']:.3g} s: a step with contact inside it {cost} its step "
                  f"without contact ({'within' if extra <= 0.3 else 'beyond'} the target of at most 30 %)."]
    return lines


def render(kind, machine, bench_dir):
    if kind == "targets":
        return targets(bench_dir, machine)
    name, data = latest(bench_dir, PREFIX[kind])
    return {"step": lambda: step_table(name, data, machine),
            "asrun": lambda: step_table(name, data, machine, " --as-run"),
            "solve": lambda: solve_table(name, data, machine),
            "multigrid": lambda: multigrid_table(name, data, machine),
            "peers": lambda: peers_table(name, data, machine),
            "peers_rounds": lambda: peers_rounds(name, data, machine),
            "peers_accuracy": lambda: peers_accuracy(name, data, machine),
            "peers_frequencies": lambda: peers_frequencies(name, data, machine),
            "memory": lambda: memory_table(name, data, machine),
            "runmemory": lambda: runmemory_table(name, data, machine),
            "fuzz": lambda: fuzz_table(name, data, machine),
            "soak": lambda: soak_table(name, data, machine),
            "killresume": lambda: killresume_table(name, data, machine),
            "ab": lambda: ab_table(name, data, machine),
            "realtime": lambda: realtime_table(name, data, machine),
            "damping": lambda: damping_table(name, data, machine),
            "python": lambda: python_table(name, data, machine),
            "contact": lambda: contact_table(name, data, machine)}[kind]()


BLOCK = re.compile(r"(<!-- bench:(?P<kind>\w+)(?P<attrs>[^>]*)-->\n)(?P<body>.*?)(<!-- /bench:(?P=kind) -->)", re.S)


def main(argv):
    check = "--check" in argv
    args = [a for a in argv if a != "--check"]
    root = args[0] if args else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    bench_dir = os.path.join(root, "docs", "bench")

    def fill(m):
        attr = re.search(r'machine="([^"]*)"', m["attrs"])
        body = "\n".join(render(m["kind"], attr[1] if attr else "", bench_dir)) + "\n"
        return m.group(1) + body + m.group(5)

    total, stale = 0, []
    for page in ("performance.md", "integrators.md", "running.md", "api.md", "heuristics.md"):
        doc = os.path.join(root, "docs", page)
        with open(doc) as f:
            text = f.read()
        new, count = BLOCK.subn(fill, text)
        total += count
        if new == text:
            continue
        if check:
            stale.append(page)
        else:
            with open(doc, "w") as f:
                f.write(new)
    if total == 0:
        print("bench_tables: the docs have no <!-- bench:KIND --> blocks", file=sys.stderr)
        return 1
    if check:
        if stale:
            print(f"bench_tables: {', '.join('docs/' + p for p in stale)} differ from docs/bench/*.json; "
                  "run /usr/bin/python3 scripts/bench_tables.py", file=sys.stderr)
            return 1
        print(f"bench_tables: {total} tables match docs/bench/")
        return 0
    print(f"bench_tables: {total} tables written")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
