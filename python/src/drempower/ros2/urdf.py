"""A URDF of a robot file's model, with a ``<ros2_control>`` block on the bridge's joint topics.

The model (MJCF, or URDF through MuJoCo's import) is compiled by MuJoCo and its
bodies, joints, geoms and inertials are written out:

* the ``<ros2_control>`` block names the robot file's joints and the bridge's
  topics for a hardware plugin that speaks them (:data:`PLUGINS`);
* each body is a link (the world body is ``world``); a body's joint (hinge:
  ``revolute``, or ``continuous`` without any range; slide: ``prismatic``) joins
  it to its parent's link, a body without one is joined by a ``fixed`` joint; a
  body with several joints gets one link per joint (``BODY__JOINT``) but the last;
* a URDF joint's frame is its MuJoCo joint's anchor, so a link's frame is its
  body's frame moved to the anchor (the arm's and the pendulum's anchors are
  their bodies' origins: there link frame and body frame are one);
* a joint of the robot file carries the file's name (the bridge's) and its limits:
  the position range is the file's ``limits.position`` narrowed by the model's
  range; velocity and effort are the file's ``limits.speed`` and ``limits.torque``,
  else those of the typical motor (300 r/min, 12 Nm at the output) through the
  joint's ``gear``;
* geoms are visuals (capsules as a cylinder and two spheres, meshes as binary
  STL files of MuJoCo's compiled vertices), and collisions too when they collide
  in the model (``contype`` or ``conaffinity`` set); planes and height fields have
  no URDF shape and are left out with a warning;
* inertials are MuJoCo's: mass, centre of mass and principal inertia.
"""

from __future__ import annotations

import math
import os
import re
import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ..errors import ConfigError
from ..robotfile import JointSpec, RobotSpec
from . import DEFAULT_PLUGIN, PLUGINS

__all__ = [
    "DEFAULT_PLUGIN",
    "PLUGINS",
    "TYPICAL_SPEED",
    "TYPICAL_TORQUE",
    "JointInfo",
    "Urdf",
    "robot_urdf",
    "rpy_of",
]

TYPICAL_SPEED = 300.0 * 2.0 * math.pi / 60.0
"""rad/s at the output of the typical motor (300 r/min), a joint's speed limit when its file gives none."""
TYPICAL_TORQUE = 12.0
"""Nm at the output of the typical motor (its peak), a joint's effort limit when its file gives none."""
STATE_INTERFACES = ("position", "velocity", "effort")
"""What the bridge publishes on the joint states topic for every joint."""


@dataclass(frozen=True)
class JointInfo:
    """One driven joint of the URDF: its name, type, limits (rad or m, rad/s, Nm) and command interfaces."""

    name: str
    model_joint: str
    kind: str
    lower: float | None
    upper: float | None
    velocity: float
    effort: float
    interfaces: tuple[str, ...]


@dataclass
class Urdf:
    """The URDF's text, the mesh files it names (file name -> bytes), the joints the robot file drives, and
    what could not be written (warnings)."""

    name: str
    text: str
    meshes: dict[str, bytes] = field(default_factory=dict)
    joints: list[JointInfo] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    chain: list[str] = field(default_factory=list)
    """The links from the root to the tip of the driven joints (the planning group's chain)."""
    adjacent: list[tuple[str, str]] = field(default_factory=list)
    colliding: list[tuple[str, str]] = field(default_factory=list)
    """Pairs of links whose collision shapes touch with every joint at 0 (a planner must ignore them)."""
    warnings: list[str] = field(default_factory=list)


# ---------------------------------------------------------------------- transforms


def _quat_mat(q: Any) -> np.ndarray:
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _tf(pos: Any, quat: Any = (1.0, 0.0, 0.0, 0.0)) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = _quat_mat(quat)
    t[:3, 3] = [float(v) for v in pos]
    return t


def rpy_of(r: np.ndarray) -> tuple[float, float, float]:
    """URDF's roll, pitch, yaw (rad) of rotation matrix ``r`` (``r = Rz(yaw) Ry(pitch) Rx(roll)``)."""
    c = math.hypot(float(r[2, 1]), float(r[2, 2]))
    pitch = math.atan2(-float(r[2, 0]), c)
    if c < 1e-9:  # pitch at +-90 deg: roll and yaw turn about one axis; put it all in yaw
        return 0.0, pitch, math.atan2(-float(r[0, 1]), float(r[1, 1]))
    return math.atan2(float(r[2, 1]), float(r[2, 2])), pitch, math.atan2(float(r[1, 0]), float(r[0, 0]))


def _num(v: float) -> str:
    text = f"{v:.9g}" if abs(v) > 1e-12 else "0"
    return "0" if text == "-0" else text


def _origin(t: np.ndarray) -> str:
    xyz = " ".join(_num(float(v)) for v in t[:3, 3])
    rpy = rpy_of(t[:3, :3])
    if all(abs(a) < 1e-12 for a in rpy):
        return f'<origin xyz="{xyz}"/>' if any(abs(float(v)) > 0 for v in t[:3, 3]) else ""
    return f'<origin xyz="{xyz}" rpy="{" ".join(_num(a) for a in rpy)}"/>'


# ---------------------------------------------------------------------- the model


def _compile(path: str) -> Any:
    from ..sim.twin import require_mujoco

    mujoco = require_mujoco()
    try:
        spec = _urdf_spec(mujoco, path) if path.lower().endswith(".urdf") else None
        spec = spec or mujoco.MjSpec.from_file(path)
        return mujoco, spec.compile(), str(spec.modelname or "")
    except Exception as exc:  # MuJoCo's parser errors have no common type
        raise ConfigError(f"model {path}: {exc}") from None


def _urdf_spec(mujoco: Any, path: str) -> Any:
    """A URDF model as MuJoCo reads it, but keeping its visuals and its links without mass, which MuJoCo's URDF
    import drops by default (``discardvisual``, ``fusestatic``); None if the URDF sets MuJoCo's compiler itself."""
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    if "<mujoco" in text:
        return None
    folder = quoteattr(os.path.dirname(os.path.abspath(path)) + os.sep)
    compiler = f'<mujoco><compiler discardvisual="false" fusestatic="false" meshdir={folder}/></mujoco>'
    text, n = re.subn(r"(<robot\b[^>]*>)", lambda m: m.group(1) + compiler, text, count=1)
    return mujoco.MjSpec.from_string(text) if n else None


def _name(mujoco: Any, m: Any, kind: Any, i: int, fallback: str) -> str:
    return str(mujoco.mj_id2name(m, kind, i) or fallback)


def stl(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """A binary STL of triangles ``faces`` (indices into ``vertices``, m)."""
    out = [b"drempower: a mesh of the robot's model".ljust(80, b" "), struct.pack("<I", len(faces))]
    for f in faces:
        a, b, c = (vertices[int(k)] for k in f)
        n = np.cross(b - a, c - a)
        norm = float(np.linalg.norm(n))
        n = n / norm if norm > 0 else n
        out.append(struct.pack("<12fH", *n, *a, *b, *c, 0))
    return b"".join(out)


def _limits(j: JointSpec | None, mj_range: tuple[float, float] | None, where: str) -> tuple[float | None, float | None]:
    lo, hi = mj_range if mj_range is not None else (None, None)
    file_range = j.limits.get("position") if j is not None else None
    if file_range is not None:
        flo, fhi = float(file_range[0]), float(file_range[1])
        lo = flo if lo is None else max(lo, flo)
        hi = fhi if hi is None else min(hi, fhi)
        if lo > hi:
            raise ConfigError(
                f"{where}: limits.position={[flo, fhi]} is outside the model's range "
                f"{list(mj_range or ())}: the joint could not move at all"
            )
    return lo, hi


def robot_urdf(
    spec: RobotSpec,
    *,
    name: str | None = None,
    mesh_uri: Callable[[str], str] = lambda f: f"meshes/{f}",
    interfaces: Sequence[str] | None = None,
    joint_commands: str | None = None,
    joint_states: str | None = None,
    plugin: str = DEFAULT_PLUGIN,
) -> Urdf:
    """The URDF of the model of ``spec`` (a :class:`ConfigError` if the file names no model or the model
    cannot be written as a URDF). ``mesh_uri`` names a mesh file in the URDF; the other arguments override
    the robot file's ``[ros2_control]``."""
    from ..bridge.joint_topics import DEFAULT_COMMANDS_TOPIC, DEFAULT_STATES_TOPIC, check_interfaces

    if plugin not in PLUGINS:
        raise ConfigError(f"plugin {plugin!r}: the plugins that speak the bridge's topics are {', '.join(PLUGINS)}")
    if spec.model is None:
        raise ConfigError(f"{spec.source}: no [model]: a URDF is written from the robot's model (MJCF or URDF)")
    mujoco, m, model_name = _compile(spec.model.file)
    obj = mujoco.mjtObj
    conf: Mapping[str, Any] = spec.ros2_control or {}
    try:
        ifaces = check_interfaces(interfaces or conf.get("command_interfaces", ("position",)))
    except ValueError as exc:
        raise ConfigError(f"{spec.source}: [ros2_control] {exc}") from None
    robot_name = name or model_name or os.path.splitext(os.path.basename(spec.model.file))[0]
    out = Urdf(robot_name, "")

    by_model = {j.model_joint or j.name: j for j in spec.joints.values()}
    model_joints = {_name(mujoco, m, obj.mjOBJ_JOINT, i, ""): i for i in range(m.njnt)}
    for j in spec.joints.values():
        mj_name = j.model_joint or j.name
        if mj_name not in model_joints:
            raise ConfigError(
                f"{spec.source}: [joints.{j.name}]: {mj_name!r} is not a joint of the model {spec.model.file}"
            )

    lines: list[str] = []
    links: list[str] = []
    joints_xml: list[str] = []
    materials: dict[tuple[float, ...], str] = {}
    body_link: dict[int, str] = {0: "world"}
    shift: dict[int, np.ndarray] = {0: np.eye(4)}  # body frame -> its (last) link's frame
    mesh_names: dict[int, str] = {}
    driven: dict[str, JointInfo] = {}
    parent_link: dict[str, str] = {}
    used = {"world"}

    def unique(base: str) -> str:
        n, k = base, 1
        while n in used:
            k += 1
            n = f"{base}_{k}"
        used.add(n)
        return n

    def geoms_of(body: int, inv_shift: np.ndarray) -> list[str]:
        parts: list[str] = []
        gt = mujoco.mjtGeom
        for g in range(m.ngeom):
            if int(m.geom_bodyid[g]) != body:
                continue
            gname = _name(mujoco, m, obj.mjOBJ_GEOM, g, f"geom {g}")
            t = inv_shift @ _tf(m.geom_pos[g], m.geom_quat[g])
            size = [float(v) for v in m.geom_size[g]]
            kind = int(m.geom_type[g])
            shapes: list[tuple[np.ndarray, str]] = []
            names: list[str] = [gname]
            if kind == gt.mjGEOM_BOX:
                shapes.append((t, f'<box size="{" ".join(_num(2 * s) for s in size)}"/>'))
            elif kind == gt.mjGEOM_SPHERE:
                shapes.append((t, f'<sphere radius="{_num(size[0])}"/>'))
            elif kind == gt.mjGEOM_CYLINDER:
                shapes.append((t, f'<cylinder radius="{_num(size[0])}" length="{_num(2 * size[1])}"/>'))
            elif kind == gt.mjGEOM_CAPSULE:
                shapes.append((t, f'<cylinder radius="{_num(size[0])}" length="{_num(2 * size[1])}"/>'))
                for end in (-1.0, 1.0):
                    shapes.append((t @ _tf((0.0, 0.0, end * size[1])), f'<sphere radius="{_num(size[0])}"/>'))
                names = [gname, f"{gname}_end0", f"{gname}_end1"]
            elif kind == gt.mjGEOM_MESH:
                mid = int(m.geom_dataid[g])
                if mid not in mesh_names:
                    base = _name(mujoco, m, obj.mjOBJ_MESH, mid, f"mesh{mid}")
                    fname = f"{base}.stl"
                    va, vn = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
                    fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
                    out.meshes[fname] = stl(
                        np.asarray(m.mesh_vert[va : va + vn]), np.asarray(m.mesh_face[fa : fa + fn])
                    )
                    mesh_names[mid] = fname
                shapes.append((t, f"<mesh filename={quoteattr(mesh_uri(mesh_names[mid]))}/>"))
            else:
                what = {gt.mjGEOM_PLANE: "a plane", gt.mjGEOM_HFIELD: "a height field"}.get(kind, f"type {kind}")
                out.warnings.append(
                    f"geom {gname!r} of link {body_link[body]!r} is {what}: URDF has no such shape, left out"
                )
                continue
            matid = int(m.geom_matid[g])
            rgba = tuple(round(float(v), 4) for v in (m.mat_rgba[matid] if matid >= 0 else m.geom_rgba[g]))
            if rgba not in materials:
                materials[rgba] = f"{out.name}_color{len(materials)}"
            collides = int(m.geom_contype[g]) or int(m.geom_conaffinity[g])
            for (tt, shape), vname in zip(shapes, names, strict=True):
                o = _origin(tt)
                parts.append(
                    f"    <visual name={quoteattr(vname)}>{o}<geometry>{shape}</geometry>"
                    f'<material name="{materials[rgba]}"/></visual>'
                )
                if collides:
                    parts.append(f"    <collision name={quoteattr(vname)}>{o}<geometry>{shape}</geometry></collision>")
        return parts

    def inertial_of(body: int, inv_shift: np.ndarray) -> list[str]:
        mass = float(m.body_mass[body])
        if mass <= 0:
            return []
        t = inv_shift @ _tf(m.body_ipos[body], m.body_iquat[body])
        i = [float(v) for v in m.body_inertia[body]]
        return [
            f'    <inertial>{_origin(t)}<mass value="{_num(mass)}"/>'
            f'<inertia ixx="{_num(i[0])}" ixy="0" ixz="0" iyy="{_num(i[1])}" iyz="0" izz="{_num(i[2])}"/></inertial>'
        ]

    def link_xml(name: str, body: int | None, inv_shift: np.ndarray) -> None:
        inner = [] if body is None else inertial_of(body, inv_shift) + geoms_of(body, inv_shift)
        links.append(name)
        if inner:
            lines.extend([f"  <link name={quoteattr(name)}>", *inner, "  </link>"])
        else:
            lines.append(f"  <link name={quoteattr(name)}/>")

    link_xml("world", 0, np.eye(4))
    for b in range(1, m.nbody):
        parent = int(m.body_parentid[b])
        bname = _name(mujoco, m, obj.mjOBJ_BODY, b, f"body{b}")
        x0 = np.linalg.inv(shift[parent]) @ _tf(m.body_pos[b], m.body_quat[b])  # in the parent's link frame
        jadr, jnum = int(m.body_jntadr[b]), int(m.body_jntnum[b])
        prev_link, prev_anchor = body_link[parent], None
        here = x0
        for k in range(jnum):
            jid = jadr + k
            jname = _name(mujoco, m, obj.mjOBJ_JOINT, jid, f"joint{jid}")
            jtype = int(m.jnt_type[jid])
            where = f"model {spec.model.file}: joint {jname!r}"
            if jtype not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                kind = "a free joint" if jtype == mujoco.mjtJoint.mjJNT_FREE else "a ball joint"
                raise ConfigError(
                    f"{where} is {kind}: a URDF joint turns or slides about one axis (hinge or slide joints only, "
                    "and a fixed base)"
                )
            if abs(float(m.qpos0[m.jnt_qposadr[jid]])) > 1e-12:
                raise ConfigError(
                    f"{where} has ref={float(m.qpos0[m.jnt_qposadr[jid]]):g}: a URDF joint is at 0 at its origin"
                )
            anchor = np.asarray(m.jnt_pos[jid], dtype=float)
            origin = here @ _tf(anchor) if prev_anchor is None else _tf(anchor - prev_anchor)
            prev_anchor = anchor
            rj = by_model.get(jname)
            uname = rj.name if rj is not None else jname
            child = bname if k == jnum - 1 else f"{bname}__{jname}"
            child = unique(child)
            mj_range = (float(m.jnt_range[jid][0]), float(m.jnt_range[jid][1])) if int(m.jnt_limited[jid]) else None
            lo, hi = _limits(rj, mj_range, f"{spec.source}: [joints.{uname}]" if rj is not None else where)
            hinge = jtype == mujoco.mjtJoint.mjJNT_HINGE
            if rj is not None:
                gear = abs(rj.gear)
                vel = float(rj.limits.get("speed", TYPICAL_SPEED / gear))
                eff = float(rj.limits.get("torque", TYPICAL_TORQUE * gear))
            else:
                vel = 0.0
                eff = float(max(abs(v) for v in m.jnt_actfrcrange[jid])) if int(m.jnt_actfrclimited[jid]) else 0.0
            urdf_kind = ("revolute" if lo is not None else "continuous") if hinge else "prismatic"
            if urdf_kind == "prismatic" and lo is None:
                raise ConfigError(f"{where} is a slide joint without a range: a URDF prismatic joint needs limits")
            axis = " ".join(_num(float(v)) for v in m.jnt_axis[jid])
            limit = (
                f'<limit lower="{_num(lo)}" upper="{_num(hi)}" effort="{_num(eff)}" velocity="{_num(vel)}"/>'
                if lo is not None and hi is not None
                else f'<limit effort="{_num(eff)}" velocity="{_num(vel)}"/>'
            )
            damping, friction = float(m.dof_damping[m.jnt_dofadr[jid]]), float(m.dof_frictionloss[m.jnt_dofadr[jid]])
            note = ""
            if rj is not None and ("speed" not in rj.limits or "torque" not in rj.limits):
                note = (
                    f"  <!-- velocity, effort: the typical motor's 300 r/min and 12 Nm through gear {rj.gear:g} -->\n"
                )
            elif rj is None:
                note = f"  <!-- {uname}: a joint of the model the robot file does not drive -->\n"
            joints_xml.append(
                f'{note}  <joint name={quoteattr(uname)} type="{urdf_kind}">{_origin(origin)}'
                f'<parent link={quoteattr(prev_link)}/><child link={quoteattr(child)}/><axis xyz="{axis}"/>'
                f'{limit}<dynamics damping="{_num(damping)}" friction="{_num(friction)}"/></joint>'
            )
            parent_link[child] = prev_link
            if rj is not None:
                driven[uname] = JointInfo(uname, jname, urdf_kind, lo, hi, vel, eff, ifaces)
            if k < jnum - 1:
                link_xml(child, None, np.eye(4))
            prev_link = child
        if jnum == 0:
            child = unique(bname)
            joints_xml.append(
                f'  <joint name={quoteattr(unique(f"{body_link[parent]}_to_{child}"))} type="fixed">{_origin(x0)}'
                f"<parent link={quoteattr(prev_link)}/><child link={quoteattr(child)}/></joint>"
            )
            parent_link[child] = prev_link
            shift[b] = np.eye(4)
        else:
            shift[b] = _tf(prev_anchor if prev_anchor is not None else (0.0, 0.0, 0.0))
        body_link[b] = child
        link_xml(child, b, np.linalg.inv(shift[b]))

    out.links = links
    out.adjacent = [(p, c) for c, p in parent_link.items()]
    out.joints = [driven[j.name] for j in spec.joints.values()]
    out.chain = _chain(parent_link, [body_link[int(m.jnt_bodyid[model_joints[j.model_joint]])] for j in out.joints])
    out.colliding = _colliding(mujoco, m, body_link, set(out.adjacent))

    head = [
        '<?xml version="1.0"?>',
        f"<!-- {out.name}: written by drempower ros2 urdf from {os.path.basename(spec.source)} and its model "
        f"{os.path.basename(spec.model.file)}. Joints, limits and topics are the robot file's. -->",
        f"<robot name={quoteattr(out.name)}>",
    ]
    for rgba, mname in materials.items():
        head.append(f'  <material name="{mname}"><color rgba="{" ".join(_num(v) for v in rgba)}"/></material>')
    block = _ros2_control(
        out.name,
        out.joints,
        joint_commands or conf.get("joint_commands_topic", DEFAULT_COMMANDS_TOPIC),
        joint_states or conf.get("joint_states_topic", DEFAULT_STATES_TOPIC),
        plugin,
    )
    out.text = "\n".join([*head, *lines, *joints_xml, *block, "</robot>", ""])
    return out


def _chain(parent_link: Mapping[str, str], tips: Sequence[str]) -> list[str]:
    """The links from the root to the deepest of ``tips``."""
    best: list[str] = []
    for tip in tips:
        path = [tip]
        while path[-1] in parent_link:
            path.append(parent_link[path[-1]])
        if len(path) > len(best):
            best = path
    return best[::-1]


def _colliding(
    mujoco: Any, m: Any, body_link: Mapping[int, str], adjacent: set[tuple[str, str]]
) -> list[tuple[str, str]]:
    """Pairs of links (not adjacent) whose colliding geoms touch or overlap at the model's zero pose."""
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    geoms = [g for g in range(m.ngeom) if (int(m.geom_contype[g]) or int(m.geom_conaffinity[g]))]
    geoms = [
        g
        for g in geoms
        if int(m.geom_type[g]) not in (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD))
    ]
    pairs: set[tuple[str, str]] = set()
    fromto = np.zeros(6)
    for a_i, a in enumerate(geoms):
        for b in geoms[a_i + 1 :]:
            la, lb = body_link[int(m.geom_bodyid[a])], body_link[int(m.geom_bodyid[b])]
            if la == lb or (la, lb) in adjacent or (lb, la) in adjacent:
                continue
            if mujoco.mj_geomDistance(m, d, a, b, 0.01, fromto) <= 0.0:
                pairs.add((la, lb) if la < lb else (lb, la))
    return sorted(pairs)


def _ros2_control(name: str, joints: Sequence[JointInfo], commands: str, states: str, plugin: str) -> list[str]:
    out = [
        f'  <ros2_control name={quoteattr(name)} type="system">',
        "    <hardware>",
        f"      <plugin>{plugin}</plugin>",
        f'      <param name="joint_commands_topic">{escape(commands)}</param>',
        f'      <param name="joint_states_topic">{escape(states)}</param>',
        "    </hardware>",
    ]
    for j in joints:
        out.append(f"    <joint name={quoteattr(j.name)}>")
        for i in j.interfaces:
            if i == "position" and j.lower is not None and j.upper is not None:
                out.append(
                    f'      <command_interface name="position"><param name="min">{_num(j.lower)}</param>'
                    f'<param name="max">{_num(j.upper)}</param></command_interface>'
                )
            else:
                out.append(f'      <command_interface name="{i}"/>')
        out.extend(f'      <state_interface name="{s}"/>' for s in STATE_INTERFACES)
        out.append("    </joint>")
    out.append("  </ros2_control>")
    return out
