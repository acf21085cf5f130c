"""Control characters that come from input never reach the terminal; ``decode`` fails on input with no frame."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from drempower.cli import main
from drempower.cli._output import clean, render_table

from .conftest import Cli

RAW = ("\x1b", "\x07", "\x9b", "\r", "\u202e")
"""ESC, BEL, CSI (C1), carriage return, right-to-left override."""


def _no_raw(text: str) -> bool:
    return not any(c in text for c in RAW)


def test_clean_escapes_every_control_character() -> None:
    assert clean("a\x1b]0;pwned\x07b") == "a\\x1b]0;pwned\\x07b"
    assert clean("x\ny\tz\r\x9b\x7f\u202e") == "x\\ny\\tz\\r\\x9b\\x7f\\u202e"
    assert clean("plain text, 30.00 deg, ünïcode") == "plain text, 30.00 deg, ünïcode"
    assert _no_raw("\n".join(render_table(["name"], [["\x1b[2Jwipe"]])))


def test_decode_escapes_what_the_log_holds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "evil.log"
    log.write_text("039#0000B4420000E803\n\x1b]0;owned\x07 not a frame \x1b[2J\r\u202e\n(1.0) ca\x1bn0 123#11\n")
    assert main(["decode", str(log)]) == 0
    out = capsys.readouterr().out
    assert _no_raw(out) and "\\x1b]0;owned\\x07 not a frame \\x1b[2J" in out
    monkeypatch.setattr("sys.stdin", io.StringIO(log.read_text()))
    assert main(["decode", "--json"]) == 0
    out = capsys.readouterr().out
    assert _no_raw(out) and [json.loads(line)["line"] for line in out.splitlines()][1].startswith("\x1b]0;owned")


def test_decode_exits_non_zero_when_no_line_is_a_frame(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "text.log"
    log.write_text("hello\nthis is not candump\n# a comment\n")
    assert main(["decode", str(log)]) == 1
    assert "no line of the input was a CAN frame" in capsys.readouterr().err
    monkeypatch.setattr("sys.stdin", io.StringIO(""))
    assert main(["decode"]) == 1
    log.write_text("hello\n039#0000B4420000E803\n")
    assert main(["decode", str(log)]) == 0


def test_errors_and_arguments_are_escaped(cli: Cli, tmp_path: Path) -> None:
    r = cli("decode", str(tmp_path / "no\x1b[31msuch\x07.log"))
    assert r.code == 2 and _no_raw(r.err) and "no\\x1b[31msuch\\x07.log" in r.err
    r = cli("state", "1", "--sim", "1", "--interface", "\x1b[2Jbogus\x07")
    assert r.code in (1, 2) and _no_raw(r.err), r.err
    r = cli("move", "1", "\x1b[2J")
    assert r.code == 2 and _no_raw(r.err) and "\\x1b[2J" in r.err
