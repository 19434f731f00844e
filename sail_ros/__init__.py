"""sail_ros: deployment dynamics and vibration of a four-quadrant solar sail."""
