"""The robot file: what it accepts, and a clear error naming the entry and key for what it does not."""

from __future__ import annotations

from pathlib import Path

import pytest

from drempower.errors import ConfigError, ValidationError
from drempower.robot import load_robot, parse_robot

GOOD = """
[buses.left]
interface = "sim"
time_scale = 5
[buses.right]
interface = "socketcan"
channel = "can1"
[joints.shoulder]
bus = "left"
id = 1
[joints.elbow]
bus = "right"
id = 1
gear = -1.0
offset = 0.25
[joints.wrist]
bus = "left"
id = 4
"""


def test_the_issues_example_reads(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(GOOD)
    spec = load_robot(path)
    assert list(spec.buses) == ["left", "right"] and list(spec.joints) == ["shoulder", "elbow", "wrist"]
    assert spec.joints["elbow"].gear == -1.0 and spec.joints["elbow"].offset == 0.25
    assert spec.joints["shoulder"].gear == 1.0 and spec.joints["shoulder"].offset == 0.0
    assert spec.open_options("left") == {"interface": "sim", "time_scale": 5, "motors": [1, 4]}
    assert spec.open_options("right") == {"interface": "socketcan", "channel": "can1"}
    assert [j.name for j in spec.joints_on("left")] == ["shoulder", "wrist"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[buses.a]\ninterface='sim'\n", "no \\[joints.NAME\\] entry"),
        ("[joints.a]\nbus='x'\nid=1\n", "no \\[buses.NAME\\] entry"),
        ("[bus.a]\ninterface='sim'\n", "unknown section 'bus'"),
        ("[buses.a]\nchannel='x'\n[joints.j]\nbus='a'\nid=1\n", r"\[buses.a\]: interface=None"),
        ("[buses.a]\ninterface='sim'\nmotors=[1]\n[joints.j]\nbus='a'\nid=1\n", "motors: a sim bus"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='b'\nid=1\n", r"\[joints.j\]: bus='b': not one of the buses"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=64\n", r"\[joints.j\]: id=64: motor ids are 1..63"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1.0\n", r"id=1.0"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\n[joints.k]\nbus='a'\nid=1\n", "joint 'j' already"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\ngear=0\n", r"gear=0"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\ngear='x'\n", r"gear='x': expected a finite number"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\noffset=nan\n", r"offset=nan"),
        ("[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\nratio=2\n", r"unknown key 'ratio'"),
        ("[buses.a]\ninterface='sim'\n[joints.1]\nbus='a'\nid=1\n", r"joint name '1'"),
        ("[buses.a]\ninterface='sim'\n[buses.b]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\n", r"\[buses.b\] carries"),
        (
            "[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\non_divergence='stop'\n",
            r"\[joints.j\]: on_divergence='stop': expected one of 'warn', 'hold', 'idle'",
        ),
        (
            "[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\non_divergence='hold'\n",
            r"\[joints.j\]: on_divergence: the shadow twin needs a \[model\]",
        ),
    ],
)
def test_bad_files_name_the_entry_and_key(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "r.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message) as info:
        load_robot(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, ValidationError) and isinstance(info.value, ValueError)


def test_unreadable_and_invalid_toml(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"cannot read robot file .*missing\.toml"):
        load_robot(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[buses.a\n")
    with pytest.raises(ConfigError, match=r"bad\.toml: not valid TOML"):
        load_robot(bad)


def test_parse_a_mapping_directly() -> None:
    spec = parse_robot({"buses": {"a": {"interface": "sim"}}, "joints": {"j": {"bus": "a", "id": 3}}}, "inline")
    assert spec.source == "inline" and spec.open_options("a")["motors"] == [3]


def test_on_divergence_per_joint_and_for_the_robot(tmp_path: Path) -> None:
    """A joint's on_divergence, else [model]'s, else "warn"; a bad [model] value names the file and key."""
    (tmp_path / "m.xml").write_text("<mujoco/>")
    head = "[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\non_divergence='hold'\n[joints.k]\nbus='a'\nid=2\n"
    path = tmp_path / "r.toml"
    path.write_text(head + "[model]\nfile='m.xml'\non_divergence='idle'\n")
    spec = load_robot(path)
    assert spec.on_divergence("j") == "hold" and spec.on_divergence("k") == "idle"
    path.write_text(head + "[model]\nfile='m.xml'\n")
    spec = load_robot(path)
    assert spec.on_divergence("j") == "hold" and spec.on_divergence("k") == "warn"
    path.write_text(head + "[model]\nfile='m.xml'\non_divergence='halt'\n")
    with pytest.raises(ConfigError, match=r"r\.toml: \[model\]: on_divergence='halt': expected one of") as info:
        load_robot(path)
    assert str(path) in str(info.value)
