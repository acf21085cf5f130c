#!/usr/bin/env python3
"""Generate code from ``spec/parameters.csv``.

Targets (each a file checked into the repository):

* ``python/src/drempower/protocol/_parameter_table.py``: the Python registry.
* ``python/src/drempower/protocol/addresses.py``: one constant per parameter address.
* ``c/include/drempower/dre_params.h``: the C parameter constants, name table and domains.

Domains (columns ``min``, ``max``, ``allowed``, ``bound``, ``domain_source``):
``min``/``max`` bound the value (inclusive, either may be blank), ``allowed``
lists the only values it takes (space separated), ``bound`` says whether an
explicit force may write outside them (``soft``) or not (``hard``), and
``domain_source`` says where the domain comes from (``doc: ...``,
``inferred: ...``, ``undocumented: ...``). The wire range of the data type
always applies, force or not.

Usage::

    python3 tools/generate.py          # (re)write every target
    python3 tools/generate.py --check  # exit 1 if any target is stale

The tests run ``--check`` so that a change to the CSV without regenerating fails.
"""

from __future__ import annotations

import argparse
import csv
import re
import struct
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CSV_PATH = ROOT / "spec" / "parameters.csv"

TYPE_CODES = {"float32": "F32", "uint32": "U32", "int32": "S32", "uint16": "U16", "int16": "S16"}


@dataclass(frozen=True)
class Row:
    name: str
    address: int
    type: str
    access: str
    user_settable: bool
    unit: str
    series: str
    description: str
    is_bool: bool
    minimum: float | None
    maximum: float | None
    allowed: tuple[float, ...]
    hard: bool
    inferred: bool

    @property
    def has_domain(self) -> bool:
        return self.minimum is not None or self.maximum is not None or bool(self.allowed)


WIRE_RANGES = {
    "uint32": (0, 0xFFFFFFFF),
    "int32": (-0x80000000, 0x7FFFFFFF),
    "uint16": (0, 0xFFFF),
    "int16": (-0x8000, 0x7FFF),
}
F32_MAX = 3.4028234663852886e38


def _number(path: Path, rec: dict[str, str], column: str, text: str) -> float:
    """One bound or allowed value: a whole number for the integer types, in the wire range."""
    try:
        value = float(text)
    except ValueError:
        raise SystemExit(f"{path}: {rec['name']}: {column} {text!r} is not a number") from None
    lo, hi = WIRE_RANGES.get(rec["type"], (-F32_MAX, F32_MAX))
    if rec["type"] != "float32" and value != int(value):
        raise SystemExit(f"{path}: {rec['name']}: {column} {text!r} is not whole ({rec['type']})")
    if not lo <= value <= hi:
        raise SystemExit(f"{path}: {rec['name']}: {column} {text!r} is outside the wire range of {rec['type']}")
    return value


def _domain(path: Path, rec: dict[str, str]) -> tuple[float | None, float | None, tuple[float, ...], bool, bool]:
    minimum = _number(path, rec, "min", rec["min"]) if rec["min"] else None
    maximum = _number(path, rec, "max", rec["max"]) if rec["max"] else None
    allowed = tuple(sorted(_number(path, rec, "allowed", t) for t in rec["allowed"].split()))
    source = rec["domain_source"]
    has = minimum is not None or maximum is not None or bool(allowed)
    if rec["bound"] not in ("", "hard", "soft") or has != (rec["bound"] != ""):
        raise SystemExit(f"{path}: {rec['name']}: bound must be hard or soft exactly when a domain is given")
    if minimum is not None and maximum is not None and minimum > maximum:
        raise SystemExit(f"{path}: {rec['name']}: min > max")
    if allowed and (minimum is not None or maximum is not None):
        raise SystemExit(f"{path}: {rec['name']}: give min/max or allowed, not both")
    if rec["access"] == "ro" and (has or source):
        raise SystemExit(f"{path}: {rec['name']}: a read-only parameter has no domain")
    if rec["access"] == "rw" and source.split(":")[0] not in ("doc", "inferred", "undocumented"):
        raise SystemExit(f"{path}: {rec['name']}: domain_source must start with doc:, inferred: or undocumented:")
    return minimum, maximum, allowed, rec["bound"] == "hard", source.startswith("inferred")


def load_rows(path: Path = CSV_PATH) -> list[Row]:
    """Read and sanity-check the parameter table."""
    rows: list[Row] = []
    with path.open(newline="", encoding="utf-8") as fh:
        for rec in csv.DictReader(fh):
            if rec["type"] not in TYPE_CODES:
                raise SystemExit(f"{path}: {rec['name']}: unknown type {rec['type']!r}")
            if rec["access"] not in ("ro", "rw"):
                raise SystemExit(f"{path}: {rec['name']}: unknown access {rec['access']!r}")
            address = int(rec["address"])
            if not 1 <= address <= 0xFFFF:
                raise SystemExit(f"{path}: {rec['name']}: address {address} does not fit u16 (0 is the fast read)")
            minimum, maximum, allowed, hard, inferred = _domain(path, rec)
            rows.append(
                Row(
                    name=rec["name"],
                    address=address,
                    type=rec["type"],
                    access=rec["access"],
                    user_settable=rec["user_settable"] == "yes",
                    unit=rec["unit"],
                    series=rec["series"],
                    description=rec["description"],
                    is_bool="bool (0/1)" in rec["description"],
                    minimum=minimum,
                    maximum=maximum,
                    allowed=allowed,
                    hard=hard,
                    inferred=inferred,
                )
            )
    names = [r.name for r in rows]
    addrs = [r.address for r in rows]
    if len(set(names)) != len(names) or len(set(addrs)) != len(addrs):
        raise SystemExit(f"{path}: duplicate parameter name or address")
    return sorted(rows, key=lambda r: r.address)


HEADER = "# Generated by tools/generate.py from spec/parameters.csv. Do not edit by hand.\n"


def _py_number(r: Row, v: float | None) -> str:
    if v is None:
        return "None"
    return repr(float(v)) if r.type == "float32" else repr(int(v))


def render_python(rows: list[Row]) -> str:
    out = [
        HEADER,
        '"""The DrEmpower parameter table (generated)."""\n',
        "from __future__ import annotations\n",
        "from .parameters import Access, DataType, Parameter\n",
        "PARAMETER_TABLE: tuple[Parameter, ...] = (",
    ]
    for r in rows:
        out.append(
            "    Parameter("
            f"{r.name!r}, {r.address}, DataType.{TYPE_CODES[r.type]}, "
            f"Access.{r.access.upper()}, {r.user_settable!r}, {r.unit!r}, {r.series!r}, "
            f"{r.is_bool!r}, {r.description!r}, {_py_number(r, r.minimum)}, {_py_number(r, r.maximum)}, "
            f"({''.join(_py_number(r, v) + ', ' for v in r.allowed).rstrip()}), {r.hard!r}, {r.inferred!r}),"
        )
    out.append(")\n")
    return "\n".join(out)


def ident(name: str) -> str:
    """The constant's name without the C prefix: ``axis0.config.can_node_id`` -> ``AXIS0_CONFIG_CAN_NODE_ID``."""
    return re.sub(r"[^A-Za-z0-9]", "_", name).upper()


def render_addresses(rows: list[Row]) -> str:
    """The Python address constants, named as the C ``DRE_P_*`` constants without the prefix."""
    out = [
        HEADER,
        '"""Parameter addresses (generated), one constant per parameter.\n',
        "Each name is the parameter's name in upper case with dots as underscores, as the",
        "C library's ``DRE_P_<NAME>`` (``axis0.config.can_node_id`` is ``AXIS0_CONFIG_CAN_NODE_ID``).",
        "Look the rest of a parameter up with ``drempower.protocol.parameter(ADDRESS)``.",
        '"""\n',
        "from __future__ import annotations\n",
        "from typing import Final\n",
    ]
    names = [ident(r.name) for r in rows]
    out.append("__all__ = [")
    out += [f'    "{n}",' for n in names]
    out.append("]\n")
    for r, n in zip(rows, names, strict=True):
        unit = f" [{r.unit}]" if r.unit else ""
        out.append(f"{n}: Final = {r.address}")
        out.append(f'"""``{r.name}`` ({r.type}, {r.access}){unit}."""')
    out.append("")
    return "\n".join(out)


def render_c(rows: list[Row]) -> str:
    """The C parameter header: one packed constant per parameter and the name table.

    Each ``DRE_P_<NAME>`` is a compile-time ``dre_param_t`` (address, data type and
    flags packed into 32 bits), so firmware that only reads and writes parameters
    needs no table in flash. The table of names and units is defined in the one
    translation unit that defines ``DRE_PARAMS_IMPLEMENTATION`` before including it.
    """
    c_types = {"float32": "DRE_F32", "uint32": "DRE_U32", "int32": "DRE_S32", "uint16": "DRE_U16", "int16": "DRE_S16"}

    def c_ident(name: str) -> str:
        return "DRE_P_" + ident(name)

    def c_string(text: str) -> str:
        return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'

    def comment(text: str) -> str:
        return text.replace("*/", "* /")

    idents = [c_ident(r.name) for r in rows]
    if len(set(idents)) != len(idents):
        raise SystemExit("parameter names collide as C identifiers")
    out = [
        "/* Generated by tools/generate.py from spec/parameters.csv. Do not edit by hand. */",
        "/**",
        " * @file dre_params.h",
        " * @brief The DrEmpower parameter table.",
        " *",
        " * Each DRE_P_<NAME> packs a parameter's address, data type (dre_dtype) and",
        " * DRE_PF_* flags into a dre_param_t constant. Units are those of the motor",
        " * (parameters outside axis0.output_shaft refer to the rotor).",
        " */",
        "#ifndef DRE_PARAMS_H",
        "#define DRE_PARAMS_H",
        "",
        "#include <stdint.h>",
        "",
        '#include "dre_codec.h"',
        "",
        "#ifdef __cplusplus",
        'extern "C" {',
        "#endif",
        "",
        "/** A parameter: bits 0-15 address, 16-23 data type, 24-31 DRE_PF_* flags. */",
        "typedef uint32_t dre_param_t;",
        "",
        "#define DRE_PF_RW 0x01u       /**< writable (otherwise read-only) */",
        "#define DRE_PF_USER 0x02u     /**< meant to be changed by users */",
        "#define DRE_PF_BOOL 0x04u     /**< bool: 0 or 1, sent as u32 */",
        "#define DRE_PF_SERIES_M 0x08u /**< M series only */",
        "#define DRE_PF_SERIES_G 0x10u /**< G series only */",
        "",
        "#define DRE_PARAM(address, dtype, flags) \\",
        "    ((dre_param_t)(address) | ((dre_param_t)(dtype) << 16) | ((dre_param_t)(flags) << 24))",
        "#define DRE_PARAM_ADDRESS(p) ((uint16_t)((p) & 0xFFFFu))",
        "#define DRE_PARAM_DTYPE(p) ((uint8_t)(((p) >> 16) & 0xFFu))",
        "#define DRE_PARAM_FLAGS(p) ((uint8_t)(((p) >> 24) & 0xFFu))",
        "",
        f"#define DRE_PARAM_COUNT {len(rows)}u",
        "",
    ]
    dtype_codes = {"DRE_F32": 0, "DRE_U16": 1, "DRE_S16": 2, "DRE_U32": 3, "DRE_S32": 4}
    for r, name in zip(rows, idents, strict=True):
        flags = []
        if r.access == "rw":
            flags.append("DRE_PF_RW")
        if r.user_settable:
            flags.append("DRE_PF_USER")
        if r.is_bool:
            flags.append("DRE_PF_BOOL")
        if r.series == "M":
            flags.append("DRE_PF_SERIES_M")
        elif r.series == "G":
            flags.append("DRE_PF_SERIES_G")
        unit = f" [{r.unit}]" if r.unit else ""
        out.append(
            f"/** {comment(r.name)} ({r.address}, {r.type}, {r.access}){comment(unit)}: {comment(r.description)} */"
        )
        out.append(
            f"#define {name} DRE_PARAM({r.address}u, {dtype_codes[c_types[r.type]]}u, {' | '.join(flags) or '0u'})"
        )
    out += [
        "",
        "/** One row of the name table. */",
        "typedef struct {",
        '    const char *name; /**< e.g. "axis0.output_shaft.pos_estimate" */',
        '    const char *unit; /**< "" when the value has no unit */',
        "    dre_param_t param;",
        "} dre_param_info;",
        "",
        "/** Every parameter, sorted by address. */",
        "extern const dre_param_info dre_param_table[DRE_PARAM_COUNT];",
        "",
        '/** The parameter named `name` ("axis1.x" is read as "axis0.x", as the vendor does), or NULL. */',
        "const dre_param_info *dre_param_find(const char *name);",
        "",
        "/** The parameter at `address`, or NULL. */",
        "const dre_param_info *dre_param_by_address(uint16_t address);",
        "",
        *_c_domain_decls(rows),
        "#ifdef DRE_PARAMS_IMPLEMENTATION",
        "const dre_param_info dre_param_table[DRE_PARAM_COUNT] = {",
    ]
    for r, name in zip(rows, idents, strict=True):
        out.append(f"    {{{c_string(r.name)}, {c_string(r.unit)}, {name}}},")
    out += [
        "};",
        *_c_domain_table(rows),
        "#endif /* DRE_PARAMS_IMPLEMENTATION */",
        "",
        "#ifdef __cplusplus",
        "}",
        "#endif",
        "",
        "#endif /* DRE_PARAMS_H */",
        "",
    ]
    return "\n".join(out)


def _c_float(v: float) -> str:
    if struct.unpack("<f", struct.pack("<f", v))[0] != v:
        raise SystemExit(f"domain bound {v!r} is not exact in float32")
    return f"{v!r}f" if v != int(v) else f"{int(v)}.0f"


def _c_domain_decls(rows: list[Row]) -> list[str]:
    """The declarations of the domain table (see ``spec/parameters.csv``)."""
    doms = [r for r in rows if r.has_domain]
    nallowed = sum(len(a) for a in {r.allowed for r in doms})
    return [
        "/* ---- domains: the values each writable parameter takes (spec/parameters.csv) */",
        "",
        "#define DRE_PD_MIN 0x01u      /**< lo bounds the value (inclusive) */",
        "#define DRE_PD_MAX 0x02u      /**< hi bounds the value (inclusive) */",
        "#define DRE_PD_SET 0x04u      /**< the value is one of count values at dre_param_allowed[first] */",
        "#define DRE_PD_HARD 0x08u     /**< no force writes outside it (otherwise a soft bound) */",
        "#define DRE_PD_INFERRED 0x10u /**< inferred (name, physics, ODrive), not documented by the vendor */",
        "",
        "/** The domain of one parameter; parameters without a row take any value of their type. */",
        "typedef struct {",
        "    uint16_t address;",
        "    uint8_t flags; /**< DRE_PD_* */",
        "    uint8_t count; /**< DRE_PD_SET: number of allowed values */",
        "    uint8_t first; /**< DRE_PD_SET: index of the first in dre_param_allowed */",
        "    float lo;      /**< DRE_PD_MIN */",
        "    float hi;      /**< DRE_PD_MAX */",
        "} dre_param_domain;",
        "",
        f"#define DRE_PARAM_DOMAIN_COUNT {len(doms)}u",
        f"#define DRE_PARAM_ALLOWED_COUNT {nallowed}u",
        "",
        "/** Every domain, sorted by address. */",
        "extern const dre_param_domain dre_param_domains[DRE_PARAM_DOMAIN_COUNT];",
        "/** The allowed values of the DRE_PD_SET domains. */",
        "extern const float dre_param_allowed[DRE_PARAM_ALLOWED_COUNT];",
        "",
        "/** The domain of the parameter at `address`, or NULL when it takes any value of its type. */",
        "const dre_param_domain *dre_param_domain_of(uint16_t address);",
        "",
        "/**",
        " * Does `value` (of data type `dtype`) lie in the domain of the parameter at",
        " * `address`? DRE_OK when it does, when the parameter has no domain, or when",
        " * `force` is non-zero and only a soft bound is exceeded; DRE_E_RANGE",
        " * otherwise (a NaN is outside every domain). The wire range of the data type",
        " * is the encoder's check (dre_encode), force or not.",
        " */",
        "dre_status dre_param_check(uint16_t address, uint8_t dtype, dre_value value, int force);",
        "",
    ]


def _c_domain_table(rows: list[Row]) -> list[str]:
    doms = [r for r in rows if r.has_domain]
    out = ["const dre_param_domain dre_param_domains[DRE_PARAM_DOMAIN_COUNT] = {"]
    allowed: list[float] = []
    first: dict[tuple[float, ...], int] = {}
    for r in doms:
        if r.allowed and r.allowed not in first:
            first[r.allowed] = len(allowed)
            allowed += r.allowed
        flags = []
        if r.minimum is not None:
            flags.append("DRE_PD_MIN")
        if r.maximum is not None:
            flags.append("DRE_PD_MAX")
        if r.allowed:
            flags.append("DRE_PD_SET")
        if r.hard:
            flags.append("DRE_PD_HARD")
        if r.inferred:
            flags.append("DRE_PD_INFERRED")
        lo = _c_float(r.minimum if r.minimum is not None else 0.0)
        hi = _c_float(r.maximum if r.maximum is not None else 0.0)
        out.append(
            f"    {{{r.address}u, {' | '.join(flags)}, {len(r.allowed)}u, {first.get(r.allowed, 0)}u, {lo}, {hi}}},"
            f" /* {r.name} */"
        )
    if len(allowed) > 255:
        raise SystemExit("too many allowed values for the u8 index of dre_param_domain")
    out += ["};", "const float dre_param_allowed[DRE_PARAM_ALLOWED_COUNT] = {"]
    out += ["    " + ", ".join(_c_float(v) for v in allowed[i : i + 8]) + "," for i in range(0, len(allowed), 8)]
    out.append("};")
    return out


TARGETS: dict[str, tuple[Path, Callable[[list[Row]], str]]] = {
    "python": (ROOT / "python" / "src" / "drempower" / "protocol" / "_parameter_table.py", render_python),
    "python-addresses": (ROOT / "python" / "src" / "drempower" / "protocol" / "addresses.py", render_addresses),
    "c": (ROOT / "c" / "include" / "drempower" / "dre_params.h", render_c),
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="do not write; exit 1 if a target is stale")
    args = ap.parse_args(argv)
    rows = load_rows()
    stale = []
    for name, (path, render) in TARGETS.items():
        text = render(rows)
        current = path.read_text(encoding="utf-8") if path.exists() else None
        if current == text:
            continue
        if args.check:
            stale.append(f"{name}: {path.relative_to(ROOT)}")
        else:
            path.write_text(text, encoding="utf-8")
            print(f"wrote {path.relative_to(ROOT)}")
    if stale:
        print("stale generated files (run python3 tools/generate.py):\n  " + "\n  ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
