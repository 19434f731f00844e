"""Documentation tables generated from the field tables stay equal to them."""

import pytest
from harness import ROOT

from sail_ros.model.fields import markdown_table
from sail_ros.runtime.config import SETTINGS

pytestmark = pytest.mark.model


def test_the_simulator_parameter_table_is_the_generated_one():
    text = (ROOT / "msg_docs/README.md").read_text()
    assert markdown_table(SETTINGS, writable=True) in text


def test_the_controller_parameter_table_is_the_generated_one():
    from sail_ros.control.settings import NODE_SETTINGS

    text = (ROOT / "msg_docs/control.md").read_text()
    assert markdown_table(NODE_SETTINGS, writable=True) in text
