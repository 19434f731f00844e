"""Time integration of the sail's equations of motion (numpy/scipy only, no ROS).

Works on any `system.LinearSystem` (the matrices at a boom motion; `SailModel` is one):

- `stepper`: `SailStepper`, the state and its steps; `control`: the step-size
  controller, the only place a step is chosen; `system`: the structure at the times a
  stepper asks about, in one cache;
- `moving` (a moving step and its error estimate), `rational` (its rational steps and
  their continuous extension), `rest` (the exact step at rest), `fast_modes` (the high
  modes a moving step follows); `dense`: the state inside an accepted step;
- `sampling`: the state on the simulator's grid; `driver`: batch runs at output times,
  with `observers` (range watch, true peaks); `peaks`: true peaks inside every step;
- `errors`: what ends a run early, and the warning of a run less accurate than asked.
"""
