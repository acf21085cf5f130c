"""Impedance control: a virtual spring (Kp) and damper (Kd) around a target angle.

torque = tff + Kp * (pos - P) + Kd * (vel - V), Kp in Nm/rad, Kd in Nm/(rad/s).
The start command goes to this motor only, so other motors keep their gains.
"""

from __future__ import annotations

import time

from _common import motor_ids, open_bus, parser


def main() -> None:
    p = parser(__doc__ or "")
    p.add_argument("--kp", type=float, default=2.0, help="stiffness, Nm/rad")
    p.add_argument("--kd", type=float, default=0.1, help="damping, Nm/(rad/s)")
    args = p.parse_args()
    with open_bus(args) as bus:
        m = bus.motor(motor_ids(args)[0])
        start = m.get_state().angle
        target = start + 45
        m.impedance_control(target, 0, 0, args.kp, args.kd, enable=True)  # enabled first if it was idle
        print(f"spring to {target:.1f} deg with Kp={args.kp} Nm/rad, Kd={args.kd} Nm/(rad/s)")
        for _ in range(10):
            time.sleep(0.1)
            st = m.get_state()
            print(f"  {st.angle:8.2f} deg {st.speed:7.2f} r/min {st.torque:6.2f} Nm")
        print(f"the spring moved the motor {st.angle - start:.1f} deg of the 45")
        m.impedance_control(target, 0, 0, 0, args.kd)  # Kp = 0: pure damping
        print("pure damping now; closing the bus puts the motor in idle")


if __name__ == "__main__":
    main()
