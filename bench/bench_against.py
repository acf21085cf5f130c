#!/usr/bin/env python3
"""The speed table's rows for this checkout beside another revision's, measured in turns in one run.

Run: ``python3 bench/bench_against.py REV [--rounds N] [--rows GROUP,...] [--requests N]``. Prints
figures; asserts nothing.

A machine's speed drifts (a shared machine's floors vary by 2x within an hour), so a figure measured
today is not comparable with one measured last week. This script checks ``REV`` out into a
temporary git worktree and runs ``bench_table.py`` (this checkout's harness, so both trees are
measured the same way) on each tree in turn, ``--rounds`` times, each run in a fresh interpreter
with ``DREMPOWER_SRC`` naming the tree's ``python/src``. For every row it prints the median over
the rounds of each tree's figure, floor and ratio, and this checkout's figure over ``REV``'s. Rows
that one tree did not print (an interface ``REV`` does not have) are left out; an interface name the
two trees open differently (``"socketcand"`` before drempower had its own client) measures, on each
tree, what that tree opens. Sub-rows whose words follow several rows (``  CPU per call``...) are
named with the row above them.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
_ROW = re.compile(
    r"^  (?P<label>.+?)\s{2,}(?P<figure>[\d.]+) (?P<unit>\S+)\s+floor\s+(?P<floor>[\d.]+) \S+\s+(?P<ratio>.*)$"
)
"""One row of ``bench_table.py``'s output: label, figure and unit, floor, ratio text."""


@contextlib.contextmanager
def worktree(rev: str) -> Iterator[Path]:
    """``rev`` checked out in a temporary git worktree (removed after)."""
    with tempfile.TemporaryDirectory(prefix="drempower-against-") as tmp:
        path = Path(tmp) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "--quiet", str(path), rev], check=True)
        try:
            yield path
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(path)], check=False)


def table(src: Path, rows: str, requests: int) -> dict[str, tuple[float, str, float, float | None]]:
    """One run of ``bench_table.py`` on the tree ``src``: label -> (figure, unit, floor, ratio or None)."""
    env = {**os.environ, "DREMPOWER_SRC": str(src)}
    cmd = [sys.executable, str(HERE / "bench_table.py"), "--rows", rows, "--requests", str(requests)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    got: dict[str, tuple[float, str, float, float | None]] = {}
    rows: list[tuple[str, str, re.Match[str]]] = []
    parent = ""
    for line in out.stdout.splitlines():
        m = _ROW.match(line)
        if m is None:
            continue
        label = m["label"].strip()
        if not m["label"].startswith("  "):
            parent = label
        rows.append((parent, label, m))
    repeated = {label for label in (r[1] for r in rows) if sum(r[1] == label for r in rows) > 1}
    for parent, label, m in rows:
        ratio = re.match(r"([\d.]+)", m["ratio"])
        if label in repeated:  # a sub-row whose words follow several rows ("  CPU per call..."): named by its row
            label = f"{parent}: {label}"
        got[label] = (
            float(m["figure"]),
            m["unit"],
            float(m["floor"]),
            float(ratio[1]) if ratio else None,
        )
    if out.returncode != 0 and not got:
        sys.stderr.write(out.stderr[-2000:])
    return got


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rev", help="the revision to compare with (a commit, tag or branch)")
    ap.add_argument("--rounds", type=int, default=5, help="runs of each tree, in turns (default 5)")
    ap.add_argument("--rows", default="inprocess,adapter", help="bench_table.py's groups (default inprocess,adapter)")
    ap.add_argument("--requests", type=int, default=2000, help="calls per latency figure (default 2000)")
    args = ap.parse_args()
    if args.rounds < 1 or args.requests < 1:
        ap.error(f"--rounds {args.rounds}, --requests {args.requests}: both must be >= 1")
    known = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet", f"{args.rev}^{{commit}}"],
        capture_output=True,
        check=False,
    )
    if known.returncode != 0:
        ap.error(f"{args.rev}: not a revision of this repository")
    here = ROOT / "python" / "src"
    with worktree(args.rev) as other:
        there = other / "python" / "src"
        runs: dict[str, list[dict[str, tuple[float, str, float, float | None]]]] = {"this": [], "rev": []}
        for _ in range(args.rounds):
            runs["rev"].append(table(there, args.rows, args.requests))
            runs["this"].append(table(here, args.rows, args.requests))
    labels = [label for label in runs["this"][0] if all(label in r for side in runs.values() for r in side)]
    if not labels:
        sys.exit("bench_against: no row ran on both trees (see the errors above)")
    print(f"this checkout against {args.rev}: medians of {args.rounds} runs each, taken in turns")
    head = f"{'this':>10} {'(floor)':>9} {'ratio':>7}   {args.rev[:10]:>10} {'(floor)':>9} {'ratio':>7}"
    print(f"  {'row':<60} {head}   this/rev  noise  verdict")
    for label in labels:
        cols = []
        for side in ("this", "rev"):
            fig = statistics.median(r[label][0] for r in runs[side])
            floor = statistics.median(r[label][2] for r in runs[side])
            ratios = [r[label][3] for r in runs[side] if r[label][3] is not None]
            ratio = f"{statistics.median(ratios):.2f}x" if ratios else ""
            cols.append((fig, floor, ratio, runs[side][0][label][1]))
        (a, af, ar, unit), (b, bf, br, _) = cols
        versus = f"{a / b:.2f}" if b else ""
        noise, verdict = _against(runs, label)
        print(
            f"  {label:<60} {a:>7.1f} {unit:<2} {af:>9.1f} {ar:>7}   {b:>7.1f} {unit:<2} {bf:>9.1f} {br:>7}"
            f"   {versus:>8}  {noise:>5}  {verdict}"
        )
    print(
        "  noise: how far one tree's ratio to its floor moves from run to run (the larger median absolute\n"
        "  deviation of the two trees, in %); verdict: the median of the rounds' this/rev ratios to the floor,\n"
        "  against twice that noise"
    )


def _against(runs: dict[str, list[dict[str, tuple[float, str, float, float | None]]]], label: str) -> tuple[str, str]:
    """A row's noise (the relative run-to-run spread of each tree's ratio to its floor, the larger, in %) and its
    verdict: this tree's ratio over the revision's, round by round (measured in turns), beside twice that noise."""

    def ratio(row: tuple[float, str, float, float | None]) -> float | None:  # figure over floor, unrounded
        return row[0] / row[2] if row[2] and row[3] is not None else None

    mine = [ratio(r[label]) for r in runs["this"]]
    theirs = [ratio(r[label]) for r in runs["rev"]]
    pairs = [(x, y) for x, y in zip(mine, theirs, strict=True) if x is not None and y]
    if not pairs:
        return "", ""
    spread = 0.0
    for side in ([x for x, _ in pairs], [y for _, y in pairs]):
        mid = statistics.median(side)
        spread = max(spread, statistics.median(abs(v - mid) for v in side) / mid)
    change = statistics.median(x / y for x, y in pairs) - 1.0
    if abs(change) <= 2 * spread:
        verdict = f"{change:+.0%}, within the noise"
    else:
        verdict = f"{change:+.0%}, {'worse' if change > 0 else 'better'}"
    return f"{spread:.0%}", verdict


if __name__ == "__main__":
    main()
