"""Finite-element model of the sail, an independent check on the modal model.

Hermite cubic beam elements for the four booms (`beam`), P1/P2 triangles for
the four membrane quadrants riding on them (`membrane`), assembled into global
`M`, `K` and solved for natural frequencies (`sail_fem`) or stepped in time from a
bent start (`transient`).
"""

from sail_ros.fem.sail_fem import SailFEM, fem_convergence
from sail_ros.fem.transient import Transient, free_vibration

__all__ = ["SailFEM", "Transient", "fem_convergence", "free_vibration"]
