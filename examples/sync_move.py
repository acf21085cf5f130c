"""Synchronised move: several motors start together and arrive together (Q mode, one broadcast start).

The move time follows the vendor's formula for the motor that moves furthest,
from freshly read positions and each motor's real trajectory mode.
"""

from __future__ import annotations

from _common import motor_ids, open_bus, parser


def main() -> None:
    args = parser(__doc__ or "", ids="1,2,3").parse_args()
    ids = motor_ids(args)
    with open_bus(args) as bus:
        bus.enable(ids)  # closed loop: a motor left idle by an earlier program would not move
        targets = [30.0 * (i + 1) * (-1) ** i for i in range(len(ids))]
        t = bus.set_angles(ids, targets, speed=30, param=60, mode=1)
        print(f"moving {ids} to {targets}: {t:.2f} s")
        for node, st in sorted(bus.positions_done(ids, timeout=(t or 0) + 5).items()):
            print(f"  motor {node}: {st.angle:8.2f} deg")
        bus.step_angles(ids, [-a for a in targets], speed=30, param=60, mode=1)  # and back, relative
        final = bus.positions_done(ids, timeout=(t or 0) + 5)
        print("back at", {n: round(s.angle, 2) for n, s in sorted(final.items())})


if __name__ == "__main__":
    main()
