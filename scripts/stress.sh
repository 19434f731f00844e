#!/usr/bin/env bash
# The long trials, each the full size of a test the suite runs CI-sized. Run them after
# changing what they guard, on a quiet machine; each prints what it measured. Extra
# arguments go to every pytest run (e.g. -x). Add a trial as one more run below.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup_env.sh" >/dev/null
source "$root/scripts/env.sh"
cd "$root"

trial() {  # trial NAME TEST [pytest args]: one test by name, wherever test/ holds it
  local name="$1" test="$2"
  shift 2
  echo "== $name"
  python -m pytest test -q -s -p no:cacheprovider -k "$test" "$@"
}

# 20 recorders, each killed (SIGKILL) at a random moment of a 100 Hz stream; each log
# recovered and compared message by message with the live stream (~2 min; the suite: 3)
SAIL_ROS_KILL_TRIALS="${SAIL_ROS_KILL_TRIALS:-20}" \
  trial "recorder killed at random times" test_sigkill_at_random_times_loses_only_the_open_chunk "$@"

# the run's error estimate against DOP853 on the 48 drawn deployments its margin was set
# on, on 48 of another seed, on 24 free hubs and on 24 loaded by plain functions (~6 min;
# the suite: 3 of a third seed, 2 free hubs loaded by plain functions and one free hub
# stepping at the phase bound)
trial "the estimate on 144 drawn deployments" \
  test_the_estimate_bounds_the_error_on_many_drawn_deployments --slow "$@"

# every README block in order, the live walk-throughs and the Monte Carlo study included
# (~2 min; the suite: the main job and the offline blocks)
trial "the whole README" test_readme_runs_top_to_bottom --slow "$@"

# 1000 valid, then 1000 malformed (NaN), then 1000 undecodable deploy commands a second,
# 10 s each, at a simulator that keeps real time and counts every command (~60 s)
trial "a flood of commands" test_a_flood_of_commands_is_held_in_real_time_and_counted --slow "$@"

# SIGINT 0.1 to 1.5 s after `sail-ros sim` starts: no traceback, exit 130 or 0 (~15 s; the
# suite: the SIGINT sent from inside its imports)
trial "an early SIGINT" test_a_sigint_soon_after_the_simulator_starts_ends_it_without_a_traceback --slow "$@"

# a scenario of 300000 waypoints at `sail-ros deploy`: refused (max_trajectory_points)
# before a spline is made; prints the time and memory the refusal took (~15 s; the suite:
# 1001 waypoints)
trial "300000 waypoints" test_a_scenario_of_300000_waypoints_is_refused_before_any_work --slow "$@"

# 200 Foxglove clients that subscribe and never read at a running simulator's bridge,
# then 20000 bad frames: max_clients kept, the rest refused and counted, the memory back
# once they leave, a few log lines; prints the bridge's memory (~40 s; the suite: 4
# clients, 300 frames)
trial "200 clients that never read" test_two_hundred_clients_that_never_read_and_twenty_thousand_bad_frames --slow "$@"
