"""A robot model's kinematic tree and geometry as the dashboard's 3D view draws it.

:func:`load_scene` reads an MJCF or URDF model into a JSON-able scene: bodies
(parent, position m and orientation quaternion w x y z in the parent's frame),
joints (body, type ``hinge``/``slide``, axis and anchor in the body's frame,
``ref`` rad or m: the position at which the body has its modelled pose) and
geoms (type, MuJoCo half-sizes m, pose in the body's frame, colour). With the
``mujoco`` package installed, MuJoCo compiles the model (MJCF or URDF, meshes
included: their vertices and faces are sent); without it, a plain MJCF parse
gives the primitives and names the mesh files for the page to load.

Nothing here needs physics: the page poses the bodies from the joint positions.
"""

from __future__ import annotations

import importlib
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from typing import Any

from ..errors import ConfigError

__all__ = ["GEOM_TYPES", "load_scene"]

GEOM_TYPES = ("plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh")
"""MuJoCo's geom types by their number (``mjtGeom``)."""
_JOINT_TYPES = ("free", "ball", "slide", "hinge")
"""MuJoCo's joint types by their number (``mjtJoint``)."""
_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)
"""MuJoCo's geom colour when none is given; a material's colour then applies."""
_VISIBLE_GROUPS = 3
"""Geoms of groups 0-2 are drawn (MuJoCo's viewer default); higher groups are usually collision shapes."""
_DIGITS = 6

Vec = tuple[float, ...]


def load_scene(path: str) -> dict[str, Any]:
    """The scene of model file ``path`` (MJCF or URDF): MuJoCo's compile when installed, else a plain MJCF parse.

    Raises :class:`ConfigError` naming the file when it cannot be read.
    """
    if not os.path.isfile(path):
        raise ConfigError(f"model file {path!r}: no such file")
    try:
        mujoco = importlib.import_module("mujoco")
    except ImportError:
        return mjcf_scene(path)
    return mujoco_scene(path, mujoco)


def _r(values: Iterable[float]) -> list[float]:
    return [round(float(v), _DIGITS) for v in values]


# ---------------------------------------------------------------------- MuJoCo


def mujoco_scene(path: str, mujoco: Any = None) -> dict[str, Any]:
    """The scene from MuJoCo's compiled model (``MjModel``'s body, joint, geom and mesh arrays)."""
    mujoco = mujoco or importlib.import_module("mujoco")
    try:
        m = mujoco.MjModel.from_xml_path(path)
    except Exception as exc:  # MuJoCo raises ValueError with the parser's message
        raise ConfigError(f"model file {path!r}: MuJoCo cannot load it: {exc}") from None
    bodies = [
        {
            "name": m.body(i).name or ("world" if i == 0 else f"body{i}"),
            "parent": int(m.body_parentid[i]) if i else -1,
            "pos": _r(m.body_pos[i]),
            "quat": _r(m.body_quat[i]),
        }
        for i in range(m.nbody)
    ]
    joints = []
    for j in range(m.njnt):
        kind = _JOINT_TYPES[int(m.jnt_type[j])]
        joints.append(
            {
                "name": m.joint(j).name,
                "body": int(m.jnt_bodyid[j]),
                "type": kind,
                "axis": _r(m.jnt_axis[j]),
                "pos": _r(m.jnt_pos[j]),
                "ref": round(float(m.qpos0[m.jnt_qposadr[j]]), _DIGITS) if kind in ("hinge", "slide") else 0.0,
            }
        )
    geoms = []
    for g in range(m.ngeom):
        rgba = tuple(float(v) for v in m.geom_rgba[g])
        if m.geom_matid[g] >= 0 and rgba == _DEFAULT_RGBA:
            rgba = tuple(float(v) for v in m.mat_rgba[m.geom_matid[g]])
        if m.geom_group[g] >= _VISIBLE_GROUPS or rgba[3] <= 0:
            continue
        geom: dict[str, Any] = {
            "name": m.geom(g).name,
            "body": int(m.geom_bodyid[g]),
            "type": GEOM_TYPES[int(m.geom_type[g])],
            "size": _r(m.geom_size[g]),
            "pos": _r(m.geom_pos[g]),
            "quat": _r(m.geom_quat[g]),
            "rgba": _r(rgba),
        }
        if geom["type"] == "mesh":
            k = int(m.geom_dataid[g])
            v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
            f0, nf = int(m.mesh_faceadr[k]), int(m.mesh_facenum[k])
            geom["vertices"] = _r(m.mesh_vert[v0 : v0 + nv].ravel())
            geom["faces"] = [int(i) for i in m.mesh_face[f0 : f0 + nf].ravel()]
        elif geom["type"] == "hfield":
            continue  # a height field is terrain, not part of the robot
        geoms.append(geom)
    return {"file": os.path.basename(path), "engine": "mujoco", "bodies": bodies, "joints": joints, "geoms": geoms}


# ---------------------------------------------------------------------- plain MJCF


def _floats(text: str | None, n: int | None = None, what: str = "") -> list[float] | None:
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        raise ConfigError(f"{what}={text!r}: expected numbers") from None
    if n is not None and len(values) != n:
        raise ConfigError(f"{what}={text!r}: expected {n} numbers")
    return values


def _qmul(a: Sequence[float], b: Sequence[float]) -> Vec:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def _axis_angle(axis: Sequence[float], angle: float) -> Vec:
    n = math.sqrt(sum(a * a for a in axis))
    if n == 0:
        return (1.0, 0.0, 0.0, 0.0)
    s = math.sin(angle / 2) / n
    return (math.cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s)


def _z_to(d: Sequence[float]) -> Vec:
    """The rotation taking +z to direction ``d`` (MuJoCo's ``mju_quatZ2Vec``)."""
    n = math.sqrt(sum(v * v for v in d))
    if n == 0:
        return (1.0, 0.0, 0.0, 0.0)
    x, y, z = (v / n for v in d)
    axis = (-y, x, 0.0)  # z cross d
    s = math.hypot(x, y)
    if s < 1e-12:
        return (1.0, 0.0, 0.0, 0.0) if z > 0 else (0.0, 1.0, 0.0, 0.0)
    return _axis_angle(axis, math.atan2(s, z))


class _Mjcf:
    """Reads bodies, joints and primitive geoms of one MJCF file (with its defaults and materials)."""

    def __init__(self, path: str) -> None:
        self.path = path
        try:
            self.root = ET.parse(path).getroot()
        except (ET.ParseError, OSError) as exc:
            raise ConfigError(f"model file {path!r}: not readable XML: {exc}") from None
        if self.root.tag != "mujoco":
            raise ConfigError(
                f"model file {path!r}: <{self.root.tag}> is not MJCF; a URDF model needs the physics extra "
                "(pip install 'drempower[physics]'), whose MuJoCo reads it"
            )
        comp = self.root.find("compiler")
        c = comp.attrib if comp is not None else {}
        self.degrees = c.get("angle", "degree") == "degree"
        self.eulerseq = c.get("eulerseq", "xyz")
        self.meshdir = c.get("meshdir", c.get("assetdir", ""))
        self.defaults: dict[str, dict[str, dict[str, str]]] = {}
        for d in self.root.findall("default"):
            self._read_default(d, "main", {})
        self.materials = {
            m.get("name", ""): m.get("rgba", "1 1 1 1") for m in self.root.iter("material") if m.get("name")
        }
        self.meshes: dict[str, dict[str, Any]] = {}
        for m in self.root.iter("mesh"):
            file = m.get("file")
            if file is None:
                continue
            name = m.get("name") or os.path.splitext(os.path.basename(file))[0]
            scale = _floats(m.get("scale"), 3, f"mesh {name} scale") or [1.0, 1.0, 1.0]
            self.meshes[name] = {"file": os.path.normpath(os.path.join(self.meshdir, file)), "scale": scale}

    def _read_default(self, d: ET.Element, name: str, inherited: dict[str, dict[str, str]]) -> None:
        own = {k: dict(v) for k, v in inherited.items()}
        for child in d:
            if child.tag != "default":
                own.setdefault(child.tag, {}).update(child.attrib)
        self.defaults[name] = own
        for child in d.findall("default"):
            self._read_default(child, child.get("class", name), own)

    def attrs(self, e: ET.Element, cls: str) -> dict[str, str]:
        out = dict(self.defaults.get(e.get("class", cls), self.defaults.get("main", {})).get(e.tag, {}))
        out.update(e.attrib)
        return out

    def angle(self, v: float) -> float:
        return math.radians(v) if self.degrees else v

    def orientation(self, a: dict[str, str], what: str) -> Vec:
        """The frame's quaternion from quat, axisangle, euler, xyaxes or zaxis (MJCF's alternatives)."""
        if "quat" in a:
            wxyz = _floats(a["quat"], 4, f"{what} quat") or [1, 0, 0, 0]
            n = math.sqrt(sum(v * v for v in wxyz)) or 1.0
            return tuple(v / n for v in wxyz)
        if "axisangle" in a:
            x, y, z, ang = _floats(a["axisangle"], 4, f"{what} axisangle") or [0, 0, 1, 0]
            return _axis_angle((x, y, z), self.angle(ang))
        if "euler" in a:
            angles = _floats(a["euler"], 3, f"{what} euler") or [0, 0, 0]
            q: Vec = (1.0, 0.0, 0.0, 0.0)
            for axis_name, ang in zip(self.eulerseq, angles, strict=True):
                unit = [0.0, 0.0, 0.0]
                unit["xyz".index(axis_name.lower())] = 1.0
                r = _axis_angle(unit, self.angle(ang))
                q = _qmul(q, r) if axis_name.islower() else _qmul(r, q)
            return q
        if "zaxis" in a:
            return _z_to(_floats(a["zaxis"], 3, f"{what} zaxis") or [0, 0, 1])
        if "xyaxes" in a:
            x0, x1, x2, y0, y1, y2 = _floats(a["xyaxes"], 6, f"{what} xyaxes") or [1, 0, 0, 0, 1, 0]
            return _matrix_quat((x0, x1, x2), (y0, y1, y2))
        return (1.0, 0.0, 0.0, 0.0)

    def scene(self) -> dict[str, Any]:
        bodies: list[dict[str, Any]] = [{"name": "world", "parent": -1, "pos": [0.0] * 3, "quat": [1.0, 0, 0, 0]}]
        joints: list[dict[str, Any]] = []
        geoms: list[dict[str, Any]] = []
        files: list[str] = []

        def walk(e: ET.Element, index: int, cls: str) -> None:
            for child in e:
                if child.tag == "geom":
                    g = self.geom(child, index, cls)
                    if g is not None:
                        geoms.append(g)
                        if g["type"] == "mesh":
                            files.append(g["url"])
                elif child.tag in ("joint", "freejoint") and index > 0:
                    joints.append(self.joint(child, index, cls))
                elif child.tag == "body":
                    a = child.attrib
                    name = a.get("name", f"body{len(bodies)}")
                    pos = _floats(a.get("pos"), 3, f"body {name} pos") or [0.0] * 3
                    bodies.append(
                        {"name": name, "parent": index, "pos": _r(pos), "quat": _r(self.orientation(a, f"body {name}"))}
                    )
                    walk(child, len(bodies) - 1, a.get("childclass", cls))

        world = self.root.find("worldbody")
        if world is not None:
            walk(world, 0, "main")
        return {
            "file": os.path.basename(self.path),
            "engine": "mjcf",
            "bodies": bodies,
            "joints": joints,
            "geoms": geoms,
            "files": files,
        }

    def joint(self, e: ET.Element, body: int, cls: str) -> dict[str, Any]:
        a = self.attrs(e, cls)
        kind = "free" if e.tag == "freejoint" else a.get("type", "hinge")
        if kind not in _JOINT_TYPES:
            raise ConfigError(f"joint {a.get('name')!r}: type={kind!r}: one of {', '.join(_JOINT_TYPES)}")
        axis = _floats(a.get("axis"), 3, "joint axis") or [0.0, 0.0, 1.0]
        n = math.sqrt(sum(v * v for v in axis)) or 1.0
        ref = (_floats(a.get("ref"), 1, "joint ref") or [0.0])[0]
        return {
            "name": a.get("name", ""),
            "body": body,
            "type": kind,
            "axis": _r(v / n for v in axis),
            "pos": _r(_floats(a.get("pos"), 3, "joint pos") or [0.0] * 3),
            "ref": round(self.angle(ref) if kind == "hinge" else ref if kind == "slide" else 0.0, _DIGITS),
        }

    def geom(self, e: ET.Element, body: int, cls: str) -> dict[str, Any] | None:
        a = self.attrs(e, cls)
        name = a.get("name", "")
        kind = a.get("type", "sphere")
        if kind not in GEOM_TYPES:
            raise ConfigError(f"geom {name!r}: type={kind!r}: one of {', '.join(GEOM_TYPES)}")
        rgba = tuple(_floats(a.get("rgba"), 4, f"geom {name!r} rgba") or _DEFAULT_RGBA)
        if "material" in a and rgba == _DEFAULT_RGBA:
            rgba = tuple(_floats(self.materials.get(a["material"], "1 1 1 1"), 4) or _DEFAULT_RGBA)
        group = int((_floats(a.get("group"), 1, "geom group") or [0])[0])
        if kind == "hfield" or group >= _VISIBLE_GROUPS or rgba[3] <= 0:
            return None
        size = (_floats(a.get("size"), None, f"geom {name!r} size") or []) + [0.0, 0.0, 0.0]
        pos: Sequence[float] = _floats(a.get("pos"), 3, f"geom {name!r} pos") or [0.0] * 3
        quat = self.orientation(a, f"geom {name!r}")
        if "fromto" in a and kind in ("capsule", "cylinder", "box", "ellipsoid"):
            f = _floats(a["fromto"], 6, f"geom {name!r} fromto") or [0.0] * 6
            d = (f[0] - f[3], f[1] - f[4], f[2] - f[5])  # MuJoCo: +z from "to" towards "from"
            half = math.sqrt(sum(v * v for v in d)) / 2
            pos = ((f[0] + f[3]) / 2, (f[1] + f[4]) / 2, (f[2] + f[5]) / 2)
            quat = _z_to(d)
            size = [size[0], half, 0.0] if kind in ("capsule", "cylinder") else [size[0], size[1], half]
        geom: dict[str, Any] = {
            "name": name,
            "body": body,
            "type": kind,
            "size": _r(size[:3]),
            "pos": _r(pos),
            "quat": _r(quat),
            "rgba": _r(rgba),
        }
        if kind == "mesh":
            mesh = self.meshes.get(a.get("mesh", ""))
            if mesh is None:
                raise ConfigError(f"geom {name!r}: mesh={a.get('mesh')!r}: no <mesh> of that name with a file")
            ext = os.path.splitext(mesh["file"])[1].lower()
            if ext not in (".stl", ".obj"):
                raise ConfigError(f"mesh {a.get('mesh')!r}: {mesh['file']}: the view reads .stl and .obj meshes")
            geom.update(url=mesh["file"].replace(os.sep, "/"), format=ext[1:], scale=_r(mesh["scale"]))
        return geom


def _matrix_quat(x: Sequence[float], y: Sequence[float]) -> Vec:
    """The quaternion of the frame whose x axis is ``x`` and whose y axis is ``y`` (made orthogonal)."""

    def unit(v: Sequence[float]) -> list[float]:
        n = math.sqrt(sum(c * c for c in v)) or 1.0
        return [c / n for c in v]

    xu = unit(x)
    dot = sum(a * b for a, b in zip(xu, y, strict=True))
    yu = unit([b - dot * a for a, b in zip(xu, y, strict=True)])
    zu = [xu[1] * yu[2] - xu[2] * yu[1], xu[2] * yu[0] - xu[0] * yu[2], xu[0] * yu[1] - xu[1] * yu[0]]
    m00, m10, m20, m01, m11, m21, m02, m12, m22 = *xu, *yu, *zu
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1) * 2
        return ((s / 4), (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s)
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1 + m00 - m11 - m22) * 2
        return ((m21 - m12) / s, s / 4, (m01 + m10) / s, (m02 + m20) / s)
    if m11 > m22:
        s = math.sqrt(1 + m11 - m00 - m22) * 2
        return ((m02 - m20) / s, (m01 + m10) / s, s / 4, (m12 + m21) / s)
    s = math.sqrt(1 + m22 - m00 - m11) * 2
    return ((m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, s / 4)


def mjcf_scene(path: str) -> dict[str, Any]:
    """The scene from a plain parse of MJCF ``path``: bodies, hinge and slide joints, primitives, STL/OBJ meshes."""
    return _Mjcf(path).scene()
