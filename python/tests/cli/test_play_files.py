"""``drempower play --dry-run`` on files that cannot be followed: one line, exit 2, no traceback; a CSV
with a byte-order mark (as spreadsheets write) is read."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from .conftest import Cli

pytest.importorskip("mcap")


@pytest.mark.parametrize(
    ("name", "content", "words"),
    [
        ("tiny.csv", b"t,1\n0,0\n1e-300,10\n", "1e-300 s after times[0]; the shortest step is 1e-06 s"),
        ("huge.csv", b"t,1\n0,0\n1,1e308\n", "positions['1'][1]=1e+308: beyond +-1e+06"),
        ("random.mcap", random.Random(7).randbytes(64), "not a readable MCAP file (InvalidMagic"),
        ("empty.mcap", b"", "not a readable MCAP file (EndOfFile: it ends early)"),
    ],
    ids=["tiny", "huge", "random", "empty"],  # the same in every worker of a parallel run
)
def test_a_file_that_cannot_be_followed_is_one_line(
    cli: Cli, tmp_path: Path, name: str, content: bytes, words: str
) -> None:
    path = tmp_path / name
    path.write_bytes(content if not name.startswith("random") else b"\x01" + content)
    r = cli("play", str(path), "--ids", "1", "--dry-run")
    assert r.code == 2 and "Traceback" not in r.err and words in r.err, r.err


def test_a_csv_with_a_byte_order_mark_is_read(cli: Cli, tmp_path: Path) -> None:
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbft,1\n0,0\n1,10\n")
    r = cli("play", str(path), "--ids", "1", "--dry-run")
    assert r.code == 0, r.err
