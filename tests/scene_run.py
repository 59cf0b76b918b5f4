#!/usr/bin/python3
"""Runs a scene for 50 steps (20 at frame-sized steps, through mesh_drop's landing) and checks what
the run wrote, not only its exit code.

Usage: scene_run.py QBOND_EXE SCENE OUT_DIR

Checks: exit 0 and nothing on stderr; run.json says completed at the last step (an adaptive
scene: at that many base timesteps of simulated time) with the scene's name and quanta; diagnostics.csv has a row
at steps 0, 10, 20, ... and at the last, every field a finite number, time increasing; the
kinetic energy is never negative; when the scene writes VTK, series.pvd lists a frame for each
row and each is on disk.
"""
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

QBOND, SCENE, OUT = sys.argv[1:4]
EVERY = 10
STEPS = 20 if json.load(open(SCENE))["timestep"] >= 1 / 120 else 50


def fail(msg):
    sys.exit(f"FAIL: {os.path.basename(SCENE)}: {msg}")


shutil.rmtree(OUT, ignore_errors=True)
r = subprocess.run([QBOND, "run", SCENE, "--steps", str(STEPS), "--every", str(EVERY), "-q", "--out", OUT],
                   capture_output=True, text=True)
if r.returncode != 0 or r.stderr.strip():
    fail(f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}")

run = json.load(open(os.path.join(OUT, "run.json")))
name = json.load(open(SCENE)).get("name")
# An adaptive scene takes --steps as a duration of that many base timesteps, in steps of its own.
adaptive = run["scene"].get("adaptive") is not None
if run["status"] != "completed":
    fail(f"run.json: status {run['status']!r} ({run['message']!r})")
if adaptive:
    if abs(run["simulated_time"] - STEPS * run["scene"]["timestep"]) > 1e-9 * STEPS * run["scene"]["timestep"]:
        fail(f"run.json: simulated {run['simulated_time']} s, expected {STEPS} x {run['scene']['timestep']} s")
elif run["last_step"] != STEPS:
    fail(f"run.json: completed at step {run['last_step']}, expected {STEPS}")
if name and run["scene"]["name"] != name:
    fail(f"run.json names the scene {run['scene']['name']!r}, the file {name!r}")
if run["quanta"] <= 0:
    fail(f"run.json: {run['quanta']} quanta")

rows = list(csv.reader(open(os.path.join(OUT, "diagnostics.csv"))))
header, body = rows[0], rows[1:]
if header[:3] != ["step", "time", "kinetic"]:
    fail(f"diagnostics.csv columns {header}")
last = run["last_step"]
expected = sorted(set(range(0, last + 1, EVERY)) | {last})
if [int(row[0]) for row in body] != expected:
    fail(f"diagnostics.csv rows at steps {[row[0] for row in body]}, expected {expected}")
for row in body:
    values = [float(v) for v in row]
    bad = [header[k] for k, v in enumerate(values) if not math.isfinite(v)]
    if bad:
        fail(f"diagnostics.csv step {row[0]}: not finite: {bad}")
    if values[2] < 0:
        fail(f"diagnostics.csv step {row[0]}: kinetic energy {values[2]}")
times = [float(row[1]) for row in body]
if any(b <= a for a, b in zip(times, times[1:])):
    fail(f"diagnostics.csv: time does not increase: {times}")

pvd = os.path.join(OUT, "series.pvd")
if os.path.exists(pvd):
    files = [d.get("file") for d in ET.parse(pvd).getroot().findall("./Collection/DataSet")]
    if len(files) != len(expected):
        fail(f"series.pvd lists {len(files)} frames, expected {len(expected)}")
    missing = [f for f in files if not os.path.exists(os.path.join(OUT, f))]
    if missing:
        fail(f"series.pvd lists frames not on disk: {missing}")
print("ok")
