"""The DDS discovery profile sail_ros's processes use (`ros.discovery`): it parses, says
what the module says, and never replaces a profile file of the user's."""

import xml.etree.ElementTree as ET

import pytest

from sail_ros.ros import discovery

pytestmark = pytest.mark.model

NS = {"dds": "http://www.eprosima.com"}


def seconds(period) -> float:
    return int(period.find("dds:sec", NS).text) + 1e-9 * int(period.find("dds:nanosec", NS).text)


@pytest.mark.parametrize("path", [discovery.PROFILE, discovery.CLIENT_PROFILE])
def test_the_profiles_announce_every_half_second_by_default(path):
    root = ET.parse(path).getroot()
    (profile,) = root.findall("dds:profiles/dds:participant", NS)
    assert profile.get("is_default_profile") == "true"
    period = profile.find("dds:rtps/dds:builtin/dds:discovery_config/dds:leaseAnnouncement", NS)
    assert seconds(period) == discovery.ANNOUNCEMENT_PERIOD_S


def test_only_the_clients_writers_ask_for_acknowledgements_every_tenth_of_a_second():
    (writer,) = (
        ET.parse(discovery.CLIENT_PROFILE).getroot().findall("dds:profiles/dds:data_writer", NS)
    )
    assert writer.get("is_default_profile") == "true"
    assert seconds(writer.find("dds:times/dds:heartbeatPeriod", NS)) == 0.1
    assert not ET.parse(discovery.PROFILE).getroot().findall("dds:profiles/dds:data_writer", NS)


def test_a_profile_file_of_the_users_is_left_alone():
    environ = {}
    assert discovery.announce_often(environ)
    assert environ == {"FASTRTPS_DEFAULT_PROFILES_FILE": str(discovery.PROFILE)}
    for name in discovery.PROFILE_VARIABLES:
        environ = {name: "/home/me/profiles.xml"}
        assert not discovery.announce_often(environ)
        assert environ == {name: "/home/me/profiles.xml"}
