"""The hub's controller live: does it reproduce the offline closed loop, and how fast is
its loop?

For each time scale asked, starts `sail-ros sim`, `sail-ros control` (both with that
scale's params file: config/closed_loop.yaml at 1, config/closed_loop_scale4.yaml at 4)
and `sail-ros recorder` as processes, and drives the reference closed-loop scenario
(config/scenario_free_hub_control.yaml) from a client node of its own
(`ros.sim_client.SimClient`, as `sail-ros send`): pause, reset (the run starts from the
scenario's initial state), deploy to 16 m in 15 s (booms a, b, c; the simulator's
deploy_duration), boom d along its cycloid to 12 m in 6 s (waypoints every 0.25 s),
resume. After `--duration` simulated seconds it stops them and prints, from the recorded log:

- the live run's peak |theta| and that of the offline closed loop
  (`analysis.closed_loop.run_closed_loop`) of the same scenario, and their largest
  difference over the run as a fraction of the offline peak (the bar: 5 %);
- the loop latency (a state sample's publication to its command's), from the
  controller's statuses on /diagnostics: the median of their window medians and the
  largest window maximum;
- the delay with which the simulator applied the commands (its answers' t_start_s less
  the sample's time), and the saturated samples, as the controller counted them.

    python benchmarks/control_loop.py                          # 20 s at time scales 1 and 4
    python benchmarks/control_loop.py --scales 4 --duration 5
    python benchmarks/control_loop.py --modes 4 6              # the sail's mode counts
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rclpy
import yaml
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from sail_ros import topics
from sail_ros.analysis.closed_loop import last_run, run_closed_loop, tilt_agreement
from sail_ros.analysis.log_series import read_log
from sail_ros.analysis.scenario import load_scenario
from sail_ros.model import SailModel, SailParameters
from sail_ros.ros.sim_client import SimClient
from sail_ros.tools.send import trajectory

ROOT = Path(__file__).resolve().parents[1]
# the params files of the time scales: one sample a tick of the simulator (5 ms at least)
CONFIGS = {
    1.0: ROOT / "config" / "closed_loop.yaml",
    4.0: ROOT / "config" / "closed_loop_scale4.yaml",
}
SCENARIO = ROOT / "config" / "scenario_free_hub_control.yaml"
TIMEOUT_S = 30.0


def drive(client: SimClient, scenario) -> None:
    """The scenario's deployment from its initial state: pause, reset, all booms to 16 m
    (deploy_duration 15 s: the cycloid of a, b, c), boom d through its cycloid's lengths
    every 0.25 s to its end at 6 s, resume; each command's answer awaited. From a client
    made before the run, so that no participant joins or leaves as the run starts."""
    client.call(topics.PAUSE_SERVICE, SetBool.Request(data=True), TIMEOUT_S)
    client.call(topics.RESET_SERVICE, Trigger.Request(), TIMEOUT_S)
    for name, message in (
        (topics.DEPLOY_CMD, Float64(data=16.0)),
        (topics.BOOM_LENGTH_CMD, trajectory(
            ["d"], [[0.25 * k, scenario.profile(0.25 * k)[0][3]] for k in range(1, 25)]
        )),
    ):  # fmt: skip
        answer = client.send(name, message, TIMEOUT_S)
        if answer.outcome != "accepted":
            raise RuntimeError(f"{name}: {answer.outcome}: {answer.message}")
    client.call(topics.PAUSE_SERVICE, SetBool.Request(data=False), TIMEOUT_S)


def start(tool: str, args: list[str], log: Path) -> subprocess.Popen:
    with open(log, "w") as stream:
        return subprocess.Popen(
            [sys.executable, "-m", "sail_ros.cli", tool, *args], stdout=stream,
            stderr=subprocess.STDOUT,
        )  # fmt: skip


def wait_for(log: Path, text: str, process: subprocess.Popen, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while text not in log.read_text():
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"{log.name}: no {text!r}:\n{log.read_text()}")
        time.sleep(0.05)


def configuration(scale: float, modes: list[int]) -> dict:
    """The params file of `scale` (CONFIGS) with the sail's mode counts."""
    document = yaml.safe_load(CONFIGS[scale].read_text())
    document["/**"]["ros__parameters"]["sail"] |= {
        "n_boom_modes": modes[0],
        "n_membrane_modes": modes[1],
    }
    return document


def live(client, scale: float, duration: float, modes: list[int], folder: Path) -> Path:
    """One live trial at `scale` driven by `client`; the recorded bag folder."""
    document = configuration(scale, modes)
    config = folder / f"closed_loop_{scale:g}.yaml"
    config.write_text(yaml.safe_dump(document))
    params = ["--ros-args", "--params-file", str(config)]
    bag = folder / f"scale_{scale:g}"
    sim = start("sim", params, folder / "sim.log")
    control = start("control", params, folder / "control.log")
    recorder = start("recorder", ["-o", str(bag)], folder / "recorder.log")
    processes = (recorder, control, sim)
    try:
        wait_for(folder / "control.log", "runs the plant of this design", control)
        wait_for(folder / "recorder.log", "recording /sail/hub_wrench_cmd ", recorder)
        drive(client, load_scenario(SCENARIO))
        time.sleep(duration / scale + 1.0)
    finally:
        for process in processes:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(20)
                except subprocess.TimeoutExpired:
                    process.kill()
    return bag


def statuses(log, name: str) -> np.ndarray:
    """The controller's status values `name` over the run (those reported)."""
    values = np.array([float(v) for v in log.controller[1].get(name, []) if v])
    return values[values >= 0]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scales", type=float, nargs="+", default=[1.0, 4.0],
                        choices=sorted(CONFIGS))  # fmt: skip
    parser.add_argument("--duration", type=float, default=20.0, help="simulated time [s]")
    parser.add_argument("--modes", type=int, nargs=2, default=[4, 6], metavar=("N_B", "N_M"))
    args = parser.parse_args()
    scenario = load_scenario(SCENARIO)
    params = SailParameters(
        **scenario.sail, n_boom_modes=args.modes[0], n_membrane_modes=args.modes[1]
    )
    print(f"closed loop of {SCENARIO.name}, (n_B, n_M) = {tuple(args.modes)}, "
          f"{args.duration:g} s simulated")  # fmt: skip
    context = rclpy.Context()
    rclpy.init(context=context)
    client = SimClient(context, "control_loop")
    with tempfile.TemporaryDirectory(prefix="control_loop_") as folder:
        for scale in args.scales:
            control = configuration(scale, args.modes)["sail_control"]["ros__parameters"]
            rate = control["state_rate_hz"]
            design = scenario.controller.replace(
                state_rate_hz=rate, loop_delay_s=control.get("loop_delay_s", 0.0)
            )
            closed = run_closed_loop(SailModel(params), scenario, design)
            bag = live(client, scale, args.duration, args.modes, Path(folder))
            log = read_log(bag)
            t, hub = last_run(log)
            keep = t <= args.duration + 1e-9
            difference, peak, compared = tilt_agreement(t[keep], hub[keep], closed)
            live_peak = float(np.hypot(hub[keep, 1], hub[keep, 2]).max())
            medians = statuses(log, "latency_median_ms")
            largest = statuses(log, "latency_max_ms")
            delays = statuses(log, "applied_delay_median_s")
            delay_max = statuses(log, "applied_delay_max_s")
            last = {k: v[-1] for k, v in log.controller[1].items()}
            simulator = log.diagnostics[1]
            factors = [float(v) for v in simulator.get("real_time_factor", []) if float(v) > 0]
            saturations = json.loads(last.get("saturations", "{}"))
            print(
                f"time scale {scale:g}, {rate:g} Hz: {compared} samples compared over "
                f"{t[keep][-1]:.2f} s; "
                f"peak |theta| live {1e3 * live_peak:.4g} mrad, offline {1e3 * peak:.4g} mrad; "
                f"largest difference {1e3 * difference:.4g} mrad = {100 * difference / peak:.3g} % "
                "of the offline peak"
            )
            print(
                f"  loop latency: median of the 1 s windows' medians "
                f"{np.median(medians):.3g} ms (windows {medians.min():.3g}-"
                f"{medians.max():.3g} ms), "
                f"largest {largest.max():.3g} ms; applied delay median {np.median(delays):.3g} s, "
                f"largest {delay_max.max() + 0.0:.3g} s; saturated samples "
                f"{last.get('saturated_samples')} of {last.get('samples')} ({saturations})"
            )
            print(
                f"  simulator: real-time factor {min(factors):.3g}-{max(factors):.3g} (median "
                f"{np.median(factors):.3g}); steps that waited for a command in vain: "
                f"{simulator.get('missed_commands', ['?'])[-1]}"
            )
    client.close(deliver=False)
    rclpy.try_shutdown(context=context)
    return 0


if __name__ == "__main__":
    sys.exit(main())
