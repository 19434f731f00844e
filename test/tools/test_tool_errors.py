"""Every tool answers a user's mistake with exit code 2 and one line naming it, no traceback."""

import argparse
import struct

import pytest
from harness import run_tool
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from sail_ros.bag import BagReader, BagWriter, DamagedBagError
from sail_ros.model.fields import ConfigError
from sail_ros.ros.program import check_params_files, read_params_files
from sail_ros.tools.common import configuration

pytestmark = pytest.mark.model


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Files a user might hand the tools by mistake."""
    root = tmp_path_factory.mktemp("inputs")
    (root / "broken.yaml").write_text("sail: [1, 2\n")
    (root / "misspelt.yaml").write_text("sail:\n  max_rat: 2.0\n")
    # the simulator's params file with a misspelt limit, a misspelt sail field, or under
    # another node's name: the simulator refuses the first two and ignores the third
    (root / "sim_limit.yaml").write_text("sail_sim:\n  ros__parameters:\n    max_rat: 2.0\n")
    (root / "sim_sail.yaml").write_text(
        "/**:\n  ros__parameters:\n    sail:\n      n_boom_mode: 5\n"
    )
    (root / "sim_node.yaml").write_text("sail_simm:\n  ros__parameters:\n    max_rate: 2.0\n")
    (root / "sim_list.yaml").write_text("sail_sim:\n  ros__parameters: [1, 2]\n")
    (root / "sail_typo.yaml").write_text(
        "scenario:\n  duration: 1.0\n  profile: {type: static, lengths: 10.0}\n"
        "sail:\n  membrane_prestres: 100\n"
    )
    (root / "no_mcap").mkdir()
    (root / "text.mcap").write_text("not an mcap file\n")
    (root / "blocker").write_text("")  # a file where a folder is needed
    (root / "program").write_bytes(b"\x7fELF\x02\x01\x01\x00" + bytes(16) + b"\xd0\x00")
    bag = root / "crc.mcap"
    with BagWriter(bag, compression="none", fsync=False) as writer:
        writer.add_topic("/sail/boom_state", "sensor_msgs/msg/JointState")
        for i in range(50):
            writer.write("/sail/boom_state", serialize_message(JointState(name=["a"])), i)
    data = bytearray(bag.read_bytes())
    chunk = data.index(b"\x06", 8)  # the first chunk record (opcode 6)
    crc_at = chunk + 1 + 8 + 8 + 8 + 8  # opcode, length, start, end, uncompressed size
    struct.pack_into("<I", data, crc_at, struct.unpack_from("<I", data, crc_at)[0] ^ 0xFFFF)
    bag.write_bytes(bytes(data))
    return root


BAD_INPUTS = [
    ("modes", ["--config", "{root}/missing.yaml"], "cannot read config '{root}/missing.yaml'"),
    ("modes", ["--config", "{root}/broken.yaml"], "broken.yaml: not valid YAML"),
    ("modes", ["--config", "{root}/misspelt.yaml"], "unknown sail parameter(s) 'max_rat'"),
    # a file that is no text at all (a program) is named with why
    ("modes", ["--config", "{root}/program"], "cannot read config '{root}/program': not UTF-8"),
    ("deploy", ["--scenario", "{root}/program"], "cannot read scenario '{root}/program': not"),
    (
        "deploy",
        ["--config", "{root}/sim_limit.yaml"],
        "unknown parameter(s) of sail_sim: 'max_rat' (did you mean 'max_rate'?)",
    ),
    (
        "modes",
        ["--config", "{root}/sim_sail.yaml"],
        "'sail.n_boom_mode' (did you mean 'sail.n_boom_modes'?)",
    ),
    ("plant", ["--config", "{root}/sim_node.yaml"], "no parameters for sail_sim (sections: "),
    (
        "deploy",
        ["--scenario", "{root}/sail_typo.yaml"],
        "{root}/sail_typo.yaml: sail section: unknown sail parameter(s) 'membrane_prestres' "
        "(did you mean 'membrane_prestress'?)",
    ),
    ("modes", ["--config", "{root}/sim_list.yaml"], "ros__parameters of sail_sim must be"),
    ("modes", ["--set", "n_boom_modes=0"], "n_boom_modes must be an integer in [1, 30], got 0"),
    ("modes", ["--set", "membrane_thickness"], "--set expects KEY=VALUE"),
    ("modes", ["--set", "sail_side=[1,"], "--set sail_side: '[1,' is not a value"),
    ("modes", ["--count", "100000"], "--count must be in [1, 56]"),
    ("modes", ["--count", "0"], "--count must be in [1, 56]"),
    ("modes", ["--csv", "{root}/blocker/f.csv"], "'{root}/blocker' is a file, not a folder"),
    ("modes", ["--lengths", "abc"], "argument --lengths: invalid float value: 'abc'"),
    ("stability", ["--points", "0"], "--points must be >= 2, got 0"),
    ("stability", ["--prestress", "10", "1"], "--prestress needs 0 < MIN < MAX"),
    ("deploy", ["--scenario", "{root}/missing.yaml"], "cannot read scenario"),
    ("deploy", ["--every", "0"], "--every must be > 0"),
    ("deploy", ["--to", "-5"], "error: --to must be > 0 m, got -5.0"),
    ("deploy", ["--duration", "-1"], "error: --duration must be > 0 s, got -1.0"),
    ("deploy", ["--t-end", "-2"], "error: --t-end must be > 0 s, got -2.0"),
    ("deploy", ["--tip", "nan"], "error: --tip must be finite, got nan"),
    ("deploy", ["--set", "n_membrane_modes=-1"], "n_membrane_modes must be an integer in [0, 400]"),
    ("deploy", ["--atol", "tips=0"], "--atol: 'tips=0': atol['tips'] must be finite and > 0"),
    ("deploy", ["--atol", "tip=1e-8"], "'tip=1e-8': atol: unknown output 'tip'; outputs are tips"),
    ("deploy", ["--atol", "tips"], "'tips': expected OUTPUT=FLOOR, outputs tips, tip_rates"),
    ("deploy", ["--atol", "tips=small"], "'tips=small': could not convert string to float"),
    ("report", ["{root}/nothing_here"], "'{root}/nothing_here' does not exist"),
    ("report", ["{root}/no_mcap"], "folder '{root}/no_mcap' has no .mcap file"),
    ("report", ["{root}/text.mcap"], "is not an MCAP file"),
    # checked whatever the log holds: before it is read
    ("report", ["{root}/text.mcap", "--set", "max_rat=3"], "unknown parameter 'max_rat' (did"),
    ("report", ["{root}/text.mcap", "--config", "{root}/missing.yaml"], "cannot read config"),
    ("report", ["{root}/crc.mcap", "--out", "{root}/crc_report"], "crc.mcap' is damaged"),
    ("send", ["move", "--booms", "a", "--point", "-1", "12"], "the time must be > 0 s"),
    ("send", ["--timeout", "0", "reset"], "--timeout must be > 0 s, got 0"),
    ("watch", ["--rate", "0"], "--rate must be > 0, got 0"),
    ("send", ["tip-force", "--booms", "e", "--values", "1"], "invalid choice: 'e'"),
    ("send", ["pressure", "--quadrants", "ab", "cd", "--values", "1", "2", "3"], "--values: one"),
    ("plant", ["--lengths", "1", "2"], "--lengths takes 1 or 4 values, got 2"),
    ("plant", ["--set", "stiffness_damping=-.5"], "stiffness_damping must be in [0, 1e+06] s"),
    ("plant", ["--npz", "{root}/blocker/p.npz"], "{root}/blocker"),
    # ROS arguments: a params file rcl could only say it could not parse
    (
        "sim",
        ["--ros-args", "--params-file", "{root}/missing.yaml"],
        "--params-file {root}/missing.yaml: No such file or directory",
    ),
    ("recorder", ["--ros-args", "--params-file", "{root}/broken.yaml"], "broken.yaml: "),
    ("sim", ["--ros-args", "--params-file", "{root}/program"], "{root}/program: not UTF-8 text"),
    ("watch", ["--ros-args", "--params-file", "{root}/misspelt.yaml"], "expected '<node>: ros"),
]


@pytest.mark.parametrize(
    ("tool", "argv", "culprit"),
    BAD_INPUTS,
    ids=[f"{tool}:{' '.join(argv)}" for tool, argv, _ in BAD_INPUTS],
)
def test_a_mistake_is_one_line_and_exit_code_2(files, tool, argv, culprit):
    argv = [item.format(root=files) for item in argv]
    code, _, err = run_tool(tool, argv)
    assert code == 2, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert "error:" in last and culprit.format(root=files) in last, err


def test_every_float_form_is_a_number(files):
    code, out, err = run_tool("modes", ["--set", "membrane_thickness=3e-6", "--count", "3"])
    assert code == 0, err
    assert "film h, rho             3e-06 m" in out
    (files / "exp.yaml").write_text("sail:\n  membrane_thickness: 3e-6\n  sail_side: 1E2\n")
    code, out, err = run_tool("modes", ["--config", str(files / "exp.yaml"), "--count", "3"])
    assert code == 0, err
    assert "3e-06 m" in out and "sail side a             100 m" in out
    code, out, err = run_tool("modes", ["--set", "mass_damping=.5", "--count", "3"])
    assert code == 0 and "alpha = 0.5 1/s" in out, err


def test_a_damaged_chunk_is_named_by_the_reader(files):
    with pytest.raises(DamagedBagError, match="crc.mcap' is damaged: .*[Cc]rc"):
        list(BagReader(files / "crc.mcap").messages())


def test_mode_counts_that_would_not_fit_are_refused_before_allocating():
    """4000 boom modes would need about 81 GiB of integrals: refused by the field's range
    (the one every program checks) before anything is allocated."""
    code, _, err = run_tool("modes", ["--set", "n_boom_modes=4000"])
    assert code == 2 and "Traceback" not in err
    assert err == "error: n_boom_modes must be an integer in [1, 30], got 4000\n"


def test_ros_arguments_rcl_refuses_are_named_without_its_internals():
    """The message of rcl without the places in its sources, and the hint about the order
    of options only where a tool's option came after --ros-args."""
    code, _, err = run_tool("sim", ["--ros-args", "-p", "x"])
    assert code == 2 and "Couldn't parse parameter override rule: '-p x'" in err, err
    assert "/src/" not in err and "go before --ros-args" not in err, err
    code, _, err = run_tool("watch", ["--ros-args", "--rate", "2"])
    assert code == 2 and "(options of the tool go before --ros-args)" in err, err


def test_a_params_file_with_nested_namespaces_is_a_params_file(tmp_path):
    """A file `/sat2: sail_sim: ros__parameters:` is the section `/sat2/sail_sim` to rcl: so
    do the tools' checks; a misspelt node under it is named with its namespace."""
    nested = tmp_path / "nested.yaml"

    def check():
        ros_argv = ["sim", "--ros-args", "--params-file", str(nested)]
        check_params_files(read_params_files(ros_argv), "sail_sim")

    nested.write_text("/sat2:\n  sail_sim:\n    ros__parameters:\n      max_rate: 2.0\n")
    check()
    nested.write_text("/sat2:\n  sail_simm:\n    ros__parameters:\n      max_rate: 2.0\n")
    with pytest.raises(ConfigError, match="has no section for node 'sail_sim' .*'/sat2/sail_simm'"):
        check()
    nested.write_text("/sat2:\n  sail_sim:\n    max_rate: 2.0\n")
    with pytest.raises(ConfigError, match="expected '<node>: ros__parameters: ...' sections"):
        check()
    # an empty section, which rcl refuses ("Cannot have a value before ros__parameters")
    nested.write_text("/sat2:\n  sail_sim:\n    ros__parameters:\n")
    with pytest.raises(ConfigError, match="ros__parameters of /sat2/sail_sim must be a mapping"):
        check()
    with pytest.raises(ValueError, match="ros__parameters of /sat2/sail_sim must be a mapping"):
        configuration(argparse.Namespace(config=str(nested), set=[]))
    # the tools' --config reads such a file as the simulator does (was: "unknown sail
    # parameter(s) '/sat2'")
    nested.write_text(
        "/sat2:\n  sail_sim:\n    ros__parameters:\n      max_rate: 2.0\n"
        "      sail.n_boom_modes: 7\n"
    )
    config = configuration(argparse.Namespace(config=str(nested), set=[]))
    assert config.sail.n_boom_modes == 7 and config.policy.max_rate == 2.0
