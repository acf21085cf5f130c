"""rmw_zenoh naming, attachments and type hashes, against the examples of rmw_zenoh's docs/design.md."""

from __future__ import annotations

import pytest

pytest.importorskip("rosbags")

from drempower.bridge import rmw, rosmsg
from drempower.bridge.typehash import type_hash

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
ADD_TWO_INTS_HASH = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
QOS_10 = "::,10:,:,:,,"


def test_topic_keys_match_the_design_document() -> None:
    string = rosmsg.dds_type_name("std_msgs/msg/String")
    assert rmw.topic_key(0, rmw.qualify("", "chatter"), string, STRING_HASH) == (
        "0/chatter/std_msgs::msg::dds_::String_/" + STRING_HASH
    )
    assert rmw.topic_key(0, rmw.qualify("/robot1", "chatter"), string, STRING_HASH) == (
        "0/robot1/chatter/std_msgs::msg::dds_::String_/" + STRING_HASH
    )
    srv = rosmsg.dds_type_name("example_interfaces/srv/AddTwoInts")
    assert rmw.topic_key(2, "/add_two_ints", srv, ADD_TWO_INTS_HASH) == (
        "2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/" + ADD_TWO_INTS_HASH
    )


def test_liveliness_tokens_match_the_design_document() -> None:
    zid = "aac3178e146ba6f1fc6e6a4085e77f21"
    assert rmw.node_token(2, zid, 0, "", "listener") == f"@ros2_lv/2/{zid}/0/0/NN/%/%/listener"
    string = rosmsg.dds_type_name("std_msgs/msg/String")
    assert rmw.entity_token(2, zid, 0, 10, "MS", "", "listener", "/chatter", string, STRING_HASH, QOS_10) == (
        f"@ros2_lv/2/{zid}/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/{STRING_HASH}/::,10:,:,:,,"
    )
    talker = "8b20917502ee955ac4476e0266340d5c"
    assert rmw.entity_token(2, talker, 0, 10, "MP", "", "talker", "/chatter", string, STRING_HASH, "::,7:,:,:,,") == (
        f"@ros2_lv/2/{talker}/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/{STRING_HASH}/::,7:,:,:,,"
    )
    server = "f9980ee0495eaafb3e38f0d19e2eae12"
    srv = rosmsg.dds_type_name("example_interfaces/srv/AddTwoInts")
    token = rmw.entity_token(2, server, 0, 10, "SS", "", "add_two_ints_server", "/add_two_ints", srv, ADD_TWO_INTS_HASH)
    assert token == (
        f"@ros2_lv/2/{server}/0/10/SS/%/%/add_two_ints_server/%add_two_ints/"
        f"example_interfaces::srv::dds_::AddTwoInts_/{ADD_TWO_INTS_HASH}/::,10:,:,:,,"
    )


def test_namespaces_are_mangled() -> None:
    assert rmw.mangle("") == "%"
    assert rmw.mangle("/robot1/joint_states") == "%robot1%joint_states"
    assert rmw.node_token(0, "z", 0, "/robot1", "n") == "@ros2_lv/0/z/0/0/NN/%/%robot1/n"
    assert rmw.qualify("robot1", "joint_states") == "/robot1/joint_states"


def test_attachment_bytes() -> None:
    gid = bytes(range(16))
    data = rmw.Attachment(5, 0x0102030405060708, gid).encode()
    assert data == bytes([5, 0, 0, 0, 0, 0, 0, 0, 8, 7, 6, 5, 4, 3, 2, 1, 16]) + gid
    assert rmw.Attachment.decode(data) == rmw.Attachment(5, 0x0102030405060708, gid)
    with pytest.raises(ValueError, match="33"):
        rmw.Attachment.decode(data[:-1])
    with pytest.raises(ValueError, match="GID length 15"):
        rmw.Attachment.decode(data[:16] + b"\x0f" + gid)


@pytest.mark.parametrize("name", [rosmsg.JOINT_STATE, rosmsg.FLOAT64_MULTI_ARRAY, "std_msgs/msg/String"])
def test_message_hashes_equal_the_cdr_librarys(name: str) -> None:
    assert rosmsg.ros_type_hash(name) == rosmsg.typestore().hash_rihs01(name)


def test_hashes_equal_published_values() -> None:
    # published by rmw_zenoh's design document and ROS 2 Jazzy's `ros2 topic info -v` / service listings
    assert rosmsg.ros_type_hash("std_msgs/msg/String") == STRING_HASH
    assert rosmsg.ros_type_hash(rosmsg.JOINT_STATE) == (
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
    )
    assert rosmsg.ros_type_hash(rosmsg.FLOAT64_MULTI_ARRAY) == (
        "RIHS01_1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f"
    )
    assert rosmsg.ros_type_hash(rosmsg.TRIGGER) == (
        "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f"
    )
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    rosmsg.register_service(store, "example_interfaces/srv/AddTwoInts", "int64 a\nint64 b\n---\nint64 sum\n")
    assert type_hash(store, "example_interfaces/srv/AddTwoInts") == ADD_TWO_INTS_HASH


def test_service_definition_without_separator_is_refused() -> None:
    from rosbags.typesys import Stores, get_typestore

    with pytest.raises(ValueError, match="no '---'"):
        rosmsg.register_service(get_typestore(Stores.ROS2_JAZZY), "a/srv/B", "int64 a\n")


def test_trigger_cdr_round_trip() -> None:
    t = rosmsg.typestore().types
    name = rosmsg.TRIGGER + "_Response"
    data = rosmsg.encode(t[name](success=True, message="ok"), name)
    assert data == bytes.fromhex("0001000001000000030000006f6b00")
    back = rosmsg.decode(data, name)
    assert back.success is True and back.message == "ok"
