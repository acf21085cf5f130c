#!/usr/bin/env python3
"""Turn the client-behaviour vectors (spec/vectors/client/*.json) into client_vectors_table.c.

Usage: gen_client_vectors.py [--check]

Writes c/tests/client_vectors_table.c next to this script (committed, so the
table can be read and diffed); with --check it writes nothing and exits 1 when
the file is stale. Vectors whose "implementations" leave out "c" are skipped.
Only the standard library is used (and gen_vector_table.py's message encoder).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from gen_vector_table import c_float, c_msg, c_string  # noqa: E402

ROOT = HERE.parent.parent
SOURCE = ROOT / "spec" / "vectors" / "client"
OUT = HERE / "client_vectors_table.c"
DTYPES = {k: f"DRE_{k.upper()}" for k in ("f32", "u16", "s16", "u32", "s32")}
STATUS = {
    "pending": "CV_PENDING",
    "ok": "CV_OK",
    "timeout": "CV_TIMEOUT",
    "move_error": "CV_MOVE_ERROR",
    "fault": "CV_FAULT",
}
ACTIONS = {
    "read": "CV_READ",
    "get_state": "CV_GET_STATE",
    "preset_start": "CV_PRESET_START",
    "send": "CV_SEND",
    "wait_done": "CV_WAIT_DONE",
}
NO_MSG = "{DRE_MSG_NONE, 0, {.preset = {0.0f, 0.0f, 0.0f}}}"


def c_frame(f: dict) -> str:
    data = bytes.fromhex(f["data"])
    return f"{{{f['id']}u, {len(data)}u, {{{', '.join(f'0x{b:02X}' for b in data)}}}}}"


def step_row(at: int, kind: str, **kw: str) -> str:
    f = {
        "req": "CV_NO_REQ",
        "node": "0",
        "dtype": "0",
        "address": "0",
        "first": "0",
        "count": "0",
        "start": NO_MSG,
        "timeout_ms": "0",
        "poll_ms": "0",
        "status": "CV_PENDING",
        "has_value": "0",
        "has_position": "0",
        "has_tdone": "0",
        "value": "0",
        "position": "0.0f",
        "trajectory_done": "0",
        "unmatched": "CV_NOT_CHECKED",
        "anomalies": "CV_NOT_CHECKED",
    }
    f.update(kw)
    return "    {" + f"{at}u, {kind}, " + ", ".join(f".{k} = {v}" for k, v in f.items() if k) + "},"


def generate() -> str:
    vectors, steps, frames, msgs, nodes = [], [], [], [], []
    for path in sorted(SOURCE.glob("*.json")):
        for vec in json.loads(path.read_text(encoding="utf-8"))["vectors"]:
            if "c" not in vec.get("implementations", ["python", "c"]):
                continue
            cfg = vec["config"]
            reqs: dict[str, int] = {}
            first = len(steps)
            for s in vec["steps"]:
                at = s["at"]
                if "do" in s:
                    do = s["do"]
                    kw = {}
                    if "req" in s:
                        kw["req"] = str(reqs.setdefault(s["req"], len(reqs)))
                    if do == "read":
                        kw.update(node=str(s["node"]), dtype=DTYPES[s["dtype"]], address=f"{s['address']}u")
                    elif do == "get_state":
                        kw["node"] = str(s["node"])
                    elif do in ("preset_start", "send"):
                        items = s["presets"] if do == "preset_start" else s["messages"]
                        kw.update(first=str(len(msgs)), count=str(len(items)))
                        msgs.extend(c_msg(m["message"], m["node"], m["fields"]) for m in items)
                        if do == "preset_start":
                            kw["start"] = c_msg("start", 0, s["start"])
                    elif do == "wait_done":
                        kw.update(
                            first=str(len(nodes)),
                            count=str(len(s["nodes"])),
                            timeout_ms=f"{s['timeout_ms']}u",
                            poll_ms=f"{s['poll_ms']}u",
                        )
                        nodes.extend(str(n) for n in s["nodes"])
                    steps.append(step_row(at, ACTIONS[do], **kw))
                elif "rx" in s or "tx" in s:
                    items = [s["rx"]] if "rx" in s else s["tx"]
                    steps.append(
                        step_row(at, "CV_RX" if "rx" in s else "CV_TX", first=str(len(frames)), count=str(len(items)))
                    )
                    frames.extend(c_frame(f) for f in items)
                elif "tx_done" in s:
                    steps.append(step_row(at, "CV_TX_DONE"))
                elif "expect" in s:
                    counts = s.get("counts", {})
                    kc = {k: str(counts[k]) for k in ("unmatched", "anomalies") if k in counts}
                    for name, want in s["expect"].items():
                        kw = {"req": str(reqs[name]), "status": STATUS[want["status"]]}
                        if "value" in want:
                            kw.update(has_value="1", value=f"INT64_C({want['value']})")
                        if "position" in want:
                            kw.update(has_position="1", position=c_float(want["position"]))
                        if "trajectory_done" in want:
                            kw.update(has_tdone="1", trajectory_done=str(int(want["trajectory_done"])))
                        steps.append(step_row(at, "CV_EXPECT", **kw, **kc))
                        kc = {}
                    if kc:
                        steps.append(step_row(at, "CV_EXPECT", **kc))
                else:
                    raise SystemExit(f"{path.name}: {vec['name']}: unknown step {s}")
            confirmed = {"in_order": "0", "confirmed": "1"}[cfg.get("tx", "in_order")]
            vectors.append(
                f"    {{{c_string(path.name)}, {c_string(vec['name'])}, {cfg['timeout_ms']}u, {confirmed}, "
                f"{cfg.get('retries', 0)}u, {first}u, {len(steps) - first}u}},"
            )
    return "\n".join(
        [
            "/* Generated by gen_client_vectors.py from spec/vectors/client: do not edit. */",
            "#include <stdint.h>",
            "",
            '#include "client_vectors.h"',
            "",
            "const dre_frame cv_frames[] = {",
            *(f"    {f}," for f in frames or ["{0u, 0u, {0}}"]),
            "};",
            "const dre_msg cv_msgs[] = {",
            *(f"    {m}," for m in msgs or [NO_MSG]),
            "};",
            "const uint8_t cv_nodes[] = {" + ", ".join(nodes or ["0"]) + "};",
            "const cv_step cv_steps[] = {",
            *steps,
            "};",
            "const cv_vector cv_vectors[] = {",
            *vectors,
            "};",
            "const unsigned cv_nvectors = sizeof cv_vectors / sizeof cv_vectors[0];",
            "",
        ]
    )


def main(argv: list[str]) -> int:
    text = generate()
    if argv[1:] == ["--check"]:
        if not OUT.exists() or OUT.read_text(encoding="utf-8") != text:
            print(f"{OUT.name} is stale: run c/tests/gen_client_vectors.py", file=sys.stderr)
            return 1
        return 0
    if argv[1:]:
        print(__doc__.splitlines()[2], file=sys.stderr)
        return 2
    OUT.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
