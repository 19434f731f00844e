"""Command-line tools (`sail-ros <tool>`): thin shells around `sail_ros.analysis` and
`sail_ros.model`."""
