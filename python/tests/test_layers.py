"""The package is layered: no module imports a module of a higher layer (docs/design.md, "Layers").

Every import counts: at module level, under ``if TYPE_CHECKING:`` (a type in a signature is part of a
layer's interface) and inside a function (a lazy import is still a dependency at run time). The few
upward imports the design wants are listed in :data:`ALLOWED`, each with the kinds it may take and why;
an entry that no longer matches an import fails too, so the list cannot rot.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

import drempower

LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("protocol", ("protocol", "errors", "_lazy")),  # the wire format, the error tree every layer raises; lazy names
    ("files", ("robotfile", "naming", "logline", "records")),  # robot files, names, log lines, frame logs
    ("sim", ("sim",)),  # the simulated motors the sim transport opens
    ("transports", ("transports",)),
    ("client", ("client", "actions")),  # the buses and motors; the table of actions the front ends share
    ("motion", ("motion",)),  # trajectories, following, identification, tuning
    ("robot", ("robot",)),
    ("apps", ("cli", "dash", "bridge", "ros2", "compat", "__main__", "")),  # "": the package's own __init__
)
"""Layers from the lowest, each with the top-level modules and packages of ``drempower`` in it. A module
may import its own layer and the layers below."""

MODULE, TYPE, LAZY = "at module level", "under TYPE_CHECKING", "inside a function"

ALLOWED: dict[tuple[str, str], tuple[frozenset[str], str]] = {}
"""(importer, imported) -> the kinds of import allowed upward, and why."""


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str
    line: int
    kind: str


def layer_of(module: str) -> int:
    """The index in :data:`LAYERS` of a ``drempower`` module; KeyError for one the table does not place."""
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else ""
    for k, (_, members) in enumerate(LAYERS):
        if top in members:
            return k
    raise KeyError(module)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def imports_of(module: str, source: str, is_package: bool, known: set[str]) -> Iterator[Import]:
    """Every import of a ``drempower`` module in ``source`` (the module ``module``), with its kind.

    ``from X import name`` names the module ``X.name`` when that is a module of ``known``, else ``X``.
    """
    package = module if is_package else module.rpartition(".")[0]

    def target(base: str, names: list[ast.alias]) -> Iterator[str]:
        for alias in names:
            sub = f"{base}.{alias.name}"
            yield sub if sub in known else base

    def walk(node: ast.AST, kind: str) -> Iterator[Import]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child.test) and kind == MODULE:
                yield from (i for stmt in child.body for i in walk_one(stmt, TYPE))
                yield from (i for stmt in child.orelse for i in walk_one(stmt, MODULE))
            else:
                yield from walk_one(child, kind)

    def walk_one(node: ast.AST, kind: str) -> Iterator[Import]:
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "drempower" or alias.name.startswith("drempower."):
                    yield Import(module, alias.name, node.lineno, kind)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                up = package.split(".")
                base = ".".join(up[: len(up) - (node.level - 1)])
                if node.module:
                    base = f"{base}.{node.module}"
            else:
                base = node.module or ""
            if base == "drempower" or base.startswith("drempower."):
                for name in target(base, node.names):
                    yield Import(module, name, node.lineno, kind)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            yield from walk(node, LAZY)
        else:
            yield from walk(node, kind)

    yield from walk(ast.parse(source), MODULE)


def violations(sources: Mapping[str, tuple[str, bool]]) -> tuple[list[str], set[tuple[str, str]]]:
    """The upward imports among ``sources`` (module -> (source, is_package)) that :data:`ALLOWED` does not
    allow, as messages; and the allowed pairs that were used."""
    known = set(sources)
    found: list[str] = []
    used: set[tuple[str, str]] = set()
    for module, (source, is_package) in sorted(sources.items()):
        for imp in dict.fromkeys(imports_of(module, source, is_package, known)):  # one per line and kind
            low, high = layer_of(imp.importer), layer_of(imp.imported)
            if high <= low:
                continue
            allowed = ALLOWED.get((imp.importer, imp.imported))
            if allowed is not None and imp.kind in allowed[0]:
                used.add((imp.importer, imp.imported))
                continue
            found.append(
                f"{imp.importer} (layer {LAYERS[low][0]}) imports {imp.imported} (layer {LAYERS[high][0]}) "
                f"{imp.kind}, line {imp.line}"
            )
    return found, used


def package_sources() -> dict[str, tuple[str, bool]]:
    root = Path(drempower.__file__).parent
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = ["drempower", *path.relative_to(root).with_suffix("").parts]
        is_package = parts[-1] == "__init__"
        if is_package:
            parts.pop()
        out[".".join(parts)] = (path.read_text(encoding="utf-8"), is_package)
    return out


def test_every_module_has_a_layer() -> None:
    sources = package_sources()
    assert len(sources) > 100
    unplaced = []
    for module in sources:
        try:
            layer_of(module)
        except KeyError:
            unplaced.append(module)
    assert not unplaced, f"modules no layer of LAYERS holds (add their package to the table): {unplaced}"


def test_no_module_imports_a_higher_layer() -> None:
    found, used = violations(package_sources())
    assert not found, "lower layers import higher ones:\n" + "\n".join(found)
    assert used == set(ALLOWED), f"ALLOWED entries no import needs any more: {sorted(set(ALLOWED) - used)}"


def _fake(modules: Mapping[str, str], packages: tuple[str, ...] = ()) -> dict[str, tuple[str, bool]]:
    """Synthetic sources: module -> source, the ``packages`` among them being ``__init__`` modules."""
    return {name: (source, name in packages) for name, source in modules.items()}


def test_an_upward_import_is_reported_naming_both_modules_and_layers() -> None:
    found, _ = violations(
        _fake({"drempower.transports.fake": "from ..robot.config import RobotSpec\n", "drempower.robot.config": ""})
    )
    assert found == [
        "drempower.transports.fake (layer transports) imports drempower.robot.config (layer robot) "
        "at module level, line 1"
    ]


def test_every_form_of_import_counts() -> None:
    sources = _fake(
        {
            "drempower.sim.a": "from .. import bridge\n",  # a package, through `from .. import`
            "drempower.sim.b": "import drempower.client.api.bus_sync as bus\n",
            "drempower.sim.c": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..motion import plan\n",
            "drempower.sim.d": "def f():\n    from drempower.robot import Robot\n    return Robot\n",
            "drempower.sim.e": "class C:\n    async def m(self):\n        from ..dash import hub\n",
            "drempower.sim.deep": "from ...transports import base\n",  # a package: `..` is drempower.sim
            "drempower.sim.deep.f": "from . import g\nfrom ... import compat\n",
            "drempower.sim.deep.g": "",
            "drempower.bridge": "",
            "drempower.client.api.bus_sync": "",
            "drempower.motion.plan": "",
            "drempower.dash.hub": "",
            "drempower.transports.base": "",
            "drempower.compat": "",
        },
        packages=("drempower.sim.deep", "drempower.bridge"),
    )
    found, _ = violations(sources)
    assert [m.split(" ")[0] for m in found] == [
        f"drempower.sim.{m}" for m in ("a", "b", "c", "d", "deep", "deep.f", "e")
    ]
    assert "imports drempower.bridge (layer apps) at module level, line 1" in found[0]
    assert "drempower.client.api.bus_sync (layer client)" in found[1]
    assert "drempower.motion.plan (layer motion) under TYPE_CHECKING, line 3" in found[2]
    assert "drempower.robot (layer robot) inside a function, line 2" in found[3]
    assert "drempower.transports.base (layer transports)" in found[4]
    assert "drempower.compat (layer apps)" in found[5]
    assert "drempower.dash.hub (layer apps) inside a function, line 3" in found[6]


def test_an_allowed_pair_counts_only_in_its_kind(monkeypatch: pytest.MonkeyPatch) -> None:
    importer, imported = "drempower.motion.follow_async", "drempower.robot"
    monkeypatch.setitem(ALLOWED, (importer, imported), (frozenset({TYPE}), "an example"))
    typed = "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..robot import AsyncRobot\n"
    assert violations(_fake({importer: typed, imported: ""})) == ([], {(importer, imported)})
    eager = "from ..robot import AsyncRobot\n"
    found, used = violations(_fake({importer: eager, imported: ""}))
    assert len(found) == 1 and "at module level" in found[0] and used == set()


def test_same_and_lower_layers_are_fine() -> None:
    sources = _fake(
        {
            "drempower.client.x": "from . import y\nfrom ..transports import base\nfrom ..errors import Error\n",
            "drempower.client.y": "from ..protocol.ids import Frame\n",
            "drempower.transports.base": "",
            "drempower.errors": "",
            "drempower.protocol.ids": "",
            "drempower.actions": "from .client import x\n",
            "drempower.robot": "from ..motion import plan\n",
            "drempower.motion.plan": "",
        },
        packages=("drempower.robot",),
    )
    assert violations(sources) == ([], set())


def test_a_module_outside_the_table_has_no_layer() -> None:
    with pytest.raises(KeyError):
        layer_of("drempower.newthing")
    assert layer_of("drempower") == layer_of("drempower.cli.monitor") == len(LAYERS) - 1
    assert layer_of("drempower.errors") == layer_of("drempower.protocol.ids") == 0


CLIENT_ROOMS = ("engine", "driver", "api")
"""The client's rooms from the lowest: the sans-I/O engine, the driver that runs it over a transport, the
front end (docs/design.md, "Layers"). A room may import its own and those below, never one above."""


def client_room_violations(sources: Mapping[str, tuple[str, bool]]) -> list[str]:
    """Imports among the client's rooms that run back up (every kind of import counts)."""

    def room(module: str) -> int | None:
        parts = module.split(".")
        if parts[:2] != ["drempower", "client"] or len(parts) < 3 or parts[2] not in CLIENT_ROOMS:
            return None
        return CLIENT_ROOMS.index(parts[2])

    found = []
    known = set(sources)
    for module, (source, is_package) in sorted(sources.items()):
        low = room(module)
        if low is None:
            continue
        for imp in dict.fromkeys(imports_of(module, source, is_package, known)):
            high = room(imp.imported)
            if high is not None and high > low:
                found.append(
                    f"{imp.importer} (room {CLIENT_ROOMS[low]}) imports {imp.imported} "
                    f"(room {CLIENT_ROOMS[high]}) {imp.kind}, line {imp.line}"
                )
    return found


def test_the_client_rooms_import_only_downward() -> None:
    sources = package_sources()
    assert all(any(m.startswith(f"drempower.client.{r}.") for m in sources) for r in CLIENT_ROOMS)
    found = client_room_violations(sources)
    assert not found, "client rooms import higher ones:\n" + "\n".join(found)


def test_a_client_room_importing_a_higher_one_is_reported() -> None:
    found = client_room_violations(
        _fake(
            {
                "drempower.client.engine.a": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                "    from ..driver.bus_driver import BusDriver\n",
                "drempower.client.driver.bus_driver": "from ..engine import a\n",
                "drempower.client.driver.b": "def f():\n    from ..api import bus_sync\n",
                "drempower.client.api.bus_sync": "from ..driver import bus_driver\n",
            }
        )
    )
    assert found == [
        "drempower.client.driver.b (room driver) imports drempower.client.api.bus_sync (room api) "
        "inside a function, line 2",
        "drempower.client.engine.a (room engine) imports drempower.client.driver.bus_driver (room driver) "
        "under TYPE_CHECKING, line 3",
    ]


def room_of(module: str) -> str:
    """The room of a ``drempower`` module: its top-level package or module, or its room of the client."""
    parts = module.split(".")
    if len(parts) >= 3 and parts[1] == "client" and parts[2] in CLIENT_ROOMS:
        return ".".join(parts[:3])
    return ".".join(parts[:2])


def circles(sources: Mapping[str, tuple[str, bool]]) -> list[list[str]]:
    """The circles among rooms (strongly connected groups of two or more), every kind of import counted."""
    known = set(sources)
    edges: dict[str, set[str]] = {}
    for module, (source, is_package) in sources.items():
        for imp in imports_of(module, source, is_package, known):
            a, b = room_of(imp.importer), room_of(imp.imported)
            if a != b:
                edges.setdefault(a, set()).add(b)
    order: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        order[v] = low[v] = len(order)
        stack.append(v)
        for w in sorted(edges.get(v, ())):
            if w not in order:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], order[w])
        if low[v] == order[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(edges):
        if v not in order:
            visit(v)
    return sorted(found)


def test_the_house_has_at_most_two_circles() -> None:
    found = circles(package_sources())
    assert len(found) <= 2, "circles among the rooms:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_a_circle_is_found_whatever_its_length() -> None:
    sources = _fake(
        {
            "drempower.sim.a": "from ..transports import b\n",
            "drempower.transports.b": "from ..client.engine import c\n",
            "drempower.client.engine.c": "def f():\n    from ...sim import a\n",
            "drempower.protocol.x": "from ..errors import E\n",
            "drempower.errors": "",
        }
    )
    assert circles(sources) == [["drempower.client.engine", "drempower.sim", "drempower.transports"]]


def cli_helper_violations(sources: Mapping[str, tuple[str, bool]]) -> list[str]:
    """Imports of a command module (``drempower.cli.move``) by a helper of the command line (``cli._robot``)."""

    def command(module: str) -> bool:
        parts = module.split(".")
        return len(parts) == 3 and parts[:2] == ["drempower", "cli"] and not parts[2].startswith("_")

    found = []
    known = set(sources)
    for module, (source, is_package) in sorted(sources.items()):
        parts = module.split(".")
        if len(parts) != 3 or parts[:2] != ["drempower", "cli"] or not parts[2].startswith("_"):
            continue
        for imp in dict.fromkeys(imports_of(module, source, is_package, known)):
            if command(imp.imported):
                found.append(f"{imp.importer} imports the command {imp.imported} {imp.kind}, line {imp.line}")
    return found


def test_the_command_lines_helpers_import_no_command() -> None:
    found = cli_helper_violations(package_sources())
    assert not found, "helpers of the command line import commands:\n" + "\n".join(found)


def test_a_helper_importing_a_command_is_reported() -> None:
    found = cli_helper_violations(
        _fake({"drempower.cli._robot": "def f():\n    from .move import _params\n", "drempower.cli.move": ""})
    )
    assert found == ["drempower.cli._robot imports the command drempower.cli.move inside a function, line 2"]
