#!/usr/bin/python3
"""End-to-end tests of `qbond view` in a real X server: Xvfb with Mesa's software OpenGL.

Usage: viewer_test.py QBOND SOURCE_DIR WORK_DIR TEST
Exits 77 (ctest's skip code, SKIP_RETURN_CODE) with a message when no display can be had: no
DISPLAY and no xvfb-run. Every other problem fails.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
from matplotlib import image

QBOND, SOURCE, WORK = (os.path.abspath(p) for p in sys.argv[1:4])
TEST = sys.argv[4]
SKIP = 77
BACKGROUND = np.array([0.16, 0.17, 0.19])  # renderer.cpp's clear colour
# Pendulum: the cube's quanta are 11..37 (the rope's 11 come first); 30 is on its far face.
PUSHED = 30


def fail(msg):
    sys.exit(f"{TEST}: {msg}")


def display_prefix():
    """How to start the viewer with a display: as is when DISPLAY works, else under xvfb-run."""
    if shutil.which("xvfb-run"):
        return ["xvfb-run", "-a", "-s", "-screen 0 1280x720x24"]
    if os.environ.get("DISPLAY"):
        return []
    print(f"{TEST}: SKIPPED: no DISPLAY and no xvfb-run (install xvfb: scripts/bootstrap --deps-only)")
    sys.exit(SKIP)


def view(name, *args):
    """Runs `qbond view` headless in WORK/name; returns (screenshot pixels, stats)."""
    d = os.path.join(WORK, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    cmd = display_prefix() + [QBOND, "view", *args, "--screenshot", "shot.png", "--stats", "stats.json"]
    r = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        fail(f"{' '.join(cmd)} exited {r.returncode}:\n{r.stdout}\n{r.stderr}")
    with open(os.path.join(d, "stats.json")) as f:
        stats = json.load(f)
    print(f"{name}: {r.stderr.strip()}")
    return image.imread(os.path.join(d, "shot.png"))[:, :, :3], stats


def script(name, events):
    path = os.path.join(WORK, name + ".json")
    os.makedirs(WORK, exist_ok=True)
    with open(path, "w") as f:
        json.dump({"events": events}, f)
    return path


def viewport(img, stats):
    x, y, w, h = stats["viewport"]
    return img[img.shape[0] - y - h:img.shape[0] - y, x:x + w]


def drawn(img):
    """Pixels of the structure: brighter than the background and the grey reference grid."""
    return np.abs(img - BACKGROUND).max(axis=2) > 0.3


def check_structure(img, stats, what):
    """Non-blank, and what is drawn lies where the camera puts the quanta (stats' pixel box)."""
    vp = viewport(img, stats)
    if vp.std() < 0.02:
        fail(f"{what}: the 3D view is blank (pixel std {vp.std():.4f})")
    mask = drawn(vp)
    x0, y0, x1, y1 = stats["quanta_px"]
    pad = 40  # sphere radius and the spring drawn past the quanta
    ys, xs = np.nonzero(mask)
    if len(xs) < 200:
        fail(f"{what}: only {len(xs)} pixels of structure drawn")
    inside = ((xs >= x0 - pad) & (xs <= x1 + pad) & (ys >= y0 - pad) & (ys <= y1 + pad)).mean()
    if inside < 0.95:
        fail(f"{what}: {inside:.1%} of the structure's pixels lie in the quanta's box {stats['quanta_px']} (want >= 95%)")
    box = mask[int(max(y0, 0)):int(y1) + 1, int(max(x0, 0)):int(x1) + 1]
    if box.mean() < 0.02:
        fail(f"{what}: the quanta's box {stats['quanta_px']} is nearly empty ({box.mean():.1%} drawn)")
    print(f"{what}: {len(xs)} structure pixels, {inside:.1%} inside the quanta's box")


def strained(img, stats):
    """Pixels coloured as clearly stretched (red) or compressed (blue) bonds."""
    vp = viewport(img, stats)
    r, g, b = vp[:, :, 0], vp[:, :, 1], vp[:, :, 2]
    # The strong ends of the diverging map (colors.cpp): hues no sphere has (bodies are grey-blue
    # with r/b ~ 0.75, anchored quanta orange with g/r ~ 0.47).
    red = (r > 0.5) & (g < 0.4 * r) & (b < 0.4 * r)
    blue = (b > 0.5) & (r < 0.55 * b)
    return int(red.sum()), int(blue.sum())


def test_pendulum_drag():
    """The pendulum is drawn where it is, and a scripted drag moves it on screen."""
    still, s0 = view("pendulum_still", "--frames", "60")
    check_structure(still, s0, "pendulum")
    drag = script("pendulum_drag", [{"frame": 10, "drag": {"quanta": PUSHED, "by": [0.6, 0.0, 0.3]}}])
    pulled, s1 = view("pendulum_drag", "--frames", "60", "--script", drag)
    check_structure(pulled, s1, "pendulum dragged")
    moved = abs(s1["quanta_px"][2] - s0["quanta_px"][2]) + abs(s1["quanta_px"][0] - s0["quanta_px"][0])
    if moved < 20:
        fail(f"the drag did not move the pendulum on screen: boxes {s0['quanta_px']} and {s1['quanta_px']}")
    print(f"pendulum: the drag moved its screen box by {moved:.0f} px")


def test_block_colouring():
    """A block at rest draws its bonds grey; pulling its free end colours them by strain."""
    scene = os.path.join(SOURCE, "tests", "scenes", "viewer_block.json")
    rest, s0 = view("block_rest", scene, "--frames", "40")
    check_structure(rest, s0, "block at rest")
    tip = 12 * 3 * 3 - 1  # the last quanta: the free end's far top corner
    drag = script("block_drag", [{"frame": 5, "drag": {"quanta": tip, "by": [0.0, 0.0, 0.06]}}])
    pulled, s1 = view("block_drag", scene, "--frames", "40", "--script", drag)
    check_structure(pulled, s1, "block pulled")
    red0, blue0 = strained(rest, s0)
    red1, blue1 = strained(pulled, s1)
    print(f"block: strained-bond pixels at rest red {red0} blue {blue0}; pulled red {red1} blue {blue1}")
    if red0 + blue0 > 20:
        fail(f"bonds of a block at rest are coloured as strained ({red0} red, {blue0} blue pixels)")
    if red1 < 100 or blue1 < 100:
        fail(f"pulling the block's end should colour bonds red (stretched) and blue (compressed): {red1} red, {blue1} blue pixels")


def vtp_points(path):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    return vtk_to_numpy(r.GetOutput().GetPoints().GetData()).astype(float)


def test_push_matches_load():
    """A scripted push on the pendulum moves it exactly as the same force as a scene load does."""
    force = [4.0, 0.0, 1.0]
    frames, per_frame = 30, 17
    push = script("push", [{"frame": 0, "push": {"quanta": PUSHED, "force": force}}])
    view("push_view", "--frames", str(frames), "--steps-per-frame", str(per_frame), "--script", push, "--save", "final.vtp")
    viewed = vtp_points(os.path.join(WORK, "push_view", "final.vtp"))

    with open(os.path.join(SOURCE, "scenes", "pendulum.json")) as f:
        scene = json.load(f)
    scene["loads"] = [{"select": {"body": "cube", "ids": [PUSHED - 11]}, "force": force}]
    d = os.path.join(WORK, "push_run")
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    with open(os.path.join(d, "scene.json"), "w") as f:
        json.dump(scene, f)
    steps = frames * per_frame
    subprocess.run([QBOND, "run", "scene.json", "--steps", str(steps), "--every", str(steps), "-q", "--out", "out"],
                   cwd=d, check=True, timeout=300)
    frames_dir = os.path.join(d, "out", "frames")
    loaded = vtp_points(os.path.join(frames_dir, sorted(os.listdir(frames_dir))[-1]))
    diff = np.abs(viewed - loaded).max()
    moved = np.abs(viewed - vtp_points(os.path.join(frames_dir, sorted(os.listdir(frames_dir))[0]))).max()
    print(f"push vs load after {steps} steps: largest position difference {diff:.3g} m (the pendulum moved {moved:.3g} m)")
    # The same forces through the same f_ext path: the same bits (VTK stores float64 positions).
    if diff != 0:
        fail(f"the viewer's push and the scene's load give positions {diff:.3g} m apart")


def test_tank_walls():
    """A tank's near walls, seen from their solid side, are not drawn over the liquid inside it."""
    img, stats = view("tank_walls", os.path.join(SOURCE, "scenes", "liquid_blob.json"), "--frames", "15")
    vp = viewport(img, stats)
    x0, y0, x1, y1 = (int(v) for v in stats["quanta_px"])
    box = vp[max(y0, 0):y1 + 1, max(x0, 0):x1 + 1]
    # The quanta are drawn light (white and strain colours); the walls a grey under 0.6 (near
    # walls drawn over the blob would leave none of the box bright; without them about two thirds).
    bright = (box.max(axis=2) > 0.6).mean()
    if bright < 0.2:
        fail(f"the liquid's box {stats['quanta_px']} is {bright:.0%} bright: something is drawn over the quanta")
    print(f"tank walls: the liquid's box is {bright:.0%} bright")


def test_mouse_drag():
    """The mouse path itself: a press on the pixel where the pendulum's cube quanta is drawn picks
    that quanta (ray casting), moving the mouse 250 px to the right pulls it along the plane
    facing the camera, and the pendulum ends elsewhere than without the drag."""
    mouse = script("mouse", [{"frame": 10, "mouse": {"press_on": PUSHED}},
                             {"frame": 11, "mouse": {"move_by": [250, 0]}},
                             {"frame": 45, "mouse": {"release": True}}])
    _, dragged = view("mouse_drag", "--frames", "60", "--script", mouse, "--save", "final.vtp")
    _, still = view("mouse_still", "--frames", "60", "--save", "final.vtp")
    if dragged["last_grab"] != PUSHED:
        fail(f"the press on quanta {PUSHED}'s pixel grabbed {dragged['last_grab']}")
    a = vtp_points(os.path.join(WORK, "mouse_drag", "final.vtp"))
    b = vtp_points(os.path.join(WORK, "mouse_still", "final.vtp"))
    moved = np.linalg.norm(a[PUSHED] - b[PUSHED])
    print(f"mouse drag: grabbed quanta {dragged['last_grab']}, which ends {moved:.3f} m from where it would have")
    if moved < 0.05:
        fail(f"the mouse drag moved quanta {PUSHED} only {moved:.3g} m")


tests = {name[5:]: f for name, f in globals().items() if name.startswith("test_")}
if TEST not in tests:
    fail(f"no such test; known: {', '.join(tests)}")
tests[TEST]()
