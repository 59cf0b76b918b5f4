#!/usr/bin/python3
"""Runs a scene for 50 steps and checks what the run wrote, not only its exit code.

Usage: scene_run.py QBOND_EXE SCENE OUT_DIR

Checks: exit 0 and nothing on stderr; run.json says completed at step 50 with the scene's name
and quanta; diagnostics.csv has a row at steps 0, 10, ..., 50, every field a finite number, time
increasing; the kinetic energy is never negative; when the scene writes VTK, series.pvd lists
the 6 frames and each is on disk.
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
STEPS, EVERY = 50, 10


def fail(msg):
    sys.exit(f"FAIL: {os.path.basename(SCENE)}: {msg}")


shutil.rmtree(OUT, ignore_errors=True)
r = subprocess.run([QBOND, "run", SCENE, "--steps", str(STEPS), "--every", str(EVERY), "-q", "--out", OUT],
                   capture_output=True, text=True)
if r.returncode != 0 or r.stderr.strip():
    fail(f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}")

run = json.load(open(os.path.join(OUT, "run.json")))
name = json.load(open(SCENE)).get("name")
if run["status"] != "completed" or run["last_step"] != STEPS:
    fail(f"run.json: status {run['status']} at step {run['last_step']}, expected completed at {STEPS}")
if name and run["scene"]["name"] != name:
    fail(f"run.json names the scene {run['scene']['name']!r}, the file {name!r}")
if run["quanta"] <= 0:
    fail(f"run.json: {run['quanta']} quanta")

rows = list(csv.reader(open(os.path.join(OUT, "diagnostics.csv"))))
header, body = rows[0], rows[1:]
if header[:3] != ["step", "time", "kinetic"]:
    fail(f"diagnostics.csv columns {header}")
if [int(row[0]) for row in body] != list(range(0, STEPS + 1, EVERY)):
    fail(f"diagnostics.csv rows at steps {[row[0] for row in body]}")
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
    if len(files) != STEPS // EVERY + 1:
        fail(f"series.pvd lists {len(files)} frames, expected {STEPS // EVERY + 1}")
    missing = [f for f in files if not os.path.exists(os.path.join(OUT, f))]
    if missing:
        fail(f"series.pvd lists frames not on disk: {missing}")
print("ok")
