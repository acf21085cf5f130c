"""``drempower udev``: rules for both adapter generations, valid udev syntax, and --install."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from drempower.cli.udev import CDC, CH340, RULES_PATH, rules

from .conftest import Cli

_ITEM = re.compile(r'^(?P<key>[A-Z_]+)(\{(?P<attr>[A-Za-z_]+)\})?(?P<op>==|!=|\+=|:=|=)"(?P<value>[^"]*)"$')
_MATCH_KEYS = {"SUBSYSTEM", "ATTRS", "ENV", "KERNEL", "ACTION"}
_ASSIGN_KEYS = {"MODE", "GROUP", "TAG", "SYMLINK", "ENV"}


def _parse(text: str) -> list[list[tuple[str, str | None, str, str]]]:
    """The rules of ``text`` (continuation lines joined): (key, attribute, operator, value) per item."""
    joined = text.replace("\\\n", "")
    out = []
    for line in joined.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        items = []
        for part in line.split(", "):
            m = _ITEM.match(part.strip())
            assert m, f"not a udev key: {part!r}"
            key, op = m["key"], m["op"]
            assert key in (_MATCH_KEYS if op in ("==", "!=") else _ASSIGN_KEYS), part
            items.append((key, m["attr"], op, m["value"]))
        out.append(items)
    return out


def test_rules_cover_both_generations_with_a_stable_name_and_user_access(cli: Cli) -> None:
    r = cli("udev")
    assert r.code == 0 and r.out == rules()
    parsed = _parse(r.out)
    assert len(parsed) == 3
    for rule, (vid, pid) in zip(parsed[:2], (CH340, CDC), strict=True):
        assert ("SUBSYSTEM", None, "==", "tty") in rule
        assert ("ATTRS", "idVendor", "==", vid) in rule and ("ATTRS", "idProduct", "==", pid) in rule
        assert ("SYMLINK", None, "+=", "drempower-usbcan") in rule
        assert ("TAG", None, "+=", "uaccess") in rule and ("GROUP", None, "=", "dialout") in rule
        assert ("MODE", None, "=", "0660") in rule
    assert ("ENV", "ID_MM_DEVICE_IGNORE", "=", "1") in parsed[1]  # ModemManager leaves the CDC adapter alone
    assert ("SYMLINK", None, "+=", "drempower-usbcan-$env{ID_PATH_TAG}") in parsed[2]
    assert int(RULES_PATH.name.split("-")[0]) < 73  # before 73-seat-late.rules, or uaccess does nothing


def test_other_usb_ids_and_bad_ones(cli: Cli) -> None:
    r = cli("udev", "--cdc-id", "0x1D50", "606f")
    assert 'ATTRS{idVendor}=="1d50", ATTRS{idProduct}=="606f"' in r.out
    r = cli("udev", "--cdc-id", "xyz", "606f")
    assert r.code == 2 and "expected four hex digits such as 0483, got 'xyz'" in r.err


@pytest.mark.skipif(shutil.which("udevadm") is None, reason="udevadm is not installed")
def test_udevadm_accepts_the_rules(tmp_path: Path) -> None:
    path = tmp_path / RULES_PATH.name
    path.write_text(rules())
    probe = subprocess.run(["udevadm", "verify", "--help"], capture_output=True, text=True, timeout=30)
    if probe.returncode != 0:
        pytest.skip("this udevadm has no verify (systemd < 253)")
    done = subprocess.run(["udevadm", "verify", "--no-style", str(path)], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stdout + done.stderr


def test_install_writes_the_file(cli: Cli, tmp_path: Path) -> None:
    path = tmp_path / "rules.d" / RULES_PATH.name
    (rec,) = cli("udev", "--install", "--path", str(path), "--json").records()
    assert rec["installed"] is True and rec["reloaded"] is False  # not the system directory: nothing reloaded
    assert path.read_text() == rules()
    (tmp_path / "a-file").write_text("")
    r = cli("udev", "--install", "--path", str(tmp_path / "a-file" / "x.rules"))
    assert r.code == 1 and r.err.startswith(f"drempower: error: cannot write {tmp_path / 'a-file' / 'x.rules'}")
