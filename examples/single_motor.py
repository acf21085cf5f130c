"""One motor: read its state, make a trapezoid move, wait for it, spin, stop.

Runs against a simulated motor by default; see _common.py for real hardware.
"""

from __future__ import annotations

import time

from _common import motor_ids, open_bus, parser

from drempower import PositionMode


def main() -> None:
    args = parser(__doc__ or "").parse_args()
    with open_bus(args) as bus:  # closing the bus idles the motors it moved
        m = bus.motor(motor_ids(args)[0])
        print("state:", m.get_state())
        volts, amps = m.get_volcur()
        print(f"supply {volts:.1f} V, current {amps:.2f} A")
        print("errors:", m.dump_error())

        m.set_mode(2)  # closed loop
        m.set_angle(90, speed=30, param=60, mode=PositionMode.Q)  # 30 r/min cruise, 60 (r/min)/s accel
        done = m.wait_position_done(timeout=10)
        print(f"reached {done.angle:.2f} deg")

        m.step_angle(-45, speed=30, param=60, mode=PositionMode.Q)  # relative move; only this motor starts
        print(f"stepped to {m.wait_position_done(timeout=10).angle:.2f} deg")

        m.set_speed(20, param=40, mode=2)  # ramp to 20 r/min at 40 (r/min)/s
        time.sleep(1.0)
        print(f"spinning at {m.get_state().speed:.1f} r/min")
        m.estop()  # immediate; no reply awaited
        print("after estop:", m.dump_error())
        m.clear_error()


if __name__ == "__main__":
    main()
