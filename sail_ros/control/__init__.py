"""Attitude control of a free hub while the booms deploy: numpy/scipy only, no ROS.

    from sail_ros.control import DesignSettings, design_schedule, DiscreteController

One chain, each module importing only those above it (and the model):

- `settings`: `DesignSettings`, the controller's design (rate, loop delay, design
  model, schedule, weights, noises) as one table of fields, shared by the node's ROS
  parameters and a scenario's `controller:` section;
- `design`: the design model at one set of boom lengths (the hub's rigid-body model, or
  the sail with a few explicit modes), discretised at the sample period with the loop
  delay, and its LQR gain and Kalman filter (`DesignPoint`);
- `schedule`: `GainSchedule`, the design points over a grid of boom lengths,
  interpolated at the mean length; written to and read from a gains file;
- `loop`: `DiscreteController`, one step per state sample (estimate, command,
  saturation with anti-windup, counts), and `StaleWatch`, the stale-state watchdog;
- `check`: the discrete closed loop against the full plant at frozen lengths and
  rates, its poles along a deployment.

The node (`nodes.control`) only wires topics, parameters, services and timers to a
`DiscreteController`; the offline closed loop (`analysis.closed_loop`) steps the model
to each sample and calls the same controller.
"""
