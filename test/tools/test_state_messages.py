"""The state record through its messages: `messages.state` names, for every field of
`model.record.SAMPLE_FIELDS`, the message that carries it, and reads a sample back."""

import numpy as np
import pytest

from sail_ros import topics
from sail_ros.messages import state
from sail_ros.model.record import FIELD_NAMES, SAMPLE_FIELDS, StateSample

pytestmark = pytest.mark.model


def test_every_record_field_has_one_message_field():
    assert (*state.JOINT_FIELDS, state.HUB_FIELD) == FIELD_NAMES
    carriers = list(state.JOINT_FIELDS.values())
    assert len(set(carriers)) == len(carriers)  # no two fields in one array
    assert tuple(dict.fromkeys(topic for topic, _ in carriers)) == topics.STATE_TOPICS


@pytest.mark.parametrize("hub", [False, True], ids=["clamped", "free-hub"])
def test_the_published_messages_give_back_the_sample(hub):
    """`topics.state_messages` then `state.sample`: every field as it was (t is not in
    the messages' arrays: NaN)."""
    rng = np.random.default_rng(1)
    sizes = {"boom": 4, "coordinate": 7, "hub": 6}
    names = [f"c{i}" for i in range(7)]
    values = {f.name: rng.uniform(-1.0, 1.0, sizes[f.per]) for f in SAMPLE_FIELDS}
    if not hub:
        values["hub"] = None
    sample = StateSample(2.5, **values)
    messages = dict(topics.state_messages(123, sample, names, with_clock=True))
    back = state.sample(messages)
    assert np.isnan(back.t)
    for name in FIELD_NAMES:
        if values[name] is None:
            assert getattr(back, name) is None, name
        else:
            np.testing.assert_allclose(getattr(back, name), values[name], rtol=1e-14, err_msg=name)


def test_a_missing_topic_or_empty_array_leaves_its_fields_none():
    sample = state.sample({topics.BOOM_STATE: topics.boom_state(0, [1.0] * 4, [0.0] * 4)})
    assert sample.lengths.tolist() == [1.0] * 4
    assert sample.tips is None and sample.q is None and sample.hub is None
    moments = topics.root_moment(0, [])
    assert state.sample({topics.ROOT_MOMENT: moments}).root_moments is None
