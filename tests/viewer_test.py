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
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    r = vtkXMLPolyDataReader()
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


def pendulum_run(name, steps, every):
    """`qbond run` of the pendulum into WORK/name; returns the run directory."""
    d = os.path.join(WORK, name)
    shutil.rmtree(d, ignore_errors=True)
    subprocess.run([QBOND, "run", "pendulum", "--steps", str(steps), "--every", str(every), "-q", "--out", d],
                   check=True, timeout=300, capture_output=True)
    return d


def box_close(a, b, px):
    return max(abs(x - y) for x, y in zip(a, b)) <= px


def test_replay():
    """A finished run replayed shows the quanta where the live viewer shows them after the same
    simulated time; --time picks the frame; the directory and its series.pvd are the same."""
    # Headless, the live viewer takes 17 steps of 1 ms a frame (1/60 s): frames written every 17
    # steps are what live frame f shows after f + 1 frames' steps.
    run = pendulum_run("replay_run", 510, 17)
    for live_frames in (10, 30):
        live_img, live = view(f"replay_live_{live_frames}", "--frames", str(live_frames))
        # Replay frame k (k = live_frames) is drawn by viewer frame k: k + 1 frames.
        img, rep = view(f"replay_{live_frames}", os.path.join(run, "series.pvd"), "--frames", str(live_frames + 1))
        check_structure(img, rep, f"replay frame {live_frames}")
        if rep["replay"]["frame"] != live_frames or rep["replay"]["frames"] != 31:
            fail(f"replay shows frame {rep['replay']} after {live_frames + 1} viewer frames, expected {live_frames} of 31")
        if abs(rep["replay"]["time"] - live_frames * 0.017) > 1e-12:
            fail(f"replay frame {live_frames} is at t = {rep['replay']['time']}, expected {live_frames * 0.017}")
        if not box_close(live["quanta_px"], rep["quanta_px"], 2):
            fail(f"after {live_frames * 17} steps the live view draws the quanta in {live['quanta_px']}, the replay in {rep['quanta_px']}")
        print(f"replay frame {live_frames}: quanta box {rep['quanta_px']} (live {live['quanta_px']})")
    # The pendulum swings: the replay's last frame is not its first.
    _, first = view("replay_first", run, "--frames", "1")
    if first["replay"]["frame"] != 0 or box_close(first["quanta_px"], rep["quanta_px"], 10):
        fail(f"replay frame 0 {first['quanta_px']} and frame 30 {rep['quanta_px']} should differ")
    # --time: the last frame at or before it; a directory replays as its series.pvd does.
    _, at = view("replay_time", run, "--frames", "1", "--time", "0.1705")
    if at["replay"]["frame"] != 10:
        fail(f"--time 0.1705 shows frame {at['replay']['frame']}, expected 10 (t = 0.17)")
    _, by_pvd = view("replay_time_pvd", os.path.join(run, "series.pvd"), "--frames", "1", "--time", "0.1705")
    if at["quanta_px"] != by_pvd["quanta_px"]:
        fail(f"the directory and its series.pvd replay differently: {at['quanta_px']} vs {by_pvd['quanta_px']}")
    # A bare name is a built-in scene's before a run folder of that name (as for `qbond run`);
    # ./NAME is the folder.
    d = os.path.join(WORK, "replay_named")
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    subprocess.run([QBOND, "run", "pendulum", "--steps", "34", "--every", "17", "-q", "--out", "pendulum"], cwd=d,
                   check=True, timeout=300, capture_output=True)
    for arg, replayed in (("pendulum", False), ("./pendulum", True)):
        r = subprocess.run(display_prefix() + [QBOND, "view", arg, "--frames", "1", "--stats", "s.json"], cwd=d,
                           capture_output=True, text=True, timeout=300)
        with open(os.path.join(d, "s.json")) as f:
            got = json.load(f)["replay"] is not None
        if r.returncode != 0 or got != replayed:
            fail(f"qbond view {arg} beside a run folder 'pendulum': exit {r.returncode}, replayed {got}, expected {replayed}")
    # With the panel: the time slider's replay controls are drawn (a non-blank panel).
    img, stats = view("replay_panel", run, "--frames", "5")
    check_structure(img, stats, "replay with the panel")


def test_camera():
    """A camera from the command line changes the picture as its geometry says; the scene's
    `camera` gives the same picture; bad cameras are refused with exit 2."""
    target = np.array([0.0, 0.0, 0.6])  # about the middle of the pendulum (rope 0.2..1.2 m, cube below)
    eye = np.array([2.0, -2.5, 1.4])

    def point(p):
        return ",".join(f"{x:g}" for x in p)

    _, default = view("cam_default", "--frames", "1")
    img1, s1 = view("cam_near", "--frames", "1", "--camera-position", point(eye), "--camera-target", point(target))
    img2, s2 = view("cam_far", "--frames", "1", "--camera-position", point(target + 2 * (eye - target)),
                    "--camera-target", point(target))
    check_structure(img1, s1, "camera near")
    if np.abs(np.array(s1["camera"]["eye"]) - eye).max() > 1e-4 or np.abs(np.array(s1["camera"]["target"]) - target).max() > 1e-6:
        fail(f"the camera is at {s1['camera']}, asked for eye {eye} target {target}")
    if box_close(default["quanta_px"], s1["quanta_px"], 10):
        fail(f"the camera did not change the picture: boxes {default['quanta_px']} and {s1['quanta_px']}")
    # The target is drawn at the view's centre: the quanta's box straddles it.
    w, h = s1["viewport"][2], s1["viewport"][3]
    x0, y0, x1, y1 = s1["quanta_px"]
    if not (x0 < w / 2 < x1 and y0 < h / 2 < y1):
        fail(f"the target {target} (the pendulum's middle) is not inside the quanta's box {s1['quanta_px']} around the centre ({w / 2}, {h / 2})")
    # Twice as far: the picture of the pendulum is half as large (perspective: within 10 %).
    ratio = (s2["quanta_px"][3] - s2["quanta_px"][1]) / (y1 - y0)
    if not 0.45 < ratio < 0.55:
        fail(f"doubling the camera's distance scaled the quanta's box by {ratio:.3f}, expected about 0.5")
    # A narrower field of view magnifies by the ratio of the tangents of the half angles.
    _, s3 = view("cam_fov", "--frames", "1", "--camera-position", point(eye), "--camera-target", point(target),
                 "--camera-fov", "30")
    expect = np.tan(np.radians(s1["camera"]["fov"] / 2)) / np.tan(np.radians(15))
    got = (s3["quanta_px"][3] - s3["quanta_px"][1]) / (y1 - y0)
    if abs(got / expect - 1) > 0.05:
        fail(f"--camera-fov 30 magnified the quanta's box {got:.3f}x, expected {expect:.3f}x")
    print(f"camera: default box {default['quanta_px']}, near {s1['quanta_px']}, twice as far x{ratio:.3f}, "
          f"fov 30 x{got:.3f} (expected {expect:.3f})")

    # The scene's camera: the same picture as the same options.
    with open(os.path.join(SOURCE, "scenes", "pendulum.json")) as f:
        scene = json.load(f)
    scene["camera"] = {"position": eye.tolist(), "target": target.tolist()}
    path = os.path.join(WORK, "cam_scene.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    img4, s4 = view("cam_scene", path, "--frames", "1")
    differ = (np.abs(viewport(img4, s4) - viewport(img1, s1)).max(axis=2) > 0).mean()
    if s4["quanta_px"] != s1["quanta_px"] or differ > 1e-3:
        fail(f"the scene's camera draws {s4['quanta_px']} ({differ:.2%} of pixels differ), the options {s1['quanta_px']}")

    # Bad cameras: refused before any window opens, exit 2, saying what is wrong.
    bad = [
        (["--camera-position", "1,1,1", "--camera-target", "1,1,1"], "must differ"),
        (["--camera-position", "0,0,5", "--camera-target", "0,0,0"], "straight up or down"),
        (["--camera-fov", "0"], "--camera-fov"),
        (["--camera-fov", "180"], "--camera-fov"),
        (["--camera-position", "1,2", "--camera-target", "0,0,0"], "X,Y,Z"),
        (["--camera-position", "1,2,nan", "--camera-target", "0,0,0"], "X,Y,Z"),
        (["--camera-position", "1,2,3"], "go together"),
    ]
    for args, says in bad:
        r = subprocess.run([QBOND, "view", "--frames", "1", *args], capture_output=True, text=True, timeout=60)
        if r.returncode != 2 or says not in r.stderr:
            fail(f"qbond view {' '.join(args)} exited {r.returncode} ({r.stderr.strip()}), expected 2 saying '{says}'")
    for cam, says in [({"position": [0, 0, 1], "target": [0, 0, 0]}, "camera.position"),
                      ({"position": [1, 0, 0]}, "go together"), ({"fov": 200}, "camera.fov")]:
        scene["camera"] = cam
        with open(path, "w") as f:
            json.dump(scene, f)
        r = subprocess.run([QBOND, "view", path, "--frames", "1"], capture_output=True, text=True, timeout=60)
        if r.returncode != 2 or says not in r.stderr:
            fail(f"a scene camera {cam} exited {r.returncode} ({r.stderr.strip()}), expected 2 saying '{says}'")
    # A replay is watched, not pushed; a series naming a missing frame is refused.
    run = pendulum_run("cam_replay_run", 34, 17)
    r = subprocess.run([QBOND, "view", run, "--frames", "1", "--script", path], capture_output=True, text=True, timeout=60)
    if r.returncode != 2 or "does not apply to a replay" not in r.stderr:
        fail(f"a replay with --script exited {r.returncode} ({r.stderr.strip()}), expected 2")
    os.remove(os.path.join(run, "frames", sorted(os.listdir(os.path.join(run, "frames")))[0]))
    r = subprocess.run([QBOND, "view", run, "--frames", "1"], capture_output=True, text=True, timeout=60)
    if r.returncode != 2 or "frame_" not in r.stderr:
        fail(f"a replay of a missing frame exited {r.returncode} ({r.stderr.strip()}), expected 2 naming the file")
    print(f"camera: {len(bad) + 3} bad cameras and 2 bad replays refused with exit 2")


def test_implicit_obstacles():
    """Obstacles held inside the implicit step (ground, sphere, box) are drawn as the same
    obstacles held by projection are, live and replayed; each of them is in the picture."""
    with open(os.path.join(SOURCE, "tests", "scenes", "viewer_obstacles.json")) as f:
        scene = json.load(f)

    def variant(name, keep):
        """The scene with its obstacles filtered and edited by keep (None: left out)."""
        s = dict(scene, heuristics=[h for h in (keep(dict(h)) for h in scene["heuristics"]) if h is not None])
        path = os.path.join(WORK, name + ".json")
        os.makedirs(WORK, exist_ok=True)
        with open(path, "w") as f:
            json.dump(s, f)
        return path

    def differ(a, b):
        """Fraction of the 3D view's pixels that differ."""
        return (np.abs(viewport(*a) - viewport(*b)).max(axis=2) > 0.02).mean()

    def projection(h):
        h.pop("method")
        return h

    implicit = view("obstacles_implicit", variant("obstacles_implicit", lambda h: h), "--frames", "2")
    projected = view("obstacles_projection", variant("obstacles_projection", projection), "--frames", "2")
    d = differ(implicit, projected)
    print(f"implicit obstacles: {d:.3%} of the view differs from the same obstacles by projection")
    if d > 1e-3:
        fail(f"implicit obstacles are drawn unlike projection ones: {d:.2%} of the view differs")
    # Each obstacle is in the picture: leaving it out changes a part of the view.
    for shape in ("ground", "sphere", "box"):
        without = view(f"obstacles_no_{shape}", variant(f"obstacles_no_{shape}", lambda h: None if h["type"] == shape else h),
                       "--frames", "2")
        d = differ(implicit, without)
        print(f"implicit obstacles: leaving out the {shape} changes {d:.1%} of the view")
        if d < 0.01:
            fail(f"the implicit {shape} is not drawn: leaving it out changes {d:.3%} of the view")
    # Replayed: the run's scene gives the obstacles back.
    run = os.path.join(WORK, "obstacles_run")
    shutil.rmtree(run, ignore_errors=True)
    subprocess.run([QBOND, "run", variant("obstacles_implicit", lambda h: h), "--steps", "10", "--every", "5", "-q",
                    "--out", run], check=True, timeout=300, capture_output=True)
    replayed = view("obstacles_replay", run, "--frames", "1")
    d = differ(implicit, replayed)
    print(f"implicit obstacles replayed: {d:.3%} of the view differs from the live view")
    if d > 0.01:
        fail(f"a replay draws the implicit obstacles unlike the live view: {d:.2%} of the view differs")


def test_realtime_column():
    """bench/viewer_realtime.py adds the viewer's measured real-time factor to `qbond bench
    --realtime`'s scene row on 2 threads (and to no other row), as simulated over wall seconds of
    the frames asked, each of 1/60 s as the bench's; the realtime table shows it as a column."""
    d = os.path.join(WORK, "realtime_column")
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    path = os.path.join(d, "realtime.json")
    subprocess.run([QBOND, "bench", "--realtime", "-n", "4", "-j", "1,2", "--scenes", "two_quanta", "--budget", "0.5",
                    "--json", path], check=True, capture_output=True, timeout=300)
    frames = 5
    display_prefix()  # skips without a display
    r = subprocess.run([sys.executable, os.path.join(SOURCE, "bench", "viewer_realtime.py"), QBOND, path, "--frames",
                        str(frames)], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        fail(f"viewer_realtime.py exited {r.returncode}:\n{r.stdout}\n{r.stderr}")
    with open(path) as f:
        doc = json.load(f)
    seen = [(row["workload"], row["threads"]) for row in doc["rows"] if "viewer" in row]
    if seen != [("two_quanta", 2)]:
        fail(f"the viewer's column is on rows {seen}, want the 2-thread two_quanta row only")
    (row,) = [row for row in doc["rows"] if "viewer" in row]
    v = row["viewer"]
    h = row["timestep"]
    if v["frames"] != frames or v["steps"] != frames * row["steps_per_frame"] or v["blowup"]:
        fail(f"viewer {v}: want {frames} frames of {row['steps_per_frame']} steps, no blow-up")
    if abs(v["simulated_seconds"] - v["steps"] * h) > 1e-9 or not v["real_time_factor"] > 0:
        fail(f"viewer {v}: simulated seconds or real-time factor")
    if doc["viewer"]["threads"] != 2 or "viewer_realtime.py" not in doc["viewer"]["command"]:
        fail(f"provenance {doc['viewer']}")
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import bench_tables
    table = bench_tables.realtime_table("realtime.json", doc, "")
    header = [c.strip() for c in table[2].split("|")]
    lines = [[c.strip() for c in line.split("|")] for line in table[4:] if line.startswith("| two_quanta")]
    col = header.index("viewer × real time")
    cells = [(line[header.index("threads")], line[col]) for line in lines]
    if cells != [("1", "–"), ("2", bench_tables.sig(v["real_time_factor"]))]:
        fail(f"the table's viewer column: {cells}")
    print(f"realtime column: two_quanta's viewer {v['real_time_factor']:.3g}x real time, the bench's frames "
          f"{row['real_time_factor']:.3g}x")


tests = {name[5:]: f for name, f in globals().items() if name.startswith("test_")}
if TEST not in tests:
    fail(f"no such test; known: {', '.join(tests)}")
tests[TEST]()
