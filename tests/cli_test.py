#!/usr/bin/python3
"""End-to-end tests of the `qbond` program: what a user types, what lands on disk.

Usage: cli_test.py QBOND_EXE SOURCE_DIR WORK_DIR TEST
Run with Debian's /usr/bin/python3 (ctest does); TEST is one of the functions named test_*.
"""
import csv
import json
import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

QBOND, SOURCE, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
BAD_SCENES = os.path.join(SOURCE, "tests", "bad_scenes")


def qbond(*args, check_code=None, **kw):
    r = subprocess.run([QBOND, *args], capture_output=True, text=True, **kw)
    if check_code is not None and r.returncode != check_code:
        sys.exit(f"qbond {' '.join(args)}: exit {r.returncode}, expected {check_code}\n"
                 f"stdout:\n{r.stdout}\nstderr:\n{r.stderr}")
    return r


def fresh(name):
    d = os.path.join(WORK, name)
    shutil.rmtree(d, ignore_errors=True)
    return d


def fail(msg):
    sys.exit("FAIL: " + msg)


def state_bytes(checkpoint):
    """The State part of a checkpoint (format: include/qbond/io/checkpoint.hpp)."""
    data = open(checkpoint, "rb").read()
    if data[:8] != b"QBONDCKP":
        fail(f"{checkpoint}: bad magic")
    off = 16
    (meta_len,) = struct.unpack_from("<Q", data, off)
    off += 8 + meta_len
    (state_len,) = struct.unpack_from("<Q", data, off)
    off += 8
    return data[off:off + state_len]


def same_state_but_old_books(whole, resumed):
    """Whether two checkpoints' states are the same bytes but for the ledger's numerical_damping,
    their last 8 bytes when a run has it, which a checkpoint of version 4 or 5 did not hold: a run
    resumed from one counts it from the resume on, less than the uninterrupted run."""
    a, b = state_bytes(whole), state_bytes(resumed)
    if a == b:
        return True
    if len(a) != len(b) or a[:-8] != b[:-8]:
        return False
    (na,), (nb,) = struct.unpack("<d", a[-8:]), struct.unpack("<d", b[-8:])
    return 0 < nb < na


def read_csv(path):
    text = open(path).read()
    if not text.endswith("\n"):
        fail(f"{path}: ends with a partial line")
    rows = list(csv.reader(text.splitlines()))
    width = len(rows[0])
    for k, r in enumerate(rows):
        if len(r) != width:
            fail(f"{path}: row {k} has {len(r)} fields, the header {width}")
    return text, rows


def test_list():
    r = qbond("run", "--list", check_code=0)
    for name in ("pendulum", "two_quanta", "four_quanta", "series_parallel", "anchored_block",
                 "twisted_bar", "cantilever", "hanging_rope"):
        if name not in r.stdout:
            fail(f"--list does not show {name}:\n{r.stdout}")
    line = next((l for l in r.stdout.splitlines() if l.split()[:1] == ["pendulum"]), "")
    if "(default)" not in line:
        fail("--list does not mark the pendulum as the default")


def test_bad_scenes():
    """Each bad scene: exit 2, the expected path + rule on stderr, nothing written."""
    expected = {}
    for line in open(os.path.join(BAD_SCENES, "expected.txt")):
        if line.strip() and not line.startswith("#"):
            name, text = line.rstrip("\n").split("\t", 1)
            expected[name] = text
    if len(expected) < 25:
        fail(f"only {len(expected)} bad scenes")
    for name, text in sorted(expected.items()):
        out = fresh("bad_" + name)
        r = qbond("run", os.path.join(BAD_SCENES, name), "--out", out, "--steps", "5")
        if r.returncode != 2:
            fail(f"{name}: exit {r.returncode}, expected 2\n{r.stderr}")
        if text not in r.stderr:
            fail(f"{name}: stderr lacks {text!r}:\n{r.stderr}")
        if os.path.exists(out):
            fail(f"{name}: {out} was created although the scene is bad")
    # validate takes them all at once: exit 2, and each scene's message, which starts with its file.
    paths = [os.path.join(BAD_SCENES, name) for name in sorted(expected)]
    v = qbond("validate", *paths)
    messages = {}
    for line in v.stderr.splitlines():
        path = next((p for p in paths if line.startswith(f"qbond: {p}: ")), None)
        if path:
            messages[path] = line
    for path, (name, text) in zip(paths, sorted(expected.items())):
        if v.returncode != 2 or text not in messages.get(path, ""):
            fail(f"validate {name}: exit {v.returncode}, message {messages.get(path)!r}")


def test_bad_options():
    for args in (["run", "--steps", "-3"], ["run", "--dt", "0"], ["run", "--integrator", "magic"],
                 ["run", "--threads", "-1"],
                 ["run", "no_such_scene"], ["run", "--resume", os.path.join(SOURCE, "README.md")]):
        r = qbond(*args, "--out", fresh("bad_option"))
        if r.returncode != 2 or not r.stderr.strip():
            fail(f"qbond {' '.join(args)}: exit {r.returncode}, stderr {r.stderr!r}")
    # A bound broken is named with the option, in a line that says the bound.
    for args, says in ((["run", "--steps", "-3"], "--steps: must be >= 0, got -3"),
                       (["run", "--dt", "0"], "--dt: must be > 0, got 0"),
                       (["bench", "--repetitions", "0"], "--repetitions: must be > 0, got 0"),
                       (["view", "--frames", "-1"], "--frames: must be > 0, got -1")):
        r = qbond(*args)
        first = r.stderr.strip().splitlines()[0] if r.stderr.strip() else ""
        if r.returncode != 2 or first != says:
            fail(f"qbond {' '.join(args)}: exit {r.returncode}, first line of stderr {first!r}, wanted {says!r}")
    # An output directory that cannot be made is named (exit 1: an output could not be written).
    blocked = os.path.join(SOURCE, "README.md", "out")
    r = qbond("run", "--steps", "2", "--out", blocked)
    if r.returncode != 1 or f"cannot create the output directory {blocked}" not in r.stderr:
        fail(f"qbond run --out {blocked}: exit {r.returncode}, stderr {r.stderr!r}")
    # An output file that cannot be written is refused before the work that would write it: a
    # benchmark, a viewer run (refused before any window opens, so no display is needed here).
    missing = os.path.join(fresh("missing_dir"), "no_such_dir")
    for args in (["bench", "--quick", "--json"], ["view", "--frames", "1", "--screenshot"],
                 ["view", "--frames", "1", "--stats"]):
        r = qbond(*args, os.path.join(missing, "out"))
        if r.returncode != 2 or f"{args[-1]} {os.path.join(missing, 'out')}: no directory {missing}" not in r.stderr:
            fail(f"qbond {' '.join(args)} into a missing directory: exit {r.returncode}, stderr {r.stderr!r}")


def test_outputs_and_vtk():
    """The default scene's outputs: CSV columns, run.json, and frames read by VTK itself."""
    out = fresh("pendulum")
    qbond("run", "--steps", "40", "--every", "10", "--threads", "2", "--out", out, "-q", check_code=0)
    _, rows = read_csv(os.path.join(out, "diagnostics.csv"))
    header = rows[0]
    standard = ("step,time,kinetic,potential,dissipated,total,px,py,pz,lx,ly,lz,max_speed,"
                "bonds_alive,bonds_broken").split(",")
    if header[:len(standard)] != standard:
        fail(f"diagnostics.csv columns {header}")
    for col in ("cube_x", "cube_y", "cube_z", "pivot_fx", "pivot_tz"):
        if col not in header:
            fail(f"diagnostics.csv lacks probe column {col}")
    if [r[0] for r in rows[1:]] != ["0", "10", "20", "30", "40"]:
        fail(f"rows at steps {[r[0] for r in rows[1:]]}")
    run = json.load(open(os.path.join(out, "run.json")))
    for key in ("qbond_version", "scene", "status", "wall_seconds", "steps_per_second", "run"):
        if key not in run:
            fail(f"run.json lacks {key}")
    if run["status"] != "completed" or run["scene"]["name"] != "pendulum":
        fail(f"run.json: {run['status']}, {run['scene'].get('name')}")
    if run["scene"]["integrator"]["threads"] != 2:
        fail(f"run.json does not record --threads 2: {run['scene']['integrator']}")
    pvd = os.path.join(out, "series.pvd")
    r = subprocess.run(["/usr/bin/python3", os.path.join(SOURCE, "tests", "vtk_readback.py"), pvd,
                        "--frames", "5", "--points", str(run["quanta"]), "--lines", str(run["bonds_alive"]),
                        "--point-arrays", "velocity,mass,id,body,kinematic,von_mises,stress",
                        "--cell-arrays", "strain,tension,bond"], capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"VTK could not read the series back:\n{r.stdout}\n{r.stderr}")


def whole_and_halves(name, scene, steps, every, options=()):
    """Runs `scene` for `steps` in one go (writing a checkpoint halfway), and for steps/2 then
    resumed to `steps`; checks the two end states are the same bytes and returns both output
    directories."""
    whole, halves = fresh(name + "_whole"), fresh(name + "_halves")
    common = [scene, "--every", str(every), "--no-vtk", "-q", *options]
    qbond("run", *common, "--steps", str(steps), "--checkpoint-every", str(steps // 2), "--out", whole, check_code=0)
    qbond("run", *common, "--steps", str(steps // 2), "--out", halves, check_code=0)
    qbond("run", "--resume", os.path.join(halves, "checkpoint.qbc"), "--steps", str(steps), "-q", check_code=0)
    if state_bytes(os.path.join(whole, "checkpoint.qbc")) != state_bytes(os.path.join(halves, "checkpoint.qbc")):
        fail(f"{scene}: resumed state differs from the uninterrupted one")
    return whole, halves


def test_series_lists_every_frame():
    """series.pvd, rewritten only as it grows by a sixteenth during a run, lists every frame at
    its end: 41 frames, the last rewrite during the run at the 40th."""
    out = fresh("series")
    qbond("run", "--steps", "400", "--every", "10", "--out", out, "-q", check_code=0)
    files = [d.get("file") for d in ET.parse(os.path.join(out, "series.pvd")).getroot().findall("./Collection/DataSet")]
    on_disk = sorted("frames/" + f for f in os.listdir(os.path.join(out, "frames")))
    if files != on_disk or len(files) != 41:
        fail(f"series.pvd lists {len(files)} frames, {len(on_disk)} on disk")


def test_resume_is_bit_for_bit():
    """N steps in one go == N/2, checkpoint, resume, N/2: same state bytes, same CSV rows."""
    whole, halves = whole_and_halves("resume", "cantilever", 200, 30)
    ta, _ = read_csv(os.path.join(whole, "diagnostics.csv"))
    tb, _ = read_csv(os.path.join(halves, "diagnostics.csv"))
    if ta != tb:
        fail(f"diagnostics differ:\n{ta}\n---\n{tb}")


def test_multigrid_resumes_bit_for_bit():
    """A run whose CG keeps a multigrid hierarchy (not in the checkpoint) drops it where it writes a
    checkpoint, as a resumed run starts without one: the two go on with the same bits."""
    whole_and_halves("resume_multigrid", "cantilever", 40, 10, ("--preconditioner", "multigrid", "--dt", "0.01"))


# A small loaded block for each kind of carry-over (velocity Verlet's forces, BDF2's history, CG's
# last solution and last two), and a version-4 checkpoint of each after 20 steps, written by the
# build before the carry-over had its own format.
CARRY_SCENES = os.path.join(SOURCE, "tests", "checkpoints_v4")
CARRY_KINDS = ("velocity_verlet", "bdf2", "cg_previous", "cg_extrapolated")


def test_carry_over_resumes_bit_for_bit():
    """The integrator's carry-over travels in the checkpoint: 40 steps in one go == 20,
    checkpoint, resume, 20, for each kind."""
    for kind in CARRY_KINDS:
        whole_and_halves("carry_" + kind, os.path.join(CARRY_SCENES, f"block_{kind}.json"), 40, 10)


def test_version4_checkpoints_resume_bit_for_bit():
    """A version-4 checkpoint is still read, its carry-over converted: resumed from step 20 it ends
    in the bytes of 40 steps in one go, but for the books' numerical damping the file lacked."""
    for kind in CARRY_KINDS:
        whole, resumed = fresh("v4_whole_" + kind), fresh("v4_resumed_" + kind)
        qbond("run", os.path.join(CARRY_SCENES, f"block_{kind}.json"), "--steps", "40", "--every", "10",
              "--no-vtk", "-q", "--out", whole, check_code=0)
        qbond("run", "--resume", os.path.join(CARRY_SCENES, f"block_{kind}.qbc"), "--steps", "40", "--no-vtk",
              "-q", "--out", resumed, check_code=0)
        if not same_state_but_old_books(os.path.join(whole, "checkpoint.qbc"), os.path.join(resumed, "checkpoint.qbc")):
            fail(f"{kind}: the run resumed from the version-4 checkpoint differs from the uninterrupted one")


def test_version5_checkpoint_with_formed_bonds_resumes_bit_for_bit():
    """A version-5 checkpoint saved only the bonds formed during the run (the scene's came from
    the scene): resumed from step 20 of a splash whose bonds broke, formed in new and reused slots
    and flowed, it ends in the bytes of 40 steps in one go, but for the books' numerical damping
    the file lacked."""
    scenes = os.path.join(SOURCE, "tests", "checkpoints_v5")
    whole, resumed = fresh("v5_whole"), fresh("v5_resumed")
    qbond("run", os.path.join(scenes, "splash.json"), "--steps", "40", "--every", "10", "--no-vtk", "-q",
          "--out", whole, check_code=0)
    qbond("run", "--resume", os.path.join(scenes, "splash.qbc"), "--steps", "40", "--no-vtk", "-q",
          "--out", resumed, check_code=0)
    if not same_state_but_old_books(os.path.join(whole, "checkpoint.qbc"), os.path.join(resumed, "checkpoint.qbc")):
        fail("the run resumed from the version-5 checkpoint differs from the uninterrupted one")
    events = open(os.path.join(resumed, "events.csv")).read()
    if events.count(",formed,") < 10:
        fail("the resumed splash forms too few bonds to test anything")


def test_events_resume_with_the_run():
    """Fracture events: a resumed run's events.csv equals the uninterrupted run's."""
    whole, halves = whole_and_halves("events", "fracture_bar", 400, 50)
    ta = open(os.path.join(whole, "events.csv")).read()
    tb = open(os.path.join(halves, "events.csv")).read()
    if not ta.startswith("step,time,event,reason,bond,i,j,strain,tension\n") or ta.count("\n") < 10:
        fail(f"events.csv of the whole run has too few breaks:\n{ta[:400]}")
    if ta != tb:
        fail("events.csv of the resumed run differs from the uninterrupted one")


def test_formed_bonds_resume_with_the_run():
    """Bonds formed (and slots reused) before a checkpoint come back on resume: a liquid splash
    resumed at its midpoint ends in the same bytes and the same events as the uninterrupted run."""
    whole, halves = whole_and_halves("formed", "liquid_blob", 1200, 100)
    ta = open(os.path.join(whole, "events.csv")).read()
    tb = open(os.path.join(halves, "events.csv")).read()
    kept = [l for l in ta.splitlines()[1:] if int(l.split(",")[0]) < 600]
    if sum(",formed," in l for l in kept) < 10 or sum(",broken," in l for l in kept) < 10:
        fail("liquid_blob forms and breaks too few bonds before the checkpoint to test anything")
    if ta != tb:
        fail("events.csv of the resumed run differs from the uninterrupted one")


def test_events_name_creation_ids():
    """A chain built from x = 0.1 down to x = 0 is renumbered by position (reversed) when loaded;
    events.csv still names the scene's ids: the chain's bond k joins quanta k and k + 1."""
    d = fresh("creation_ids")
    os.makedirs(d)
    scene = os.path.join(d, "chain.json")
    with open(scene, "w") as f:
        json.dump({"timestep": 1e-5, "steps": 300,
                   "materials": {"m": {"stiffness": 100}},
                   "bodies": [{"name": "rope", "type": "chain", "start": [0.1, 0, 0], "end": [0, 0, 0],
                               "count": 11, "quanta_mass": 1e-3, "material": "m"}],
                   "anchors": [{"select": {"ids": [0]}},
                               {"select": {"ids": [10]}, "motion": {"translate": {"velocity": [-2, 0, 0]}}}],
                   "heuristics": [{"type": "break", "max_strain": 0.05}]}, f)
    qbond("run", scene, "-q", "--out", os.path.join(d, "out"), check_code=0)
    _, rows = read_csv(os.path.join(d, "out", "events.csv"))
    head, rows = rows[0], rows[1:]
    if not rows:
        fail("the pulled chain did not break")
    col = {name: k for k, name in enumerate(head)}
    for r in rows:
        bond, i, j = (int(r[col[c]]) for c in ("bond", "i", "j"))
        if (i, j) != (bond, bond + 1):
            fail(f"event {r}: bond {bond} of the chain joins quanta {bond} and {bond + 1}")
    # The first to break is the one at the pulled end, id 9 (quanta 9 and 10).
    if int(rows[0][col["bond"]]) != 9:
        fail(f"first break {rows[0]}, expected bond 9 at the pulled end")


def test_corrupt_checkpoint():
    out = fresh("corrupt")
    qbond("run", "two_quanta", "--steps", "10", "--out", out, "-q", check_code=0)
    ck = os.path.join(out, "checkpoint.qbc")
    data = bytearray(open(ck, "rb").read())
    for name, blob, needle in (("truncated", data[:len(data) // 2], "truncated"),
                               ("flipped", data[:-20] + bytes([data[-20] ^ 1]) + data[-19:], "checksum")):
        bad = os.path.join(out, name + ".qbc")
        open(bad, "wb").write(blob)
        r = qbond("run", "--resume", bad, "-q")
        if r.returncode != 2 or needle not in r.stderr:
            fail(f"{name} checkpoint: exit {r.returncode}, stderr {r.stderr!r}")


def test_sigint_leaves_a_resumable_run():
    out = fresh("sigint")
    p = subprocess.Popen([QBOND, "run", "cantilever", "--steps", "10000000", "--every", "5", "--no-vtk",
                          "--out", out], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    csv_path = os.path.join(out, "diagnostics.csv")
    deadline = time.time() + 120
    while time.time() < deadline:
        if os.path.exists(csv_path) and open(csv_path).read().count("\n") >= 4:
            break
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=120)
    if p.returncode != 130:
        fail(f"exit {p.returncode} after SIGINT, expected 130\n{stderr}")
    if "resume" not in stderr:
        fail(f"no resume hint on stderr: {stderr!r}")
    _, rows = read_csv(csv_path)
    last = int(rows[-1][0])
    run = json.load(open(os.path.join(out, "run.json")))
    if run["status"] != "stopped" or run["last_step"] != last:
        fail(f"run.json says {run['status']} at {run['last_step']}, CSV ends at {last}")
    if not run["message"].startswith(f"interrupted at step {last} ") or "checkpoint.qbc" not in run["message"]:
        fail(f"run.json's message does not say where the run was interrupted: {run['message']!r}")
    qbond("run", "--resume", os.path.join(out, "checkpoint.qbc"), "--steps", str(last + 10), "-q", check_code=0)
    _, rows = read_csv(csv_path)
    if int(rows[-1][0]) != last + 10:
        fail(f"resumed run ends at {rows[-1][0]}, expected {last + 10}")


def test_blowup_stops_with_a_message():
    out = fresh("blowup")
    r = qbond("run", "cantilever", "--integrator", "explicit_euler", "--dt", "0.01", "--steps", "1000",
              "--out", out, "-q")
    if r.returncode != 3:
        fail(f"exit {r.returncode}, expected 3\n{r.stderr}")
    for word in ("blow-up at step", "t =", "quanta"):
        if word not in r.stderr:
            fail(f"blow-up message lacks {word!r}: {r.stderr}")
    run = json.load(open(os.path.join(out, "run.json")))
    if run["status"] != "blowup" or not os.path.exists(os.path.join(out, "checkpoint.qbc")):
        fail(f"run.json status {run['status']}, or no checkpoint")
    _, rows = read_csv(os.path.join(out, "diagnostics.csv"))
    for v in rows[-1][1:]:
        if v in ("nan", "-nan", "inf", "-inf"):
            fail(f"the last row is not the last good state: {rows[-1]}")


def test_adaptive_finishes_what_fixed_blows_up():
    """scenes/adaptive_pendulum.json: without its `adaptive` section (the same fixed 3 ms Verlet
    steps) it blows up; with it the run completes its 2 s, varies the step (diagnostics.csv's
    timestep column), and keeps the energy the integrator made or lost under 1 % of the energy."""
    scene = json.load(open(os.path.join(SOURCE, "scenes", "adaptive_pendulum.json")))
    fixed = dict(scene)
    del fixed["adaptive"]
    d = fresh("adaptive")
    os.makedirs(d)
    with open(os.path.join(d, "fixed.json"), "w") as f:
        json.dump(fixed, f)
    r = qbond("run", "fixed.json", "--out", "fixed", "-q", cwd=d)
    if r.returncode != 3:
        fail(f"the fixed 3 ms step should blow up (exit 3), got {r.returncode}\n{r.stderr}")
    qbond("run", os.path.join(SOURCE, "scenes", "adaptive_pendulum.json"), "--out", "adaptive", "-q", cwd=d,
          check_code=0)
    _, rows = read_csv(os.path.join(d, "adaptive", "diagnostics.csv"))
    col = {name: k for k, name in enumerate(rows[0])}
    t = [float(r[col["time"]]) for r in rows[1:]]
    h = [float(r[col["timestep"]]) for r in rows[2:]]
    if abs(t[-1] - scene["duration"]) > 1e-12:  # a multiple of the timestep: the run's end time
        fail(f"the adaptive run ended at t = {t[-1]}, not {scene['duration']}")
    if not (min(h) < scene["timestep"] / 3 and max(h) > 1.5 * min(h)):
        fail(f"the timestep column should vary below the 1 ms stability limit: {min(h)}..{max(h)}")
    last = rows[-1]
    numerical = abs(float(last[col["numerical_damping"]]) + float(last[col["numerical"]]))
    # The controller's bound: drift <= energy * max over steps of max(|E(0)|, kinetic + bond energy);
    # here gravity's potential (z >= 0) is >= 0, so kinetic + potential bounds kinetic + bonds.
    scale = max([abs(float(rows[1][col["total"]]))] +
                [float(r[col["kinetic"]]) + abs(float(r[col["potential"]])) for r in rows[1:]])
    if numerical > scene["adaptive"]["energy"] * scale:
        fail(f"numerical energy {numerical} J exceeds {scene['adaptive']['energy']} of {scale} J")
    print(f"adaptive: {len(rows) - 1} rows, h in [{min(h):.3g}, {max(h):.3g}] s, numerical {numerical:.3g} J")


def test_bench_quick():
    """`qbond bench --quick` (what CI runs so the suite cannot rot): one table row per integrator
    and thread count, the same rows in the JSON, every figure finite and positive, counts those of
    the workload, the triad measured on each thread count and each row's bound taken with its own."""
    os.makedirs(fresh("bench"))
    path = os.path.join(WORK, "bench", "bench.json")
    r = qbond("bench", "--quick", "-j", "1,2", "--json", path, check_code=0)
    # Debian's Google Benchmark warns about its own build; the program says whose build that is.
    if "Library was built as DEBUG" in r.stderr and "not the code it times" not in r.stderr:
        fail(f"Google Benchmark's DEBUG warning is left unexplained:\n{r.stderr}")
    if "x bound" not in r.stdout or "vs 1T" not in r.stdout or "2 threads" not in r.stdout:
        fail(f"no table printed:\n{r.stdout}")
    doc = json.load(open(path))
    names = sorted((row["integrator"], row["threads"]) for row in doc["rows"])
    if names != [(i, t) for i in ["default", "hybrid_frozen", "hybrid_sweep", "velocity_verlet"] for t in (1, 2)]:
        fail(f"rows {names}")
    by_threads = doc["triad_bytes_per_second_by_threads"]
    if sorted(by_threads) != ["1", "2"] or doc["triad_bytes_per_second"] != by_threads["1"]:
        fail(f"triad {by_threads}, {doc['triad_bytes_per_second']}")
    for row in doc["rows"]:
        if row["bandwidth_bytes_per_second"] != by_threads[str(row["threads"])]:
            fail(f"bound not taken on the row's thread count: {row}")
        if not (row["speedup_over_one_thread"] > 0) or (row["threads"] == 1 and row["speedup_over_one_thread"] != 1):
            fail(f"speed-up {row}")
    for row in doc["rows"]:
        # n = 10: 1000 quanta; bonds along x, y, z (3 * 10 * 10 * 9) and face diagonals (6 * 10 * 9 * 9).
        if row["quanta"] != 1000 or row["bonds"] != 2700 + 4860:
            fail(f"workload counts {row}")
        for key in ("seconds_per_step", "ns_per_bond_step", "ratio_to_bandwidth_bound", "bytes_per_quanta_step"):
            if not (0 < row[key] < 1e9):
                fail(f"{key} = {row[key]}")
    if not doc["triad_bytes_per_second"] > 1e8:
        fail(f"bandwidth {doc['triad_bytes_per_second']} B/s")
    # --as-run: the same step with the energy ledger and rollback copy `qbond run` keeps.
    qbond("bench", "--quick", "--as-run", "--integrators", "hybrid_frozen", "--json", path, check_code=0)
    rows = json.load(open(path))["rows"]
    if [(row["integrator"], row["as_run"]) for row in rows] != [("hybrid_frozen+run", True)]:
        fail(f"--as-run rows {rows}")
    # The solver comparison: the same system solved by each, to the stated residual.
    qbond("bench", "--quick", "--solve", "--json", path, check_code=0)
    rows = {row["solver"]: row for row in json.load(open(path))["rows"]}
    # PETSc's rows are there when the build has PETSc (QBOND_PETSC), both or neither.
    petsc = ["petsc_boomeramg", "petsc_gamg"] if "petsc_gamg" in rows else []
    if sorted(rows) != sorted(["eigen_cg", "eigen_cholesky", "qbond_cg", "qbond_mg"] + petsc):
        fail(f"solve rows {sorted(rows)}")
    for name, row in rows.items():
        # PETSc stops on its recursive residual; the true one may exceed it by rounding.
        bound = 1e-10 if name == "eigen_cholesky" else 2e-6 if name.startswith("petsc") else 1e-6
        if not row["relative_residual"] <= bound or not row["seconds"] > 0:
            fail(f"{name}: {row}")
    for name in petsc:
        row = rows[name]
        if not (0 < row["setup_seconds"] and 0 < row["solve_seconds"] and row["iterations"] >= 1
                and row["setup_seconds"] + row["solve_seconds"] <= row["seconds"]):
            fail(f"{name}: {row}")
    # The multigrid row's set-up and CG times apart, within its whole.
    mg = rows["qbond_mg"]
    if not (0 < mg["setup_seconds"] and 0 < mg["solve_seconds"] and mg["setup_seconds"] + mg["solve_seconds"] <= mg["seconds"]
            and mg["levels"] >= 1 and mg["iterations"] >= 1):
        fail(f"qbond_mg: {mg}")
    r = qbond("bench", "--quick", "--integrators", "nonsense")
    if r.returncode == 0 or "unknown integrator 'nonsense'" not in r.stderr:
        fail(f"an unknown integrator was accepted: {r.returncode} {r.stderr}")


def test_bench_realtime():
    """`qbond bench --realtime` (performance.md): a row for each workload and thread count, each
    with frames measured, a positive frame time, keeps_up and the real-time factor as the mean
    frame (the run's throughput) says, and the speed of every core; a budget too short for the
    frames asked cuts the row off and says so."""
    path = os.path.join(fresh("bench_realtime"), "realtime.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    r = qbond("bench", "--realtime", "-n", "4", "-j", "1,2", "--scenes", "two_quanta", "--budget", "2",
              "--json", path, check_code=0)
    if "keeps up" not in r.stdout:
        fail(f"no table printed:\n{r.stdout}")
    doc = json.load(open(path))
    got = [(row["workload"], row["threads"]) for row in doc["rows"]]
    if got != [("lattice n=4", 1), ("lattice n=4", 2), ("lattice n=4 tol=1e-4", 1), ("lattice n=4 tol=1e-4", 2),
               ("two_quanta", 1), ("two_quanta", 2)]:
        fail(f"rows {got}")
    # The lattice rows: the default tolerance and the real-time one; every frame measured, the
    # free face lifted by the pull after settling.
    for row in doc["rows"][:4]:
        want = 1e-4 if "tol=1e-4" in row["workload"] else 1e-6
        if row["tolerance"] != want or row["frames"] != doc["lattice_frames"]:
            fail(f"lattice row {row}")
        face = row["pulled_face_z"]
        if not face or not face["end"] > face["settled"]:
            fail(f"the pull did not lift the face: {row}")
    if doc["rows"][4]["pulled_face_z"] is not None:
        fail(f"a scene row with a pull: {doc['rows'][4]}")
    for row in doc["rows"]:
        if not (row["frames"] >= 1 and row["median_frame_seconds"] > 0 and row["steps_per_frame"] >= 1):
            fail(f"row {row}")
        mean = row["mean_frame_seconds"]
        if not 0 < mean <= row["max_frame_seconds"] or abs(row["real_time_factor"] * mean - 1 / 60) > 1e-12:
            fail(f"mean frame {row}")
        if row["keeps_up"] != (mean <= 1 / 60) or row["failure"]:
            fail(f"keeps_up {row}")
        # Every core the process may use timed before the row, the fastest at 1.
        cores = row["core_speeds"]
        if (sorted(cores["cpus"]) != sorted(os.sched_getaffinity(0)) or len(cores["speed"]) != len(cores["cpus"])
                or max(cores["speed"]) != 1 or not all(0 < s <= 1 for s in cores["speed"])):
            fail(f"core speeds {cores}")
    if "--realtime" not in doc["command"] or doc["budget_seconds"] != 2:
        fail(f"provenance {doc['command']} {doc['budget_seconds']}")
    # Huge pages (performance.md): asked for where the kernel gives them only when asked, unless
    # the environment says otherwise.
    try:
        with open("/sys/kernel/mm/transparent_hugepage/enabled") as f:
            madvise = "[madvise]" in f.read()
    except OSError:
        madvise = False
    own = {k: v for k, v in os.environ.items() if k not in ("GLIBC_TUNABLES", "QBOND_NO_HUGE_PAGES")}
    for extra, want in [({}, madvise), ({"QBOND_NO_HUGE_PAGES": "1"}, False)]:
        qbond("bench", "--realtime", "-n", "4", "-j", "1", "--scenes", "two_quanta", "--budget", "0.2",
              "--json", path, check_code=0, env={**own, **extra})
        if json.load(open(path))["huge_pages"] != want:
            fail(f"huge pages asked for {not want} with {extra or 'no setting'} (kernel's madvise mode: {madvise})")
    # A budget shorter than the frames: cut off, and said.
    qbond("bench", "--realtime", "-n", "6", "-j", "1", "--scenes", "pendulum", "--budget", "1e-6",
          "--json", path, check_code=0)
    rows = json.load(open(path))["rows"]
    if not all(row["cut_off"] and row["frames"] >= 1 for row in rows):
        fail(f"not cut off: {rows}")


def test_bench_contact():
    """`qbond bench --contact` (heuristics.md): a row a scene, its implicit and contact-free
    variants timed in every round; the projection variant timed too, or its blow-up named (the
    projection rule is not stable at frame-sized steps); bad requests are refused."""
    path = os.path.join(fresh("bench_contact"), "contact.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    r = qbond("bench", "--contact", "--scenes", "block_rest,gap", "--rounds", "2", "--json", path, check_code=0)
    if "implicit/none" not in r.stdout:
        fail(f"no table printed:\n{r.stdout}")
    doc = json.load(open(path))
    if [row["scene"] for row in doc["rows"]] != ["block_rest", "gap"] or doc["rounds"] != 2:
        fail(f"rows {[row['scene'] for row in doc['rows']]}, rounds {doc['rounds']}")
    for row in doc["rows"]:
        for v in ("implicit", "none"):
            if row[v]["failure"] or len(row[v]["rounds_ms"]) != 2 or not row[v]["median_ms"] > 0:
                fail(f"{row['scene']} {v}: {row[v]}")
        p = row["projection"]
        timed = not p["failure"] and len(p["rounds_ms"]) == 2 and p["median_ms"] > 0
        if not (timed or "blow-up" in p["failure"]):
            fail(f"{row['scene']} projection: {p}")
        if not (row["implicit_over_none"] > 0 and (row["implicit_over_projection"] is None) == (not timed)):
            fail(f"ratios {row}")
    if "--contact" not in doc["command"]:
        fail(f"provenance {doc['command']}")
    r = qbond("bench", "--contact", "--scenes", "pendulum_that_is_not_there")
    if r.returncode == 0:
        fail("an unknown scene was accepted")
    r = qbond("bench", "--contact", "--realtime")
    if r.returncode == 0 or "give one" not in r.stderr:
        fail(f"--contact with --realtime: {r.returncode} {r.stderr}")


def test_bench_ab():
    """bench/ab.py (two builds' benchmark rows timed in interleaved rounds, performance.md):
    one row a benchmark, both builds' times and the two ratios finite and positive (no bound on
    them: they are timings), and a filter matching nothing is an error that says so."""
    bench = os.path.join(os.path.dirname(os.path.abspath(QBOND)), "qbond_bench")
    script = os.path.join(SOURCE, "bench", "ab.py")
    r = subprocess.run([sys.executable, script, bench, bench, "--filter", "step/velocity_verlet/n:10/",
                        "--rounds", "2", "--min-time", "0.01", "--", "--integrators=velocity_verlet", "--n=10"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"ab.py failed ({r.returncode}): {r.stderr}")
    lines = r.stdout.splitlines()
    if len(lines) != 2 or not lines[0].startswith("row") or not lines[1].startswith("step/velocity_verlet/n:10/"):
        fail(f"ab.py printed:\n{r.stdout}")
    figures = [float(x) for x in lines[1].split()[2:]]
    if len(figures) != 6 or not all(0 < x < 1e9 for x in figures):
        fail(f"figures {figures}")
    r = subprocess.run([sys.executable, script, bench, bench, "--filter", "nothing/matches", "--rounds", "1"],
                       capture_output=True, text=True)
    if r.returncode == 0 or "no benchmark matches 'nothing/matches'" not in r.stderr:
        fail(f"an empty filter was accepted: {r.returncode} {r.stderr}")

def test_step_times():
    """qbond_step_times (each step timed on its own, performance.md): its four figures in order
    (min <= p10 <= p25 <= median, all finite and positive), and an unknown integrator or a step
    count that is not a positive integer is an error that says so."""
    program = os.path.join(os.path.dirname(os.path.abspath(QBOND)), "qbond_step_times")
    r = subprocess.run([program, "--n=6", "--integrator=velocity_verlet", "--steps=20", "--threads=2"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"qbond_step_times failed ({r.returncode}): {r.stderr}")
    words = r.stdout.split()
    if words[:4] != ["velocity_verlet", "n=6", "threads=2", "steps=20"] or words[5::2] != ["min", "p10", "p25", "median"]:
        fail(f"qbond_step_times printed: {r.stdout}")
    figures = [float(x) for x in words[6::2]]
    if not all(0 < x < 1e6 for x in figures) or figures != sorted(figures):
        fail(f"figures {figures}")
    for bad, says in (("--integrator=nope", "unknown integrator: nope"), ("--steps=0", "not a positive integer")):
        r = subprocess.run([program, "--n=6", bad], capture_output=True, text=True)
        if r.returncode != 2 or says not in r.stderr:
            fail(f"{bad} gave {r.returncode}: {r.stderr}")

def enumerators(header, enum):
    """The enumerators of `enum class ENUM` in a header, in order."""
    import re
    text = open(os.path.join(SOURCE, header)).read()
    body = text[text.index("enum class " + enum):]
    body = body[body.index("{") + 1:body.index("};")]
    body = re.sub(r"//[^\n]*", "", body)
    return [m.group(1) for m in re.finditer(r"^\s*(\w+)\s*(?:=[^,]*)?,", body, re.M)]


def test_integrator_keys():
    """The integrator table is the one list of integrators: `qbond run --help` lists every
    integrator of QBOND_INTEGRATORS with its line, and docs/scene-format.md's `integrator` section
    every integrator and every option key (IntegratorOption; the scene keys are the enumerators'
    names)."""
    header = os.path.join("include", "qbond", "integrators", "integrators.hpp")
    text = open(os.path.join(SOURCE, header)).read()
    listing = re.search(r"#define QBOND_INTEGRATORS\(X\)((?:[^\n]*\\\n)*[^\n]*)", text)
    types = re.findall(r"\bX\((\w+)\)", listing.group(1)) if listing else []
    options = enumerators(header, "IntegratorOption")
    if len(types) < 9 or len(options) < 12:
        fail(f"parsed {types} and {options} from {header}")
    help_text = qbond("run", "--help", check_code=0).stdout
    for t in types:
        if f"  {t}: " not in help_text:
            fail(f"`qbond run --help` does not list integrator {t}:\n{help_text}")
    doc = open(os.path.join(SOURCE, "docs", "scene-format.md")).read()
    section = doc[doc.index("## `integrator`"):]
    section = section[:section.index("\n## ", 1)]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    keys = [row.split("`")[1] for row in rows]
    for o in options:
        if o not in keys:
            fail(f"docs/scene-format.md's integrator table has no row for `{o}` (rows: {keys})")
    type_row = next(row for row in rows if row.startswith("| `type`"))
    for t in types:
        if f"`{t}`" not in type_row:
            fail(f"docs/scene-format.md's `type` row does not list {t}")
    # An unknown integrator is refused with the table's names.
    r = qbond("run", "--integrator", "magic", "--out", fresh("integrator_keys"))
    if r.returncode != 2 or not all(t in r.stderr for t in types):
        fail(f"--integrator magic: exit {r.returncode}, stderr {r.stderr!r}")


def test_experiment_output_and_progress():
    """`qbond experiment` writes into ./experiment_results by default, prints each experiment and
    claim as it goes, and draws its plots with the plot.py found beside the program."""
    cwd = fresh("experiment_cwd")
    os.makedirs(cwd)
    r = qbond("experiment", "eq14_15", "--fast", cwd=cwd, check_code=0)
    out = os.path.join(cwd, "experiment_results", "eq14_15")
    for f in ("summary.md", "results.json", "statics.csv", "eq14_15.png"):
        if not os.path.exists(os.path.join(out, f)):
            fail(f"qbond experiment eq14_15 did not write experiment_results/eq14_15/{f}:\n{r.stdout}")
    lines = r.stdout.splitlines()
    if not lines or not lines[0].startswith("eq14_15: ") or not any(l.startswith("  pass ") for l in lines) \
            or "-> " not in lines[-1]:
        fail(f"progress lines: {r.stdout!r}")
    result = json.load(open(os.path.join(out, "results.json")))
    if not result["passed"] or not result["fast"] or not result["paper"]["quote"]:
        fail(f"results.json: {result}")


def test_experiment_keeps_committed_results():
    """The source tree's experiments/results is refused without --update-results, untouched."""
    committed = os.path.join(SOURCE, "experiments", "results")
    summary = os.path.join(committed, "eq14_15", "summary.md")
    before = open(summary).read()
    for target in (committed, committed + "/", os.path.join(committed, "..", "results")):
        r = qbond("experiment", "eq14_15", "--fast", "--no-plots", "-o", target)
        if r.returncode != 2 or "--update-results" not in r.stderr:
            fail(f"-o {target}: exit {r.returncode}, stderr {r.stderr!r}")
    if open(summary).read() != before:
        fail("the committed summary changed")


def test_experiment_relocated_program():
    """A copy of the program elsewhere draws plots with share/qbond/plot.py beside it, and without
    one says so and still writes its results."""
    prefix = fresh("experiment_install")
    os.makedirs(os.path.join(prefix, "bin"))
    exe = os.path.join(prefix, "bin", "qbond")
    shutil.copy2(QBOND, exe)
    r = subprocess.run([exe, "experiment", "eq14_15", "--fast", "-o", os.path.join(prefix, "bare")],
                       capture_output=True, text=True)
    if r.returncode != 0 or "plot.py was not found" not in r.stdout \
            or not os.path.exists(os.path.join(prefix, "bare", "eq14_15", "summary.md")):
        fail(f"without plot.py: exit {r.returncode}, stdout {r.stdout!r}, stderr {r.stderr!r}")
    share = os.path.join(prefix, "share", "qbond")
    os.makedirs(share)
    for script in ("plot.py", "fig11_getfem.py"):
        shutil.copy2(os.path.join(SOURCE, "experiments", script), share)
    r = subprocess.run([exe, "experiment", "eq14_15", "--fast", "-o", os.path.join(prefix, "drawn")],
                       capture_output=True, text=True)
    if r.returncode != 0 or not os.path.exists(os.path.join(prefix, "drawn", "eq14_15", "eq14_15.png")):
        fail(f"with share/qbond/plot.py: exit {r.returncode}, stdout {r.stdout!r}, stderr {r.stderr!r}")


# Hardened input and outputs (docs/running.md, "What is checked"): each test reproduces a failure
# once seen and checks the refusal, its exit code and its message.

def xxh64(data, seed=0):
    """XXH64 as the xxHash specification defines it (the checkpoint checksum, version 6)."""
    m = (1 << 64) - 1
    p1, p2, p3, p4, p5 = (0x9E3779B185EBCA87, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9, 0x85EBCA77C2B2AE63,
                          0x27D4EB2F165667C5)
    rotl = lambda x, r: ((x << r) | (x >> (64 - r))) & m
    rnd = lambda acc, v: (rotl((acc + v * p2) & m, 31) * p1) & m
    n, p = len(data), 0
    if n >= 32:
        v = [(seed + p1 + p2) & m, (seed + p2) & m, seed, (seed - p1) & m]
        while n - p >= 32:
            for k in range(4):
                v[k] = rnd(v[k], struct.unpack_from("<Q", data, p + 8 * k)[0])
            p += 32
        h = (rotl(v[0], 1) + rotl(v[1], 7) + rotl(v[2], 12) + rotl(v[3], 18)) & m
        for x in v:
            h = ((h ^ rnd(0, x)) * p1 + p4) & m
    else:
        h = (seed + p5) & m
    h = (h + n) & m
    while n - p >= 8:
        h = (rotl(h ^ rnd(0, struct.unpack_from("<Q", data, p)[0]), 27) * p1 + p4) & m
        p += 8
    if n - p >= 4:
        h = (rotl(h ^ ((struct.unpack_from("<I", data, p)[0] * p1) & m), 23) * p2 + p3) & m
        p += 4
    while p < n:
        h = (rotl(h ^ ((data[p] * p5) & m), 11) * p1) & m
        p += 1
    h ^= h >> 33
    h = (h * p2) & m
    h ^= h >> 29
    h = (h * p3) & m
    return h ^ (h >> 32)


def rewrite_metadata(checkpoint, out, edit):
    """Writes `out`: `checkpoint` with its metadata JSON changed by edit(meta) and a valid checksum,
    as a forger would."""
    data = open(checkpoint, "rb").read()
    (meta_len,) = struct.unpack_from("<Q", data, 16)
    meta = json.loads(data[24:24 + meta_len])
    edit(meta)
    text = json.dumps(meta).encode()
    rest = data[24 + meta_len:-8]
    body = data[:16] + struct.pack("<Q", len(text)) + text + rest
    open(out, "wb").write(body + struct.pack("<Q", xxh64(body)))


def test_thread_counts_are_bounded():
    """-j and OMP_NUM_THREADS above the bound are refused before anything runs (the scene's key:
    tests/bad_scenes/threads_too_many.json)."""
    out = fresh("threads")
    for args, env, says in ((["-j", "20000"], {}, "--threads: must be <= "),
                            (["-j", "0"], {"OMP_NUM_THREADS": "100000"}, "OMP_NUM_THREADS=100000"),
                            ([], {"OMP_NUM_THREADS": "100000"}, "OMP_NUM_THREADS=100000")):
        r = qbond("run", "cantilever", "--steps", "2", "--out", out, *args, env={**os.environ, **env}, timeout=60)
        if r.returncode != 2 or says not in r.stderr or "hardware threads" not in r.stderr:
            fail(f"{args} {env}: exit {r.returncode}, stderr {r.stderr!r}")
        if os.path.exists(out):
            fail(f"{args} {env}: {out} was written although the thread count is refused")
    qbond("run", "cantilever", "--steps", "2", "--out", out, "-q", "-j", "2", env={**os.environ, "OMP_NUM_THREADS": "3"},
          check_code=0)


def test_counts_that_overflow_are_refused():
    """Step counts from the command line that overflow or round to nothing (the scene's keys:
    tests/bad_scenes/duration_overflows_steps.json, timestep_denormal.json)."""
    for args, says in ((["--dt", "5e-324"], "--dt: "), (["--duration", "1e308"], "--duration: "),
                       (["--steps", str(2**60)], "--steps: must be <= 2^53")):
        r = qbond("run", "cantilever", "--out", fresh("overflow"), *args)
        if r.returncode != 2 or says not in r.stderr:
            fail(f"{args}: exit {r.returncode}, stderr {r.stderr!r}")


def test_deep_json_is_refused():
    """200 000 nested arrays (400 KB) are refused with the depth, by `validate` and `run`, where
    they once overflowed the stack."""
    d = fresh("deep")
    os.makedirs(d)
    scene = os.path.join(d, "deep.json")
    open(scene, "w").write('{"timestep": 0.001, "a": ' + "[" * 200000 + "]" * 200000 + "}")
    for args in (["validate", scene], ["run", scene, "--out", os.path.join(d, "out")]):
        r = qbond(*args, timeout=60)
        if r.returncode != 2 or "nested deeper than 64 arrays and objects" not in r.stderr or scene not in r.stderr:
            fail(f"{args[0]}: exit {r.returncode}, stderr {r.stderr[:300]!r}")


def test_special_files_are_refused():
    """A FIFO, /dev/zero, a directory or an 8 GiB sparse file given as a checkpoint or a scene is
    refused at once (exit 2, the file named): nothing reads them whole first."""
    d = fresh("special")
    os.makedirs(d)
    fifo, sparse = os.path.join(d, "fifo"), os.path.join(d, "sparse.qbc")
    os.mkfifo(fifo)
    with open(sparse, "wb") as f:
        f.truncate(8 << 30)
    cases = [(["run", "--resume", fifo], "a FIFO"), (["run", "--resume", "/dev/zero"], "a character device"),
             (["run", "--resume", d], "a directory"), (["run", "--resume", sparse], "no QBONDCKP header"),
             (["validate", fifo], "a FIFO"), (["validate", "/dev/zero"], "a character device"),
             (["run", fifo], "a FIFO")]
    for args, says in cases:
        t0 = time.time()
        r = qbond(*args, "-q" if args[0] == "run" else "--max-memory=1G", timeout=30)
        path = args[-1]
        if r.returncode != 2 or says not in r.stderr or path not in r.stderr or time.time() - t0 > 5:
            fail(f"{args}: exit {r.returncode} after {time.time() - t0:.1f} s, stderr {r.stderr!r}")


def test_checkpoint_metadata_is_checked():
    """A checkpoint whose checksum matches but whose metadata is wrong is refused like a bad scene
    (exit 2, the file and the JSON path); the directory a resume writes is never the file's."""
    out = fresh("forged")
    qbond("run", "two_quanta", "--steps", "10", "--out", out, "-q", check_code=0)
    ck = os.path.join(out, "checkpoint.qbc")
    elsewhere = fresh("forged_elsewhere")
    for name, edit, says in (
            ("steps", lambda m: m["run"].update(steps=-5), "run.steps: must be >= 0, got -5"),
            ("every", lambda m: m["run"].update(every=-1), "run.every: must be >= 1, got -1"),
            ("checkpoint_every", lambda m: m["run"].update(checkpoint_every=-3),
             "run.checkpoint_every: must be >= 0, got -3"),
            ("ledger", lambda m: m["run"].update(ledger="no"), "run.ledger: expected true or false, got a string"),
            ("threads", lambda m: m["scene"]["integrator"].update(threads=-2), "integrator.threads: must be >= 0"),
            ("no_scene", lambda m: m.pop("scene"), "metadata: scene: required key missing"),
            ("unknown", lambda m: m.update(extra=1), "metadata: extra: unknown key"),
            ("huge", lambda m: m["run"].update(steps=1e999), "invalid JSON")):
        bad = os.path.join(out, f"forged_{name}.qbc")
        rewrite_metadata(ck, bad, edit)
        if name == "huge":  # json.dumps writes Infinity; put the overflowing literal in its place
            data = open(bad, "rb").read().replace(b"Infinity", b"1e999   ")
            body = data[:-8]
            open(bad, "wb").write(body + struct.pack("<Q", xxh64(body)))
        r = qbond("run", "--resume", bad, "-q")
        if r.returncode != 2 or says not in r.stderr or bad not in r.stderr:
            fail(f"{name}: exit {r.returncode}, stderr {r.stderr!r}")
    # out_dir in the file is ignored: the resume writes beside its checkpoint.
    moved = os.path.join(out, "forged_out_dir.qbc")
    rewrite_metadata(ck, moved, lambda m: m["run"].update(out_dir=elsewhere, steps=20))
    qbond("run", "--resume", moved, "-q", check_code=0)
    if os.path.exists(elsewhere):
        fail(f"the resume wrote into {elsewhere}, the directory the checkpoint named")
    if json.load(open(os.path.join(out, "run.json")))["last_step"] != 20:
        fail("the resume did not write beside its checkpoint")


def test_version5_checkpoints_still_read():
    """A new checkpoint is version 6 with an XXH64 checksum; a version-5 file (FNV-1a, written by
    the build before format 6) is read, and its bytes relabelled version 6 are refused."""
    out = fresh("v5")
    qbond("run", "cantilever", "--steps", "20", "--no-vtk", "--out", out, "-q", check_code=0)
    data = open(os.path.join(out, "checkpoint.qbc"), "rb").read()
    if struct.unpack_from("<I", data, 8)[0] != 6 or struct.unpack_from("<Q", data, len(data) - 8)[0] != xxh64(
            data[:-8]):
        fail("a new checkpoint is not version 6 with an XXH64 checksum")
    old = bytearray(open(os.path.join(SOURCE, "tests", "checkpoints_v5", "splash.qbc"), "rb").read())
    if struct.unpack_from("<I", old, 8)[0] != 5:
        fail("tests/checkpoints_v5/splash.qbc is not a version-5 file")
    v5 = os.path.join(out, "v5.qbc")
    open(v5, "wb").write(old)
    qbond("run", "--resume", v5, "--steps", "25", "--out", fresh("v5_a"), "-q", check_code=0)
    struct.pack_into("<I", old, 8, 6)
    relabelled = os.path.join(out, "relabelled.qbc")
    open(relabelled, "wb").write(old)
    r = qbond("run", "--resume", relabelled, "--steps", "25", "--out", fresh("v5_b"), "-q")
    if r.returncode != 2 or "checksum" not in r.stderr:
        fail(f"a version-5 file relabelled 6: exit {r.returncode}, stderr {r.stderr!r}")


def test_output_directory_is_locked():
    """Six runs started at once into one directory: those refused say so (exit 1) and the CSV holds
    one run's rows; a run that holds the directory refuses others, naming its process; the lock
    file a killed run leaves is taken over."""
    out = fresh("locked")
    procs = [subprocess.Popen([QBOND, "run", "cantilever", "--steps", "200", "--every", "10", "--no-vtk", "-q",
                               "--out", out], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(6)]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
    for code, err in results:
        if code not in (0, 1) or (code == 1 and "is in use by another run" not in err):
            fail(f"a concurrent run: exit {code}, stderr {err!r}")
    _, rows = read_csv(os.path.join(out, "diagnostics.csv"))
    if [r[0] for r in rows[1:]] != [str(k) for k in range(0, 201, 10)]:
        fail(f"diagnostics.csv of six concurrent runs: steps {[r[0] for r in rows[1:]]}")
    # Held: a long run, and a second one refused while it runs.
    p = subprocess.Popen([QBOND, "run", "cantilever", "--steps", "10000000", "--no-vtk", "--out", out],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and json.load(open(os.path.join(out, "run.json")))["status"] != "running":
        time.sleep(0.05)
    r = qbond("run", "cantilever", "--steps", "10", "--out", out)
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=120)
    if r.returncode != 1 or f"(process {p.pid})" not in r.stderr or "run.lock" not in r.stderr:
        fail(f"a run into a held directory: exit {r.returncode}, stderr {r.stderr!r}")
    # The lock file now names a dead process: taken over.
    if open(os.path.join(out, "run.lock")).read().strip() != str(p.pid):
        fail("run.lock does not hold the process id of its last owner")
    qbond("run", "cantilever", "--steps", "10", "--out", out, "-q", check_code=0)


def test_failed_runs_end_run_json():
    """A write that fails mid-run (here: a file size limit, as a full disk would) exits 1 naming
    the file, and run.json ends with status "failed" and the reason."""
    import resource

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (100000, 100000))
    out = fresh("failed")
    # The pendulum writes a diagnostics row every step: the limit is reached in a fraction of a second.
    r = subprocess.run([QBOND, "run", "pendulum", "--steps", "1000000", "--every", "1", "--no-vtk", "--out", out, "-q"],
                       capture_output=True, text=True, preexec_fn=limit, timeout=300)
    if r.returncode != 1 or "diagnostics.csv" not in r.stderr:
        fail(f"exit {r.returncode}, stderr {r.stderr!r}")
    run = json.load(open(os.path.join(out, "run.json")))
    if run["status"] != "failed" or "diagnostics.csv" not in run["message"]:
        fail(f"run.json: status {run['status']!r}, message {run.get('message')!r}")


# The exit status ctest reads as "skipped" (SKIP_RETURN_CODE in tests/CMakeLists.txt).
SKIPPED = 77


def test_full_disk_ends_run_json_failed():
    """A run whose outputs fill their file system (a 1 MB tmpfs, mounted in a private mount
    namespace so that nothing outside the test sees it) exits 1 naming the file it could not
    write, run.json ends "failed" with that reason, no temporary file is left, and the checkpoint
    of the last scheduled step before the disk filled is intact: it resumes. Skipped where a tmpfs
    cannot be mounted (not root, or no unshare(1) or mount namespaces)."""
    unshare = shutil.which("unshare")
    if os.geteuid() != 0 or not unshare or \
            subprocess.run([unshare, "--mount", "--propagation", "private", "true"], capture_output=True).returncode:
        print("skipped: mounting a tmpfs needs root and unshare(1) with mount namespaces")
        sys.exit(SKIPPED)
    d = fresh("full_disk")
    mnt, kept = os.path.join(d, "mnt"), os.path.join(d, "kept")
    os.makedirs(mnt)
    every = 10
    # Inside the namespace: mount, run until the disk is full, copy what the run left to the real
    # disk (the tmpfs goes with the namespace). Exit 200 when the mount itself is refused.
    script = ('mount -t tmpfs -o size=1m qbond_full_disk "$1" || exit 200\n'
              '"$2" run pendulum --steps 1000000 --every 1 --checkpoint-every "$4" --out "$1/out" -q\n'
              'code=$?\ncp -a "$1/out" "$3" || exit 201\nexit $code\n')
    r = subprocess.run([unshare, "--mount", "--propagation", "private", "/bin/sh", "-c", script, "sh", mnt, QBOND,
                        kept, str(every)], capture_output=True, text=True, timeout=600)
    if r.returncode == 200:
        print(f"skipped: mount -t tmpfs was refused: {r.stderr.strip()}")
        sys.exit(SKIPPED)
    if r.returncode != 1 or "No space left on device" not in r.stderr or os.path.join(mnt, "out") not in r.stderr:
        fail(f"exit {r.returncode}, stderr {r.stderr!r}")
    run = json.load(open(os.path.join(kept, "run.json")))
    if run["status"] != "failed" or "No space left on device" not in run.get("message", ""):
        fail(f"run.json: status {run['status']!r}, message {run.get('message')!r}")
    left = [f for _, _, files in os.walk(kept) for f in files if ".tmp." in f]
    if left:
        fail(f"temporary files left: {left}")
    # The checkpoint is the last one the schedule asked for: at the failed step's multiple of
    # `every`, or the one before when writing that one is what failed.
    last = run["last_step"]
    again = fresh("full_disk_resumed")
    qbond("run", "--resume", os.path.join(kept, "checkpoint.qbc"), "--steps", str(last + 1), "--no-vtk",
          "--out", again, "-q", check_code=0)
    first = json.load(open(os.path.join(again, "run.json")))["first_step"]
    if first <= 0 or first not in (last // every * every, last // every * every - every):
        fail(f"the checkpoint left is at step {first}; the run failed at step {last}, checkpointing every {every}")


def test_stale_temporaries_are_removed():
    """Temporaries that killed runs left (.checkpoint.qbc.tmp.PID, frames/.frame_*.vtp.tmp.PID)
    are removed when a run starts in the directory; a live process's are kept."""
    out = fresh("stale")
    os.makedirs(os.path.join(out, "frames"))
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = [os.path.join(out, f".checkpoint.qbc.tmp.{dead.pid}"),
             os.path.join(out, "frames", f".frame_0000000010.vtp.tmp.{dead.pid}")]
    live = os.path.join(out, f".run.json.tmp.{os.getpid()}")
    for f in stale + [live]:
        open(f, "w").write("partial")
    qbond("run", "two_quanta", "--steps", "5", "--out", out, "-q", check_code=0)
    if any(os.path.exists(f) for f in stale) or not os.path.exists(live):
        fail(f"left: {[f for f in stale + [live] if os.path.exists(f)]}")


def test_memory_limit():
    """A scene whose run is estimated above --max-memory is refused before it is built, with the
    estimate and the limit (the default's: tests/bad_scenes/memory_too_large.json)."""
    out = fresh("memory")
    for cmd in (["run", "cantilever", "--out", out], ["validate", "cantilever"]):
        r = qbond(*cmd, "--max-memory", "10M")
        if r.returncode != 2 or "would need about" not in r.stderr or "more than the limit of 10 MB (--max-memory)" \
                not in r.stderr:
            fail(f"{cmd[0]} --max-memory 10M: exit {r.returncode}, stderr {r.stderr!r}")
    r = qbond("run", "cantilever", "--max-memory", "lots", "--out", out)
    if r.returncode != 2 or "--max-memory" not in r.stderr:
        fail(f"--max-memory lots: exit {r.returncode}, stderr {r.stderr!r}")
    qbond("run", "cantilever", "--steps", "5", "--max-memory", "1GiB", "--out", out, "-q", check_code=0)
    r = qbond("run", "--resume", os.path.join(out, "checkpoint.qbc"), "--max-memory", "10M", "-q")
    if r.returncode != 2 or "more than the limit" not in r.stderr:
        fail(f"resume --max-memory 10M: exit {r.returncode}, stderr {r.stderr!r}")


def test_folder_named_like_a_builtin_scene():
    """A run's output folder named like a built-in scene does not hide the scene: a bare name is
    the built-in scene (with a note naming the folder), ./NAME the folder, NAME.json or a path with
    a '/' a file."""
    d = fresh("shadow")
    os.makedirs(d)
    qbond("run", "cantilever", "--steps", "5", "-o", "cantilever", "-q", cwd=d, check_code=0)
    r = qbond("run", "cantilever", "--steps", "5", "-o", "again", cwd=d, check_code=0)
    if "running cantilever:" not in r.stdout or "for the folder of that name, write ./cantilever" not in r.stderr:
        fail(f"the built-in scene behind a folder of its name:\n{r.stdout}\n{r.stderr}")
    r = qbond("validate", "./cantilever", cwd=d)
    if r.returncode != 2 or "a directory, not a regular file" not in r.stderr:
        fail(f"./cantilever (a folder): exit {r.returncode}, stderr {r.stderr!r}")
    # A file of a built-in scene's name: the bare name is still the built-in scene, ./NAME the file.
    with open(os.path.join(d, "pendulum"), "w") as f:
        json.dump({"name": "my_pendulum", "timestep": 1e-3, "steps": 2, "materials": {"m": {"stiffness": 10}},
                   "bodies": [{"name": "rope", "type": "chain", "start": [0, 0, 0], "end": [0.1, 0, 0], "count": 2,
                               "quanta_mass": 1, "material": "m"}]}, f)
    if "my_pendulum" not in qbond("validate", "./pendulum", cwd=d, check_code=0).stdout:
        fail("./pendulum did not load the file")
    r = qbond("validate", "pendulum", cwd=d, check_code=0)
    if "my_pendulum" in r.stdout or "for the file of that name, write ./pendulum" not in r.stderr:
        fail(f"pendulum with a file of that name:\n{r.stdout}\n{r.stderr}")
    r = qbond("validate", "no_such_scene", cwd=d)
    if r.returncode != 2 or "unknown built-in scene 'no_such_scene'" not in r.stderr:
        fail(f"an unknown name: exit {r.returncode}, stderr {r.stderr!r}")


def test_resume_with_nothing_to_run():
    """A resume whose end is at or before the checkpoint's step is refused (exit 2) saying where
    the checkpoint is, and writes nothing: the finished run's files are left as they were."""
    out = fresh("nothing_to_run")
    qbond("run", "cantilever", "--steps", "40", "--every", "10", "--no-vtk", "--out", out, "-q", check_code=0)
    ck = os.path.join(out, "checkpoint.qbc")
    before = {f: open(os.path.join(out, f), "rb").read() for f in ("run.json", "diagnostics.csv", "checkpoint.qbc")}
    for args, says in ((["--steps", "10"], "past the run's end at step 10"),
                       ([], "already at the run's end at step 40")):
        r = qbond("run", "--resume", ck, *args, "-q")
        if r.returncode != 2 or "the checkpoint is at step 40" not in r.stderr or says not in r.stderr \
                or "--steps above 40" not in r.stderr:
            fail(f"resume {args}: exit {r.returncode}, stderr {r.stderr!r}")
        for f, data in before.items():
            if open(os.path.join(out, f), "rb").read() != data:
                fail(f"resume {args} rewrote {f}")
    qbond("run", "--resume", ck, "--steps", "41", "-q", check_code=0)
    # An adaptive run ends at a time: the same for its horizon.
    out = fresh("nothing_to_run_adaptive")
    qbond("run", "adaptive_pendulum", "--duration", "0.05", "--no-vtk", "--out", out, "-q", check_code=0)
    r = qbond("run", "--resume", os.path.join(out, "checkpoint.qbc"), "-q")
    if r.returncode != 2 or "already at the run's end at t = " not in r.stderr or "--duration beyond" not in r.stderr:
        fail(f"adaptive resume: exit {r.returncode}, stderr {r.stderr!r}")


def test_options_that_do_not_apply_are_refused():
    """An integrator option the chosen integrator (or its solver) does not read is refused with
    exit 2, naming the integrators that read it, rather than ignored."""
    out = fresh("unread_options")
    for args, says in (
            (["--integrator", "coupled_implicit", "--neighbours", "frozen", "--iterations", "5"],
             "--neighbours does not apply to the integrator coupled_implicit (it is read by hybrid_implicit)"),
            (["--integrator", "coupled_implicit", "--iterations", "5"],
             "--iterations does not apply to the integrator coupled_implicit"),
            (["--integrator", "velocity_verlet", "--solver", "cg"],
             "--solver does not apply to the integrator velocity_verlet"),
            (["--integrator", "hybrid_implicit", "--preconditioner", "multigrid"],
             "--preconditioner does not apply to the integrator hybrid_implicit"),
            (["--integrator", "coupled_implicit", "--solver", "ldlt", "--tolerance", "1e-3"],
             "--tolerance applies to coupled_implicit with the solver cg only, not ldlt"),
            (["--integrator", "coupled_implicit", "--solver", "dense", "--preconditioner", "multigrid"],
             "--preconditioner applies to coupled_implicit with the solver cg only, not dense"),
            (["--integrator", "bdf2", "--iterations", "3"], "--iterations applies to bdf2 with the solver sweep only")):
        r = qbond("run", "two_quanta", "--steps", "3", "--out", out, *args)
        if r.returncode != 2 or says not in r.stderr or os.path.exists(out):
            fail(f"{args}: exit {r.returncode}, stderr {r.stderr!r}")
    # Each of them where it applies.
    for args in (["--integrator", "hybrid_implicit", "--neighbours", "frozen", "--iterations", "2", "--tolerance", "1e-3"],
                 ["--integrator", "coupled_implicit", "--solver", "cg", "--preconditioner", "multigrid"],
                 ["--integrator", "bdf2", "--solver", "sweep", "--iterations", "3"]):
        qbond("run", "two_quanta", "--steps", "3", "--out", out, "-q", *args, check_code=0)


def test_help_shows_no_parser_internals():
    """Every command's --help is the program's words: no default values in braces, no enumeration
    maps, no validator names (CLI11's '{false}', 'ENUM:value in {plain->2,...}', 'INT:POSITIVE',
    'Needs:')."""
    for cmd in ([], ["run"], ["validate"], ["statics"], ["export"], ["schema"], ["key-tables"], ["experiment"], ["bench"], ["view"]):
        r = qbond(*cmd, "--help", check_code=0)
        for internal in ("{false}", "{true}", "ENUM", "->", "value in {", "INT:", "FLOAT:", "TEXT:", "Needs:",
                         "Excludes:", " in ["):
            if internal in r.stdout:
                fail(f"qbond {' '.join(cmd)} --help shows {internal!r}:\n{r.stdout}")
    r = qbond("view", "--help", check_code=0)
    if ("--bonds strain|tension|plain" not in r.stdout or "--no-ui " not in r.stdout
            or "--size N (64 to 8192)" not in r.stdout):
        fail(f"view --help:\n{r.stdout}")
    r = qbond("run", "--help", check_code=0)
    if "--steps N (not with --duration)" not in r.stdout:
        fail(f"run --help:\n{r.stdout}")


def bar_scene(path, count, stiffness, force, anchored=True):
    """A chain along x of `count` quanta 1 cm apart, bonds of `stiffness` [N/m], the first quanta
    anchored (or not) and `force` [N] pulling the last one along x."""
    with open(path, "w") as f:
        json.dump({"timestep": 1e-3, "steps": 10,
                   "materials": {"m": {"stiffness": stiffness}},
                   "bodies": [{"name": "bar", "type": "chain", "start": [0, 0, 0], "end": [0.01 * (count - 1), 0, 0],
                               "count": count, "quanta_mass": 1e-3, "material": "m"}],
                   "anchors": [{"select": {"ids": [0]}}] if anchored else [],
                   "loads": [{"select": {"ids": [count - 1]}, "force": [force, 0, 0]}],
                   "output": {"probes": [{"name": "support", "select": {"ids": [0]}}]}}, f)


def test_statics_of_a_loaded_bar():
    """`qbond statics` on a bar of N quanta (N - 1 bonds of stiffness k) held at one end and pulled
    by F at the other: every bond carries F, quanta m moves m F / k (exact for linear bonds along
    their axis), the reaction is -F, and the outputs are a run's kinds (CSV, VTK, JSON)."""
    d = fresh("statics")
    os.makedirs(d)
    scene, out = os.path.join(d, "bar.json"), os.path.join(d, "out")
    count, k, force = 11, 250.0, 0.5
    bar_scene(scene, count, k, force)
    r = qbond("statics", scene, "-o", out, check_code=0)
    if "equilibrium after" not in r.stdout:
        fail(f"stdout:\n{r.stdout}")
    # Newton stops at a force residual of 1e-8 F: a displacement within 1e-8 F of compliance at
    # most (N - 1) / k, a tension within 1e-8 F of the N forces summed.
    tol = 1e-8
    _, rows = read_csv(os.path.join(out, "quanta.csv"))
    col = {name: c for c, name in enumerate(rows[0])}
    if len(rows) != count + 1:
        fail(f"quanta.csv has {len(rows) - 1} rows, expected {count}")
    for row in rows[1:]:
        i = int(row[col["id"]])
        ux, uy, uz = (float(row[col[c]]) for c in ("ux", "uy", "uz"))
        if abs(ux - i * force / k) > tol * force / k * count or abs(uy) > 1e-15 or abs(uz) > 1e-15:
            fail(f"quanta {i}: u = ({ux}, {uy}, {uz}), expected ({i * force / k}, 0, 0)")
        rx = float(row[col["rx"]])
        if abs(rx - (-force if i == 0 else 0)) > tol * force:
            fail(f"quanta {i}: reaction {rx}")
        if abs(float(row[col["x"]]) - 0.01 * i - ux) > 1e-15:
            fail(f"quanta {i}: position and displacement disagree")
    _, bonds = read_csv(os.path.join(out, "bonds.csv"))
    if len(bonds) != count or any(abs(float(b[4]) - force) > tol * force * count for b in bonds[1:]) \
            or any(abs(float(b[3]) - force / k / 0.01) > tol for b in bonds[1:]):
        fail(f"bond tensions and strains {bonds}")
    st = json.load(open(os.path.join(out, "statics.json")))
    if not st["converged"] or st["residual"] > tol or abs(st["load"][0] - force) > 1e-15 \
            or abs(st["load"][0] + st["reaction"][0]) > tol * force * count:
        fail(f"statics.json: {st}")
    # The probe on the support reports the same reaction as a run's diagnostics row.
    _, diag = read_csv(os.path.join(out, "diagnostics.csv"))
    dcol = {name: c for c, name in enumerate(diag[0])}
    if len(diag) != 2 or abs(float(diag[1][dcol["support_fx"]]) + force) > tol * force:
        fail(f"diagnostics.csv: {diag}")
    vtp = open(os.path.join(out, "static.vtp"), "rb").read()
    for needle in (b'NumberOfPoints="11"', b'Name="displacement"', b'Name="reaction"', b'Name="von_mises"'):
        if needle not in vtp:
            fail(f"static.vtp lacks {needle!r}")
    # A bar pulled but held nowhere has no equilibrium: exit 3, said, the outputs still written.
    bar_scene(scene, count, k, force, anchored=False)
    out = os.path.join(d, "free")
    r = qbond("statics", scene, "-o", out, "-q")
    if r.returncode != 3 or "no equilibrium" not in r.stderr:
        fail(f"a free bar: exit {r.returncode}, stderr {r.stderr!r}")
    if json.load(open(os.path.join(out, "statics.json")))["converged"]:
        fail("a free bar converged")
    # A slender beam under its weight: Newton's steps rotate bonds, which the line search must
    # not mistake for a lack of progress. The clamp holds the weight to the tolerance.
    out = os.path.join(d, "cantilever")
    qbond("statics", "cantilever", "-o", out, "-q", check_code=0)
    st = json.load(open(os.path.join(out, "statics.json")))
    if st["iterations"] > 10 or any(abs(l + r) > 1e-8 * abs(st["load"][2]) for l, r in zip(st["load"], st["reaction"])):
        fail(f"cantilever: {st['iterations']} iterations, load {st['load']}, reaction {st['reaction']}")


def test_twist_and_hold_scene():
    """scenes/twist_and_hold.json turns its bar's end to 30 degrees in 0.5 s by one smooth
    keyframe, then holds it: the end's quanta stand exactly at the turn w(s) = 3s^2 - 2s^3 of 30
    degrees at each frame (half of it at 0.25 s), the same at 0.5 s and 1 s; at the end the bar,
    twisted and come to rest, needs opposite torques about its axis from its two supports (their
    sum is the rate of change of its angular momentum)."""
    import math
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    out = fresh("twist_and_hold")
    qbond("run", os.path.join(SOURCE, "scenes", "twist_and_hold.json"), "--every", "125", "-o", out, "-q",
          check_code=0)

    def points(step):
        r = vtkXMLPolyDataReader()
        r.SetFileName(os.path.join(out, "frames", f"frame_{step:010d}.vtp"))
        r.Update()
        data = r.GetOutput()
        ids = data.GetPointData().GetArray("id")
        return {int(ids.GetValue(k)): data.GetPoint(k) for k in range(data.GetNumberOfPoints())}
    start = points(0)
    end = [i for i, p in start.items() if p[0] > 0.189]
    if len(end) != 16:
        fail(f"{len(end)} quanta at the twisted end, expected 4 x 4")
    c = (0.19, 0.015, 0.015)
    for step in (125, 250, 375, 500, 1000):
        s = min(step / 500, 1.0)
        angle = math.radians(30) * s * s * (3 - 2 * s)
        now = points(step)
        for i in end:
            y, z = start[i][1] - c[1], start[i][2] - c[2]
            want = (start[i][0], c[1] + y * math.cos(angle) - z * math.sin(angle),
                    c[2] + y * math.sin(angle) + z * math.cos(angle))
            if max(abs(a - b) for a, b in zip(now[i], want)) > 1e-12:
                fail(f"step {step}: quanta {i} at {now[i]}, expected {want}")
    _, rows = read_csv(os.path.join(out, "diagnostics.csv"))
    col = {name: k for k, name in enumerate(rows[0])}
    last = rows[-1]
    held, twisted = float(last[col["held_end_tx"]]), float(last[col["twisted_end_tx"]])
    if not (held < 0 < twisted) or abs(held + twisted) > 1e-6 * abs(held):
        fail(f"torques about the bar's axis at the end: held {held}, twisted {twisted} N m")


def schema_errors(schema, value, node=None, path="", root=None):
    """The places where `value` breaks `node` (of `schema`): the draft-07 keywords the scene
    schema uses ($ref, type, properties, additionalProperties, required, items, minItems,
    maxItems, minProperties, enum, const, allOf, anyOf, not, if/then/else)."""
    node = schema if node is None else node
    if "$ref" in node:
        node = schema["definitions"][node["$ref"].split("/")[-1]]
    kinds = {"object": dict, "array": list, "string": str, "boolean": bool}
    t = node.get("type")
    if t == "number" and not (isinstance(value, (int, float)) and not isinstance(value, bool)) \
            or t == "integer" and not (isinstance(value, int) and not isinstance(value, bool)) \
            or t in kinds and not isinstance(value, kinds[t]):
        return [f"{path}: not a {t}"]
    errors = []
    if "enum" in node and value not in node["enum"]:
        errors.append(f"{path}: {value!r} not in {node['enum']}")
    if "const" in node and value != node["const"]:
        errors.append(f"{path}: {value!r} is not {node['const']!r}")
    if isinstance(value, dict):
        props = node.get("properties", {})
        for k in node.get("required", []):
            if k not in value:
                errors.append(f"{path}.{k}: required")
        if len(value) < node.get("minProperties", 0):
            errors.append(f"{path}: too few keys")
        for k, v in value.items():
            if k in props:
                errors += schema_errors(schema, v, props[k], f"{path}.{k}")
            elif node.get("additionalProperties") is False:
                errors.append(f"{path}.{k}: unknown key")
            elif isinstance(node.get("additionalProperties"), dict):
                errors += schema_errors(schema, v, node["additionalProperties"], f"{path}.{k}")
    if isinstance(value, list):
        if not node.get("minItems", 0) <= len(value) <= node.get("maxItems", len(value)):
            errors.append(f"{path}: {len(value)} items")
        if "items" in node:
            for k, v in enumerate(value):
                errors += schema_errors(schema, v, node["items"], f"{path}[{k}]")
    for sub in node.get("allOf", []):
        errors += schema_errors(schema, value, sub, path)
    if "anyOf" in node and all(schema_errors(schema, value, sub, path) for sub in node["anyOf"]):
        errors.append(f"{path}: matches none of anyOf")
    if "not" in node and not schema_errors(schema, value, node["not"], path):
        errors.append(f"{path}: matches 'not'")
    if "if" in node:
        branch = node.get("then") if not schema_errors(schema, value, node["if"], path) else node.get("else")
        if branch is not None:
            errors += schema_errors(schema, value, branch, path)
    return errors


def test_schema_matches_the_reader():
    """`qbond schema` is docs/scene.schema.json, byte for byte; every built-in scene (comments
    aside) passes it, annotated ones too, and each bad scene the reader refuses for an unknown key
    or type the schema refuses as well."""
    r = qbond("schema", check_code=0)
    committed = open(os.path.join(SOURCE, "docs", "scene.schema.json")).read()
    if r.stdout != committed:
        fail("docs/scene.schema.json differs from `qbond schema`: regenerate it (qbond schema > docs/scene.schema.json)")
    schema = json.loads(r.stdout)
    scenes = sorted(f for f in os.listdir(os.path.join(SOURCE, "scenes")) if f.endswith(".json"))
    if len(scenes) < 20:
        fail(f"only {len(scenes)} scenes")
    for name in scenes:
        scene = json.load(open(os.path.join(SOURCE, "scenes", name)))
        errors = schema_errors(schema, scene)
        if errors:
            fail(f"scenes/{name} breaks the schema the reader accepts it by: {errors[:5]}")
        # Notes on every object are accepted by both.
        def annotate(v):
            if isinstance(v, dict):
                return {**{k: annotate(x) for k, x in v.items()}, "notes": ["a note"]}
            return [annotate(x) for x in v] if isinstance(v, list) else v
        noted = annotate(scene)
        # Motions and the materials map take notes beside their entries as well.
        errors = schema_errors(schema, noted)
        if errors:
            fail(f"scenes/{name} with notes everywhere: {errors[:5]}")
    # The reader's unknown keys and wrong types are the schema's.
    refused = 0
    for line in open(os.path.join(BAD_SCENES, "expected.txt")):
        if line.startswith("#") or "\t" not in line:
            continue
        name, says = line.rstrip("\n").split("\t", 1)
        if not any(w in says for w in ("unknown key", "unknown body type", "expected a number", "expected an object",
                                        "unknown heuristic")):
            continue
        if not schema_errors(schema, json.load(open(os.path.join(BAD_SCENES, name)))):
            fail(f"{name} (the reader says {says!r}) passes the schema")
        refused += 1
    if refused < 5:
        fail(f"only {refused} bad scenes of unknown keys or types")
    # A key no object takes, put in each object of a few scenes in turn: refused by both, and
    # every kind of object met on the way.
    d = fresh("schema")
    os.makedirs(d)
    kinds = set()

    def objects(v, path=()):
        if isinstance(v, dict):
            yield path
            for k, x in v.items():
                yield from objects(x, path + (k,))
        elif isinstance(v, list):
            for k, x in enumerate(v):
                yield from objects(x, path + (k,))
    for name in ("collision.json", "gas_and_block.json", "liquid_blob.json", "plastic_beam.json", "twisted_bar.json"):
        scene = json.load(open(os.path.join(SOURCE, "scenes", name)))
        for path in objects(scene):
            broken = json.loads(json.dumps(scene))
            target = broken
            for k in path:
                target = target[k]
            target["no_such_key"] = 1
            if not any("no_such_key" in e for e in schema_errors(schema, broken)):
                fail(f"{name} with no_such_key at {path} passes the schema")
            f = os.path.join(d, "broken.json")
            json.dump(broken, open(f, "w"))
            v = qbond("validate", f)
            if v.returncode != 2 or "no_such_key" not in v.stderr:
                fail(f"{name} with no_such_key at {path}: the reader says {v.stderr!r}")
            kinds.add(path[-2] if len(path) >= 2 and isinstance(path[-1], int) else path[-1] if path else "scene")
    if len(kinds) < 12:
        fail(f"too few kinds of object tried: {sorted(map(str, kinds))}")
def test_default_never_gains_energy():
    """scenes/four_quanta.json at h = 5 s: the default integrator's linearised step would take the
    2 J of the four quanta to 86.8 J in one step; retaken in substeps, no row of diagnostics.csv
    exceeds the initial energy, and the run reports no gain."""
    out = fresh("no_gain")
    r = qbond("run", "four_quanta", "--dt", "5", "--steps", "200", "--every", "1", "--out", out, check_code=0)
    if "warning" in r.stderr:
        fail(f"the default integrator's run warns: {r.stderr}")
    _, rows = read_csv(os.path.join(out, "diagnostics.csv"))
    col = {name: k for k, name in enumerate(rows[0])}
    e0 = float(rows[1][col["total"]])
    worst = max(float(row[col["total"]]) for row in rows[1:])
    if abs(e0 - 2.0) > 1e-12 or worst > e0 * (1 + 1e-8):
        fail(f"the energy went from {e0} J to {worst} J")
    if len(rows) != 202:
        fail(f"{len(rows) - 1} rows, expected 201")
    run = json.load(open(os.path.join(out, "run.json")))
    if run["status"] != "completed" or run["energy_gain"]["exceeded"]:
        fail(f"run.json: {run['status']}, {run['energy_gain']}")


def pendulum_stopping_on_energy_gain(d):
    """The pendulum scene with limits.stop_on_energy_gain, written into the new directory d."""
    os.makedirs(d)
    scene = json.load(open(os.path.join(SOURCE, "scenes", "pendulum.json")))
    scene["limits"] = {"stop_on_energy_gain": True}
    path = os.path.join(d, "pendulum.json")
    json.dump(scene, open(path, "w"))
    return path


def test_no_ledger():
    """--no-ledger steps the same bits (velocity Verlet: the ledger only watches it), writes the
    ledger's columns as nan and run.json's run.ledger false, keeps that in its checkpoint, and is
    refused, before anything is written, beside what reads the ledger every step."""
    runs = {}
    for name, extra in (("ledger", []), ("no_ledger", ["--no-ledger"])):
        out = fresh("ledger_" + name)
        qbond("run", "pendulum", "--integrator", "velocity_verlet", "--dt", "1e-4", "--steps", "200", "--every", "20",
              "--out", out, "-q", *extra, check_code=0)
        runs[name] = out
    _, with_books = read_csv(os.path.join(runs["ledger"], "diagnostics.csv"))
    _, without = read_csv(os.path.join(runs["no_ledger"], "diagnostics.csv"))
    header = with_books[0]
    books = {"dissipated", "work", "numerical_damping", "numerical"}
    if not books <= set(header) or len(with_books) != len(without):
        fail(f"diagnostics: header {header}, {len(with_books)} and {len(without)} rows")
    for a, b in zip(with_books[1:], without[1:]):
        for column, x, y in zip(header, a, b):
            if column in books:
                if y != "nan" or x == "nan":
                    fail(f"step {a[0]} {column}: {x} with the ledger, {y} without")
            elif x != y:
                fail(f"step {a[0]} {column}: {x} with the ledger, {y} without: the steps differ")
    if json.load(open(os.path.join(runs["no_ledger"], "run.json")))["run"]["ledger"] is not False:
        fail("run.json: run.ledger is not false")
    qbond("run", "--resume", os.path.join(runs["no_ledger"], "checkpoint.qbc"), "--steps", "240", "-q", check_code=0)
    _, resumed = read_csv(os.path.join(runs["no_ledger"], "diagnostics.csv"))
    if resumed[-1][0] != "240" or resumed[-1][header.index("numerical")] != "nan":
        fail(f"resumed: last row {resumed[-1]}")
    # Refused: the adaptive step and stop_on_energy_gain read the ledger every step.
    d = fresh("ledger_refused")
    stopping = pendulum_stopping_on_energy_gain(d)
    for path, why in ((os.path.join(SOURCE, "scenes", "adaptive_pendulum.json"), "the adaptive step"),
                      (stopping, "limits.stop_on_energy_gain")):
        out = os.path.join(d, "out")
        r = qbond("run", path, "--no-ledger", "--out", out)
        if r.returncode != 2 or "--no-ledger: " + why not in r.stderr or os.path.exists(out):
            fail(f"{path} --no-ledger: exit {r.returncode}, stderr {r.stderr!r}")


def test_energy_gain_is_reported():
    """hybrid_implicit (one sweep a step, its default) on the pendulum at 1/60 s pumps energy: the
    run warns, events.csv has an energy_gain row, run.json says exceeded; with
    limits.stop_on_energy_gain the run ends there with exit status 3."""
    out = fresh("gain")
    r = qbond("run", "pendulum", "--integrator", "hybrid_implicit", "--neighbours", "sweep", "--dt", "0.0166667",
              "--steps", "180", "--out", out, check_code=0)
    if "warning: the energy exceeded its initial value plus the external work" not in r.stderr:
        fail(f"no warning: {r.stderr!r}")
    run = json.load(open(os.path.join(out, "run.json")))
    gain = run["energy_gain"]
    if run["status"] != "completed" or not gain["exceeded"] or not gain["relative"] > gain["limit"]:
        fail(f"run.json: {run['status']}, {gain}")
    _, rows = read_csv(os.path.join(out, "events.csv"))
    hits = [row for row in rows[1:] if row[2] == "energy_gain"]
    if len(hits) != 1 or int(hits[0][0]) != gain["first_step"]:
        fail(f"events.csv energy_gain rows: {hits}, run.json first_step {gain['first_step']}")
    # The same run told to stop at the gain, from a scene file with the key.
    d = fresh("gain_stop")
    path = pendulum_stopping_on_energy_gain(d)
    r = qbond("run", path, "--integrator", "hybrid_implicit", "--neighbours", "sweep", "--dt", "0.0166667",
              "--steps", "180", "--out", os.path.join(d, "out"), "-q")
    if r.returncode != 3 or "energy gained at step" not in r.stderr:
        fail(f"stop_on_energy_gain: exit {r.returncode}, stderr {r.stderr!r}")
    run = json.load(open(os.path.join(d, "out", "run.json")))
    if run["status"] != "blowup" or run["last_step"] >= 180:
        fail(f"stop_on_energy_gain: run.json {run['status']} at step {run['last_step']}")



def lammps_sections(path):
    """The sections of a LAMMPS data file: {keyword: [entry lines]} (comments and blank lines
    dropped), and the header's bond-type comments {type: description}."""
    sections, current, comments = {}, None, {}
    for line in open(path).read().splitlines()[1:]:
        if line.startswith("# bond type "):
            t, _, rest = line[len("# bond type "):].partition(":")
            comments[int(t)] = rest.strip()
        text = line.split("#")[0].strip()
        if not text:
            continue
        if text[0].isalpha():
            current = text
            sections[current] = []
        elif current:
            sections[current].append(text)
    return sections, comments


def bond_set(sections, comments):
    """A data file's bonds as {(smaller atom ID, larger atom ID): the bond type's law and numbers}."""
    out = {}
    for line in sections.get("Bonds", []):
        _, t, a, b = line.split()
        out[tuple(sorted((int(a), int(b))))] = comments.get(int(t), t)
    return out


def same_structure(a, b):
    """Two data files qbond wrote hold the same structure: the same header counts, masses,
    atoms (but for their molecule IDs: a scene read from a data file is one body), velocities
    and bonds, character for character."""
    sa, ca = lammps_sections(a)
    sb, cb = lammps_sections(b)
    for section in ("Masses", "Atoms", "Velocities"):
        la, lb = sa.get(section, []), sb.get(section, [])
        if section == "Atoms":
            la, lb = ([" ".join(x.split()[:1] + x.split()[2:]) for x in lines] for lines in (la, lb))
        if la != lb or not la:
            diff = [(x, y) for x, y in zip(la, lb) if x != y][:3]
            fail(f"{section} of {a} and {b} differ: {diff or (len(la), len(lb))}")
    if bond_set(sa, ca) != bond_set(sb, cb) or not bond_set(sa, ca):
        fail(f"the bonds of {a} and {b} differ")


LAMMPS_SCENE = {
    "timestep": 0.001, "steps": 1,
    "materials": {"steel": {"stiffness": 20000, "damping": 0.5}, "rope": {"stiffness": 300}},
    "bodies": [
        {"name": "block", "type": "lattice", "cell": "cubic", "size": [4, 3, 2], "spacing": 0.0137,
         "material": "steel", "quanta_mass": 0.0123, "velocity": [0.1, -0.2, 0.3],
         "origin": [0.01, 0.02, 0.1], "rotation": {"axis": [1, 2, 3], "angle": 0.3}},
        {"name": "rope", "type": "chain", "start": [0.1, 0.03, 0.12], "end": [0.25, 0.03, 0.12], "count": 7,
         "material": "rope", "total_mass": 0.031}]}


def reading_scene(data, materials):
    return {"timestep": 0.001, "steps": 1, "materials": LAMMPS_SCENE["materials"],
            "bodies": [{"name": "read", "type": "lammps", "file": data, "bond_materials": materials}]}


def test_export_lammps():
    """`qbond export SCENE --lammps FILE` writes a data file whose header counts match its
    sections, and which a `lammps` body reads back as the same structure: exporting that scene
    again writes the same atoms, velocities, masses and bonds, character for character."""
    d = fresh("export_lammps")
    os.makedirs(d)
    scene = os.path.join(d, "scene.json")
    json.dump(LAMMPS_SCENE, open(scene, "w"))
    first = os.path.join(d, "first.data")
    r = qbond("export", scene, "--lammps", first, check_code=0)
    if "wrote" not in r.stdout or "31 atoms" not in r.stdout:
        fail(r.stdout)
    sections, comments = lammps_sections(first)
    header = open(first).read()
    atoms = len(sections["Atoms"])
    if atoms != 31 or f"\n{atoms} atoms\n" not in header:
        fail(f"{atoms} atom lines; header:\n{header[:400]}")
    if f"\n{len(sections['Bonds'])} bonds\n" not in header or "2 atom types" not in header or "2 bond types" not in header:
        fail(header[:400])
    if sorted(comments.values()) != sorted(["linear, stiffness 20000, damping 0.5 (axial)",
                                            "linear, stiffness 300, damping 0 (axial)"]):
        fail(f"bond type comments {comments}")
    names = ["steel" if "20000" in comments[t] else "rope" for t in sorted(comments)]
    again = os.path.join(d, "again.json")
    json.dump(reading_scene(first, names), open(again, "w"))
    second = os.path.join(d, "second.data")
    qbond("export", again, "--lammps", second, "-q", check_code=0)
    same_structure(first, second)
    # Refusals: no such directory, a bond type without a material, a bad line.
    r = qbond("export", scene, "--lammps", os.path.join(d, "nowhere", "x.data"), check_code=2)
    if "no directory" not in r.stderr:
        fail(r.stderr)
    json.dump(reading_scene(first, ["steel"]), open(again, "w"))
    r = qbond("validate", again, check_code=2)
    if "bond_materials: expected 2 material names" not in r.stderr:
        fail(r.stderr)
    broken = os.path.join(d, "broken.data")
    open(broken, "w").write(open(first).read().replace("\nAtoms # bond\n\n1 ", "\nAtoms # bond\n\n1 x "))
    json.dump(reading_scene(broken, names), open(again, "w"))
    r = qbond("validate", again, check_code=2)
    if "broken.data:" not in r.stderr or "an Atoms line of this style" not in r.stderr:
        fail(r.stderr)


def test_lammps_reads_the_export():
    """LAMMPS itself (`lmp`, when installed; the test is skipped without it) reads an export with
    read_data and writes it back with write_data; qbond reads LAMMPS's file as the same structure:
    the same atoms, velocities and masses (re-exported character for character) and bonds."""
    lmp = shutil.which("lmp") or shutil.which("lmp_serial")
    if not lmp:
        print("SKIP: LAMMPS (lmp) is not installed")
        sys.exit(77)
    d = fresh("lammps_reads")
    os.makedirs(d)
    scene = os.path.join(d, "scene.json")
    json.dump(LAMMPS_SCENE, open(scene, "w"))
    ours = os.path.join(d, "ours.data")
    qbond("export", scene, "--lammps", ours, "-q", check_code=0)
    theirs = os.path.join(d, "theirs.data")
    script = os.path.join(d, "in.lmp")
    open(script, "w").write(f"units si\natom_style bond\nboundary f f f\nread_data {ours}\nwrite_data {theirs}\n")
    r = subprocess.run([lmp, "-in", script, "-log", "none", "-screen", "none"], capture_output=True, text=True, cwd=d)
    if r.returncode != 0 or not os.path.exists(theirs):
        fail(f"lmp: exit {r.returncode}\n{r.stdout}\n{r.stderr}")
    _, comments = lammps_sections(ours)
    names = ["steel" if "20000" in comments[t] else "rope" for t in sorted(comments)]
    again = os.path.join(d, "again.json")
    json.dump(reading_scene(theirs, names), open(again, "w"))
    back = os.path.join(d, "back.data")
    qbond("export", again, "--lammps", back, "-q", check_code=0)
    same_structure(ours, back)


def test_file_body_scenes():
    """The example scenes of the file-reading bodies build what their files hold: the tet_mesh
    bar (81 nodes, 344 unique edges of 192 tetrahedra), the CSV truss (13 quanta, 23 bonds) and
    the LAMMPS data file LAMMPS wrote (31 atoms)."""
    for name, quanta, bonds in (("tet_bar", 81, 344), ("csv_truss", 13, 23), ("lammps_drop", 31, None)):
        for arg in (os.path.join(SOURCE, "scenes", name + ".json"), name):  # the built-in one reads its files compiled in
            r = qbond("validate", arg, check_code=0)
            counts = {k: int(v) for k, v in re.findall(r"^  (quanta|bonds) +(\d+)", r.stdout, re.M)}
            if counts.get("quanta") != quanta or (bonds is not None and counts.get("bonds") != bonds):
                fail(f"{arg}: {r.stdout}")

def test_tet_bar_statics():
    """`qbond statics` on the tet_mesh bar clamped at x = 0: the load is the weight of the free
    nodes, g ρ Σ V_i with V_i the lumped volumes recomputed here from scenes/meshes/bar.msh (a
    quarter of each tetrahedron's volume to each of its nodes), and the clamp's reaction balances
    it to Newton's tolerance (1e-8 of the load)."""
    lines = open(os.path.join(SOURCE, "scenes", "meshes", "bar.msh")).read().split("\n")
    start = lines.index("$Nodes")
    nodes = {}
    for line in lines[start + 2:start + 2 + int(lines[start + 1])]:
        tag, x, y, z = line.split()
        nodes[int(tag)] = (float(x), float(y), float(z))
    start = lines.index("$Elements")
    volume = {tag: 0.0 for tag in nodes}
    for line in lines[start + 2:start + 2 + int(lines[start + 1])]:
        f = [int(v) for v in line.split()]
        tet = f[3 + f[2]:]
        a, b, c, d = (nodes[t] for t in tet)
        u, v, w = ([q[k] - a[k] for k in range(3)] for q in (b, c, d))
        det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])
        for t in tet:
            volume[t] += abs(det) / 24
    free = sum(v for tag, v in volume.items() if nodes[tag][0] > 0.001)
    expected = -9.81 * 1000 * free
    d = fresh("tet_bar_statics")
    qbond("statics", os.path.join(SOURCE, "scenes", "tet_bar.json"), "-o", d, "--no-vtk", "-q", check_code=0)
    result = json.load(open(os.path.join(d, "statics.json")))
    load, reaction = result["load"], result["reaction"]
    if abs(load[2] - expected) > 1e-12 * abs(expected) or abs(load[0]) > 0 or abs(load[1]) > 0:
        fail(f"load {load}, expected [0, 0, {expected}]")
    if any(abs(load[k] + reaction[k]) > 1e-8 * abs(expected) for k in range(3)):
        fail(f"reaction {reaction} does not balance the load {load}")



def test_key_tables_match_the_declarations():
    """`qbond key-tables --check` passes on the committed docs; on a copy with a stale table it
    fails naming the command, and `qbond key-tables` writes the committed text back."""
    docs = [os.path.join(SOURCE, "docs", f) for f in ("scene-format.md", "heuristics.md")]
    r = qbond("key-tables", "--check", *docs)
    if r.returncode != 0:
        fail(f"the docs' key tables differ from the declarations: run build/qbond key-tables "
             f"docs/scene-format.md docs/heuristics.md\n{r.stderr}")
    d = fresh("key_tables")
    os.makedirs(d)
    copy = os.path.join(d, "scene-format.md")
    committed = open(docs[0]).read()
    stale = committed.replace("| `damping_zone` |", "| `damping_zone_old` |")
    if stale == committed:
        fail("docs/scene-format.md has no `damping_zone` row to make stale")
    open(copy, "w").write(stale)
    r = qbond("key-tables", "--check", copy, check_code=1)
    if "regenerate: qbond key-tables" not in r.stderr or open(copy).read() != stale:
        fail(f"--check on a stale table: {r.stderr!r}, or it wrote the file")
    qbond("key-tables", copy, check_code=0)
    if open(copy).read() != committed:
        fail("qbond key-tables did not write the committed tables back")
    open(copy, "w").write("no tables\n")
    r = qbond("key-tables", copy, check_code=2)
    if "no <!-- keys:NAME --> table" not in r.stderr:
        fail(f"a file without tables: {r.stderr!r}")


if __name__ == "__main__":
    os.makedirs(WORK, exist_ok=True)
    globals()["test_" + sys.argv[4]]()
    print("ok")
