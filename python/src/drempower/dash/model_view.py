"""The dashboard's 3D view, server side: the robot's model for the page, and the hand from outside on a twin.

The model is the one the robot file names (``[model] file = "arm.xml"``), or one
given to the dashboard. Each joint of the robot file drives the model joint of
its ``model_joint`` (default: its own name); the page turns the motor's angle
into the joint's position as the robot layer does (``radians(angle) / gear +
offset``). The hand from outside (a force on a body, a torque on a joint, for a
time) needs the robot twin behind the bus: on real motors or the plain
simulator it is refused, and the page says so.
"""

from __future__ import annotations

import importlib
import math
import os
from typing import TYPE_CHECKING, Any, Protocol

from aiohttp import web

from ..errors import ConfigError, DrEmpowerError, ValidationError
from ..sim.twin import PUSH_LIMITS  # the twin's own bounds, one place
from .keys import KEYS_PER_BUS
from .logline import log
from .model_scene import load_scene

if TYPE_CHECKING:
    from .hub import Hub

__all__ = ["PUSH_LIMITS", "ModelView", "TwinHand", "add_routes"]

NO_TWIN = (
    "the hand from outside needs the robot twin (a robot file with a [model], simulated, with the physics "
    "extra: pip install 'drempower[physics]'); these motors have none"
)


class TwinHand(Protocol):
    """What the dashboard needs of a twin: a force/torque on a body and a torque on a joint, for a time."""

    def push(
        self,
        body: str,
        force: tuple[float, float, float] = ...,
        torque: tuple[float, float, float] = ...,
        duration: float = ...,
    ) -> None: ...

    def push_joint(self, joint: str, torque: float, duration: float = ...) -> None: ...

    def release(self) -> None: ...


def no_twin_reason(hub: Hub) -> str:
    """Why this dashboard cannot push (the truth of its case): no model, no physics extra, or a twin that
    runs in another process (a robot file whose buses are served, e.g. by ``drempower sim --robot``)."""
    robot = hub.robot
    spec = getattr(robot, "spec", None)
    if spec is None or getattr(spec, "model", None) is None:
        return NO_TWIN
    try:
        importlib.import_module("mujoco")
    except ImportError:
        return (
            f"the hand from outside needs the physics extra for the twin of {spec.source}: "
            "pip install 'drempower[physics]'"
        )
    served = [(name, b.interface) for name, b in spec.buses.items() if b.interface != "sim"]
    remote = served_twin_address(hub)
    if remote is not None:
        name, host, port = remote
        return (
            f"bus {name!r} of {spec.source} is served at {host}:{port} by a program that takes no pushes (a simulator "
            "without the model, an older one, or real motors behind socketcand): only a twin run by drempower sim "
            "--robot with a [model] can be pushed from here"
        )
    if served:
        name, kind = served[0]
        return (
            f"the hand pushes a twin this dashboard runs; bus {name!r} of {spec.source} is {kind}: its twin (if any, "
            "e.g. drempower sim --robot) runs in another process. To push, run the dashboard on the robot file "
            "with sim buses itself (drempower dash --robot FILE), or push in the program that runs the twin "
            "(robot.twin.push(...))"
        )
    return NO_TWIN


def served_twin_address(hub: Hub) -> tuple[str, str, int] | None:
    """The first socketcand bus of the hub's robot file (its name, host and port) when the file names a
    model: where ``drempower sim --robot`` takes the pushes of its twin (:mod:`drempower.sim.hand_link`)."""
    spec = getattr(hub.robot, "spec", None)
    if spec is None or getattr(spec, "model", None) is None:
        return None
    for name, b in spec.buses.items():
        port = b.options.get("port")
        if b.interface == "socketcand" and isinstance(port, int) and not isinstance(port, bool):
            return name, str(b.options.get("host", "127.0.0.1")), port
    return None


def remote_hand(hub: Hub) -> TwinHand | None:
    """The hand of a twin that another process runs (``drempower sim --robot``) and serves over socketcand,
    when it answers that it takes pushes; else None."""
    where = served_twin_address(hub)
    if where is None:
        return None
    from ..sim.hand_link import RemoteHand

    hand = RemoteHand(where[1], where[2])
    return hand if hand.ready() else None


def model_of(hub: Hub) -> str | None:
    """The model file the robot file of ``hub`` names (absolute), or None."""
    robot = hub.robot
    model = getattr(robot.spec, "model", None) if robot is not None else None
    file = getattr(model, "file", None)
    return file if isinstance(file, str) else None


def twin_of_hub(hub: Hub) -> TwinHand | None:
    """The twin behind the hub's buses (the simulator's), or None on real motors or the plain simulator."""
    try:
        twin_mod = importlib.import_module("drempower.sim.twin")
    except ImportError:
        return None
    find = getattr(twin_mod, "twin_of", None)
    if find is None:
        return None
    for _, bus in hub.buses:
        sim = getattr(bus.transport, "bus", None)
        if sim is not None:
            with_twin = find(sim)
            if with_twin is not None:
                return with_twin  # type: ignore[no-any-return]
    return None


def _vector(args: dict[str, Any], key: str, bound: float, unit: str) -> tuple[float, float, float]:
    value = args.get(key, [0.0, 0.0, 0.0])
    if not isinstance(value, list) or len(value) != 3:
        raise ValidationError(f"{key}={value!r}: expected three numbers x, y, z in {unit}")
    out = []
    for axis, v in zip("xyz", value, strict=True):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ValidationError(f"{key} {axis}={v!r}: expected a finite number of {unit}")
        if abs(v) > bound:
            raise ValidationError(f"{key} {axis}={v:g}: outside -{bound:g}..{bound:g} {unit}")
        out.append(float(v))
    return out[0], out[1], out[2]


def _number(args: dict[str, Any], key: str, lo: float, hi: float, unit: str, *, open_low: bool = False) -> float:
    v = args.get(key)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ValidationError(f"{key}={v!r}: expected a finite number of {unit}")
    if v > hi or v < lo or (open_low and v == lo):
        low = f"above {lo:g}" if open_low else f"{lo:g}"
        raise ValidationError(f"{key}={v:g}: outside {low}..{hi:g} {unit}")
    return float(v)


class ModelView:
    """The model of one dashboard: its scene (for ``/model``), the joints' mapping, and the hand.

    ``model``: a model file to draw (default: the robot file's ``[model]``);
    ``twin``: the twin to push (default: the one behind the hub's buses, if any).
    """

    def __init__(self, hub: Hub, model: str | None = None, twin: TwinHand | None = None) -> None:
        self.hub = hub
        self.file = os.path.abspath(model) if model else model_of(hub)
        self.scene: dict[str, Any] | None = None
        self.error: str | None = None
        self._twin = twin
        self._remote: TwinHand | None = None
        self._remote_asked = False
        if self.file is not None:
            try:
                self.scene = load_scene(self.file)
            except ConfigError as exc:
                self.error = str(exc)  # shown in the view

    @property
    def twin(self) -> TwinHand | None:
        """The twin to push: the one given, the one behind the hub's buses, or one another process runs and
        serves (asked once: ``< push ready >``)."""
        own = self._twin if self._twin is not None else twin_of_hub(self.hub)
        if own is not None:
            return own
        if not self._remote_asked:
            self._remote_asked = True
            self._remote = remote_hand(self.hub)
        return self._remote

    def mapping(self) -> list[dict[str, Any]]:
        """Each robot joint's motor key, model joint, gear and offset (rad)."""
        robot = self.hub.robot
        if robot is None:
            return []
        index = {name: k for k, (name, _) in enumerate(self.hub.buses)}
        return [
            {
                "key": index[j.bus] * KEYS_PER_BUS + j.id,
                "joint": j.name,
                "model_joint": getattr(j, "model_joint", None) or j.name,
                "gear": j.gear,
                "offset": j.offset,
            }
            for j in robot.spec.joints.values()
        ]

    def document(self) -> dict[str, Any]:
        """What ``/model`` sends: the scene (or None and why), the joints' mapping, whether a twin can be pushed."""
        if self.scene is None:
            why = self.error or (
                "no model: give the dashboard a robot file whose [model] names an MJCF or URDF file (--robot FILE)"
            )
        else:
            why = None
        twin = self.twin is not None and self.scene is not None
        return {
            "scene": self.scene,
            "error": why,
            "joints": self.mapping(),
            "twin": twin,
            "read_only": self.hub.read_only,
            "hand": None if twin else no_twin_reason(self.hub),
            "limits": PUSH_LIMITS,
        }

    def mesh_path(self, rel: str) -> str | None:
        """The file of a mesh the plain-MJCF scene names (relative to the model), or None for any other path."""
        if self.scene is None or self.file is None or rel not in self.scene.get("files", ()):
            return None
        return os.path.join(os.path.dirname(self.file), rel)

    def release(self) -> None:
        """End every push on the twin now (ESTOP does it: nothing from outside keeps moving a joint)."""
        twin = self.twin
        if twin is None:
            return
        try:
            twin.release()
        except DrEmpowerError as exc:  # a twin in another process that is gone: nothing left to push it
            log(f"ESTOP: the pushes on the twin could not be released: {exc}")

    def do_push(self, who: str, args: dict[str, Any]) -> str:
        """One push from a page: ``kind`` ``body`` (``force``, ``torque`` vectors) or ``joint`` (``torque`` Nm),
        on ``target`` for ``duration`` s. Checked whole before the twin is touched; returns what was done."""
        twin = self.twin
        if twin is None or self.scene is None:
            raise DrEmpowerError(no_twin_reason(self.hub))
        kind = args.get("kind")
        target = args.get("target")
        duration = _number(args, "duration", 0.0, PUSH_LIMITS["duration"], "s", open_low=True)
        if kind == "body":
            bodies = [b["name"] for b in self.scene["bodies"][1:]]
            if target not in bodies:
                raise ValidationError(f"target={target!r}: not a body of the model ({', '.join(bodies)})")
            force = _vector(args, "force", PUSH_LIMITS["force"], "N")
            torque = _vector(args, "torque", PUSH_LIMITS["torque"], "Nm")
            what = f"push body {target}: force {force} N, torque {torque} Nm for {duration:g} s"
            self.hub._control(who, what)  # refused when read-only; logged like every control action
            twin.push(str(target), force=force, torque=torque, duration=duration)
        elif kind == "joint":
            joints = [j["joint"] for j in self.mapping()]
            if target not in joints:
                raise ValidationError(f"target={target!r}: not a joint of the robot ({', '.join(joints)})")
            limit = PUSH_LIMITS["torque"]
            tq = _number(args, "torque", -limit, limit, "Nm")
            what = f"push joint {target}: torque {tq:g} Nm for {duration:g} s"
            self.hub._control(who, what)
            twin.push_joint(str(target), tq, duration=duration)
        else:
            raise ValidationError(f"kind={kind!r}: expected 'body' or 'joint'")
        return what


def add_routes(app: web.Application, view: ModelView) -> None:
    """``GET /model``: :meth:`ModelView.document` as JSON; ``GET /model/file/PATH``: a mesh the scene names."""

    async def model(request: web.Request) -> web.StreamResponse:
        return web.json_response(view.document(), headers={"Cache-Control": "no-store"})

    async def mesh(request: web.Request) -> web.StreamResponse:
        path = view.mesh_path(request.match_info["path"])
        if path is None or not os.path.isfile(path):
            raise web.HTTPNotFound()
        return web.FileResponse(path)

    app.router.add_get("/model", model)
    app.router.add_get("/model/file/{path:.+}", mesh)
