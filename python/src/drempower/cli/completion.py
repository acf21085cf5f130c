"""``drempower completion bash``: a bash completion script (subcommands, options, parameter names)."""

from __future__ import annotations

import argparse
from typing import Any

from ..protocol import parameters
from ._output import json_line

GROUP = "logs and tools"
"""Where ``drempower --help`` lists this module's subcommands."""

_FILE_OPTIONS = ("--serial", "--uart", "--csv")

_SCRIPT = """\
# bash completion for drempower. Load it with:
#   source <(drempower completion bash)
# or save it as ~/.local/share/bash-completion/completions/drempower
_drempower() {{
    local cur=${{COMP_WORDS[COMP_CWORD]}} prev=${{COMP_WORDS[COMP_CWORD-1]}}
    local cmd="" npos=0 i w
    for ((i = 1; i < COMP_CWORD; i++)); do
        w=${{COMP_WORDS[i]}}
        if [[ -z $cmd ]]; then
            [[ $w != -* ]] && cmd=$w
        elif [[ " {valued} " == *" $w "* ]]; then
            ((i++))
        elif [[ $w != -* ]]; then
            ((npos++))
        fi
    done
    COMPREPLY=()
    case $prev in
        -i|--interface) COMPREPLY=($(compgen -W "{interfaces}" -- "$cur")); return;;
        {files}) COMPREPLY=($(compgen -f -- "$cur")); return;;
    esac
    if [[ -z $cmd ]]; then
        COMPREPLY=($(compgen -W "{commands} --help --version" -- "$cur"))
    elif [[ $cur == -* ]]; then
        case $cmd in
{options}
        esac
    elif [[ ($cmd == get && $npos -ge 1) || ($cmd == set && $npos -ge 1 && $((npos % 2)) -eq 1) ]]; then
        COMPREPLY=($(compgen -W "{names}" -- "$cur"))
    fi
}}
complete -o default -F _drempower drempower
"""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "completion",
        help="print a shell completion script (bash)",
        description="Print a bash completion script: `source <(drempower completion bash)`.",
    )
    p.add_argument("shell", choices=("bash",), help="the shell (bash; zsh can use it through bashcompinit)")
    p.add_argument("--json", action="store_true", help='print {"shell": ..., "script": ...} instead of the script')
    p.set_defaults(func=run)


def _visible(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if a.help != argparse.SUPPRESS]


def bash_script(parser: argparse.ArgumentParser) -> str:
    """The completion script for ``parser`` (the ``drempower`` parser)."""
    from can.interfaces import VALID_INTERFACES

    (subparsers,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    commands: dict[str, argparse.ArgumentParser] = subparsers.choices
    valued: set[str] = set()
    cases = []
    for name, cmd in commands.items():
        flags = [s for a in _visible(cmd) for s in a.option_strings]
        valued.update(s for a in _visible(cmd) if a.option_strings and a.nargs != 0 for s in a.option_strings)
        cases.append(f'            {name}) COMPREPLY=($(compgen -W "{" ".join(flags)}" -- "$cur"));;')
    return _SCRIPT.format(
        valued=" ".join(sorted(valued)),
        interfaces=" ".join(sorted(VALID_INTERFACES)),
        files="|".join(_FILE_OPTIONS),
        commands=" ".join(commands),
        options="\n".join(cases),
        names=" ".join(p.name for p in parameters()),
    )


def run(args: argparse.Namespace) -> int:
    from . import build_parser

    script = bash_script(build_parser())
    if args.json:
        print(json_line({"shell": args.shell, "script": script}))
    else:
        print(script, end="")
    return 0
