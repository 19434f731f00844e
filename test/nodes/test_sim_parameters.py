"""The simulator node's parameters as ROS declares them: every one described, with
unit, range and whether it may change."""

import pytest

from sail_ros.nodes.sim import SPECS

pytestmark = pytest.mark.node


def test_every_parameter_is_described_with_unit_and_range():
    for spec in SPECS:
        descriptor = spec.descriptor()
        assert descriptor.description and descriptor.name == spec.name
        if spec.element_type not in (str, bool):  # a text or a flag has no unit
            assert "[" in spec.description, f"{spec.name}: no unit"
            assert descriptor.floating_point_range or descriptor.integer_range
        assert descriptor.read_only == (
            spec.name.startswith("sail.")
            or spec.name
            in {
                "integration_step",
                "max_model_step",
                "model_rtol",
                "time_scale",
                "realtime_priority",
                "frame_id",
                "inertial_frame_id",
                "shape_divisions",
                "max_queued_commands",
            }
        )
