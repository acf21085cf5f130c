"""``import drempower`` stays light: heavy modules load when first used, and every public name still resolves."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = (
    "asyncio",
    "can",
    "serial",
    "json",
    "drempower.client.api.bus_async",
    "drempower.client.api.bus_async",
    "drempower.client.engine.backup",
    "drempower.robot",
    "drempower.sim",
    "drempower.records",
    "drempower.cli",
)


def _run(code: str) -> object:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    return json.loads(out.stdout)


def test_import_drempower_loads_no_heavy_module() -> None:
    loaded = _run(
        "import sys\n"
        "import drempower\n"
        f"heavy = [m for m in {HEAVY!r} if m in sys.modules]\n"
        "import json\n"  # the probe's own output, after the check
        "print(json.dumps(heavy))\n"
    )
    assert loaded == []


def test_lazy_names_resolve_to_their_modules() -> None:
    got = _run(
        "import json, drempower, drempower.client as c\n"
        "from drempower import *\n"
        "from drempower.client import *\n"
        "print(json.dumps([drempower.AsyncBus.__module__, drempower.AsyncMotor.__module__,\n"
        "    drempower.open_bus_async.__module__, c.ConfigBackup.__module__, c.ParamRecord.__module__,\n"
        "    c.RestoreReport.__module__, AsyncBus is drempower.AsyncBus]))\n"
    )
    assert got == [
        "drempower.client.api.bus_async",  # the one source of both front ends
        "drempower.client.api.bus_async",
        "drempower.client.api.bus_async",
        "drempower.client.engine.backup",
        "drempower.client.engine.backup",
        "drempower.client.engine.backup",
        True,
    ]


def test_unknown_names_still_raise_attribute_error() -> None:
    import drempower
    import drempower.client

    for module in (drempower, drempower.client):
        try:
            module.NoSuchThing  # type: ignore[attr-defined]  # noqa: B018
        except AttributeError as exc:
            assert "NoSuchThing" in str(exc)
        else:  # pragma: no cover
            raise AssertionError(f"{module.__name__}.NoSuchThing resolved")
