#!/usr/bin/python3
"""Writes docs/experiments.md from the committed results in experiments/results/.

Usage: scripts/experiments_doc.py [--check] [ROOT]   (ROOT: the repository, default: this script's parent)

The page is experiments/experiments.md.in with its markers replaced:

- `{{summary}}`: a table of every experiment (from each results.json: the system the paper made
  its claim for, what qbond measures, how it stands to the paper, the claims checked);
- `{{section NAME}}`: experiment NAME's title as a heading, its plots, and its summary.md (the
  paper's claim quoted with the system it was made for, the set-up, the tables, every claim with
  pass/FAIL or informative);
- `{{NAME.KEY}}` or `{{NAME.KEY:FORMAT}}`: the value KEY of NAME's results.json, formatted by
  Python's FORMAT (default `.4g`); `{{A.X / B.Y:FORMAT}}`: the ratio of two values.

So every number on the page comes from the results the program wrote. With --check it writes
nothing and exits 1 when the page differs from what the results give, or when a committed
result is a fast-mode run or records a failed claim (a ctest test).
"""
import json
import os
import re
import sys

MARKER = re.compile(r"\{\{([^{}]+)\}\}")


def load(results_dir):
    """Every experiment's results.json and summary.md, by name."""
    found = {}
    for name in sorted(os.listdir(results_dir)):
        path = os.path.join(results_dir, name, "results.json")
        if not os.path.exists(path):
            continue
        with open(path) as f:
            r = json.load(f)
        with open(os.path.join(results_dir, name, "summary.md")) as f:
            r["summary_md"] = f.read()
        found[name] = r
    return found


def summary_table(results, order):
    rows = ["| experiment | the paper's claim was made for | qbond measures | agrees? | claims checked |",
            "|---|---|---|---|---|"]
    for name in order:
        r = results[name]
        anchor = "#" + re.sub(r"[^a-z0-9 _-]", "", r["title"].lower()).replace(" ", "-")
        system = r["paper"]["system"] if r["paper"]["quote"] else "(not in the paper: " + r["paper"]["system"] + ")"
        passed = sum(1 for c in r["checks"] if c["pass"])
        checks = f"{passed}/{len(r['checks'])} pass"
        if r["informative"]:
            checks += f", {len(r['informative'])} informative"
        verdict = r["verdict"] if r["passed"] else r["verdict"] + " (a checked claim FAILED)"
        rows.append(f"| [{name}]({anchor}) | {system} | {r['measured']} | {verdict} | {checks} |")
    return "\n".join(rows)


def section(results_dir, name, r):
    """The experiment's heading, its plots, and its summary.md below its title."""
    pngs = sorted(p for p in os.listdir(os.path.join(results_dir, name)) if p.endswith(".png"))
    images = "".join(f"![{p[:-4]}](../experiments/results/{name}/{p})\n" for p in pngs)
    body = r["summary_md"].split("\n", 1)[1].strip("\n")
    return f"## {r['title']}\n\n" + (images + "\n" if images else "") + body


def render(root):
    results_dir = os.path.join(root, "experiments", "results")
    results = load(results_dir)
    with open(os.path.join(root, "experiments", "experiments.md.in")) as f:
        template = f.read()
    order = [m.group(1).split()[1] for m in MARKER.finditer(template) if m.group(1).startswith("section ")]
    missing = sorted(set(results) - set(order))
    if missing:
        raise SystemExit(f"experiments_doc: experiments.md.in has no section for {', '.join(missing)}")

    def replace(m):
        key = m.group(1).strip()
        if key == "summary":
            return summary_table(results, order)
        if key.startswith("section "):
            name = key.split()[1]
            if name not in results:
                raise SystemExit(f"experiments_doc: no experiments/results/{name}/results.json")
            return section(results_dir, name, results[name])
        expr, _, fmt = key.partition(":")
        parts = [value(p.strip()) for p in expr.split(" / ")]
        if any(p is None for p in parts):
            return "∞"
        v = parts[0]
        for p in parts[1:]:
            v /= p
        return format(v, fmt or ".4g")

    def value(ref):
        name, _, field = ref.partition(".")
        if name not in results or field not in results[name]["values"]:
            raise SystemExit(f"experiments_doc: no value '{field}' in experiments/results/{name}/results.json")
        return results[name]["values"][field]

    page = MARKER.sub(replace, template)
    problems = [f"{n}: a fast-mode run" for n, r in results.items() if r["fast"]]
    problems += [f"{n}: a claim failed" for n, r in results.items() if not r["passed"]]
    return page, problems


def main():
    args = sys.argv[1:]
    check = "--check" in args
    args = [a for a in args if a != "--check"]
    root = args[0] if args else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    page, problems = render(root)
    target = os.path.join(root, "docs", "experiments.md")
    for p in problems:
        print(f"experiments_doc: experiments/results/{p}", file=sys.stderr)
    if check:
        with open(target) as f:
            current = f.read()
        if current != page:
            print("experiments_doc: docs/experiments.md is not what experiments/results give: "
                  "run scripts/experiments_doc.py", file=sys.stderr)
            return 1
        return 1 if problems else 0
    with open(target, "w") as f:
        f.write(page)
    print(f"experiments_doc: wrote {target}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
