"""Steps release the GIL: a Python thread makes progress while qbond steps."""
import sys
import threading
import time

import qbond


def test_a_python_thread_progresses_during_a_long_step():
    w = qbond.World()
    w.add_cubic_lattice((12, 12, 12), spacing=0.01, quanta_mass=1e-3, stiffness=1e4)
    sim = qbond.Simulation(w, 1e-3, threads=1)
    ticks = 0
    stop = threading.Event()

    def count():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1

    worker = threading.Thread(target=count)
    worker.start()
    # The counter's rate while the main thread sleeps (GIL free), under the same load as below.
    t0, k0 = time.perf_counter(), ticks
    time.sleep(0.1)
    rate = (ticks - k0) / (time.perf_counter() - t0)
    # One call of at least 1 s: with the GIL held the counter could advance only until the call
    # took the GIL, at most one switch interval (sys.getswitchinterval(), 5 ms) of counting. The
    # long call leaves room for other processes taking the cores (ctest runs tests side by side).
    steps, seconds = 4, 0.0
    while seconds < 1.0:  # until one call lasts long enough to tell (steps get cheaper once warm)
        steps *= 2
        start_ticks, start = ticks, time.perf_counter()
        sim.step(steps)
        during, seconds = ticks - start_ticks, time.perf_counter() - start
    stop.set()
    worker.join()
    held = rate * sys.getswitchinterval()  # what a GIL-holding call would leave the counter
    assert rate > 0, "the counter did not run while the main thread slept"
    assert during > max(10 * held, 0.02 * rate * seconds), (
        f"{during} ticks in {seconds:.3f} s of stepping; {rate:.0f} ticks/s while sleeping")
