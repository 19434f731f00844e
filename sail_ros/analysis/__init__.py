"""Analyses built on the model: numpy/scipy, no plotting.

Only the two log modules touch ROS (message classes and CDR serialisation);
the others need nothing beyond the model.

- `modes`: natural frequencies grouped by multiplicity, representative mode
  shapes, the finite-element cross-check (seed Tab. 2, Fig. 2).
- `stability`: the largest real part of the Eq. 3 eigenvalues against
  membrane prestress and extension rate, critical prestress.
- `scenario`: deployment scenarios (boom profiles, initial conditions) read
  from YAML.
- `deployment`: an offline deployment run and its time series (seed Fig. 3).
- `energy`: mechanical energy per boom and per quadrant coordinate group.
- `log_export`, `log_series`: deployment runs into MCAP logs with the live
  simulator's topics, and logs back into time series.
- `load_changes`: when a run's loads change, in words for its figures.
- `modes_table`, `plant_table`, `stability_table`: what `sail-ros modes`, `plant`
  and `stability` found, one object each that renders their text, JSON and CSV.
- `demo_run`: the demo's reference deployment and the summary of its recording.
- `log_report`, `log_tables`, `log_true_peaks`: what `sail-ros report` finds in a log
  (its ranges, peaks, energies, real-time factor, parameter changes), its CSV tables,
  and the log run again for its true peaks.
"""
