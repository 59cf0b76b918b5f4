#!/usr/bin/python3
"""Collects the final statistics of long libFuzzer runs into docs/bench/fuzz-DATE.json.

Usage: scripts/fuzz_summary.py OUT_JSON TARGET=LOG...
Each LOG is the output of `build-asan/TARGET_fuzzer -runs=N -print_final_stats=1 CORPUS`
followed by a line "rc CODE" (its exit status); docs/running.md ("Fuzzing") renders the table.
"""
import datetime
import json
import os
import re
import sys

rows = []
for arg in sys.argv[2:]:
    target, log = arg.split("=", 1)
    text = open(log, errors="replace").read()
    stat = lambda key: int(re.search(rf"^stat::{key}:\s+(\d+)", text, re.M).group(1))
    done = re.search(r"^Done (\d+) runs in (\d+) second", text, re.M)
    rc = int(re.search(r"^rc (\d+)", text, re.M).group(1))
    rows.append({"target": target, "runs": stat("number_of_executed_units"), "seconds": int(done.group(2)) if done else None,
                 "peak_rss_mb": stat("peak_rss_mb"),
                 "result": "no crash, no leak" if rc == 0 and "ERROR:" not in text
                 else "an input over the 10 s timeout" if "ERROR: libFuzzer: timeout" in text
                 else f"failed (exit {rc})"})
json.dump({"date": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"), "machine": f"{os.cpu_count()} cores",
           "command": "build-asan/TARGET_fuzzer -runs=1000000 build-asan/corpus/TARGET (after scripts/fuzz)",
           "rows": rows}, open(sys.argv[1], "w"), indent=1)
