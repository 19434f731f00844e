"""The state record through its messages: `messages.state` names, for every field of
`model.record.SAMPLE_FIELDS`, the message that carries it, and reads a sample back."""

import numpy as np
import pytest

from sail_ros import topics
from sail_ros.messages import state as state_msg
from sail_ros.model.record import FIELD_NAMES, SAMPLE_FIELDS, StateSample

pytestmark = pytest.mark.model


def test_every_record_field_has_one_message_field():
    assert (*state_msg.JOINT_FIELDS, state_msg.HUB_FIELD) == FIELD_NAMES
    carriers = list(state_msg.JOINT_FIELDS.values())
    assert len(set(carriers)) == len(carriers)  # no two fields in one array
    assert tuple(dict.fromkeys(topic for topic, _ in carriers)) == topics.STATE_TOPICS


@pytest.mark.parametrize("hub", [False, True], ids=["clamped", "free-hub"])
def test_the_published_messages_give_back_the_sample(hub):
    """`messages.state.state_messages` then `messages.state.sample`: every field as it
    was (t is not in the messages' arrays: NaN)."""
    rng = np.random.default_rng(1)
    sizes = {"boom": 4, "coordinate": 7, "hub": 6}
    names = [f"c{i}" for i in range(7)]
    values = {f.name: rng.uniform(-1.0, 1.0, sizes[f.per]) for f in SAMPLE_FIELDS}
    if not hub:
        values["hub"] = None
    sample = StateSample(2.5, **values)
    messages = dict(state_msg.state_messages(123, sample, names, with_clock=True))
    back = state_msg.sample(messages)
    assert np.isnan(back.t)
    for name in FIELD_NAMES:
        if values[name] is None:
            assert getattr(back, name) is None, name
        else:
            np.testing.assert_allclose(getattr(back, name), values[name], rtol=1e-14, err_msg=name)


def test_a_missing_topic_or_empty_array_leaves_its_fields_none():
    sample = state_msg.sample({topics.BOOM_STATE: state_msg.boom_state(0, [1.0] * 4, [0.0] * 4)})
    assert sample.lengths.tolist() == [1.0] * 4
    assert sample.tips is None and sample.q is None and sample.hub is None
    moments = state_msg.root_moment(0, [])
    assert state_msg.sample({topics.ROOT_MOMENT: moments}).root_moments is None
