"""identify on a busy host: the fit uses each state frame's own time, and a poor excitation or fit is
refused with one line (exit 1), never reported with a parameter far off."""

from __future__ import annotations

import math
import subprocess
import sys
import threading
import time

import pytest

import drempower
from drempower.cli import main
from drempower.cli._connect import TIME_SCALE_ENV
from drempower.motion import identify as ident
from drempower.motion.identify import IdentificationError, excitation, from_samples
from drempower.sim.defaults import MotorModel

J, B, C = 0.0048, 0.002, 0.1
"""The synthetic joint: inertia kg m^2, viscous Nm s/rad, Coulomb Nm."""


def _samples(rate: float = 200.0, seconds: float = 4.0) -> tuple[list[float], list[float], list[float], list[float]]:
    """A joint of inertia J with friction B, C driven by an impedance controller along the excitation,
    integrated finely and sampled at ``rate`` Hz: (s, rad, rad/s, Nm) with exact times."""
    q = v = 0.0
    dt = 1e-4
    ts: list[float] = []
    qs: list[float] = []
    vs: list[float] = []
    taus: list[float] = []
    every = round(1 / rate / dt)
    for k in range(round(seconds / dt)):
        t = k * dt
        ref, vel = excitation(t, 0.0, 0.3, seconds)
        tau = 5.0 * (ref - q) + 0.2 * (vel - v)
        if k % every == 0:
            ts.append(t)
            qs.append(q)
            vs.append(v)
            taus.append(tau)
        a = (tau - B * v - C * math.copysign(1.0, v) * (abs(v) > 1e-6)) / J
        v += a * dt
        q += v * dt
    return ts, qs, vs, taus


def test_the_fit_of_exact_samples_recovers_the_joint() -> None:
    got = from_samples("j", 200.0, *_samples(), seconds=4.0)
    assert got.inertia == pytest.approx(J, rel=0.03) and got.coulomb == pytest.approx(C, rel=0.05)
    assert got.fit > 0.99


def test_samples_a_busy_host_missed_are_refused_not_fitted() -> None:
    ts, qs, vs, taus = _samples()
    keep = [k for k in range(len(ts)) if k % 5 not in (1, 2)]  # two samples of every five never came
    with pytest.raises(IdentificationError, match=r"refused: \d+ of \d+ samples missed or late"):
        from_samples("j", 200.0, *([x[k] for k in keep] for x in (ts, qs, vs, taus)), seconds=4.0)


def test_a_poor_fit_is_refused() -> None:
    ts, qs, vs, taus = _samples()
    noisy = [tau + (0.3 if k % 2 else -0.3) for k, tau in enumerate(taus)]  # torque readings off by +-0.3 Nm
    with pytest.raises(IdentificationError, match="refused: a poor fit"):
        from_samples("j", 200.0, ts, qs, vs, noisy, seconds=4.0)


def test_the_bus_keeps_each_state_frames_own_time_when_the_simulator_falls_behind() -> None:
    """A simulator held up (as a busy host holds it) falls behind the host's clock; a state read then
    arrives late by the host's clock, but its frame's own time is the simulator's."""
    with drempower.open_bus("sim", motors=[1], stop_on_close=False) as bus:
        sim = bus.transport.bus  # type: ignore[attr-defined]
        bus.motor(1).get_state()
        before = bus.frame_time(1)
        assert before is not None
        held = threading.Event()

        def hold() -> None:
            with sim.lock:  # the simulator's thread cannot run: its clock stands still
                held.set()
                time.sleep(0.5)

        th = threading.Thread(target=hold)
        th.start()
        held.wait()
        st = bus.motor(1).get_state(timeout=2.0)
        th.join()
        own = bus.frame_time(1)
        assert own is not None
        # the host waited 0.5 s; the simulator made up at most a little of it (it falls behind)
        assert st.timestamp - before >= 0.45
        assert own - before < st.timestamp - before - 0.3


def test_drempower_identify_refuses_a_poor_fit_with_one_line_and_exit_1(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(ident, "MIN_FIT", 1.01)  # no fit is good enough
    monkeypatch.delenv(TIME_SCALE_ENV, raising=False)
    code = main(["identify", "1", "--sim", "1", "--yes", "--seconds", "2", "--json"])
    out, err = capsys.readouterr()
    assert code == 1 and out == ""
    assert err.startswith("drempower: error: identify: refused: a poor fit") and len(err.strip().splitlines()) == 1


@pytest.mark.timeout(120)
def test_identify_beside_three_busy_processes_is_close_to_the_truth_or_refused(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Real time, on the plain simulator, with three processes spinning beside it on the 2 cores."""
    monkeypatch.delenv(TIME_SCALE_ENV, raising=False)
    spin = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(3)]
    try:
        code = main(["identify", "1", "--sim", "1", "--yes", "--json", "--seconds", "4"])
    finally:
        for p in spin:
            p.kill()
            p.wait()
    out, err = capsys.readouterr()
    truth = MotorModel().rotor_inertia * 10.0**2  # the default gear ratio 10
    if code == 1:
        assert "identify: refused" in err and len(err.strip().splitlines()) == 1, err
    else:
        import json

        assert code == 0, err
        assert json.loads(out)["inertia"] == pytest.approx(truth, rel=0.3)
