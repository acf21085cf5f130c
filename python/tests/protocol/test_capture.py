"""Decoding a capture in order: a parameter reply of value 0 is told from its read request."""

from __future__ import annotations

from drempower.protocol import CaptureDecoder, DataType, FastRead, ParamValue, ReadParam, decode_frame


def _frame(msg: ReadParam | ParamValue) -> tuple[int, bytes]:
    f = msg.encode()
    return f.arbitration_id, f.data


def test_zero_reply_repeats_the_request_bytes() -> None:
    """The ambiguity this decoder exists for, from the encoder itself."""
    assert _frame(ReadParam(3, 30001, DataType.U32)) == _frame(ParamValue(3, 30001, DataType.U32, 0))
    assert decode_frame(*_frame(ParamValue(3, 30001, DataType.U32, 0)))[0] == "host"


def test_read_then_zero_reply_then_next_read() -> None:
    cap = CaptureDecoder()
    read = _frame(ReadParam(3, 30001, DataType.U32))
    assert cap.decode(*read) == ("host", ReadParam(3, 30001, DataType.U32))
    assert cap.decode(*read) == ("motor", ParamValue(3, 30001, DataType.U32, 0))
    assert cap.decode(*read)[0] == "host"  # answered: the same bytes again are a new read


def test_non_zero_reply_closes_the_read() -> None:
    cap = CaptureDecoder()
    read = _frame(ReadParam(1, 38007, DataType.F32))
    assert cap.decode(*read)[0] == "host"
    assert cap.decode(*_frame(ParamValue(1, 38007, DataType.F32, 12.5))) == (
        "motor",
        ParamValue(1, 38007, DataType.F32, 12.5),
    )
    assert cap.decode(*read)[0] == "host"


def test_reads_of_other_motors_and_parameters_do_not_pair() -> None:
    cap = CaptureDecoder()
    assert cap.decode(*_frame(ReadParam(1, 30001, DataType.U32)))[0] == "host"
    assert cap.decode(*_frame(ReadParam(2, 30001, DataType.U32)))[0] == "host"
    assert cap.decode(*_frame(ReadParam(1, 30002, DataType.U32)))[0] == "host"
    assert cap.decode(*_frame(ReadParam(2, 30001, DataType.U32)))[0] == "motor"


def test_an_unanswered_read_expires_with_the_frames_times() -> None:
    cap = CaptureDecoder(reply_window=0.1)
    read = _frame(ReadParam(4, 30001, DataType.U32))
    assert cap.decode(*read, time=10.0)[0] == "host"
    assert cap.decode(*read, time=10.5)[0] == "host"  # a retry, not a reply
    assert cap.decode(*read, time=10.501)[0] == "motor"


def test_a_forced_direction_is_kept() -> None:
    cap = CaptureDecoder()
    read = _frame(ReadParam(4, 30001, DataType.U32))
    assert cap.decode(*read, direction="host")[0] == "host"
    assert cap.decode(*read, direction="host")[0] == "host"


def test_repeated_fast_reads_stay_fast_reads() -> None:
    """A fast read (address 0) is answered by a state frame, never by an identical frame."""
    cap = CaptureDecoder()
    f = FastRead(2).encode()
    assert [cap.decode(f.arbitration_id, f.data, time=t) for t in (1.0, 1.1, 1.2)] == [("host", FastRead(2))] * 3
