"""``drempower params``."""

from __future__ import annotations

import json

import pytest

from drempower.cli import main


def test_params_filters(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["params", "output_shaft", "vel"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:2] == ["address", "name"]
    names = [ln.split()[1] for ln in lines[1:]]
    assert "axis0.output_shaft.vel_limit" in names
    assert all("output_shaft" in n for n in names)


def test_params_json_and_flags(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["params", "--json", "--writable", "--user", "--series", "M"]) == 0
    recs = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert recs and all(r["access"] == "rw" and r["user_settable"] and r["series"] in ("", "M") for r in recs)
    assert not any(r["series"] == "G" for r in recs)
    reply = [r for r in recs if r["name"].endswith("enable_reply_state")]
    assert reply == [
        {
            "name": "axis0.config.extra_setting.enable_reply_state",
            "address": 31214,
            "type": "u32",
            "bool": True,
            "access": "rw",
            "user_settable": True,
            "unit": "",
            "series": "",
            "description": reply[0]["description"],
            "domain": "one of 0, 1 (hard)",
        }
    ]
    gains = [r for r in recs if r["name"] == "axis0.controller.config.pos_gain"]
    assert gains[0]["domain"] == "0..1000 (soft, inferred)"


def test_params_no_match(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["params", "no-such-parameter-word"]) == 1
    assert "no parameter matches" in capsys.readouterr().err
