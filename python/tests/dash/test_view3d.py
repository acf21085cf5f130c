"""The dashboard's 3D view: the model's scene, the page posing it from the live states, and the hand from outside.

The asynchronous tests come first: once the module's browser (Playwright's synchronous API) runs, it holds an
event loop in this thread.
"""

from __future__ import annotations

import json
import math
import os
import struct
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

aiohttp = pytest.importorskip("aiohttp")

from drempower import open_robot  # noqa: E402
from drempower.dash.model_scene import load_scene, mjcf_scene  # noqa: E402
from drempower.dash.model_view import NO_TWIN, ModelView  # noqa: E402
from drempower.errors import ConfigError  # noqa: E402
from drempower.protocol.flags import MotorError  # noqa: E402

from ..conftest import REPO_ROOT  # noqa: E402
from .conftest import serve_in_thread  # noqa: E402
from .test_browser import eventually  # noqa: E402

ARM = """
<mujoco model="test arm">
  <compiler angle="degree"/>
  <default>
    <geom size="0.05"/>
    <default class="link"><geom type="capsule" size="0.03" rgba="0.2 0.5 0.8 1"/></default>
  </default>
  <asset><material name="red" rgba="0.9 0.2 0.2 1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="0.5 0.5 0.01" rgba="0.9 0.9 0.9 1"/>
    <body name="base" pos="0 0 0.1">
      <geom type="cylinder" size="0.06 0.05" material="red"/>
      <body name="upper" pos="0 0 0.05" euler="0 0 30">
        <joint name="shoulder" axis="0 0 1"/>
        <geom class="link" fromto="0 0 0.04 0 0 0.3"/>
        <body name="fore" pos="0 0 0.3" quat="0.9 0.1 0 0">
          <joint name="elbow" axis="0 1 0" pos="0 0 0.01" ref="10"/>
          <geom class="link" fromto="0 0 0 0.25 0 0"/>
          <body name="hand" pos="0.25 0 0">
            <joint name="wrist" axis="1 1 0"/>
            <geom type="box" size="0.02 0.03 0.04" pos="0 0 0.01" axisangle="1 0 0 45"/>
            <geom type="sphere" size="0.02" group="3"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
"""Three hinges (one with a reference angle, one on a skew axis), every primitive, defaults and a material."""

ROBOT = """
[buses.arm]
interface = "sim"
[joints.shoulder]
bus = "arm"
id = 1
[joints.elbow]
bus = "arm"
id = 2
gear = -2.0
offset = 0.2
[joints.wrist]
bus = "arm"
id = 3
"""
"""The elbow is geared: its model angle is -angle/2 + 0.2 rad."""


@pytest.fixture
def model(tmp_path: Path) -> Path:
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    return path


@pytest.fixture
def served_arm(tmp_path: Path, model: Path) -> Iterator[tuple[str, Any, Any, Any]]:
    (tmp_path / "robot.toml").write_text(ROBOT)
    robot = open_robot(tmp_path / "robot.toml", stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot, model=str(model))
    try:
        yield url, hub, dash, robot
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


def test_the_plain_mjcf_reading_agrees_with_mujoco(model: Path) -> None:
    mujoco = pytest.importorskip("mujoco")
    from drempower.dash.model_scene import mujoco_scene

    a, b = mujoco_scene(str(model), mujoco), mjcf_scene(str(model))
    assert a["engine"] == "mujoco" and b["engine"] == "mjcf" and b.pop("files") == []
    for part in ("bodies", "joints", "geoms"):
        assert a[part] == b[part], part
    assert [j["name"] for j in a["joints"]] == ["shoulder", "elbow", "wrist"]
    assert a["joints"][1]["ref"] == pytest.approx(math.radians(10), abs=1e-6)
    assert a["joints"][2]["axis"] == pytest.approx([math.sqrt(0.5), math.sqrt(0.5), 0], abs=1e-6)
    assert [g["type"] for g in a["geoms"]] == ["plane", "cylinder", "capsule", "capsule", "box"]  # group 3 left out
    assert a["geoms"][1]["rgba"] == [0.9, 0.2, 0.2, 1.0]  # the material's colour


def test_a_model_that_cannot_be_read_is_named(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body><geom type='cone'/></body></worldbody></mujoco>")
    with pytest.raises(ConfigError, match="type='cone': one of plane"):
        mjcf_scene(str(bad))
    urdf = tmp_path / "r.urdf"
    urdf.write_text("<robot name='r'/>")
    with pytest.raises(ConfigError, match="not MJCF; a URDF model needs the physics extra"):
        mjcf_scene(str(urdf))
    with pytest.raises(ConfigError, match="no such file"):
        load_scene(str(tmp_path / "missing.xml"))


async def _ws_call(url: str, req: dict[str, Any]) -> dict[str, Any]:
    async with aiohttp.ClientSession() as s, s.ws_connect(url.rstrip("/") + "/ws") as ws:
        await ws.receive_json()  # hello
        await ws.send_json({**req, "req": 1})
        while True:
            m = await ws.receive_json(timeout=5)
            if m.get("t") == "reply":
                return m  # type: ignore[no-any-return]


async def test_the_model_document_maps_joints_and_refuses_the_hand_without_a_twin(
    served_arm: tuple[str, Any, Any, Any],
) -> None:
    url = served_arm[0]
    async with aiohttp.ClientSession() as s, s.get(url + "model") as r:
        assert r.status == 200
        doc = await r.json()
    assert doc["error"] is None and doc["twin"] is False and doc["hand"] == NO_TWIN
    assert [b["name"] for b in doc["scene"]["bodies"]] == ["world", "base", "upper", "fore", "hand"]
    assert doc["joints"] == [
        {"key": 1, "joint": "shoulder", "model_joint": "shoulder", "gear": 1.0, "offset": 0.0},
        {"key": 2, "joint": "elbow", "model_joint": "elbow", "gear": -2.0, "offset": 0.2},
        {"key": 3, "joint": "wrist", "model_joint": "wrist", "gear": 1.0, "offset": 0.0},
    ]
    reply = await _ws_call(url, {"op": "push", "kind": "joint", "target": "elbow", "torque": 1.0, "duration": 0.5})
    assert reply["ok"] is False and reply["error"] == NO_TWIN
    async with aiohttp.ClientSession() as s, s.get(url + "model/file/..%2Frobot.toml") as r:
        assert r.status == 404  # only the meshes the scene names are served


class Hand:
    """Records the pushes the dashboard hands to a twin (the twin's own behaviour is tested with it)."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []

    def push(self, body: str, force: Any = (0, 0, 0), torque: Any = (0, 0, 0), duration: float = 1.0) -> None:
        self.calls.append(("push", body, tuple(force), tuple(torque), duration))

    def push_joint(self, joint: str, torque: float, duration: float = 1.0) -> None:
        self.calls.append(("push_joint", joint, torque, duration))

    def release(self) -> None:
        self.calls.append(("release",))


async def test_a_push_is_checked_whole_before_it_reaches_the_twin(served_arm: tuple[str, Any, Any, Any]) -> None:
    url, hub, dash, _ = served_arm
    hand = Hand()
    dash.view._twin = hand
    fore = {"kind": "body", "target": "fore", "duration": 1}
    bad = [
        ({**fore, "force": [0, 0, 5000]}, "force z=5000: outside -1000..1000 N"),
        ({"kind": "body", "target": "nose", "force": [0, 0, 1], "duration": 1}, "target='nose': not a body"),
        ({"kind": "joint", "target": "elbow", "torque": 1, "duration": 0}, "duration=0: outside above 0..10 s"),
        ({"kind": "joint", "target": "elbow", "torque": "x", "duration": 1}, "torque='x': expected a finite number"),
        ({"kind": "spin", "target": "elbow", "duration": 1}, "kind='spin': expected 'body' or 'joint'"),
    ]
    for req, error in bad:
        reply = await _ws_call(url, {"op": "push", **req})
        assert reply["ok"] is False and error in reply["error"], reply
    assert hand.calls == []
    ok = await _ws_call(url, {"op": "push", "kind": "body", "target": "fore", "force": [1, 0, -5], "duration": 0.5})
    assert ok["ok"] is True and ok["result"].startswith("push body fore")
    ok = await _ws_call(url, {"op": "push", "kind": "joint", "target": "elbow", "torque": -2, "duration": 1})
    assert ok["ok"] is True
    assert hand.calls == [
        ("push", "fore", (1.0, 0.0, -5.0), (0.0, 0.0, 0.0), 0.5),
        ("push_joint", "elbow", -2.0, 1.0),
    ]
    reply = await _ws_call(url, {"op": "estop"})
    assert reply["ok"] is True and hand.calls[-1] == ("release",)  # ESTOP lets go of the twin too
    hub.read_only = True
    reply = await _ws_call(url, {"op": "push", "kind": "joint", "target": "elbow", "torque": -2, "duration": 1})
    assert reply["ok"] is False and reply["error"] == "this dashboard is read-only (--read-only)"
    assert len(hand.calls) == 3


URDF = """
<robot name="two">
  <link name="base"><collision><geometry><cylinder radius="0.05" length="0.1"/></geometry></collision>
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><collision><origin xyz="0 0 0.15"/><geometry><box size="0.04 0.04 0.3"/></geometry></collision>
    <inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="lift" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.05" rpy="0 0 0.5"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="5"/></joint>
</robot>
"""


def test_a_urdf_model_is_read_by_mujoco(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    path = tmp_path / "two.urdf"
    path.write_text(URDF)
    scene = load_scene(str(path))
    assert scene["engine"] == "mujoco"
    assert [b["name"] for b in scene["bodies"]] == ["world", "arm"]  # the fixed base is part of the world
    assert scene["bodies"][1]["quat"] == pytest.approx([math.cos(0.25), 0, 0, math.sin(0.25)], abs=1e-6)  # yaw 0.5
    lift = {"name": "lift", "body": 1, "type": "hinge", "axis": [0, 1, 0], "pos": [0, 0, 0], "ref": 0}
    assert scene["joints"] == [lift]
    shapes = [(g["type"], g["size"]) for g in scene["geoms"]]
    assert shapes == [("cylinder", [0.05, 0.05, 0]), ("box", [0.02, 0.02, 0.15])]


def _drawn_vs_state(p: Any) -> tuple[dict[str, float], dict[str, float]]:
    """The angles drawn (read from the three.js objects) and those the states give, in one page evaluation."""
    got = p.evaluate("[window.drempowerView.jointAngles(), window.drempowerView.motorAngles()]")
    drawn, motor = got[0], {int(k): v for k, v in got[1].items()}
    expect = {
        "shoulder": motor[1],
        "elbow": math.degrees(math.radians(motor[2]) / -2.0 + 0.2),
        "wrist": motor[3],
    }
    return drawn, expect


_LEFT_HALF_COLOURS = """(() => {
  const src = document.querySelector('#v3d-canvas canvas');
  const c = document.createElement('canvas'); c.width = src.width; c.height = src.height;
  const g = c.getContext('2d'); g.drawImage(src, 0, 0);
  const d = g.getImageData(0, 0, Math.floor(c.width / 2), c.height).data, seen = new Set();
  for (let i = 0; i < d.length; i += 4 * 7) seen.add(d[i] + ',' + d[i + 1] + ',' + d[i + 2]);
  return seen.size;
})()"""
"""How many colours the left half of the 3D view's canvas holds (one: blank)."""


def test_the_3d_view_follows_a_moving_joint(browser: Any, served_arm: tuple[str, Any, Any, Any], shots: Path) -> None:
    url, hub, _, robot = served_arm
    ctx = browser.new_context(viewport={"width": 800, "height": 500})
    errors: list[str] = []
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.on("pageerror", lambda e: errors.append(str(e)))
        p.goto(url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        p.get_by_role("button", name="Scan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("window.drempowerView && window.drempowerView.ready")
        assert p.evaluate("window.drempowerView.joints()") == ["shoulder", "elbow", "wrist"]
        assert "arm.xml" in p.locator("#v3d-note").inner_text()
        assert p.locator("#hand-go").is_disabled() and "needs the robot twin" in p.locator("#hand-note").inner_text()
        p.wait_for_function("Object.keys(window.drempowerView.motorAngles()).length === 3")
        bus = robot.buses["arm"]
        sims = bus.transport.bus.motors
        for i, angle in ((1, 120.0), (2, -90.0), (3, 45.0)):
            bus.motor(i).set_angle(angle, 20.0, 20.0, 1)  # trapezoid moves of about a second
            hub.commanded.add(i)
        seen: list[float] = []
        t_end = time.monotonic() + 8
        while time.monotonic() < t_end:
            drawn, expect = _drawn_vs_state(p)
            for name, want in expect.items():
                assert abs(drawn[name] - want) < 0.5, (name, drawn[name], want)
            seen.append(drawn["shoulder"])
            if all(abs(sims[i].position - a) < 0.05 for i, a in ((1, 120), (2, -90), (3, 45))):
                break
            time.sleep(0.05)
        # it moved through the way, not only to the end
        assert len({round(a) for a in seen if 10 < a < 110}) >= 3, seen
        truth = {  # the simulated motors themselves, at rest
            "shoulder": sims[1].position,
            "elbow": math.degrees(math.radians(sims[2].position) / -2.0 + 0.2),
            "wrist": sims[3].position,
        }

        def drawn_at_rest() -> bool:  # once the last states reach the page
            drawn = _drawn_vs_state(p)[0]
            return all(abs(drawn[name] - want) < 0.5 for name, want in truth.items())

        assert eventually(drawn_at_rest, 5), (_drawn_vs_state(p)[0], truth)
        assert p.evaluate("window.drempowerView.highlighted()") == []
        sims[2].inject_error(MotorError.DRV_FAULT)
        p.wait_for_function("window.drempowerView.highlighted().join() === 'elbow'")
        assert "error: elbow" in p.locator("#v3d-errors").inner_text()
        p.screenshot(path=str(shots / "dash-3d.png"))
        bus.motor(2).clear_error()
        p.wait_for_function("window.drempowerView.highlighted().length === 0")
        # pinned beside the other views: the plots and the 3D view side by side
        p.get_by_label("keep beside the other views").check()
        p.get_by_role("tab", name="Plots").click()
        assert p.locator("#plot").is_visible() and p.locator("#v3d-canvas canvas").is_visible()
        plot, view = (p.locator(s).bounding_box() for s in ("#plot", "#v3d-canvas"))
        assert plot is not None and view is not None and plot["x"] + plot["width"] <= view["x"]
        # the 3D tab while pinned: the view over the whole page (not a panel beside an empty half), drawn
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("document.querySelector('#v3d-canvas canvas').width > 0")
        box = p.locator("#v3d-canvas").bounding_box()
        assert box is not None and box["x"] < 50 and box["width"] > 0.8 * 800, box
        time.sleep(0.3)  # a frame drawn at the new size
        left = p.evaluate(_LEFT_HALF_COLOURS)
        assert left > 3, left  # the robot and the grid drawn on the left half too, not one blank colour
    finally:
        ctx.close()
    assert not errors, errors


def test_the_hand_pushes_the_twin_and_the_view_follows(browser: Any, tmp_path: Path, model: Path) -> None:
    """On the robot twin (the robot file names the model): a joint torque from the page turns the joint."""
    pytest.importorskip("mujoco")
    pytest.importorskip("drempower.sim.twin")
    (tmp_path / "robot.toml").write_text('[model]\nfile = "arm.xml"\n' + ROBOT)
    robot = open_robot(tmp_path / "robot.toml", stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)  # the model the robot file names
    ctx = browser.new_context(viewport={"width": 800, "height": 500})
    try:
        bus = robot.buses["arm"]
        sims = bus.transport.bus.motors
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.get_by_role("button", name="Scan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("window.drempowerView && window.drempowerView.ready")
        assert p.evaluate("window.drempowerView.twin") is True and p.locator("#hand-go").is_enabled()
        bus.motor(1).set_mode(1)  # idle: the shoulder turns freely about its vertical axis
        start = sims[1].position
        p.locator("#hand-kind").select_option("joint")
        p.locator("#hand-target").select_option("shoulder")
        p.locator("#hand-torque").fill("1")
        p.locator("#hand-duration").fill("0.3")
        p.get_by_role("button", name="Push").click()
        p.wait_for_function("document.querySelector('#msg').textContent.startsWith('push joint shoulder')")
        deadline = time.monotonic() + 5
        while abs(sims[1].position - start) < 10 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert sims[1].position - start > 10  # turned the way it was pushed
        drawn, expect = _drawn_vs_state(p)
        assert abs(drawn["shoulder"] - expect["shoulder"]) < 0.5
        twin = robot.twin
        # the 0.3 s push ends on the twin's clock, which may run behind the wall clock on a busy machine
        assert eventually(lambda: twin.pushes == [], 10)
        p.locator("#hand-duration").fill("10")
        p.get_by_role("button", name="Push").click()
        p.wait_for_function("document.querySelector('#msg').textContent.endsWith('for 10 s')")
        assert len(twin.pushes) == 1
        p.get_by_role("button", name="ESTOP").click()
        assert eventually(lambda: twin.pushes == [], 2)  # ESTOP lets go of the twin too
        p.locator("#hand-torque").fill("500")
        p.get_by_role("button", name="Push").click()
        msg = p.locator("#msg").inner_text()
        assert "torque Nm: 500 is outside -200..200 Nm" in msg and "hand-torque" not in msg, msg  # as labelled
        p.locator("#hand-kind").select_option("body")  # the default body is one a joint moves, not the base
        moving = {b for b in p.locator("#hand-target option").all_inner_texts()} - {"base"}
        assert p.locator("#hand-target").input_value() in moving, moving
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


ARM6 = REPO_ROOT / "examples" / "robots" / "arm6.toml"


def test_the_example_arm_on_its_twin(browser: Any, shots: Path) -> None:
    """The 6-joint example arm, posed by its motors on the twin: every drawn joint within 0.5 deg of its state."""
    pytest.importorskip("mujoco")
    pytest.importorskip("drempower.sim.twin")
    if not ARM6.exists():
        pytest.skip(f"{ARM6.name} is not in this tree")
    robot = open_robot(ARM6, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    ctx = browser.new_context(viewport={"width": 800, "height": 500})
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.get_by_role("button", name="Scan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("window.drempowerView && window.drempowerView.ready")
        pose = {"base_yaw": 0.6, "shoulder": 0.5, "elbow": -0.9, "wrist_pitch": 0.7}
        for name, rad in pose.items():
            robot.joint(name).set_position(rad)
        mapping = {j["joint"]: j for j in dash.view.mapping()}
        deadline = time.monotonic() + 8
        while time.monotonic() < deadline:
            drawn, motor = p.evaluate("[window.drempowerView.jointAngles(), window.drempowerView.motorAngles()]")
            state = {
                n: math.degrees(math.radians(motor[str(j["key"])]) / j["gear"] + j["offset"])
                for n, j in mapping.items()
                if str(j["key"]) in motor
            }
            assert len(state) == 6
            for n, want in state.items():
                assert abs(drawn[mapping[n]["model_joint"]] - want) < 0.5, (n, drawn, want)
            if all(abs(state[n] - math.degrees(rad)) < 1 for n, rad in pose.items()):
                break
            time.sleep(0.1)
        assert all(abs(state[n] - math.degrees(rad)) < 1 for n, rad in pose.items()), state
        time.sleep(0.3)
        p.screenshot(path=str(shots / "twin-3d.png"))
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


def test_without_a_model_the_view_says_how_to_get_one(page: Any) -> None:
    page.get_by_role("tab", name="3D").click()
    page.wait_for_function("window.drempowerView && window.drempowerView.error")
    assert "no model: give the dashboard a robot file whose [model]" in page.locator("#v3d-note").inner_text()
    assert page.locator("#hand-go").is_disabled()


MESHES = """
<mujoco>
  <compiler meshdir="meshes"/>
  <asset>
    <mesh name="tet" file="tet.stl" scale="0.1 0.1 0.1"/>
    <mesh file="cube.obj"/>
  </asset>
  <worldbody>
    <body name="base">
      <joint name="spin"/>
      <geom name="tet" type="mesh" mesh="tet" rgba="0.8 0.3 0.1 1"/>
      <geom name="cube" type="mesh" mesh="cube" pos="0.2 0 0"/>
    </body>
  </worldbody>
</mujoco>
"""
TET = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
TET_FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
CUBE_OBJ = "".join(f"v {x} {y} {z}\n" for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)) + (
    "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
)


@pytest.fixture
def mesh_model(tmp_path: Path) -> Path:
    """A model of two meshes: a binary STL tetrahedron (scaled) and an OBJ cube, in a mesh folder."""
    (tmp_path / "meshes").mkdir()
    stl = bytearray(80) + struct.pack("<I", len(TET_FACES))
    for face in TET_FACES:
        stl += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *TET[i]) for i in face) + b"\0\0"
    (tmp_path / "meshes" / "tet.stl").write_bytes(bytes(stl))
    (tmp_path / "meshes" / "cube.obj").write_text(CUBE_OBJ)
    path = tmp_path / "meshes.xml"
    path.write_text(MESHES)
    return path


def test_meshes_come_from_mujoco_or_from_their_files(mesh_model: Path) -> None:
    plain = mjcf_scene(str(mesh_model))
    tet, cube = plain["geoms"]
    assert tet["url"] == "meshes/tet.stl" and tet["format"] == "stl" and tet["scale"] == [0.1, 0.1, 0.1]
    assert cube["url"] == "meshes/cube.obj" and cube["format"] == "obj" and cube["pos"] == [0.2, 0.0, 0.0]
    assert plain["files"] == ["meshes/tet.stl", "meshes/cube.obj"]
    mujoco = pytest.importorskip("mujoco")
    from drempower.dash.model_scene import mujoco_scene

    compiled = mujoco_scene(str(mesh_model), mujoco)
    tet, cube = compiled["geoms"]
    assert len(tet["vertices"]) == 3 * 4 and len(tet["faces"]) == 3 * 4  # MuJoCo merges the STL's repeated vertices
    assert len(cube["vertices"]) == 3 * 8 and len(cube["faces"]) == 3 * 12  # the quads split in triangles
    v = [tet["vertices"][i : i + 3] for i in range(0, 12, 3)]
    longest = max(math.dist(a, b) for a in v for b in v)  # MuJoCo turns a mesh to its principal axes
    assert longest == pytest.approx(0.1 * math.sqrt(2), abs=1e-6)  # scaled


def test_the_page_loads_the_mesh_files_the_model_names(browser: Any, tmp_path: Path, mesh_model: Path) -> None:
    (tmp_path / "robot.toml").write_text('[buses.b]\ninterface = "sim"\n[joints.spin]\nbus = "b"\nid = 1\n')
    robot = open_robot(tmp_path / "robot.toml", stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot, model=str(mesh_model))
    dash.view.scene = mjcf_scene(str(mesh_model))  # as without MuJoCo: the page reads the files
    ctx = browser.new_context(viewport={"width": 800, "height": 500})
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("window.drempowerView && window.drempowerView.ready")
        count = "n => window.drempowerView.world.getObjectByName(n).geometry.getAttribute('position')?.count || 0"
        p.wait_for_function(f"({count})('tet') > 0 && ({count})('cube') > 0")
        assert p.evaluate(f"({count})('tet')") == 3 * 4  # STLLoader: three vertices per triangle
        assert p.evaluate("window.drempowerView.world.getObjectByName('tet').scale.x") == pytest.approx(0.1)
        assert ModelView.mesh_path(dash.view, "meshes.xml") is None  # the model itself is not a mesh
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


def test_a_dashboard_pushes_a_twin_that_drempower_sim_runs_in_another_process(tmp_path: Path) -> None:
    """The ready file of ``drempower sim --robot`` (a socketcand bus), the simulator in a process of its own:
    the dashboard's hand pushes its twin through the simulator's socketcand port (``< push ... >``), and
    the joint turns there; the twin's own refusal comes back in its words."""
    pytest.importorskip("mujoco")
    import subprocess
    import sys

    from drempower.dash.hub import Hub
    from drempower.errors import DrEmpowerError
    from drempower.sim.hand_link import RemoteHand

    arm6 = REPO_ROOT / "examples" / "robots" / "arm6.toml"
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT / "python" / "src")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "drempower", "sim", "--robot", str(arm6), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        path = None
        assert proc.stdout is not None
        for line in proc.stdout:
            if '"robot_file"' in line:
                path = json.loads(line)["robot_file"]
            if '"running"' in line:
                break
        assert path is not None, proc.stderr.read() if proc.stderr else ""
        with open_robot(path, stop_on_close=False, timeout=2) as robot:
            hub = Hub(robot)
            try:
                view = ModelView(hub)
                doc = view.document()
                assert doc["twin"] is True and doc["hand"] is None, doc["hand"]
                motor = robot.buses["arm"].motor(1)
                motor.set_mode(1)  # idle: the base turns freely about its vertical axis
                start = motor.get_state().angle
                said = view.do_push("t", {"kind": "joint", "target": "base_yaw", "torque": 5.0, "duration": 0.5})
                assert said == "push joint base_yaw: torque 5 Nm for 0.5 s"
                assert eventually(lambda: abs(motor.get_state().angle - start) > 5, 10), motor.get_state().angle
                port = robot.spec.buses["arm"].options["port"]
                with pytest.raises(DrEmpowerError, match="not a body of the model"):
                    RemoteHand(str(robot.spec.buses["arm"].options["host"]), int(port)).push("nope", (1, 0, 0))
            finally:
                hub.close()
    finally:
        proc.terminate()
        proc.wait(10)


def test_a_dashboard_says_truly_why_a_served_bus_without_a_twin_cannot_be_pushed(tmp_path: Path) -> None:
    """A robot file with a model whose socketcand bus is served by a simulator without a twin: the hand
    says that this program takes no pushes (not "needs the physics extra", which is installed)."""
    from drempower.dash.hub import Hub
    from drempower.sim import SimBus
    from drempower.sim.socketcand import attach_socketcand

    arm6 = REPO_ROOT / "examples" / "robots" / "arm6.xml"
    with attach_socketcand(SimBus([1])) as server:
        path = tmp_path / "robot.toml"
        path.write_text(
            f'[model]\nfile = "{arm6}"\n[buses.arm]\ninterface = "socketcand"\nhost = "127.0.0.1"\n'
            f'port = {server.port}\nchannel = "can0"\n[joints.base_yaw]\nbus = "arm"\nid = 1\n'
        )
        with open_robot(path, stop_on_close=False, timeout=2) as robot:
            hub = Hub(robot)
            try:
                doc = ModelView(hub).document()
            finally:
                hub.close()
    assert doc["twin"] is False and doc["hand"] != NO_TWIN
    assert f"served at 127.0.0.1:{server.port} by a program that takes no pushes" in doc["hand"], doc["hand"]
    assert "physics extra" not in doc["hand"]


def test_a_push_on_a_body_is_drawn_and_its_deflection_shown(
    browser: Any, tmp_path: Path, model: Path, shots: Path
) -> None:
    """On the robot twin: a 60 N push on the forearm draws its force as an arrow at the body for as long as
    it lasts (and a second after), and the page writes the joints' deflection (the idle shoulder turns)."""
    pytest.importorskip("mujoco")
    pytest.importorskip("drempower.sim.twin")
    (tmp_path / "robot.toml").write_text('[model]\nfile = "arm.xml"\n' + ROBOT)
    robot = open_robot(tmp_path / "robot.toml", stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    ctx = browser.new_context(viewport={"width": 900, "height": 600})
    try:
        bus = robot.buses["arm"]
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.get_by_role("button", name="Scan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("window.drempowerView && window.drempowerView.ready")
        bus.motor(1).set_mode(1)  # idle: the shoulder turns freely about its vertical axis
        assert p.locator("#hand-target").input_value() != "base"  # the default body moves
        p.locator("#hand-kind").select_option("body")
        p.locator("#hand-target").select_option("fore")
        p.locator("#hand-fx").fill("0")
        p.locator("#hand-fy").fill("60")  # across the arm: a torque about the shoulder's axis
        p.locator("#hand-fz").fill("0")
        p.locator("#hand-duration").fill("1")
        p.get_by_role("button", name="Push").click()
        p.wait_for_function("window.drempowerView.push && window.drempowerView.push.arrow")
        arrow = p.evaluate(
            "(() => { let a = null; window.drempowerView.world.traverse((o) => { if (o.name === 'push:fore') a = o; });"
            " return a && a.visible; })()"
        )
        assert arrow is True
        p.wait_for_function(
            "Math.abs(window.drempowerView.push.deflection.shoulder || 0) > 5", timeout=10_000
        )  # the idle shoulder swung, and the page says by how much
        text = p.locator("#hand-deflection").inner_text()
        assert text.startswith("force (0, 60, 0) N on fore: deflection ") and "shoulder" in text, text
        p.screenshot(path=str(shots / "dash-3d-push.png"))
        p.wait_for_function("window.drempowerView.push.arrow === false", timeout=15_000)  # gone after the push
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()
