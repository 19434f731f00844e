#!/usr/bin/env bash
# The figures docs/figures holds (the README shows them), made by the tools at their
# default settings (the converged mode counts) unless the README gives others, each
# with the command the README gives for it; then copied into docs/figures. Run after
# changing a figure or what it shows (~20 min on 2 cores, most of it the Monte Carlo
# study and the stability map):
#   bash scripts/figures.sh [WORK_DIR]    (default out/figures; the runs' outputs stay)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
source "$root/scripts/env.sh"
cd "$root"
work="${1:-out/figures}"
rm -rf "$work"
mkdir -p "$work"
docs="$root/docs/figures"

step() { echo "== $*" >&2; }

step "mode shapes (sail-ros modes --figures)"
sail-ros modes --figures "$work/modes" >/dev/null
sail-ros modes --view 3d --shapes 4 --figures "$work/modes_3d" >/dev/null

step "the reference deployment (sail-ros deploy --figures, --mcap) and its report"
sail-ros deploy --figures "$work/reference" --mcap "$work/reference.mcap" >/dev/null
sail-ros report "$work/reference.mcap" --out "$work/reference_report" >/dev/null

step "the loaded deployment and its report"
sail-ros deploy --scenario config/scenario_loaded.yaml --mcap "$work/loaded.mcap" >/dev/null
sail-ros report "$work/loaded.mcap" --out "$work/loaded_report" >/dev/null

step "the free hub"
sail-ros deploy --scenario config/scenario_free_hub.yaml --every 5 --figures "$work/free_hub" \
  >/dev/null

step "the free hub's closed loop (the README's counts)"
sail-ros deploy --scenario config/scenario_free_hub_control.yaml --set n_boom_modes=4 \
  --set n_membrane_modes=6 --every 5 --figures "$work/control" >/dev/null

step "the plant"
sail-ros plant --lengths 20 22 20 22 --set mass_damping=0.02 --set stiffness_damping=1e-3 \
  --figure "$work/plant_bode.png" >/dev/null

step "stability (the fully deployed sail; the map over three lengths)"
sail-ros stability --figures "$work/stability" >/dev/null
sail-ros stability --lengths 20 40 70.71 --figures "$work/stability_lengths" >/dev/null

step "the Monte Carlo study"
sail-ros montecarlo config/study_reference.yaml --out "$work/study" >/dev/null

step "a live run (sail-ros demo) and its report"
sail-ros demo -o "$work/demo" >/dev/null
sail-ros report "$work/demo" --out "$work/demo_report" --no-convergence >/dev/null

step "copied into $docs"
copy() { cp "$work/$1" "$docs/$2"; }
copy modes/mode_shapes.png mode_shapes.png
copy modes_3d/mode_shapes.png mode_shapes_3d.png
copy reference/deployment_snapshots.png deployment_snapshots.png
copy reference/tip_deflections.png tip_deflections.png
copy reference/boom_lengths.png boom_lengths.png
copy reference_report/modal_energies.png modal_energies.png
copy loaded_report/root_moments.png root_moments.png
copy free_hub/hub_attitude.png hub_attitude.png
copy control/closed_loop.png closed_loop.png
copy plant_bode.png plant_bode.png
copy stability/stability.png stability.png
copy stability/eigenvalue_loci.png eigenvalue_loci.png
copy stability_lengths/stability_map.png stability_map.png
copy study/envelopes.png mc_envelopes.png
copy study/peaks.png mc_peaks.png
copy study/influence.png mc_influence.png
copy demo_report/real_time_factor.png real_time_factor.png
ls -l "$docs"
