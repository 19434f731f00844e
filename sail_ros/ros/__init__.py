"""rclpy glue shared by the nodes and the tools that talk to them: running a ROS
program from a tool's `main` (`cli`), and declaring parameters from their tables
(`parameters`)."""
