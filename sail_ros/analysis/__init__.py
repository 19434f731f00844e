"""Analyses built on the model: numpy/scipy, no plotting.

Only the log modules (`log_export`, `log_series`, `log_rerun`, `parameter_history`)
touch ROS (message classes and CDR serialisation); the others need nothing beyond the
model and the integrator.

- `modes`: natural frequencies grouped by multiplicity, representative mode
  shapes, the finite-element cross-check (seed Tab. 2, Fig. 2).
- `stability`: the largest real part of the Eq. 3 eigenvalues against
  membrane prestress and extension rate, critical prestress.
- `plant`: the sail as a linear plant at frozen lengths and rates.
- `schema`, `scenario`, `reference`: the keys of the scenario and study files, the
  deployment scenarios (boom profiles, initial conditions, loads) read from them, and
  the reference deployment with `sail-ros deploy`'s options.
- `deployment`: an offline deployment run and its time series (seed Fig. 3);
  `closed_loop`: the same with the hub's controller closing the loop;
  `convergence`: reruns with more modes until the peaks settle; `deploy_study`: what
  `sail-ros deploy` runs of these.
- `montecarlo`: Monte Carlo deployments; `execution`: many cases on Dask, or here.
- `energy`: mechanical energy per boom and per quadrant coordinate group.
- `log_export`, `log_series`: deployment runs into MCAP logs with the live
  simulator's topics, and logs back into time series; `parameter_history`: a log's
  parameter changes; `log_rerun`: a log run again offline.
- `load_changes`: when a run's loads change, in words for its figures.
- `modes_table`, `plant_table`, `stability_table`: what `sail-ros modes`, `plant`
  and `stability` found, one object each that renders their text, JSON and CSV.
- `demo_run`: the demo's reference deployment and the summary of its recording.
- `log_report`, `log_tables`, `log_peaks`, `log_true_peaks`: what `sail-ros report`
  finds in a log (its ranges, peaks between samples, energies, real-time factor,
  parameter changes), its CSV tables, and the log run again for its true peaks.
- `json_values`: values as the tools' `--json` outputs take them.
"""
