"""Ctrl-C inside the C integration (issue 10, item 9).

Before: SIGINT during a long ``simulate`` was acted on only when the C call returned
(18 s later in the issue's case).  Now the driver polls Python's signal wakeup pipe
every GS_POLL_EVERY right-hand side evaluations and returns GS_ERR_INTERRUPTED; the
CLI prints "interrupted" and exits 130.  The bound asserted here is generous (the
machine is shared); the measured latency is printed (``-s``) and reported.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import gearsym

ROOT = Path(__file__).resolve().parents[1]
KS_SCENE = ROOT / "scenes" / "kahraman_singh.toml"
KS_MODEL = ROOT / "models" / "kahraman_singh.toml"

#: compile (cached), then run `gearsym simulate` of 200,000 forcing periods (about a minute
#: of CPU on this machine) through the CLI's entry point
CHILD = """
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)  # a shell's background job starts with SIGINT ignored
import gearsym
from gearsym.cli import main
gearsym.load_scene(sys.argv[1]).compile()
print("start", flush=True)
sys.exit(main(["simulate", sys.argv[1], "--periods", "200000"]))
"""


@pytest.fixture(autouse=True)
def sigint_handled():
    """Python's own SIGINT handler for the test: a process started as a background job of a
    non-interactive shell (``cmd &``, as some CI runners do) inherits SIGINT ignored, and
    Python then leaves it ignored."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


@pytest.fixture(scope="module")
def long_scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("intr")
    scene = d / "long.toml"
    scene.write_text(KS_SCENE.read_text().replace('"../models/kahraman_singh.toml"', json.dumps(str(KS_MODEL)))
                     .replace("points_per_period = 64", "points_per_period = 1\nmax_steps = 100000000"))
    gearsym.load_scene(scene).generate(generated_dir=d / "gen")
    return scene, d / "gen"


def test_ctrl_c_stops_a_long_integration_and_the_cli_exits_130(long_scene):
    scene, gen = long_scene
    env = dict(os.environ, GEARSYM_GENERATED=str(gen), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    p = subprocess.Popen([sys.executable, "-c", CHILD, str(scene)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env)
    try:
        assert p.stdout.readline().strip() == "start", p.stderr.read()
        time.sleep(1.0)  # well inside the C integration
        t0 = time.perf_counter()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=600)
        latency = time.perf_counter() - t0
    finally:
        if p.poll() is None:
            p.kill()
    print(f"\nSIGINT -> process exit: {latency:.3f} s")
    assert p.returncode == 130, (p.returncode, err[-2000:])
    assert err.strip().splitlines()[-1] == "gearsym: interrupted" and "Traceback" not in err
    assert latency < 5.0  # before: the whole integration (about a minute)


def test_simulate_raises_keyboard_interrupt_and_restores_the_wakeup_fd(long_scene):
    scene, gen = long_scene
    system = gearsym.load_scene(scene).compile(generated_dir=gen)
    before = signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(before)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    t0 = time.perf_counter()
    try:
        with pytest.raises(KeyboardInterrupt):
            system.simulate(periods=200000, n_out=2)
        latency = time.perf_counter() - t0 - 0.3
    finally:
        timer.cancel()
    print(f"\nSIGINT -> KeyboardInterrupt: {latency * 1e3:.1f} ms")
    assert latency < 5.0
    assert signal.set_wakeup_fd(before) == before  # restored after the call
    # the next call is not interrupted by what is left of the signal
    traj = system.simulate(periods=3)
    assert traj.t[-1] == pytest.approx(3 * traj.period)


def test_threads_run_without_interrupt_polling(long_scene):
    scene, gen = long_scene
    system = gearsym.load_scene(scene).compile(generated_dir=gen)
    ref = system.simulate(periods=5).y[-1]
    res = []
    th = threading.Thread(target=lambda: res.append(system.simulate(periods=5).y[-1]))
    th.start()
    th.join()
    assert res[0].tolist() == ref.tolist()


def test_sigterm_stops_a_long_integration_and_the_cli_exits_143(long_scene):
    """Issue 25 item 5: SIGTERM is handled like Ctrl-C (before: the default action killed the
    process, -15, with no clean-up; a map's workers then stayed behind)."""
    scene, gen = long_scene
    env = dict(os.environ, GEARSYM_GENERATED=str(gen), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    p = subprocess.Popen([sys.executable, "-c", CHILD, str(scene)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env)
    try:
        assert p.stdout.readline().strip() == "start", p.stderr.read()
        time.sleep(1.0)  # well inside the C integration
        t0 = time.perf_counter()
        p.send_signal(signal.SIGTERM)
        out, err = p.communicate(timeout=600)
        latency = time.perf_counter() - t0
    finally:
        if p.poll() is None:
            p.kill()
    print(f"\nSIGTERM -> process exit: {latency:.3f} s")
    assert p.returncode == 143, (p.returncode, err[-2000:])
    assert err.strip().splitlines()[-1] == "gearsym: terminated" and "Traceback" not in err
    assert latency < 5.0  # the driver stops on SIGTERM too (not only when the minute-long call returns)


def test_sigterm_handler_only_inside_the_cli_and_restored():
    from gearsym.cli import main
    from gearsym.engine.interrupt import GS_INTR_SIGINT, GS_INTR_SIGTERM, signal_mask
    from gearsym.signals import sigterm_interrupts

    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert signal_mask() == GS_INTR_SIGINT  # a library user's SIGTERM is not turned into an interrupt
    with sigterm_interrupts():
        assert signal_mask() == GS_INTR_SIGINT | GS_INTR_SIGTERM
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert main(["models"]) == 0
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    # somebody else's handler is left alone
    mine = signal.signal(signal.SIGTERM, lambda *a: None)
    try:
        with sigterm_interrupts():
            assert signal_mask() == GS_INTR_SIGINT
    finally:
        signal.signal(signal.SIGTERM, mine)


def test_an_interrupted_child_is_asked_to_stop_and_cleans_up(tmp_path):
    """Issue 25 item 10: a compiler interrupted by Ctrl-C / SIGTERM gets SIGTERM (and removes its
    temporary files: gcc's ``cc*.s``) before it would be killed; ``subprocess.run`` kills at once."""
    from gearsym.signals import run_child

    scratch, ready = tmp_path / "scratch.s", tmp_path / "ready"
    script = (f'trap \'rm -f "{scratch}"; exit 1\' TERM; touch "{scratch}"; touch "{ready}"; '
              f'while :; do sleep 0.05; done')

    def interrupt_when_ready():
        while not ready.exists():
            time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)

    th = threading.Thread(target=interrupt_when_ready)
    th.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            run_child(["sh", "-c", script])
    finally:
        th.join()
    assert ready.exists() and not scratch.exists()
