#!/usr/bin/python3
"""The viewer's own real-time factor beside `qbond bench --realtime`'s (docs/performance.md).

Usage: bench/viewer_realtime.py QBOND REALTIME_JSON [--frames 60] [--threads 2] [--scenes a,b]

`qbond bench --realtime` times a frame's steps alone; the viewer also draws, polls and swaps. For
each built-in scene of REALTIME_JSON (a `qbond bench --realtime --json` file) this runs `qbond view
SCENE --frames F --stats FILE` headless, under xvfb-run (Mesa's software OpenGL) unless DISPLAY
works, with OMP_NUM_THREADS = --threads (the built-in scenes leave their thread count to it), and
adds the stats' measured real-time factor (simulated seconds over the frames' wall seconds: each
headless frame steps 1/60 s, as the bench's frames do) to the scene's row of that thread count as
`viewer`, and how it was measured to the file as `viewer`: command, date, load, renderer. Exits 1
when a scene's viewer fails to run, 2 when no display can be had.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time


def display_prefix():
    """How to start the viewer with a display: under xvfb-run when it exists, else on DISPLAY."""
    if shutil.which("xvfb-run"):
        return ["xvfb-run", "-a", "-s", "-screen 0 1280x720x24"]
    if os.environ.get("DISPLAY"):
        return []
    sys.exit("viewer_realtime: no xvfb-run and no DISPLAY (install xvfb: scripts/bootstrap --deps-only)")


def view_stats(qbond, scene, frames, threads, work):
    """The viewer's --stats of `frames` headless frames of a built-in scene on `threads` threads."""
    stats = os.path.join(work, f"{scene}.json")
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    cmd = display_prefix() + [qbond, "view", scene, "--frames", str(frames), "--stats", stats]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=work)
    # Exit 3: the scene blew up, which the stats say (`blowup`); anything else is a failure.
    if r.returncode not in (0, 3) or not os.path.exists(stats):
        raise SystemExit(f"viewer_realtime: {' '.join(cmd)} exited {r.returncode}:\n{r.stderr}")
    with open(stats) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("qbond")
    ap.add_argument("json", help="a `qbond bench --realtime --json` file; its scene rows gain the viewer's column")
    ap.add_argument("--frames", type=int, default=60, help="headless frames a scene (default: 60, 1 s simulated)")
    ap.add_argument("--threads", type=int, default=2, help="the viewer's threads, and the rows it joins (default: 2)")
    ap.add_argument("--scenes", help="only these built-in scenes, comma-separated (default: every scene row)")
    a = ap.parse_args()
    if a.frames < 1 or a.threads < 1:
        sys.exit("viewer_realtime: --frames and --threads must be at least 1")
    with open(a.json) as f:
        doc = json.load(f)
    rows = [r for r in doc["rows"] if r["kind"] == "scene" and r["threads"] == a.threads]
    if a.scenes:
        wanted = a.scenes.split(",")
        unknown = sorted(set(wanted) - {r["workload"] for r in rows})
        if unknown:
            sys.exit(f"viewer_realtime: no {a.threads}-thread row of {', '.join(unknown)} in {a.json}")
        rows = [r for r in rows if r["workload"] in wanted]
    if not rows:
        sys.exit(f"viewer_realtime: {a.json} has no scene row on {a.threads} threads")
    load_start = os.getloadavg()[0]
    renderer = None
    with tempfile.TemporaryDirectory(prefix="qbond_viewer_realtime_") as work:
        for r in rows:
            s = view_stats(os.path.abspath(a.qbond), r["workload"], a.frames, a.threads, work)
            renderer = s["gl_renderer"]
            r["viewer"] = {"real_time_factor": s["real_time_factor"], "frames": s["frames"], "steps": s["steps"],
                           "simulated_seconds": s["simulated_seconds"], "median_frame_seconds": s["frame_ms"]["median"] / 1e3,
                           "physics_ms_per_frame": s["physics_ms_per_frame"],
                           "render_ms_per_frame": s["render_ms_per_frame"], "blowup": s["blowup"]}
            bench = f"{r['real_time_factor']:.3g}x" if r["real_time_factor"] is not None else "-"
            print(f"{r['workload']:<20} viewer {s['real_time_factor']:9.3g}x real time "
                  f"(physics {s['physics_ms_per_frame']:.2f} ms, drawing {s['render_ms_per_frame']:.2f} ms a frame); "
                  f"the bench's frames {bench}", flush=True)
    doc["viewer"] = {"command": "bench/viewer_realtime.py " + " ".join(sys.argv[1:]),
                     "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "frames": a.frames,
                     "threads": a.threads, "gl_renderer": renderer, "nice": os.nice(0),
                     "load_average": [load_start, os.getloadavg()[0]]}
    with open(a.json + ".tmp", "w") as f:
        json.dump(doc, f, indent=1, sort_keys=True)
    os.replace(a.json + ".tmp", a.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
