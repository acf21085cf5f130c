"""The docs' python-can configuration section says what python-can reads on each OS."""

from __future__ import annotations

import platform
import re

import can.util

from .conftest import REPO_ROOT


def _rows() -> dict[str, list[str]]:
    text = (REPO_ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    section = text.split("### python-can configuration", 1)[1].split("\n#", 1)[0]
    rows = {}
    for line in section.splitlines():
        m = re.match(r"^\| (Linux, macOS|Windows) \| (.*) \|$", line)
        if m:
            rows[m[1]] = re.findall(r"`([^`]+)`", m[2])
    return rows


def test_config_files_of_this_os_match_python_can() -> None:
    rows = _rows()
    assert set(rows) == {"Linux, macOS", "Windows"}
    system = platform.system()
    if system == "Windows":
        expected = ["~/can.conf", "can.ini", "%APPDATA%\\can.ini"]
        assert rows["Windows"] == expected and len(can.util.CONFIG_FILES) == 3
    elif system in ("Linux", "Darwin"):
        assert rows["Linux, macOS"] == can.util.CONFIG_FILES
    assert "can.ini" not in rows["Linux, macOS"]


def test_environment_variables_match_python_can() -> None:
    text = (REPO_ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    section = text.split("### python-can configuration", 1)[1].split("\n#", 1)[0]
    source = can.util.load_environment_config.__doc__ or ""
    for name in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        assert name in section and name in source
