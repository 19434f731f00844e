"""The Foxglove side of `sail-ros bridge`, apart from its node: the protocol's schemas,
services and server log (`protocol`), and what the bridge knows of its clients and
counts (`clients`). Neither creates a ROS node."""
