"""``/diagnostics`` read by a Zenoh client in rmw_zenoh's formats: one status per joint, OK/WARN/ERROR with the
health key-values, every second and at once when a motor faults."""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any

from drempower.bridge import rmw, rosmsg
from drempower.bridge.diagnostics import DIAGNOSTIC_ARRAY, ERROR, OK, WARN

from .conftest import Served, session, wait_for

KEY = f"0/diagnostics/diagnostic_msgs::msg::dds_::DiagnosticArray_/{rosmsg.ros_type_hash(DIAGNOSTIC_ARRAY)}"


class _Listener:
    def __init__(self) -> None:
        self.got: list[tuple[float, Any, rmw.Attachment]] = []
        self.lock = threading.Lock()

    def __call__(self, sample: Any) -> None:
        msg = rosmsg.decode(sample.payload.to_bytes(), DIAGNOSTIC_ARRAY)
        with self.lock:
            self.got.append((time.monotonic(), msg, rmw.Attachment.decode(sample.attachment.to_bytes())))

    def statuses(self) -> dict[str, Any]:
        with self.lock:
            return {s.name: s for s in self.got[-1][1].status}


def test_one_status_per_joint_with_the_health_values_about_once_a_second(served: Served) -> None:
    assert served.bridge.diagnostics_key == KEY
    heard = _Listener()
    with session(connect=[served.endpoint]) as ros:
        sub = ros.declare_subscriber(KEY, heard)
        wait_for(lambda: len(heard.got) >= 3, limit=10)
        sub.undeclare()
    st = heard.statuses()
    assert set(st) == {"drempower/motor_1", "drempower/motor_2"}
    one = st["drempower/motor_1"]
    assert one.level == OK and one.hardware_id == "motor 1" and one.message == "OK"
    values = {kv.key: kv.value for kv in one.values}
    assert set(values) == {"motor_temp_c", "driver_temp_c", "current_limit_a", "derating", "errors"}
    assert float(values["current_limit_a"]) == 15.0 and values["errors"] == "none"
    times = [t for t, _, _ in heard.got]
    gaps = [b - a for a, b in itertools.pairwise(times)]
    assert all(0.5 < g < 2.5 for g in gaps), gaps  # 1 Hz, on a shared machine
    seqs = [a.sequence_number for _, _, a in heard.got]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)


def test_hot_is_warn_and_a_fault_is_error_published_at_once(served: Served) -> None:
    motors = served.sim.bus.motors
    motors[1].thermal.winding = 96.0  # derating
    heard = _Listener()
    with session(connect=[served.endpoint]) as ros:
        sub = ros.declare_subscriber(KEY, heard)
        wait_for(lambda: bool(heard.got) and heard.statuses()["drempower/motor_1"].level == WARN, limit=10)
        warn = heard.statuses()["drempower/motor_1"]
        assert "derates" in warn.message and "motor 1" in warn.message
        assert float({kv.key: kv.value for kv in warn.values}["derating"]) > 0.1
        wait_for(lambda: len(heard.got) >= 2, limit=10)  # a full period begins
        with heard.lock:
            before = len(heard.got)
        t0 = time.monotonic()
        motors[2].thermal.board = 101.0  # the firmware trips: the state stream's E bit changes
        wait_for(lambda: heard.statuses()["drempower/motor_2"].level == ERROR, limit=10)
        took = time.monotonic() - t0
        sub.undeclare()
    err = heard.statuses()["drempower/motor_2"]
    assert "fet_thermistor" in err.message and "OVER_TEMP" in err.message and "Fix:" in err.message
    assert "fet_thermistor.OVER_TEMP" in {kv.key: kv.value for kv in err.values}["errors"]
    print(f"error published {took:.3f} s after the trip, {len(heard.got) - before} arrays")
    assert took < 0.9  # on change: before the next 1 Hz array would have been due
