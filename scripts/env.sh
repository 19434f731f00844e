# Source me: the environment variables ROS 2 needs inside .venv.
# AMENT_PREFIX_PATH lets rclpy and the recorder find installed message
# definitions (share/<pkg>/msg/*.msg ship with the PyPI wheels).
_sail_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export AMENT_PREFIX_PATH="$_sail_root/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$_sail_root/.venv/ros_log}"
export HOME="${HOME:-$_sail_root/.venv}"
export MPLBACKEND="${MPLBACKEND:-Agg}"
# DDS discovery stays on this machine unless asked otherwise (SUBNET: the local
# network; ROS_STATIC_PEERS for given hosts): anyone who can reach the domain
# can command the simulator.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export PATH="$_sail_root/.venv/bin:$PATH"
unset _sail_root
# The model works on small dense matrices, where one BLAS thread is fastest;
# parallel tools use processes instead.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
