"""ROS 2 nodes of sail_ros, each started by a tool `main(argv=None)`."""
