"""Command-line tools (`sail-ros <tool>`): thin shells around `sail_ros.model`."""
