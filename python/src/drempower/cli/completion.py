"""``drempower completion bash|zsh|fish``: shell completion (subcommands, options, parameter names).

Parameter names complete in full (``axis0.controller.config.vel_limit``) and by
the unique end that ``get``/``set`` accept (``stall_current_limit``). The
interfaces offered for ``-i`` are python-can's, except ``udp_multicast``, which
sends to the whole network.
"""

from __future__ import annotations

import argparse
from collections import Counter
from dataclasses import dataclass
from typing import Any

from ..protocol import parameters
from ._output import json_line

GROUP = "logs and tools"
"""Where ``drempower --help`` lists this module's subcommands."""

SHELLS = ("bash", "zsh", "fish")
_FILE_OPTIONS = ("--serial", "--uart", "--csv", "-w", "--output")
_NOT_OFFERED = frozenset({"udp_multicast"})
"""python-can interfaces not offered for ``-i``: udp_multicast reaches every host of the network."""

_BASH = """\
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

_ZSH = """\
#compdef drempower
# zsh completion for drempower. Load it with (after compinit):
#   source <(drempower completion zsh)
# or save it as _drempower in a directory of $fpath
_drempower() {{
    local -a commands names interfaces valued opts
    commands=(
{described}
    )
    names=({names})
    interfaces=({interfaces})
    valued=({valued})
    if (( CURRENT == 2 )); then
        _describe -t commands 'drempower command' commands
        return
    fi
    local cmd=$words[2] npos=0 i w
    for ((i = 3; i < CURRENT; i++)); do
        w=$words[i]
        if (( ${{valued[(Ie)$w]}} )); then
            ((i++))
        elif [[ $w != -* ]]; then
            ((npos++))
        fi
    done
    case $words[CURRENT-1] in
        -i|--interface) compadd -a interfaces; return;;
        {files}) _files; return;;
    esac
    if [[ $PREFIX == -* ]]; then
        case $cmd in
{options}
        esac
        compadd -a opts
    elif [[ ($cmd == get && $npos -ge 1) || ($cmd == set && $npos -ge 1 && $((npos % 2)) -eq 1) ]]; then
        compadd -a names
    fi
}}
if [[ $zsh_eval_context[-1] == loadautofunc ]]; then
    _drempower "$@"
else
    compdef _drempower drempower
fi
"""

_FISH_HEAD = """\
# fish completion for drempower. Load it with:
#   drempower completion fish | source
# or save it as ~/.config/fish/completions/drempower.fish
function __drempower_name_wanted
    # true where get/set take a parameter NAME: get ID NAME..., set ID NAME VALUE NAME VALUE...
    set -l words (commandline -opc)
    set -l cmd $words[2]
    set -l npos 0
    set -l skip 0
    for w in $words[3..-1]
        if test $skip -eq 1
            set skip 0
        else if contains -- $w {valued}
            set skip 1
        else if not string match -q -- '-*' $w
            set npos (math $npos + 1)
        end
    end
    test "$cmd" = get -a $npos -ge 1; and return 0
    test "$cmd" = set -a $npos -ge 1 -a (math $npos % 2) -eq 1
end
complete -c drempower -f
complete -c drempower -n __fish_use_subcommand -l version -d 'show the version'
"""


@dataclass(frozen=True, slots=True)
class _Command:
    name: str
    help: str
    options: list[argparse.Action]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "completion",
        help="print a shell completion script (bash, zsh, fish)",
        description=(
            "Print a completion script: `source <(drempower completion bash)` (bash), "
            "`source <(drempower completion zsh)` (zsh, after compinit), `drempower completion fish | source`."
        ),
    )
    p.add_argument("shell", choices=SHELLS, help="the shell")
    p.add_argument("--json", action="store_true", help='print {"shell": ..., "script": ...} instead of the script')
    p.set_defaults(func=run)


def completable_names() -> list[str]:
    """Every parameter's full name, then the unique ends of names that ``get``/``set`` accept."""
    full = [p.name for p in parameters()]
    ends = Counter(n.rsplit(".", 1)[-1] for n in full)
    short = [n.rsplit(".", 1)[-1] for n in full if "." in n and ends[n.rsplit(".", 1)[-1]] == 1]
    return full + [s for s in short if s not in full]


def interfaces() -> list[str]:
    """The python-can interfaces offered for ``-i`` (not udp_multicast)."""
    from can.interfaces import VALID_INTERFACES

    return sorted(set(VALID_INTERFACES) - _NOT_OFFERED)


def _commands(parser: argparse.ArgumentParser) -> list[_Command]:
    (subparsers,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    helps = {a.dest: a.help or "" for a in subparsers._choices_actions}
    out = []
    for name, cmd in subparsers.choices.items():
        visible = [a for a in cmd._actions if a.help != argparse.SUPPRESS and a.option_strings]
        out.append(_Command(name, helps.get(name, ""), visible))
    return out


def _valued(commands: list[_Command]) -> list[str]:
    return sorted({s for c in commands for a in c.options if a.nargs != 0 for s in a.option_strings})


def bash_script(parser: argparse.ArgumentParser) -> str:
    """The bash completion script for ``parser`` (the ``drempower`` parser)."""
    commands = _commands(parser)
    cases = [
        f'            {c.name}) COMPREPLY=($(compgen -W "{" ".join(s for a in c.options for s in a.option_strings)}" '
        f'-- "$cur"));;'
        for c in commands
    ]
    return _BASH.format(
        valued=" ".join(_valued(commands)),
        interfaces=" ".join(interfaces()),
        files="|".join(_FILE_OPTIONS),
        commands=" ".join(c.name for c in commands),
        options="\n".join(cases),
        names=" ".join(completable_names()),
    )


def _quote(text: str) -> str:
    """``text`` in single quotes for fish (which takes ``\\'`` and ``\\\\`` inside them)."""
    return "'" + text.replace("\\", "\\\\").replace("'", "\\'") + "'"


def _zsh_quote(text: str) -> str:
    """``text`` in single quotes for zsh (which takes no escapes inside them)."""
    return "'" + text.replace("'", "'\\''") + "'"


def zsh_script(parser: argparse.ArgumentParser) -> str:
    """The zsh completion script for ``parser``."""
    commands = _commands(parser)
    described = [f"        {_zsh_quote(c.name + ':' + c.help.replace(':', chr(92) + ':'))}" for c in commands]
    cases = [
        f"            {c.name}) opts=({' '.join(s for a in c.options for s in a.option_strings)});;" for c in commands
    ]
    return _ZSH.format(
        described="\n".join(described),
        names=" ".join(completable_names()),
        interfaces=" ".join(interfaces()),
        valued=" ".join(_valued(commands)),
        files="|".join(_FILE_OPTIONS),
        options="\n".join(cases),
    )


def fish_script(parser: argparse.ArgumentParser) -> str:
    """The fish completion script for ``parser``."""
    commands = _commands(parser)
    lines = [_FISH_HEAD.format(valued=" ".join(_valued(commands)))]
    for c in commands:
        lines.append(f"complete -c drempower -n __fish_use_subcommand -a {c.name} -d {_quote(c.help)}")
    for c in commands:
        seen = f"'__fish_seen_subcommand_from {c.name}'"
        for a in c.options:
            words = []
            for s in a.option_strings:
                words += ["-l", s[2:]] if s.startswith("--") else ["-s", s[1:]]
            if a.nargs != 0:
                words.append("-r")
                if any(s in _FILE_OPTIONS for s in a.option_strings):
                    words.append("-F")
                elif "--interface" in a.option_strings:
                    words += ["-a", _quote(" ".join(interfaces()))]
                elif a.choices:
                    words += ["-a", _quote(" ".join(map(str, a.choices)))]
            text = (a.help or "").replace("%(default)s", str(a.default)).replace("%%", "%")
            lines.append(f"complete -c drempower -n {seen} {' '.join(words)} -d {_quote(text)}")
    names = " ".join(completable_names())
    lines.append(f"complete -c drempower -n __drempower_name_wanted -a {_quote(names)}")
    return "\n".join(lines) + "\n"


_SCRIPTS = {"bash": bash_script, "zsh": zsh_script, "fish": fish_script}


def run(args: argparse.Namespace) -> int:
    from . import build_parser

    script = _SCRIPTS[args.shell](build_parser())
    if args.json:
        print(json_line({"shell": args.shell, "script": script}))
    else:
        print(script, end="")
    return 0
