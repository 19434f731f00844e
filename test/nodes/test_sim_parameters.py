"""The nodes' parameters as ROS declares them, from their setting tables: every one
described, the simulator's with unit, range and whether it may change."""

import pytest

from sail_ros.nodes import bridge, control, recorder, replay
from sail_ros.nodes.sim import SPECS
from sail_ros.ros.parameters import descriptor

pytestmark = pytest.mark.node


def test_every_parameter_is_described_with_unit_and_range():
    for spec in SPECS:
        found = descriptor(spec)
        assert found.description and found.name == spec.name
        if spec.element_type not in (str, bool):  # a text or a flag has no unit
            assert "[" in spec.description, f"{spec.name}: no unit"
            assert found.floating_point_range or found.integer_range
        assert found.read_only == (
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


@pytest.mark.parametrize("node", [recorder, replay, bridge, control], ids=lambda m: m.__name__)
def test_every_node_declares_its_parameters_from_a_setting_table(node):
    names = [spec.name for spec in node.SPECS]
    assert len(names) == len(set(names)) > 3
    for spec in node.SPECS:
        found = descriptor(spec)
        assert found.name == spec.name and found.description == spec.description
        assert spec.check(spec.default) == spec.default
