"""Steps release the GIL: a Python thread makes progress while qbond steps."""
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
    time.sleep(0.05)
    # One call that lasts a good fraction of a second; with the GIL held the counter could not
    # advance at all until it returned.
    start_ticks, start = ticks, time.perf_counter()
    sim.step(40)
    during, seconds = ticks - start_ticks, time.perf_counter() - start
    stop.set()
    worker.join()
    assert seconds > 0.05, "the step call was too short to tell"
    assert during > 1000, f"only {during} ticks in {seconds:.3f} s of stepping"
