"""set_id on scripted time: it never makes two motors share an id, and saves nothing it did not check."""

from __future__ import annotations

import pytest

from drempower.client.engine.ops import set_id
from drempower.client.errors import IdTakenError, NoMotorError
from drempower.protocol import FastRead, SystemCommand, WriteParam

from .rig import Rig


def test_an_id_already_answered_is_refused_without_waiting_or_writing() -> None:
    rig = Rig([1, 2], timeout=0.1)
    opn = rig.run(set_id(rig.session, 2, 1))
    with pytest.raises(IdTakenError, match="id 1 is already taken"):
        opn.result()
    assert [c for _, c in rig.wire] == [FastRead(2), FastRead(1)] and rig.now == pytest.approx(0.001)


def test_a_missing_motor_is_named_at_the_timeout_and_nothing_is_written() -> None:
    rig = Rig([1, 2], timeout=0.1)
    opn = rig.run(set_id(rig.session, 3, 5))
    with pytest.raises(NoMotorError, match="no motor answers at id 3"):
        opn.result()
    assert [c for _, c in rig.wire] == [FastRead(3), FastRead(5)] and rig.now == pytest.approx(0.1)


def test_a_lost_write_saves_nothing() -> None:
    rig = Rig([3], timeout=0.1)  # the scripted motor ignores writes: it keeps answering at 3
    opn = rig.run(set_id(rig.session, 3, 9))
    with pytest.raises(NoMotorError, match="does not answer at its new id 9; nothing was saved"):
        opn.result()
    assert len(rig.sent(WriteParam)) == 1 and not rig.sent(SystemCommand)
