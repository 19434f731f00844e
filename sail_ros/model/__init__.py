"""The sail's structural model: numpy/scipy only, no ROS.

from sail_ros.model import SailParameters, SailModel
"""

from sail_ros.model.parameters import SailParameters
from sail_ros.model.profiles import CycloidalProfile, StaticProfile, WaypointProfile
from sail_ros.model.sail_model import SailModel
from sail_ros.model.stepper import IntegrationError, SailStepper

__all__ = [
    "CycloidalProfile",
    "IntegrationError",
    "SailModel",
    "SailParameters",
    "SailStepper",
    "StaticProfile",
    "WaypointProfile",
]
