"""Stream a trajectory at 200 Hz in T mode and read every motor's state each cycle.

Each period sends one T-mode target per motor and collects one state per motor
(``bus.cycle``): with ``enable_reply_state`` on, the control frame itself is
answered, otherwise a fast read follows it. The filter bandwidth is half the
command rate, as the vendor recommends.
"""

from __future__ import annotations

import math
import time

from _common import motor_ids, open_bus, parser

RATE = 200.0  # Hz
BANDWIDTH = RATE / 2  # 1/s


def main() -> None:
    p = parser(__doc__ or "", ids="1,2")
    p.add_argument("--seconds", type=float, default=2.0, help="how long to stream")
    p.add_argument("--amplitude", type=float, default=30.0, help="sine amplitude (deg)")
    args = p.parse_args()
    ids = motor_ids(args)
    with open_bus(args) as bus:
        motors = [bus.motor(i) for i in ids]
        bus.enable(ids)  # closed loop: a motor left idle by an earlier program would not follow
        for m in motors:
            m.enable_reply_state()  # one frame each way per motor and cycle
        start = {m.id: m.get_state().angle for m in motors}
        period, late, worst = 1.0 / RATE, 0, 0.0
        t0 = time.perf_counter()
        n = int(args.seconds * RATE)
        for k in range(n):
            phase = 2 * math.pi * 0.5 * k * period
            cmds = [
                m.make_angle(start[m.id] + args.amplitude * (j + 1) / len(motors) * math.sin(phase), 0, BANDWIDTH)
                for j, m in enumerate(motors)
            ]
            states = bus.cycle(cmds)
            worst = max(worst, max(abs(states[c.node].angle - c.position) for c in cmds))
            wait = t0 + (k + 1) * period - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            else:
                late += 1
        elapsed = time.perf_counter() - t0
        print(f"{n} cycles of {len(ids)} motors in {elapsed:.2f} s ({n / elapsed:.0f} Hz), {late} late")
        print(f"largest tracking error seen: {worst:.2f} deg")


if __name__ == "__main__":
    main()
