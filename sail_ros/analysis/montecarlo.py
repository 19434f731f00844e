"""Monte Carlo deployments: a base scenario, dispersed inputs, one run per sample.

A study file (see config/study_reference.yaml; every key, unit, default and range
in docs/scenarios.md, made from the sections here)::

    study:
      description: free text
      samples: 200
      seed: 7
      scenario: scenario_reference.yaml   # a file (relative to the study file) or a mapping
      output_rate_hz: 10                  # samples of each run [Hz]
      dispersions:                        # any subset; keys below
        boom_bending_stiffness: {distribution: normal, mean: 6000.0, std: 300.0}
        membrane_prestress: {distribution: lognormal, median: 6890.0, sigma: 0.2}
        initial_tip_deflection.a: {distribution: uniform, low: 0.05, high: 0.15}
        rate.b: {distribution: normal, mean: 1.0, std: 0.05}
      jam: {probability: 0.1, fraction: {distribution: uniform, low: 0.2, high: 0.9}}

Keys: a float field of `SailParameters`; `initial_tip_deflection.<boom>` [m]
(the boom bent in its first mode); `rate.<boom>`, a factor on that boom's
deployment rate (its cycloidal profile runs in duration / factor). `jam`: with
`probability`, one boom (drawn uniformly) stops dead at `fraction` of its
travel. Distributions: `normal` (mean, std), `uniform` (low, high),
`lognormal` (median, sigma of the log).

Every sample's inputs come from its own generator, seeded by (study seed,
sample index), so a sample gives the same numbers wherever and in whatever
order it runs. A sample is written out as an ordinary scenario file
(`sample_scenario`): `sail-ros deploy` reruns it to the same numbers. Every
sample keeps the simulator's policy (`run_deployment`): a draw that asks what the
simulator would refuse, or a run that leaves the linear range, is a row with its
error.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from sail_ros.analysis.deployment import hold_peaks, output_count, output_times, run_deployment
from sail_ros.analysis.scenario import BOOMS, scenario_from_dict
from sail_ros.analysis.schema import Section, check_number, key
from sail_ros.model import SailModel, SailParameters, yaml_values
from sail_ros.policy import OutOfRangeError, Policy

STUDY = Section(
    "study",
    "A study file holds one section, `study:`.",
    (
        key("description", "text", "", "free text; the summary and figures show it",
            default=""),
        key("samples", "integer", "-", "how many samples to run", minimum=1),
        key("seed", "integer", "-", "seed of every sample's generator (with the sample's "
            "index)", default=0, minimum=0),
        key("scenario", "file or mapping", "", "the base scenario: a scenario file (relative "
            "to the study file) or a scenario mapping (`scenario:` and `sail:`)"),
        key("output_rate_hz", "number", "Hz", "samples of each run's time histories",
            default=10.0, minimum=0.0, above_minimum=True, maximum=1000.0),
        key("dispersions", "mapping", "", "input -> distribution (below): a float field of "
            "`SailParameters`, `initial_tip_deflection.<boom>` [m] (the boom bent in its "
            "first mode), `rate.<boom>` [-] (a factor on that boom's deployment rate: its "
            "cycloidal profile runs in duration / factor)", default=None, absent="none"),
        key("jam", "mapping", "", "a jammed boom (`study.jam`, below)", default=None,
            absent="no jams"),
    ),
)  # fmt: skip
JAM = Section(
    "study.jam",
    "With `probability`, one boom (drawn uniformly) stops dead at `fraction` of its travel "
    "(its base profile must be cycloidal).",
    (
        key("probability", "number", "-", "chance that a sample jams a boom", minimum=0.0,
            maximum=1.0),
        key("fraction", "distribution", "-", "where along its travel the boom jams"),
    ),
)  # fmt: skip
DISTRIBUTION_SECTIONS = {
    "normal": Section(
        "distribution: normal",
        "Normal: `mean` and standard deviation `std`.",
        (key("distribution", "text", "", "`normal`"),
         key("mean", "number", "", "mean, in the input's unit"),
         key("std", "number", "", "standard deviation, in the input's unit", minimum=0.0)),
    ),
    "uniform": Section(
        "distribution: uniform",
        "Uniform over [low, high].",
        (key("distribution", "text", "", "`uniform`"),
         key("low", "number", "", "lowest value, in the input's unit"),
         key("high", "number", "", "highest value (>= low), in the input's unit")),
    ),
    "lognormal": Section(
        "distribution: lognormal",
        "Lognormal: `median` and `sigma`, the standard deviation of the log.",
        (key("distribution", "text", "", "`lognormal`"),
         key("median", "number", "", "median, in the input's unit", minimum=0.0,
             above_minimum=True),
         key("sigma", "number", "-", "standard deviation of the natural log", minimum=0.0)),
    ),
}  # fmt: skip
SECTIONS = (STUDY, JAM, *DISTRIBUTION_SECTIONS.values())
# kind -> its two parameters
DISTRIBUTIONS = {
    kind: tuple(k.name for k in section.keys if k.name != "distribution")
    for kind, section in DISTRIBUTION_SECTIONS.items()
}
ENVELOPE_BYTES = 4 * 4 + 8  # a sample's tips (float32, 4 booms) and time, kept per output time
# what a dispersion may draw: not the mode counts, nor a switch (free_hub: the base sail's)
FLOAT_FIELDS = tuple(
    name
    for name in SailParameters.field_names()
    if isinstance(getattr(SailParameters(), name), float)
)
OUTPUTS = (
    *(f"peak_tip_{b}_m" for b in BOOMS),
    *(f"peak_tip_{b}_time_s" for b in BOOMS),
    *(f"peak_root_moment_{b}_N_m" for b in BOOMS),
    *(f"peak_root_moment_{b}_time_s" for b in BOOMS),
    "peak_tip_m",
    "final_energy_J",
    "stability_margin_1_s",
    "error_estimate",  # the run's, relative to peak, the larger of tips and root moments
)
# with a free hub: its peak heave and tilt (OutputPeaks) and the holds' peak reactions
# (`hold_peaks`), columns only when a sample has them
HUB_OUTPUTS = ("peak_hub_heave_m", "peak_hub_heave_time_s", "peak_hub_tilt_rad",
               "peak_hub_tilt_time_s", "peak_hold_force_N", "peak_hold_torque_N_m")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Distribution:
    """A scalar distribution: normal (a = mean, b = std), uniform (a = low, b = high)
    or lognormal (a = median, b = sigma of the log)."""

    kind: str
    a: float
    b: float

    def draw(self, rng: np.random.Generator) -> float:
        if self.kind == "normal":
            return float(rng.normal(self.a, self.b))
        if self.kind == "uniform":
            return float(rng.uniform(self.a, self.b))
        return float(self.a * math.exp(rng.normal(0.0, self.b)))


@dataclasses.dataclass(frozen=True)
class Study:
    """A validated study (see the module docstring)."""

    description: str
    samples: int
    seed: int
    scenario: dict  # the base scenario document
    output_rate_hz: float
    dispersions: dict[str, Distribution]  # key -> distribution, in sorted key order
    jam_probability: float
    jam_fraction: Distribution | None

    @property
    def input_names(self) -> tuple[str, ...]:
        jam = ("jam_boom", "jam_fraction") if self.jam_fraction is not None else ()
        return (*self.dispersions, *jam)


def load_study(path) -> Study:
    """Read and validate a study file (ValueError naming the key)."""
    path = Path(path)
    document = yaml_values.load_file(path, "study")
    try:
        return study_from_dict(document, path.parent)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def study_from_dict(document, folder: Path = Path(".")) -> Study:
    if not isinstance(document, dict) or set(document) != {"study"}:
        raise ValueError("expected a mapping with one section 'study'")
    body = STUDY.check_keys(document["study"], "study")
    samples = STUDY.number(body, "samples", "study")
    seed = STUDY.number(body, "seed", "study")
    rate = STUDY.number(body, "output_rate_hz", "study")
    scenario = _scenario_document(body["scenario"], folder)
    dispersions = body.get("dispersions") or {}
    if not isinstance(dispersions, dict):
        raise ValueError(f"study.dispersions must be a mapping, got {dispersions!r}")
    checked = {}
    for name in sorted(dispersions):
        _check_key(name, scenario)
        checked[name] = _distribution(dispersions[name], f"study.dispersions.{name}")
    probability, fraction = 0.0, None
    jam = body.get("jam")
    if jam is not None:
        JAM.check_keys(jam, "study.jam")
        probability = JAM.number(jam, "probability", "study.jam")
        fraction = _distribution(jam["fraction"], "study.jam.fraction")
        _cycloidal_booms(scenario, "study.jam")
    study = Study(
        str(body.get("description", "")),
        samples,
        seed,
        scenario,
        float(rate),
        checked,
        float(probability),
        fraction,
    )
    sample_scenario(study, 0)  # the base scenario with the first draw must be valid
    return study


def check_study(study: Study, base_sail: dict, policy: Policy) -> None:
    """What the study asks before it runs: its base scenario within the policy
    (`scenario.check_scenario`, as every sample is checked), and its outputs within the
    memory an offline output may hold (`Policy.check_output`: the envelopes kept of every
    sample).

    Raises:
        ValueError: naming the value and its limit, or the estimate.
    """
    from sail_ros.analysis.scenario import check_scenario

    scenario = scenario_from_dict(study.scenario)
    model = SailModel(SailParameters.from_dict({**base_sail, **scenario.sail}))
    try:
        check_scenario(scenario, model, policy)
    except ValueError as error:
        raise ValueError(f"study.scenario: {error}") from None
    times = output_count(scenario.duration, study.output_rate_hz) + 1  # the end merged in
    Policy.check_output(
        study.samples * times,
        ENVELOPE_BYTES,
        f"{study.samples} samples of {times} output times each",
        "fewer samples, a shorter duration or a lower output_rate_hz",
    )


def _scenario_document(spec, folder: Path) -> dict:
    if isinstance(spec, str):
        path = folder / spec
        try:
            document = yaml_values.load(path.read_text())
        except OSError as error:
            raise ValueError(
                f"study.scenario: cannot read {str(path)!r}: {error.strerror}"
            ) from None
    elif isinstance(spec, dict):
        document = spec
    else:
        raise ValueError(f"study.scenario must be a scenario file or mapping, got {spec!r}")
    try:
        scenario_from_dict(document)
    except ValueError as error:
        raise ValueError(f"study.scenario: {error}") from None
    return copy.deepcopy(document)


def input_unit(name: str) -> str:
    """The unit of a study input (a dispersion key or a jam input): a
    `SailParameters` field's own, m for `initial_tip_deflection.<boom>`, "-" for a
    rate factor, the jammed boom's index (-1: none, 0..3: a..d) and the fraction of
    its travel at which it jams."""
    head = name.partition(".")[0]
    if head == "initial_tip_deflection":
        return "m"
    if head in ("rate", "jam_boom", "jam_fraction"):
        return "-"
    return SailParameters.unit(name)


def _check_key(key: str, scenario: dict) -> None:
    head, _, boom = key.partition(".")
    if not boom and key in FLOAT_FIELDS:
        return
    if head in ("initial_tip_deflection", "rate") and boom in BOOMS:
        if head == "rate":
            _cycloidal_booms(scenario, f"study.dispersions.{key}")
        return
    raise ValueError(
        f"study.dispersions: unknown key {key!r}; keys are SailParameters fields "
        f"({', '.join(FLOAT_FIELDS)}), initial_tip_deflection.<boom>, rate.<boom> "
        "(boom a, b, c or d)"
    )


def _cycloidal_booms(scenario: dict, where: str) -> None:
    profile = scenario["scenario"]["profile"]
    specs = [profile] if "type" in profile else [profile[b] for b in BOOMS]
    if any(spec.get("type") != "cycloidal" for spec in specs):
        raise ValueError(f"{where} needs a cycloidal base profile (one, or one per boom)")


def _distribution(spec, where: str) -> Distribution:
    if not isinstance(spec, dict) or spec.get("distribution") not in DISTRIBUTIONS:
        raise ValueError(
            f"{where} must be a mapping with distribution: {' | '.join(DISTRIBUTIONS)}, "
            f"got {spec!r}"
        )
    kind = spec["distribution"]
    section = DISTRIBUTION_SECTIONS[kind]
    try:
        section.check_keys(spec, where)
    except ValueError:
        names = DISTRIBUTIONS[kind]
        raise ValueError(
            f"{where}: a {kind} distribution takes {', '.join(names)}, got {spec!r}"
        ) from None
    a, b = (
        check_number(spec[entry.name], f"{where}.{entry.name}", entry.spec)
        for entry in section.keys
        if entry.name != "distribution"
    )
    if kind == "uniform" and not a <= b:
        raise ValueError(f"{where}: uniform needs low <= high, got {a} > {b}")
    return Distribution(kind, float(a), float(b))


def sample_inputs(study: Study, index: int) -> dict[str, float]:
    """The inputs of sample `index`: from the generator seeded (study seed, index),
    drawn in a fixed order (dispersions by key, then the jam)."""
    rng = np.random.default_rng([study.seed, index])
    values = {key: distribution.draw(rng) for key, distribution in study.dispersions.items()}
    if study.jam_fraction is not None:
        jammed = rng.random() < study.jam_probability
        boom = int(rng.integers(4))
        fraction = study.jam_fraction.draw(rng)
        values["jam_boom"] = float(boom) if jammed else -1.0
        values["jam_fraction"] = fraction if jammed else math.nan
    return values


def sample_scenario(study: Study, index: int, inputs: dict | None = None) -> dict:
    """Sample `index` as an ordinary scenario document (what `sail-ros deploy` runs)."""
    inputs = sample_inputs(study, index) if inputs is None else inputs
    document = copy.deepcopy(study.scenario)
    body = document["scenario"]
    sail = dict(document.get("sail") or {})
    body["description"] = f"{body.get('description', '')} | study sample {index}".strip(" |")
    profile = body["profile"]
    per_boom = any(key.startswith("rate.") for key in inputs) or inputs.get("jam_boom", -1) >= 0
    if per_boom and "type" in profile:
        profile = {b: copy.deepcopy(profile) for b in BOOMS}
        body["profile"] = profile
    for name, value in inputs.items():
        head, _, boom = name.partition(".")
        if name in FLOAT_FIELDS:
            sail[name] = value
        elif head == "initial_tip_deflection":
            initial = body.setdefault("initial", {}) or {}
            body["initial"] = initial
            modes = dict(initial.get("mode_state") or {})
            modes[boom] = value
            initial["mode_state"] = modes
        elif head == "rate":
            if not value > 0:
                raise ValueError(f"rate.{boom} = {value:g}: a deployment rate factor must be > 0")
            spec = profile[boom]
            spec["duration"] = float(spec["duration"]) / value
            if "t0" in spec:
                spec["t0"] = float(spec["t0"]) / value
    boom_index = int(inputs.get("jam_boom", -1.0))
    if boom_index >= 0:
        spec = profile[BOOMS[boom_index]]
        start, end = (np.asarray(spec[k], dtype=float) for k in ("start", "end"))
        start, end = np.broadcast_to(start, 4)[boom_index], np.broadcast_to(end, 4)[boom_index]
        spec["stop_at"] = float(start + inputs["jam_fraction"] * (end - start))
    if sail:
        document["sail"] = sail
    return document


def run_sample(case) -> dict:
    """One sample, as a row: its index, inputs and outputs, or its error (never raises).

    `case` = (study, index, base sail parameters as a dict[, the policy: by default the
    simulator's])."""
    study, index, base_sail, *policy = case
    policy = policy[0] if policy else Policy()
    row: dict = {"sample": index}
    try:
        started = time.perf_counter()
        inputs = sample_inputs(study, index)
        row.update(inputs)
        document = sample_scenario(study, index, inputs)
        scenario = scenario_from_dict(document)
        params = SailParameters.from_dict({**base_sail, **scenario.sail})
        model = SailModel(params)
        t_eval = output_times(scenario.duration, study.output_rate_hz)
        built = time.perf_counter()
        # a row reads the tips at the output times (their envelope) and the state at the
        # end, a step's end: nothing else of the state inside steps
        run = run_deployment(model, scenario, t_eval, policy=policy, states=False)
        integrated = time.perf_counter()
        if run.alarm:
            raise OutOfRangeError(run.alarm)
        with np.errstate(over="ignore", invalid="ignore"):
            energy = model.energy(run.q[-1], run.qd[-1], run.lengths[-1])
            margin = float(model.elastic_eigenvalues(run.lengths[-1], run.rates[-1]).real.max())
        tips, moments, _ = run.peaks  # true peaks, from inside every step
        if not (np.all(np.isfinite(tips.value)) and math.isfinite(energy)):
            raise ValueError("the state became non-finite")
        for k, boom in enumerate(BOOMS):
            row[f"peak_tip_{boom}_m"] = float(tips.value[k])
            row[f"peak_tip_{boom}_time_s"] = float(tips.time_s[k])
            row[f"peak_root_moment_{boom}_N_m"] = float(moments.value[k])
            row[f"peak_root_moment_{boom}_time_s"] = float(moments.time_s[k])
        row["peak_tip_m"] = float(tips.value.max())
        row["final_energy_J"] = float(energy)
        row["error_estimate"] = max(
            run.accuracy.relative_error["tips"], run.accuracy.relative_error["root_moments"]
        )
        row["_accuracy_warning"] = run.accuracy.warning
        row["stability_margin_1_s"] = margin
        if run.peaks.hub is not None:
            hub = run.peaks.hub  # z_h, theta_x, theta_y, tilt
            row["peak_hub_heave_m"] = float(hub.value[0])
            row["peak_hub_heave_time_s"] = float(hub.time_s[0])
            row["peak_hub_tilt_rad"] = float(hub.value[3])
            row["peak_hub_tilt_time_s"] = float(hub.time_s[3])
            holds = hold_peaks(model, scenario.profile, float(run.t[-1]))
            row["peak_hold_force_N"] = holds.force
            row["peak_hold_torque_N_m"] = holds.torque
        row["error"] = ""
        # for the envelopes and the benchmark's cost split [s] and steps, not the CSV
        row["_tips"] = run.tips.astype(np.float32)
        row["_t"] = run.t
        row["_seconds"] = (built - started, integrated - built, time.perf_counter() - integrated)
        row["_steps"] = (run.accuracy.steps, run.accuracy.rejected)
    except Exception as error:  # a sample that fails is a row, not a crashed study
        row["error"] = f"{type(error).__name__}: {error}".replace("\n", " ")
    return row


@dataclasses.dataclass(frozen=True)
class Summary:
    """What a study found, over the samples that ran.

    Attributes:
        succeeded, failed: sample counts.
        percentiles: output -> (5 %, 50 %, 95 %), a free hub's (`HUB_OUTPUTS`) last.
        influence: (input, Spearman rank correlation with peak_tip_m), strongest first.
        worst: sample indices with the largest peak_tip_m, worst first (up to five).
        n_boom_modes, n_membrane_modes: the mode counts every sample ran with (the
            peaks depend on them: `sail-ros deploy --convergence` reruns a sample with
            more).
    """

    succeeded: int
    failed: int
    percentiles: dict[str, tuple[float, float, float]]
    influence: list[tuple[str, float]]
    worst: list[int]
    n_boom_modes: int
    n_membrane_modes: int


def study_parameters(study: Study, base_sail: dict) -> SailParameters:
    """The sail of the study's base scenario (its mode counts hold for every sample: the
    dispersions change only float fields)."""
    return SailParameters.from_dict({**base_sail, **(study.scenario.get("sail") or {})})


def study_sail(study: Study, sail: SailParameters) -> SailParameters:
    """The sail every sample starts from: `sail` with the automatic membrane count of the
    study's nominal scenario written out (its base sail and shortest length), so that the
    dispersed prestress and stiffness do not change the model's size."""
    scenario = scenario_from_dict(study.scenario)
    nominal = sail.replace(**scenario.sail).resolved(scenario.shortest_length)
    return sail.replace(
        n_membrane_modes=nominal.membrane_modes, resolved_length=nominal.resolved_length
    )


def summarize(study: Study, rows: list[dict], base_sail: dict, worst: int = 5) -> Summary:
    import scipy.stats

    good = [row for row in rows if row is not None and not row.get("error")]
    failed = sum(1 for row in rows if row is not None and row.get("error"))
    percentiles = {}
    for name in (*OUTPUTS, *hub_outputs(good)):
        values = np.array([row[name] for row in good], dtype=float)
        if values.size:
            low, middle, high = np.percentile(values, [5, 50, 95])
            percentiles[name] = (float(low), float(middle), float(high))
    peak = np.array([row["peak_tip_m"] for row in good], dtype=float)
    influence = []
    for name in study.input_names:
        values = np.array([row[name] for row in good], dtype=float)
        finite = np.isfinite(values)
        if finite.sum() < 3 or np.ptp(values[finite]) == 0 or np.ptp(peak[finite]) == 0:
            continue
        rho = scipy.stats.spearmanr(values[finite], peak[finite]).statistic
        influence.append((name, float(rho)))
    influence.sort(key=lambda item: -abs(item[1]))
    order = np.argsort(-peak, kind="stable")[:worst]
    params = study_parameters(study, base_sail)
    return Summary(
        len(good),
        failed,
        percentiles,
        influence,
        [good[i]["sample"] for i in order],
        params.n_boom_modes,
        params.n_membrane_modes,
    )


def accuracy_warning(rows: list[dict]) -> str:
    """One line when samples' error estimates exceed twice their tolerance (their
    `_accuracy_warning`): how many, and the largest's own warning; "" if none does."""
    warned = [row for row in rows if row.get("_accuracy_warning")]
    if not warned:
        return ""
    worst = max(warned, key=lambda row: row["error_estimate"])
    return (
        f"warning: {len(warned)} of {len(rows)} samples' error estimates exceed twice "
        f"their tolerance, the largest sample {worst['sample']}: {worst['_accuracy_warning']}"
    )


def tip_histories(rows: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """`(t, tips)`: the tip deflections [m] of the samples `rows` (that ran) on the first
    one's output times [s] (k,), (samples, k, 4)."""
    t = rows[0]["_t"]
    tips = [[np.interp(t, row["_t"], row["_tips"][:, k]) for k in range(4)] for row in rows]
    return t, np.stack(tips).transpose(0, 2, 1)


def csv_columns(study: Study, rows=()) -> list[str]:
    """The CSV's columns: the sample, its inputs, the outputs (a free hub's when a row
    has them) and the error."""
    return ["sample", *study.input_names, *OUTPUTS, *hub_outputs(rows), "error"]


def hub_outputs(rows) -> tuple[str, ...]:
    """A free hub's outputs (`HUB_OUTPUTS`) when one of `rows` has them, else ()."""
    return HUB_OUTPUTS if any(r is not None and HUB_OUTPUTS[0] in r for r in rows) else ()


def csv_text(study: Study, rows: list[dict]) -> str:
    """The rows as CSV, floats in full (repr), samples in index order."""
    columns = csv_columns(study, rows)
    lines = [",".join(columns)]
    for row in sorted((r for r in rows if r is not None), key=lambda r: r["sample"]):
        cells = []
        for name in columns:
            value = row.get(name, "")
            if isinstance(value, float):
                cells.append(repr(value))
            elif name == "error":
                cells.append('"' + str(value).replace('"', "'") + '"' if value else "")
            else:
                cells.append(str(value))
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"
