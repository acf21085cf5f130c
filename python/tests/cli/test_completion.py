"""Shell completion for bash, zsh and fish: subcommands, options, full and short parameter names,
and never python-can's udp_multicast. Each script is run by its shell when the shell is installed."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from drempower.cli import build_parser
from drempower.cli.completion import bash_script, completable_names, fish_script, interfaces, zsh_script

from .conftest import Cli

SHORT = "stall_current_limit"
"""A short name the docs recommend: the unique end of axis0.config.extra_setting.stall_current_limit."""


@pytest.mark.parametrize("shell", ["bash", "zsh", "fish"])
def test_scripts_offer_commands_options_and_names(cli: Cli, shell: str) -> None:
    r = cli("completion", shell)
    assert r.code == 0
    for word in ("monitor", "bus-load", "set-bitrate", "axis0.output_shaft.vel_limit", SHORT, "retries", "socketcan"):
        assert word in r.out, word
    assert "udp_multicast" not in r.out
    assert "sim-time-scale" not in r.out


def test_names_are_full_then_unique_ends() -> None:
    names = completable_names()
    assert "axis0.config.extra_setting.stall_current_limit" in names and SHORT in names
    assert "vel_limit" not in names  # the end of several names: get would refuse it
    assert len(names) == len(set(names))
    assert "udp_multicast" not in interfaces() and "socketcan" in interfaces() and "virtual" in interfaces()


def _run(argv: list[str], script: str, tmp_path: Path, name: str) -> str:
    path = tmp_path / name
    path.write_text(script)
    done = subprocess.run([*argv, str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout


BASH_DRIVER = """
source "$1"
complete_line() {{
    COMP_WORDS=($1); COMP_CWORD=$2; COMPREPLY=(); _drempower; printf '%s\\n' "${{COMPREPLY[@]}}"; echo ---
}}
{calls}
"""


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash is not installed")
def test_bash_completes(tmp_path: Path) -> None:
    calls = [
        "complete_line 'drempower mo' 1",
        "complete_line 'drempower get 1 stall_cur' 3",
        "complete_line 'drempower state 1 --ret' 3",
        "complete_line 'drempower state -i ' 3",
        "complete_line 'drempower set 1 stall_current_limit 2 vbus_v' 5",
    ]
    driver = tmp_path / "driver.sh"
    driver.write_text(BASH_DRIVER.format(calls="\n".join(calls)))
    out = _run(["bash", str(driver)], bash_script(build_parser()), tmp_path, "drempower.bash")
    blocks = [b.split() for b in out.split("---")[:-1]]
    assert blocks[0] == ["monitor", "move"]
    assert blocks[1] == [SHORT]
    assert blocks[2] == ["--retries"]
    assert "socketcan" in blocks[3] and "udp_multicast" not in blocks[3]
    assert blocks[4] == ["vbus_voltage"]


ZSH_DRIVER = """
compadd() {{ [[ $1 == -a ]] && print -l -- ${{(P)2}} || print -l -- "$@"; }}
_describe() {{ print -l -- ${{(P)4}}; }}
_files() {{ print FILES; }}
compdef() {{ }}
source "$1"
{calls}
"""


@pytest.mark.skipif(shutil.which("zsh") is None, reason="zsh is not installed")
def test_zsh_completes(tmp_path: Path) -> None:
    def call(words: str, prefix: str) -> str:
        n = len(words.split())
        return f"words=({words}); CURRENT={n}; PREFIX={prefix!r}; _drempower | grep -- '^{prefix}'; echo ---"

    calls = [
        call("drempower get 1 stall_cur", "stall_cur"),
        call("drempower state 1 --ret", "--ret"),
        call("drempower state -i sock", "sock"),
        call("drempower mon", "mon"),
        call("drempower she", "she"),
        call("drempower record --outp", "--outp"),
    ]
    driver = tmp_path / "driver.zsh"
    driver.write_text(ZSH_DRIVER.format(calls="\n".join(calls)))
    out = _run(["zsh", "-f", str(driver)], zsh_script(build_parser()), tmp_path, "_drempower")
    blocks = [b.split() for b in out.split("---")[:-1]]
    assert blocks[0] == [SHORT]
    assert blocks[1] == ["--retries"]
    assert blocks[2] == ["socketcan", "socketcand"]
    assert blocks[3][0].startswith("monitor:")
    assert blocks[4][0].startswith("shell:")
    assert blocks[5] == ["--output"]


@pytest.mark.skipif(shutil.which("fish") is None, reason="fish is not installed")
def test_fish_completes(tmp_path: Path) -> None:
    script = tmp_path / "drempower.fish"
    script.write_text(fish_script(build_parser()))

    def complete(line: str) -> list[str]:
        done = subprocess.run(
            ["fish", "--no-config", "-c", f"source {script}; complete -C {line!r}"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert done.returncode == 0, done.stderr
        return [row.split("\t")[0] for row in done.stdout.splitlines()]

    assert complete("drempower get 1 stall_cur") == [SHORT]
    assert complete("drempower set 1 stall_current_limit 2 vbus_v") == ["vbus_voltage"]
    assert complete("drempower set 1 stall_current_limit 2") == []  # a VALUE, not a name
    assert complete("drempower state 1 --ret") == ["--retries"]
    assert "socketcan" in complete("drempower state -i sock") and "udp_multicast" not in complete("drempower state -i ")
    assert complete("drempower mon") == ["monitor"]
    assert complete("drempower she") == ["shell"]
    assert complete("drempower record --outp") == ["--output"]  # -o stays python-can's option
