#!/usr/bin/python3
"""Runs the scenes of contact inside the step and prints their measured table (docs/heuristics.md).

Usage: scripts/contact_table.py [BUILD_DIR]   (default: build; needs BUILD_DIR/qbond)
Reads each run's diagnostics.csv: the ledger's columns on every row and what the scene shows.
"""
import csv
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build")
RUNS = os.path.join(BUILD, "contact_runs")
RADIUS = 0.005  # the scenes' margin [m]


def run(scene):
    out = os.path.join(RUNS, scene)
    subprocess.run([os.path.join(BUILD, "qbond"), "run", os.path.join(ROOT, "scenes", scene + ".json"),
                    "--out", out, "--quiet"], check=True, stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "diagnostics.csv")) as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def ledger(rows):
    """Least `dissipated`, and largest |numerical| over the largest kinetic or potential energy
    (the potential from the ground, or its change since the start)."""
    scale = max(max(r["kinetic"], abs(r["potential"]), abs(r["potential"] - rows[0]["potential"])) for r in rows)
    return min(r["dissipated"] for r in rows), max(abs(r["numerical"]) for r in rows) / scale


def main():
    table = ["| scene (h = 1/60 s) | shows | measured | least `dissipated` [J] | max \\|`numerical`\\| / max(KE, PE) |",
             "|---|---|---|---|---|"]
    rest = run("block_rest")
    settled = [r for r in rest if r["time"] >= 1.0]
    z = [r["block_z"] for r in settled]
    ke = max(r["kinetic"] for r in settled)
    d, n = ledger(rest)
    table.append(f"| block_rest | a 4×4×4 block at rest for 10 s | mean height varies {(max(z) - min(z)) / RADIUS:.2e} "
                 f"radii after 1 s; kinetic energy ≤ {ke:.2e} J | {d:.3g} | {n:.3g} |")
    incline = run("block_incline")
    half = incline[len(incline) // 2]
    last = incline[-1]
    a = (last["block_vx"] - half["block_vx"]) / (last["time"] - half["time"]) if "block_vx" in last else float("nan")
    if math.isnan(a):
        # The probe gives positions: the acceleration from the last three rows' mean position.
        x = [r["block_x"] for r in incline[-3:]]
        t = [r["time"] for r in incline[-3:]]
        a = ((x[2] - x[1]) / (t[2] - t[1]) - (x[1] - x[0]) / (t[1] - t[0])) / ((t[2] - t[0]) / 2)
    g = 9.81
    expected = g * (math.sin(math.radians(35)) - 0.4 * math.cos(math.radians(35)))
    d, n = ledger(incline)
    table.append(f"| block_incline | sliding with μ_k = 0.4 at 35° | acceleration {a:.3f} m/s² "
                 f"(g (sin θ − μ_k cos θ) = {expected:.3f}) | {d:.3g} | {n:.3g} |")
    bounce = run("ball_bounce")
    zs = [r["ball_z"] - RADIUS for r in bounce]
    apex = [zs[i] for i in range(1, len(zs) - 1) if zs[i] >= zs[i - 1] and zs[i] > zs[i + 1] and zs[i] > 1e-4]
    ratios = [b / a for a, b in zip([zs[0]] + apex, apex)][:3]
    d, n = ledger(bounce)
    table.append(f"| ball_bounce | e = 0.5 from 1 m | apex ratios {', '.join(f'{r:.3f}' for r in ratios)} "
                 f"(e² = 0.25) | {d:.3g} | {n:.3g} |")
    stack = run("stack")
    table.append(rest_row("stack", "three 4×4×4 blocks stacked on the ground", stack, ["bottom", "middle", "top"], 2.0))
    trampoline = run("trampoline")
    table.append(rest_row("trampoline", "a 4×4×4 block dropped 20 cm onto a 15×15 sheet held on its edges, pair friction 0.5", trampoline,
                          ["block", "sheet"], 4.0))
    gap = run("gap")
    d, n = ledger(gap)
    table.append(f"| gap | a 3×3×3 block dropped 30 cm onto ledges 1.5 cm apart, pair friction 0.5 | block's mean height "
                 f"{gap[-1]['block_z'] * 100:.2f} cm at the end (ledges' centres at 10 cm), falls through: "
                 f"{'no' if gap[-1]['block_z'] > 0.1 else 'yes'} | {d:.3g} | {n:.3g} |")
    mesh = run("mesh_drop")
    table.append(rest_row("mesh_drop", "a voxelised torus and blob (2 065 quanta) dropped tilted on the ground, friction 0.5",
                          mesh, ["torus", "blob"], 0.5, radius=0.0025))
    print("\n".join(table))
    print()
    print(flight(gap))
    print()
    print(convergence())
    print()
    print(mesh_convergence())


def flight(rows):
    """The gap's `numerical_damping` on its last row before the block touches, against backward
    Euler's closed-form loss in free fall, N · ½ M g² h² after N steps (gravity's work at the end
    velocity, M g h v_{n+1}, against the kinetic energy's change, M g h (v_n + v_{n+1})/2), and
    the remainder `numerical` then and at the end."""
    with open(os.path.join(ROOT, "scenes", "gap.json")) as f:
        scene = json.load(f)
    h, g = scene["timestep"], 9.81
    block = next(b for b in scene["bodies"] if b["name"] == "block")
    M = block["size"][0] * block["size"][1] * block["size"][2] * block["quanta_mass"]
    free = [r for r in rows if r["contact_energy"] == 0 and r["dissipated_contact"] == 0]
    last = free[-1]
    predicted = last["step"] * 0.5 * M * g * g * h * h
    scale = max(max(r["kinetic"], abs(r["potential"]), abs(r["potential"] - rows[0]["potential"])) for r in rows)
    return (f"gap: after {int(last['step'])} steps of free fall `numerical_damping` = "
            f"{last['numerical_damping']:.6g} J; N ½ M g² h² = {predicted:.6g} J; `numerical` then "
            f"{last['numerical']:.3g} J, at the end {rows[-1]['numerical']:.3g} J "
            f"({abs(rows[-1]['numerical']) / scale:.3g} of the largest energy)")


STEPS_PER_SECOND = (60, 120, 240, 480)  # the convergence tables' steps, h = 1/n


def converge(name, duration, edit, steps=STEPS_PER_SECOND):
    """Runs scenes/NAME.json edited by `edit` at each h = 1/n of `steps` for `duration` s and
    returns (n, its last diagnostics row: the probed bodies' mean positions and the ledger)."""
    with open(os.path.join(ROOT, "scenes", name + ".json")) as f:
        scene = json.load(f)
    edit(scene)
    for body in scene["bodies"]:  # the files it names (meshes), from where the run's copy is
        if "file" in body:
            body["file"] = os.path.join(ROOT, "scenes", body["file"])
    os.makedirs(RUNS, exist_ok=True)
    last = []
    for n in steps:
        s = dict(scene, timestep=1.0 / n, duration=duration)
        s["output"] = dict(scene["output"], every=n // 6)
        path = os.path.join(RUNS, f"{name}_{n}.json")
        with open(path, "w") as f:
            json.dump(s, f)
        out = os.path.join(RUNS, f"{name}_{n}")
        subprocess.run([os.path.join(BUILD, "qbond"), "run", path, "--out", out, "--quiet"], check=True,
                       stdout=subprocess.DEVNULL)
        with open(os.path.join(out, "diagnostics.csv")) as f:
            last.append((n, {k: float(v) for k, v in list(csv.DictReader(f))[-1].items()}))
    return last


def no_friction(scene):
    # Without friction: a stuck contact's rest state depends on its history (static friction holds
    # any tangential load below μ_s f_n), so the state with it need not converge.
    for rule in scene["heuristics"]:
        rule.pop("friction", None)


def ground_in_step(scene):
    for rule in scene["heuristics"]:
        rule["method"] = "implicit"


def convergence():
    """The trampoline's block and sheet mean heights after 4 s (at rest) at h = 1/60 ... 1/480 s
    without pair friction, the change from the step before, and `numerical_damping` and
    `numerical` then."""
    rows = ["| h [s] | block's mean height after 4 s [m] | change from the h before | sheet's [m] | change | "
            "`numerical_damping` [J] | `numerical` [J] |",
            "|---|---|---|---|---|---|---|"]
    prev = None
    for n, r in converge("trampoline", 4.0, no_friction):
        b, sh = r["block_z"], r["sheet_z"]
        change = ("", "") if prev is None else (f"{b - prev[0]:.2e}", f"{sh - prev[1]:.2e}")
        rows.append(f"| 1/{n} | {b:.7f} | {change[0]} | {sh:.7f} | {change[1]} | {r['numerical_damping']:.4f} | "
                    f"{r['numerical']:.4f} |")
        prev = (b, sh)
    # With friction, dropped over the sheet's hollows: the block lands where it rests.
    rows += ["", "With the pair friction, the block dropped over the hollows between the sheet's quanta "
             "(origin (−15, −15) mm):", "",
             "| h [s] | block's mean (x, y) after 4 s [mm] | its mean height [m] | change from the h before | "
             "`numerical` [J] |", "|---|---|---|---|---|"]
    prev = None
    for n, r in converge("trampoline", 4.0, hollows):
        b = r["block_z"]
        rows.append(f"| 1/{n} | ({r['block_x'] * 1000:.3f}, {r['block_y'] * 1000:.3f}) | {b:.7f} | "
                    f"{'' if prev is None else f'{b - prev:.2e}'} | {r['numerical']:.2g} |")
        prev = b
    # As shipped, over the sheet's quanta, it rests where the impact's vibration leaves it: down to
    # 1/960 s, where the steps resolve that vibration.
    rubbing = converge("trampoline", 4.0, lambda scene: None, STEPS_PER_SECOND + (960,))
    rows += ["", "With the scene's pair friction as shipped: the block's mean (x, z) after 4 s at h = 1/60 ... 1/960 s: " +
             ", ".join(f"({r['block_x'] * 1000:.2f}, {r['block_z'] * 1000:.2f}) mm" for _, r in rubbing)]
    return "\n".join(rows)


def hollows(scene):
    # The block over the hollows between the sheet's quanta, centred on it.
    block = next(b for b in scene["bodies"] if b["name"] == "block")
    block["origin"] = [-0.015, -0.015, block["origin"][2]]


def mesh_convergence():
    """mesh_drop with its ground in the step, without friction, after 1.5 s (both bodies resting,
    the blob still gliding) at h = 1/60 ... 1/480 s: each body's mean height and its change, and
    the largest change of a body's mean horizontal position (x or y) from the h before. CG to a
    relative residual of 1e-9: at the default 1e-6 the horizontal positions differ by ~1e-5 m from
    one h to the next whatever h, the solver's error and not the step's."""
    def edit(scene):
        no_friction(scene)
        ground_in_step(scene)
        scene["integrator"] = dict(scene.get("integrator", {}), tolerance=1e-9)
    rows = ["| h [s] | torus's mean height [m] | change | blob's [m] | change | largest horizontal change [m] |",
            "|---|---|---|---|---|---|"]
    prev = None
    for n, r in converge("mesh_drop", 1.5, edit):
        if prev is None:
            rows.append(f"| 1/{n} | {r['torus_z']:.8f} |  | {r['blob_z']:.8f} |  |  |")
        else:
            side = max(abs(r[k] - prev[k]) for k in ("torus_x", "torus_y", "blob_x", "blob_y"))
            rows.append(f"| 1/{n} | {r['torus_z']:.8f} | {r['torus_z'] - prev['torus_z']:.2e} | {r['blob_z']:.8f} | "
                        f"{r['blob_z'] - prev['blob_z']:.2e} | {side:.2e} |")
        prev = r
    ys = [r["torus_y"] for _, r in converge("mesh_drop", 1.5, ground_in_step)]
    rows += ["", "With the scene's friction: the torus's mean y after 1.5 s at h = 1/60 ... 1/480 s: " +
             ", ".join(f"{y * 1000:.1f} mm" for y in ys)]
    return "\n".join(rows)


def rest_row(name, shows, rows, bodies, settle, radius=RADIUS):
    """A resting scene's row: after `settle` s, each body's mean height's largest change over the rest
    of the run in radii (of `radius`), and the kinetic energy over the gravity energy released."""
    after = [r for r in rows if r["time"] >= settle]
    drift = max(max(r[b + "_z"] for r in after) - min(r[b + "_z"] for r in after) for b in bodies)
    released = rows[0]["potential"] - after[0]["potential"]
    ke = max(r["kinetic"] for r in after)
    d, n = ledger(rows)
    return (f"| {name} | {shows} | after {settle:g} s: mean heights vary ≤ {drift / radius:.2e} radii; kinetic energy "
            f"≤ {ke / released:.2e} of the {released * 1000:.3g} mJ released | {d:.3g} | {n:.3g} |")


if __name__ == "__main__":
    main()
