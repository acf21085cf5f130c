"""Writing a joint's identification where the twin uses it, so the twin becomes the robot's.

Two places: the robot file's ``[joints.NAME.identified]`` table (``inertia``, ``viscous``, ``coulomb``;
the twin then sets the joint's damping and friction loss to them, and its armature to the inertia less
what the model's links give), written by a small textual edit that keeps the file's comments and order;
or a copy of the model (MJCF) with the joint's ``armature``, ``damping`` and ``frictionloss`` attributes
(a robot file using it sets ``friction = "model"``). The gravity term is not written: the model's masses
give it.
"""

from __future__ import annotations

import os
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import ConfigError
from ..robotfile import IDENTIFIED_KEYS
from .identify import Identification

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib  # type: ignore[import-not-found, no-redef, unused-ignore]

if TYPE_CHECKING:
    from ..robotfile import RobotSpec
    from ..sim.twin import Twin

__all__ = ["identified_table", "model_copy_path", "write_identified", "write_model", "write_robot_file"]

_HEADER = re.compile(r"^\s*\[\s*([^\[\]]+?)\s*\]\s*(#.*)?$")


def identified_table(got: Identification) -> dict[str, float]:
    """The ``identified`` table's values (each at least 0: a fit's small negative friction is 0)."""
    return {"inertia": max(0.0, got.inertia), "viscous": max(0.0, got.viscous), "coulomb": max(0.0, got.coulomb)}


def _key_parts(header: str) -> list[str]:
    """A table header's dotted key as its parts (bare or quoted)."""
    try:
        doc = tomllib.loads(f"[{header}]\n")
    except tomllib.TOMLDecodeError:
        return []
    parts: list[str] = []
    node: object = doc
    while isinstance(node, dict) and len(node) == 1:
        key = next(iter(node))
        parts.append(key)
        node = node[key]
    return parts


def write_robot_file(path: str | os.PathLike[str], joint: str, got: Identification) -> None:
    """Set ``[joints.<joint>.identified]`` of the robot file ``path`` to ``got``'s inertia, viscous and
    Coulomb friction: the table's lines are replaced if it is there, else it is added after the joint's
    last table; every other line stays as it is. Refused (:class:`ConfigError`, the file untouched) when
    the result would not read back with these values."""
    p = Path(path)
    lines = p.read_text(encoding="utf-8").splitlines(keepends=True)
    values = identified_table(got)
    body = [f"{k} = {values[k]:.6g}\n" for k in IDENTIFIED_KEYS]
    tables: list[tuple[int, list[str]]] = []  # (line index, key parts) of every table header
    for i, line in enumerate(lines):
        m = _HEADER.match(line)
        if m and not line.lstrip().startswith("[["):
            tables.append((i, _key_parts(m.group(1))))
    ends = [i for i, _ in tables[1:]] + [len(lines)]
    own = ["joints", joint]
    out: list[str] | None = None
    for (start, parts), end in zip(tables, ends, strict=True):
        if parts == [*own, "identified"]:
            out = [*lines[: start + 1], *body, *_blank_tail(lines[start + 1 : end]), *lines[end:]]
            break
    if out is None:
        last = [(start, end) for (start, parts), end in zip(tables, ends, strict=True) if parts[:2] == own]
        header = f"[joints.{_toml_key(joint)}.identified]\n"
        if last:
            end = last[-1][1]
            while end > last[-1][0] + 1 and not lines[end - 1].strip():
                end -= 1
            tail = lines[end:]
            before = lines[:end]
            if before and not before[-1].endswith("\n"):
                before[-1] += "\n"
            out = [*before, "\n", header, *body, *(["\n"] if tail else []), *tail]
        else:  # the joint is an inline table or a dotted key: the new table goes at the end
            if lines and not lines[-1].endswith("\n"):
                lines[-1] += "\n"
            out = [*lines, "\n", header, *body]
    text = "".join(out)
    try:
        back = tomllib.loads(text)["joints"][joint]["identified"]
    except (tomllib.TOMLDecodeError, KeyError, TypeError) as exc:
        raise ConfigError(f"{p}: cannot add [joints.{joint}.identified] to this file ({exc}); add it by hand") from None
    if any(abs(back[k] - float(f"{values[k]:.6g}")) > 0 for k in IDENTIFIED_KEYS):
        raise ConfigError(f"{p}: [joints.{joint}.identified] does not read back as written; add it by hand")
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, p)


def _blank_tail(lines: list[str]) -> list[str]:
    """The blank and comment lines at the end of a table's body (kept before the next table)."""
    k = len(lines)
    while k > 0 and (not lines[k - 1].strip() or lines[k - 1].lstrip().startswith("#")):
        k -= 1
    return lines[k:]


def _toml_key(name: str) -> str:
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


def model_copy_path(model_file: str | os.PathLike[str]) -> Path:
    """Where :func:`write_model` puts its copy by default: beside the model, ``NAME.identified.xml``."""
    p = Path(model_file)
    return p.with_name(p.stem + ".identified" + p.suffix)


def write_model(
    model_file: str | os.PathLike[str],
    model_joint: str,
    got: Identification,
    out: str | os.PathLike[str],
    links_inertia: float = 0.0,
) -> Path:
    """Write to ``out`` a copy of the MJCF model ``model_file`` whose joint ``model_joint`` has ``got``'s
    viscous friction as ``damping``, Coulomb friction as ``frictionloss`` and its inertia less
    ``links_inertia`` (kg m^2, the model's own at the joint) as ``armature``. ``out`` may be the model
    itself (in place). Returns ``out``."""
    try:
        tree = ET.parse(model_file)
    except (OSError, ET.ParseError) as exc:
        raise ConfigError(f"model {model_file}: {exc}") from None
    found = [j for j in tree.getroot().iter("joint") if j.get("name") == model_joint]
    if not found:
        raise ConfigError(f"model {model_file}: no <joint name={model_joint!r}> (an MJCF model is needed)")
    values = identified_table(got)
    j = found[0]
    j.set("armature", f"{max(0.0, values['inertia'] - links_inertia):.6g}")
    j.set("damping", f"{values['viscous']:.6g}")
    j.set("frictionloss", f"{values['coulomb']:.6g}")
    target = Path(out)
    tree.write(target, encoding="unicode", xml_declaration=False)
    return target


def links_inertia(twin: Twin, model_joint: str) -> float:
    """The model's own inertia (kg m^2) at joint ``model_joint`` in its reference pose, armature excluded."""
    import mujoco

    with twin.lock:
        m = twin.model
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, model_joint)
        if jid < 0:
            raise ConfigError(f"model {twin.source}: no joint {model_joint!r}")
        dof = int(m.jnt_dofadr[jid])
        return float(m.dof_M0[dof] - m.dof_armature[dof])


def write_identified(
    spec: RobotSpec, got: Identification, where: str | os.PathLike[str] | bool, *, twin: Twin | None = None
) -> Path:
    """Write ``got`` where ``where`` says: True or the robot file's path: the robot file's joint entry;
    a path ending in ``.xml``: a copy of the model there (``twin`` gives the links' own inertia; without
    it the whole inertia is the armature); returns the file written."""
    if where is True or (not isinstance(where, bool) and os.fspath(where) == spec.source):
        if not os.path.isfile(spec.source):
            raise ConfigError(f"identify: the robot {spec.source!r} is not a file: nothing to write into")
        write_robot_file(spec.source, got.joint, got)
        return Path(spec.source)
    if isinstance(where, bool) or not os.fspath(where).endswith(".xml"):
        raise ConfigError(f"identify: write={where!r}: expected True (the robot file) or a model copy's path (.xml)")
    if spec.model is None:
        raise ConfigError(f"{spec.source}: no [model]: nothing to copy the identification into")
    model_joint = spec.joints[got.joint].model_joint or got.joint
    inertia = 0.0 if twin is None else links_inertia(twin, model_joint)
    return write_model(spec.model.file, model_joint, got, where, inertia)
