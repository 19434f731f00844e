"""The README's and the guide's numbers that are facts of the code agree with the code:
how many parameters the main job finds stored (the simulator's own and those every rclpy
node declares), and every default they quote as "`name` (value)" or "`name`, value"."""

import re

import pytest
import yaml
from harness import ROOT
from rclpy.node import Node

from sail_ros.runtime.config import DEFAULTS, PARAMETERS

pytestmark = pytest.mark.node

README = (ROOT / "README.md").read_text()
GUIDE = "\n".join(page.read_text() for page in sorted((ROOT / "docs").rglob("*.md"))
                  if "_build" not in page.parts and "_generated" not in page.parts)  # fmt: skip


def test_the_stored_parameter_count_is_the_simulators(ros_context):
    """The recorder stores every parameter the simulator node lists: its declared ones
    and rclpy's own (use_sim_time, ...), which a bare node lists too."""
    bare = Node("bare", context=ros_context)
    try:
        expected = len(PARAMETERS) + len(bare._parameters)
    finally:
        bare.destroy_node()
    quoted = re.findall(r"simulator parameters stored: (\d+) \(", README)
    assert quoted and {int(n) for n in quoted} == {expected}


def test_quoted_defaults_are_the_defaults():
    quoted = re.findall(r"`([a-z_.]+)` \(([-0-9.e]+)\)|`([a-z_.]+)`, ([-0-9.e]+) ", README + GUIDE)
    checked = 0
    for name_a, value_a, name_b, value_b in quoted:
        name, value = (name_a, value_a) if name_a else (name_b, value_b)
        if name in PARAMETERS:
            assert yaml.safe_load(value) == DEFAULTS[name], name
            checked += 1
    assert checked >= 3  # tip_warn_fraction, tip_error_fraction, max_model_step


def test_the_recorders_page_lists_every_topic_it_records_by_default():
    topics = yaml.safe_load((ROOT / "config" / "recorder.yaml").read_text())
    (section,) = topics.values()
    page = (ROOT / "msg_docs" / "recorder.md").read_text()
    listed = set(re.findall(r"^\| `(/[^`]+)` \|", page, flags=re.MULTILINE))
    defaults = {name if name.startswith("/") else "/" + name
                for name in section["ros__parameters"]["topics"]}  # fmt: skip
    assert defaults == listed
