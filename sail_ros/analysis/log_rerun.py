"""A simulator's log run again offline: the motion, loads and state it records, at the
log's mode counts or at more.

A recorder's log of the simulator holds what its run depended on: the boom lengths
and rates at every sample (/sail/boom_state), the modal state (/sail/modal_state),
the load commands and the simulator's answers to them (sail/pressure_cmd,
sail/tip_force_cmd, sail/command_status: which were applied, and from when), and
the parameters (`sail_sim_parameters`: the sail, `solar_pressure`). The loads come
from the answers alone: an accepted load command's answer holds the four values held
from then on. `rerun_log`
rebuilds the run from them: the booms follow the cubic Hermite through the logged
lengths and rates (`model.profiles.SampledProfile`), the loads step where the
simulator applied them, and the state starts from the first logged modal sample,
and again after each reset (the simulator then publishes a fresh sample at the time
of the last one). It integrates that with the true peaks (`peaks.OutputPeaks`), at
the log's mode counts and, for their convergence, at more; how closely the rerun at
the log's mode counts reproduces the logged tips says whether the log held all the
run depended on.
"""

from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.serialization import deserialize_message

from sail_ros import topics
from sail_ros.analysis.deployment import carried_over
from sail_ros.analysis.log_series import LogSeries, runs_of
from sail_ros.bag import BagReader
from sail_ros.integrate.peaks import OutputPeaks, Peak, Peaks
from sail_ros.messages import commands as commands_msg
from sail_ros.model import SailModel
from sail_ros.model.loads import LoadSchedule
from sail_ros.model.profiles import SampledProfile
from sail_ros.model.yaml_values import load as load_yaml


def rerun_log(log: LogSeries, model: SailModel, carried_from: SailModel | None = None):
    """Run `log` (`read_log`) again with `model`; with `carried_from` (the log's own model,
    fewer modes) the logged coordinates carry over by name into `model`'s. Returns the
    true peaks (`Peaks`, times on the log's time axis), how closely the rerun reproduces
    the logged tip deflections (the largest difference over the largest logged value)
    and how many runs the log held (a reset starts one).

    Raises:
        ValueError: the log lacks what a rerun needs (boom and modal states on the
            same stamps, simulation-time stamps), naming it.
    """
    if log.boom is None or log.modal is None or log.tips is None:
        raise ValueError("a rerun needs /sail/boom_state, /sail/modal_state, /sail/tip_deflection")
    if not log.simulation_time:
        raise ValueError("a rerun needs the log's simulation time (its /diagnostics)")
    boom_rows, modal_rows = _paired(log.boom.stamp_ns, log.modal.stamp_ns)
    if boom_rows.size < 2:
        raise ValueError("/sail/boom_state and /sail/modal_state share fewer than 2 stamps")
    source = carried_from or model
    if log.modal.names != source.coordinate_names:
        raise ValueError(
            f"/sail/modal_state names {len(log.modal.names)} coordinates, the model "
            f"{source.n} (n_B = {source.n_boom_modes}, n_M = {source.n_membrane_modes})"
        )
    t = log.seconds(log.boom.stamp_ns[boom_rows])
    lengths, rates = log.boom.position[boom_rows], log.boom.velocity[boom_rows]
    q_logged, qd_logged = log.modal.position[modal_rows], log.modal.velocity[modal_rows]
    tip_rows = _paired(log.boom.stamp_ns[boom_rows], log.tips.stamp_ns)
    commands = applied_loads(log)
    solar = solar_pressure(log)
    tips, found = np.empty((t.size, 4)), []
    for part in runs_of(t):
        times = t[part]
        start = times[0]
        q0, qd0 = q_logged[part.start], qd_logged[part.start]
        if source is not model:
            q0, qd0 = carried_over(q0, source, model), carried_over(qd0, source, model)
        peaks = OutputPeaks(model)
        if times.size > 1:
            profile = SampledProfile(times - start, lengths[part], rates[part])
            loads = _schedule(commands, solar, start, times[-1])
            switches = [
                s for s in (loads.switch_times if loads else []) if 0 < s < times[-1] - start
            ]
            t_eval = np.union1d(times - start, switches)
            t_run, q, _ = model.simulate(  # the tips alone: no velocities inside steps
                profile, t_eval[-1], q0, qd0, t_eval=t_eval, loads=loads, observer=peaks,
                rates=None,
            )  # fmt: skip
            on_samples = np.isin(t_run, times - start)
            tips[part] = model.tip_deflections(q[on_samples])
        else:
            tips[part] = model.tip_deflections(q0)
        found.append((start, peaks.peaks if times.size > 1 else None))
    peaks = _combined(found)
    logged = log.tips.position[tip_rows[1]]
    difference = np.abs(tips[tip_rows[0]] - logged).max()
    agreement = float(difference / max(np.abs(logged).max(), 1e-300))
    return peaks, agreement, len(found)


def _paired(first, second) -> tuple[np.ndarray, np.ndarray]:
    """Indices into two stamp series (each in publishing order, a reset repeating a stamp)
    of the samples both hold: a recorder stopped between two topics of one sample, or a
    lost message, leaves one without the other."""
    rows_a, rows_b = [], []
    i = j = 0
    while i < len(first) and j < len(second):
        if first[i] == second[j]:
            rows_a.append(i)
            rows_b.append(j)
            i, j = i + 1, j + 1
        elif first[i] < second[j]:
            i += 1
        else:
            j += 1
    return np.array(rows_a, dtype=int), np.array(rows_b, dtype=int)


def applied_loads(log: LogSeries) -> list[tuple[float, str, np.ndarray]]:
    """`(simulation time, topic, the values then held)` of every load command the
    simulator accepted, from its answers on sail/command_status (the recorder takes them
    from the start, where a command's short-lived publisher may come and go unseen)."""
    status = topics.absolute(topics.COMMAND_STATUS, log.namespace)
    kinds = (*topics.LOAD_NAMES, topics.HUB_WRENCH_CMD)
    loads = {topics.absolute(name, log.namespace): name for name in kinds}
    applied = []
    answers = (
        answer
        for message in BagReader(log.path).messages([status])
        for answer in commands_msg.command_answers(
            deserialize_message(message.data, DiagnosticArray)
        )
    )
    for answer in answers:
        if answer.outcome != commands_msg.ACCEPTED or answer.topic not in loads:
            continue
        held = answer.values.get(commands_msg.LOADS_HELD)
        if held is None:
            raise ValueError(
                f"the answers to {answer.topic} hold no {commands_msg.LOADS_HELD}: "
                "the loads of the run are unknown"
            )
        values = np.array(load_yaml(held), dtype=float)
        applied.append((float(answer.values["t_start_s"]), loads[answer.topic], values))
    return sorted(applied, key=lambda item: item[0])


def solar_pressure(log: LogSeries) -> float:
    """The `solar_pressure` parameter [Pa] recorded with the log (0 if absent)."""
    text = (log.parameters or {}).get("solar_pressure")
    return float(load_yaml(text)) if text is not None else 0.0


class HeldLoads:
    """The loads a simulator holds from its accepted load commands (`applied_loads`): each
    command topic's latest values, zeros at a run's start and after a reset."""

    def __init__(self):
        self.reset()

    def reset(self) -> None:
        self.values = {topics.PRESSURE_CMD: np.zeros(4), topics.TIP_FORCE_CMD: np.zeros(4),
                       topics.HUB_WRENCH_CMD: np.zeros(3)}  # fmt: skip

    def apply(self, topic: str, values) -> None:
        self.values[topic] = values

    def inputs(self, solar: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of the pressures [Pa] with the solar pressure `solar` [Pa] added, the tip
        forces [N] and the hub wrench [N, N m, N m]."""
        values = self.values
        return (values[topics.PRESSURE_CMD] + solar, values[topics.TIP_FORCE_CMD].copy(),
                values[topics.HUB_WRENCH_CMD].copy())  # fmt: skip


def _schedule(commands, solar: float, start: float, end: float) -> LoadSchedule | None:
    """The loads of one run from `start` to `end` [s] (times from its start): the commands
    applied in it, held; a run starts unloaded but for the solar pressure."""
    held = HeldLoads()

    def step(t):
        return (t, *held.inputs(solar))

    steps = [step(0.0)]
    for t, topic, values in commands:
        if not start < t <= end:
            continue
        held.apply(topic, values)
        if t - start == steps[-1][0]:
            steps.pop()
        steps.append(step(t - start))
    if len(steps) == 1 and not (steps[0][1].any() or steps[0][2].any()):
        return None
    if not any(s[3].any() for s in steps):  # a clamped hub's schedule has no wrench
        steps = [s[:3] for s in steps]
    return LoadSchedule(steps)


def _combined(found) -> Peaks:
    """The peaks of every run, the largest of each output kept, times on the log's axis."""
    best = [np.zeros(4), np.full(4, np.nan), np.zeros(4), np.full(4, np.nan)]
    for start, peaks in found:
        if peaks is None:
            continue
        for kind, (value, time) in enumerate((peaks.tip_deflection, peaks.root_moment)):
            better = value > best[2 * kind]
            best[2 * kind] = np.where(better, value, best[2 * kind])
            best[2 * kind + 1] = np.where(better, time + start, best[2 * kind + 1])
    return Peaks(Peak(best[0], best[1]), Peak(best[2], best[3]))
