"""The bus core's frame taps: every frame both ways, in order; a failing tap harms nothing."""

from __future__ import annotations

from drempower import open_bus
from drempower.protocol import FastRead
from drempower.protocol.ids import Frame


def test_taps_see_sent_and_received_frames_and_can_be_removed() -> None:
    seen: list[tuple[Frame, bool]] = []

    def broken(frame: Frame, tx: bool) -> None:
        raise RuntimeError("a faulty tap")

    with open_bus("sim", motors=[2]) as bus:
        bus.add_tap(broken)
        bus.add_tap(lambda f, tx: seen.append((f, tx)))
        st = bus.motor(2).get_state()  # the faulty tap is logged and skipped: the exchange still works
        assert st.node == 2
        assert [(f.arbitration_id, tx) for f, tx in seen] == [
            (FastRead(2).encode().arbitration_id, True),
            (0x43, False),
        ]
        bus.remove_tap(broken)
        for tap in bus._core.frame_taps:
            bus.remove_tap(tap)
        bus.motor(2).get_state()
        assert len(seen) == 2
