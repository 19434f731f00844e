"""The figures of a deploy study (`analysis.deploy_study.DeployStudy`): the snapshots of
the sail, the tip deflections (with the load changes marked), the boom lengths and
rates; with a free hub its tilt, heave and hold reactions; with a controller the open
and the closed loop and the commands."""

from __future__ import annotations

from pathlib import Path

FIGURES = ("deployment_snapshots.png", "tip_deflections.png", "boom_lengths.png")
HUB_FIGURE = "hub_attitude.png"  # with a free hub: its tilt, heave and hold reactions
CLOSED_LOOP_FIGURE = "closed_loop.png"  # with a controller: open against closed loop


def deploy_figures(folder: Path, found, scenario, snapshots, description: str) -> list[Path]:
    """Draw the study's figures into `folder` (`FIGURES`, and `HUB_FIGURE` with a free
    hub, `CLOSED_LOOP_FIGURE` with a controller); the snapshots at the times [s] of
    `snapshots` the run reached (else its start). Returns the files written."""
    # here, not at the top: the names above are read for the tool's help, without matplotlib
    from sail_ros.analysis.deployment import hold_reactions
    from sail_ros.analysis.load_changes import schedule_changes
    from sail_ros.plots.control import closed_loop_figure
    from sail_ros.plots.deployment import snapshots_figure
    from sail_ros.plots.histories import (
        boom_lengths_figure,
        hub_attitude_figure,
        tip_deflections_figure,
    )

    model, result = found.model, found.result
    loads = [(change.t_s, change.text) for change in schedule_changes(scenario.loads)]
    rows = [result.index_of(t) for t in snapshots if t <= result.t[-1] + 1e-9] or [0]
    snapshots_path, tips_path, lengths_path = (folder / name for name in FIGURES)
    hub = []
    if result.hub is not None:
        holds = hold_reactions(model, scenario.profile, result.t)
        hub.append(
            hub_attitude_figure(result.t, result.hub, holds, folder / HUB_FIGURE, description)
        )
    written = [
        snapshots_figure(
            model,
            result.t[rows],
            result.lengths[rows],
            result.q[rows],
            snapshots_path,
            title=f"Deployment snapshots: {description}",
        ),
        tip_deflections_figure(result.t, result.tips, tips_path, title=description, loads=loads),
        boom_lengths_figure(
            result.t, result.lengths, result.rates, lengths_path, title=description
        ),
        *hub,
    ]
    if found.closed is not None:
        closed, open_loop = found.closed, found.open_loop
        written.append(
            closed_loop_figure(
                (open_loop.t, open_loop.hub),
                (closed.run.t, closed.run.hub),
                (closed.run.t, closed.commands, closed.inputs, closed.limits),
                folder / CLOSED_LOOP_FIGURE,
                description,
            )
        )
    return written
