"""How the programs end when things around them go wrong: a SIGINT that comes while a
program started from a script is still starting, and a teardown that never returns."""

import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.multiprocess


def _ignoring_sigint():
    # what a non-interactive shell does to a background job (`sail-ros recorder &`)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _default_sigint():
    # what an interactive shell gives a foreground program, whatever the test runner's
    # own SIGINT disposition is at the moment (an ignored one would be inherited)
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_a_sigint_while_starting_in_the_background_finishes_the_recording(ros_env, tmp_path):
    """The SIGINT comes while the entry point imports the recorder's modules (its second
    of imports), before the recorder exists: it is acted on when the recorder starts,
    which finishes an empty bag and exits 0, instead of being ignored for good (a
    recorder that runs on after `kill -INT`). Importing the package alone changes no
    signal handling."""
    folder = tmp_path / "bag"
    program = (
        "import importlib, os, signal, sys\n"
        "import sail_ros, sail_ros.cli\n"
        "assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # quiet imports\n"
        "load = importlib.import_module\n"
        "def importing(name, *args, **kwargs):\n"
        "    if name == 'sail_ros.nodes.recorder':\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "    return load(name, *args, **kwargs)\n"
        "importlib.import_module = importing\n"
        f"sys.exit(sail_ros.cli.main(['recorder', '-o', {str(folder)!r}]))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", program],
        env=ros_env,
        preexec_fn=_ignoring_sigint,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    assert "SIGINT: finishing the recording" in result.stderr
    assert (folder / "metadata.yaml").is_file()


def test_a_sigint_while_the_simulator_imports_ends_it_without_a_traceback(ros_env):
    """Ctrl-C while `sail-ros sim` is still importing its modules (its SIGINT handling is
    Python's until the node takes it over): the program ends with the shell's exit code
    for it, 130, and not a KeyboardInterrupt traceback."""
    program = (
        "import importlib, os, signal, sys\n"
        "import sail_ros.cli\n"
        "assert signal.getsignal(signal.SIGINT) is signal.default_int_handler\n"
        "load = importlib.import_module\n"
        "def importing(name, *args, **kwargs):\n"
        "    if name == 'sail_ros.nodes.sim':\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "    return load(name, *args, **kwargs)\n"
        "importlib.import_module = importing\n"
        "sys.exit(sail_ros.cli.main(['sim']))\n"
    )
    result = run_script(program, ros_env)
    assert result.returncode == 130, result.stderr
    assert "Traceback" not in result.stderr and "KeyboardInterrupt" not in result.stderr


def test_a_sigint_whose_interrupt_a_finalizer_drops_still_stops_the_simulator(ros_env):
    """Ctrl-C while `sail-ros sim` imports, its KeyboardInterrupt raised inside a finalizer
    (Python prints it and goes on, as it does in a callback): the signal was noted all the
    same, and the simulator stops as soon as it has started (exit 0), instead of running
    on after the user's Ctrl-C."""
    program = (
        "import importlib, os, signal, sys, time\n"
        "import sail_ros.cli\n"
        "class Dropping:\n"
        "    def __del__(self):  # the interrupt is raised here, printed and dropped\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        time.sleep(0.01)\n"
        "load = importlib.import_module\n"
        "def importing(name, *args, **kwargs):\n"
        "    if name == 'sail_ros.nodes.sim':\n"
        "        Dropping()\n"
        "    return load(name, *args, **kwargs)\n"
        "importlib.import_module = importing\n"
        "sys.exit(sail_ros.cli.main(['sim']))\n"
    )
    result = run_script(program, ros_env)
    assert "Exception ignored in" in result.stderr and "KeyboardInterrupt" in result.stderr
    assert result.returncode == 0, result.stderr
    assert "SIGINT: stopping at t = 0.000000 s" in result.stderr


@pytest.mark.slow
def test_a_sigint_soon_after_the_simulator_starts_ends_it_without_a_traceback(ros_env):
    """The trial of the test above as a user meets it: `sail-ros sim` sent SIGINT 0.1 to
    1.5 s after it started, in its imports, its set-up or its run: every time it ends
    within 10 s, with 130 (still importing) or 0 (stopped by its node), and no
    traceback. Not sooner: the first 40-50 ms here are the interpreter's own start
    (`site` imports the ROS wheels' path hook, 26 ms), before any of the program runs,
    where a Ctrl-C meets Python's own handling."""
    for delay in (0.1, 0.15, 0.2, 0.3, 0.5, 1.0, 1.5):
        process = subprocess.Popen(
            ["sail-ros", "sim"], env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True,
        )  # fmt: skip
        time.sleep(delay)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=10)
        assert process.returncode in (0, 130), (delay, err)
        assert "Traceback" not in err, (delay, err)


def run_script(text: str, env: dict) -> subprocess.CompletedProcess:
    """Python `text` run in a process of its own, started as from a terminal (SIGINT at
    its default; its output kept, at most 60 s)."""
    return subprocess.run(
        [sys.executable, "-c", text], env=env, capture_output=True, text=True, timeout=60,
        preexec_fn=_default_sigint,
    )  # fmt: skip


def test_a_node_refused_at_start_whose_teardown_sticks_still_ends(ros_env):
    """A node tool whose node is refused while being built (`ConfigError`): the node goes
    with the error's traceback, before `run_node`'s own teardown; its teardown sticking
    there (Fast DDS can deadlock removing a participant) ends the process all the same,
    with exit code 1 and the stacks, instead of hanging."""
    stuck = (
        "import argparse, re\n"
        "from sail_ros.ros import program as cli\n"
        "from sail_ros.ros.parameters import ConfigError\n"
        "cli.TEARDOWN_LIMIT_S = 0.5\n"
        "class Node:\n"
        "    def __del__(self):  # a teardown that never ends, holding the interpreter\n"
        "        re.match(r'(a+)+$', 'a' * 64 + 'b')\n"
        "def body(namespace, stop):\n"
        "    node = Node()\n"
        "    raise ConfigError('compression must be one of zstd, lz4, none')\n"
        "raise SystemExit(cli.run_node('probe', argparse.ArgumentParser(), [], body))\n"
    )
    started = time.monotonic()
    result = run_script(stuck, ros_env)
    assert result.returncode == 1 and time.monotonic() - started < 30.0, result.stderr
    assert "compression must be one of" in result.stderr
    assert "Timeout (0:00:00.500000)!" in result.stderr and "__del__" in result.stderr


def test_a_stuck_teardown_ends_the_process_even_holding_the_interpreter_lock(ros_env):
    """`bounded_teardown`'s watchdog needs no interpreter lock: a teardown stuck in code
    that holds it (here a regular expression that backtracks for ever) still ends, with
    exit code 1 and the stacks; a teardown that returns leaves no watchdog behind."""
    stuck = (
        "import re\n"
        "from sail_ros.ros.program import bounded_teardown\n"
        "with bounded_teardown(0.5):\n"
        "    re.match(r'(a+)+$', 'a' * 64 + 'b')\n"
    )
    started = time.monotonic()
    result = run_script(stuck, ros_env)
    assert result.returncode == 1 and time.monotonic() - started < 30.0
    assert "Timeout (0:00:00.500000)!" in result.stderr and "<string>" in result.stderr

    finished = (
        "import time\n"
        "from sail_ros.ros.program import bounded_teardown\n"
        "with bounded_teardown(0.2):\n"
        "    pass\n"
        "time.sleep(0.6)\n"
    )
    result = run_script(finished, ros_env)
    assert result.returncode == 0 and result.stderr == ""
