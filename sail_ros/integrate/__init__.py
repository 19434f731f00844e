"""Time integration of the sail's equations of motion (numpy/scipy only, no ROS).

Works on any `stepper.LinearSystem` (the matrices at a boom motion; `SailModel` is one):

- `stepper`: `SailStepper`, the state and its steps;
- `rational` (a moving step), `rest` (the exact step at rest), `fast_modes` (the high
  modes a moving step follows);
- `sampling`: the state on the simulator's grid; `driver`: batch runs at output times;
- `peaks`: true peaks inside every step.
"""
