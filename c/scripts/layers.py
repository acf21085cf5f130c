#!/usr/bin/env python3
"""Check that the C library's modules call one another in layers, never in a cycle.

Reads the symbol tables of the library's object files with `nm` (what each
module defines and what it leaves undefined), builds the graph "module A calls
into module B", and fails when that graph has a cycle or an edge that goes
against the declared layer order below (a module may call only modules of a
lower layer). Usage: layers.py NM OBJECT... (the objects of c/src/*.c; an
argument may hold several, separated by ';', as CMake's $<TARGET_OBJECTS> gives them).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

# Lowest first. A module calls only modules of lower layers (never its own layer).
LAYERS: list[set[str]] = [
    {"dre_codec", "dre_params", "dre_errors", "dre_framing"},
    {"dre_bus"},
    {"dre_moves"},
    {"dre_motor"},
    {"dre_wait", "dre_verified", "dre_batch", "dre_health"},
]


def module_of(obj: Path) -> str:
    """dre_bus.c.o, dre_bus.o, dre_bus.c.obj -> dre_bus."""
    return obj.name.split(".", 1)[0]


def symbols(nm: str, obj: Path) -> tuple[set[str], set[str]]:
    """(defined, undefined) external symbols of one object file."""
    out = subprocess.run([nm, "-g", str(obj)], check=True, capture_output=True, text=True).stdout
    defined: set[str] = set()
    undefined: set[str] = set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == "U":
            undefined.add(parts[1])
        elif len(parts) == 3:
            defined.add(parts[2])
    return defined, undefined


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of `graph` as a list of modules (first == last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def main(argv: list[str]) -> int:
    if len(argv) < 3:
        print("usage: layers.py NM OBJECT...", file=sys.stderr)
        return 2
    nm, objs = argv[1], [Path(o) for a in argv[2:] for o in a.split(";") if o]
    owner: dict[str, str] = {}
    needs: dict[str, set[str]] = {}
    for obj in objs:
        defined, undefined = symbols(nm, obj)
        mod = module_of(obj)
        needs[mod] = undefined
        for sym in defined:
            owner[sym] = mod
    graph = {mod: {owner[s] for s in und if s in owner and owner[s] != mod} for mod, und in needs.items()}
    layer = {mod: i for i, group in enumerate(LAYERS) for mod in group}
    errors: list[str] = []
    unknown = sorted(set(graph) - set(layer))
    if unknown:
        errors.append(f"modules without a layer (add them to LAYERS): {', '.join(unknown)}")
    cycle = find_cycle(graph)
    if cycle:
        errors.append("call cycle: " + " -> ".join(cycle))
    for mod in sorted(graph):
        for dep in sorted(graph[mod]):
            if mod in layer and dep in layer and layer[dep] >= layer[mod]:
                syms = sorted(s for s in needs[mod] if owner.get(s) == dep)
                errors.append(f"{mod} (layer {layer[mod]}) calls {dep} (layer {layer[dep]}): {', '.join(syms)}")
    for mod in sorted(graph, key=lambda m: (layer.get(m, -1), m)):
        print(f"{mod:14} -> {', '.join(sorted(graph[mod])) or '-'}")
    for err in errors:
        print(f"layers: {err}", file=sys.stderr)
    if not errors:
        print(f"layers: {len(graph)} modules, no cycle, every call goes to a lower layer")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
