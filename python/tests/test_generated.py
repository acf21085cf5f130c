"""Generated files are up to date with their sources, and the Python sources use the generated address names."""

from __future__ import annotations

import io
import shutil
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

from .conftest import REPO_ROOT


def _check(script: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(REPO_ROOT / "tools" / script), "--check"], capture_output=True, text=True, check=False
    )


def test_parameter_code_is_fresh() -> None:
    r = _check("generate.py")
    assert r.returncode == 0, r.stderr


def test_vectors_are_fresh() -> None:
    r = _check("gen_vectors.py")
    assert r.returncode == 0, r.stderr


_PARTS = [
    Path("tools/generate.py"),
    Path("spec/parameters.csv"),
    Path("python/src/drempower/protocol/_parameter_table.py"),
    Path("c/include/drempower/dre_params.h"),
    Path("python/src/drempower/protocol/addresses.py"),
]


def test_staleness_is_detected(tmp_path: Path) -> None:
    """A hand edit of a generated file fails the check (run on a copy, not on the working tree)."""
    parts = _PARTS
    for rel in parts:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO_ROOT / rel, tmp_path / rel)
    script = [sys.executable, str(tmp_path / "tools" / "generate.py"), "--check"]
    assert subprocess.run(script, capture_output=True, text=True, check=False).returncode == 0
    for rel in (parts[2], parts[4]):
        target = tmp_path / rel
        text = target.read_text()
        target.write_text(text + "# edited by hand\n")
        r = subprocess.run(script, capture_output=True, text=True, check=False)
        assert r.returncode == 1
        assert rel.name in r.stderr
        target.write_text(text)


def test_domain_change_makes_the_tables_stale(tmp_path: Path) -> None:
    """A domain changed in the CSV alone leaves the Python table and the C header stale."""
    for rel in _PARTS:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO_ROOT / rel, tmp_path / rel)
    csv_path = tmp_path / "spec/parameters.csv"
    text = csv_path.read_text()
    assert ",,1,63,,hard," in text
    csv_path.write_text(text.replace(",,1,63,,hard,", ",,1,62,,hard,"))
    script = [sys.executable, str(tmp_path / "tools" / "generate.py")]
    r = subprocess.run([*script, "--check"], capture_output=True, text=True, check=False)
    assert r.returncode == 1
    assert "_parameter_table.py" in r.stderr and "dre_params.h" in r.stderr and "addresses.py" not in r.stderr
    assert subprocess.run(script, capture_output=True, text=True, check=False).returncode == 0
    table = (tmp_path / _PARTS[2]).read_text()
    header = (tmp_path / _PARTS[3]).read_text()
    assert "'CAN bus node ID (motor ID).', 1, 62, (), True, False)" in table
    assert "{31001u, DRE_PD_MIN | DRE_PD_MAX | DRE_PD_HARD, 0u, 0u, 1.0f, 62.0f}" in header


def test_address_constants_match_the_table() -> None:
    """Every parameter has its address constant, named as the C DRE_P_* constant without the prefix."""
    from drempower.protocol import addresses
    from drempower.protocol.parameters import parameters

    header = (REPO_ROOT / "c/include/drempower/dre_params.h").read_text()
    for p in parameters():
        name = p.name.replace(".", "_").upper()
        assert getattr(addresses, name) == p.address
        assert f"#define DRE_P_{name} DRE_PARAM({p.address}u," in header
    assert addresses.AXIS0_CONFIG_CAN_NODE_ID == 31001
    assert len(addresses.__all__) == len(list(parameters()))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (",,1,63,,hard,", ",,63,1,,hard,", "min > max"),
        (",,1,63,,hard,", ",,1,63,,,", "bound must be hard or soft exactly when a domain is given"),
        (",,1,63,,hard,", ",,1,63.5,,hard,", "is not whole (uint32)"),
        (",,1,63,,hard,", ",,1,1e10,,hard,", "outside the wire range of uint32"),
        (
            "DC bus (supply) voltage.,,,,,,",
            "DC bus (supply) voltage.,,0,,,soft,doc: x",
            "a read-only parameter has no domain",
        ),
    ],
)
def test_a_malformed_domain_is_refused(tmp_path: Path, old: str, new: str, message: str) -> None:
    for rel in _PARTS[:2]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO_ROOT / rel, tmp_path / rel)
    csv_path = tmp_path / "spec/parameters.csv"
    text = csv_path.read_text()
    assert text.count(old) == 1
    csv_path.write_text(text.replace(old, new))
    r = subprocess.run(
        [sys.executable, str(tmp_path / "tools" / "generate.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert r.returncode != 0 and message in r.stderr


# The rule: in python/src/drempower, a parameter address is written by its generated name
# (``from ..protocol.addresses import AXIS0_CONFIG_CAN_NODE_ID``), never as a number. A
# number that is not an address but equals one (a rate, a count) is allowed on a line
# that carries the marker comment below.
NOT_AN_ADDRESS = "# not a parameter address"
_SRC = REPO_ROOT / "python/src/drempower"
_GENERATED = {_SRC / "protocol/_parameter_table.py", _SRC / "protocol/addresses.py"}


def _five_digit_addresses() -> frozenset[int]:
    from drempower.protocol.parameters import parameters

    return frozenset(p.address for p in parameters() if p.address >= 10_000)


def address_literals(source: str, addresses: frozenset[int]) -> list[tuple[int, str]]:
    """(line, literal) of every integer literal in ``source`` that equals one of ``addresses``."""
    found = []
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type != tokenize.NUMBER or NOT_AN_ADDRESS in tok.line:
            continue
        try:
            value = int(tok.string, 0)
        except ValueError:  # a float or imaginary literal
            continue
        if value in addresses:
            found.append((tok.start[0], tok.string))
    return found


def test_the_address_scan_finds_literals_and_spares_other_numbers() -> None:
    addresses = _five_digit_addresses()
    source = (
        "ram[31214] = 1\n"
        "x = read(0x7919)\n"  # 31001 in hex
        "y = {\n    35_104: 'traj_mode',\n}\n"
        "BAUDS = (9600, 19200, 57600, 115200, 1_000_000)\n"
        "port = 29536\n"
        "limit = 31001.0\n"
        "ok = 32002  # not a parameter address\n"
        "s = '31001'  # 31001 in a string or a comment is documentation\n"
    )
    assert address_literals(source, addresses) == [(1, "31214"), (2, "0x7919"), (4, "35_104")]


def test_no_address_literals_in_the_python_sources() -> None:
    """Five-digit parameter addresses appear in src by name only (the generated files aside)."""
    addresses = _five_digit_addresses()
    files = sorted(set(_SRC.rglob("*.py")) - _GENERATED)
    assert len(files) > 50
    found = [
        f"{path.relative_to(REPO_ROOT)}:{line}: {literal} (use drempower.protocol.addresses)"
        for path in files
        for line, literal in address_literals(path.read_text(encoding="utf-8"), addresses)
    ]
    assert not found, "\n".join(found)
