"""``drempower twin fit`` and ``twin check`` against a hidden truth: the example arm with other joint
parameters, a transport delay and sensor noise, recorded on the virtual clock while it follows an
excitation (see ``fit_support``).

The fit recovers each fitted joint's armature, damping and friction loss within 20 %; on a held-out
recording the fitted twin's RMS position error is at most half the nominal twin's; a joint the recording
does not move is refused in one line naming it and the parameter, before the fit; so is, after it, a
parameter the recording does not tell well enough (its uncertainty beyond --max-error), and ``--fixed``
keeps it.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from drempower.cli import main

from .conftest import ROBOTS
from .fit_support import NOISE, TRUTH, record, truth_robot

pytest.importorskip("scipy", reason="the twin fit needs the fit extra: pip install 'drempower[fit]'")
pytest.importorskip("mcap_ros2", reason="recordings need the records extra")

FITTED = ("elbow", "wrist_pitch")
"""The joints the test fits (a shorter test than all six; bench/bench_twin.py fits all six)."""
ARM = ROBOTS / "arm6.toml"


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("twin-fit")
    real = truth_robot(tmp, {j: TRUTH[j] for j in FITTED})
    return {
        "fit": record(real, tmp / "fit.mcap", 8.0, joints=FITTED),
        "held": record(real, tmp / "held.mcap", 6.0, joints=FITTED, amplitude=0.25),
        "real": real,
        "tmp": tmp,
    }


@pytest.mark.timeout(900)
def test_fit_recovers_the_truth_and_the_fitted_twin_halves_the_error(
    recordings: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    out = recordings["tmp"] / "arm6.fitted.toml"
    started = time.monotonic()
    code = main(
        [
            "twin",
            "fit",
            str(recordings["fit"]),
            "--robot",
            str(ARM),
            "--joints",
            ",".join(FITTED),
            "--write",
            str(out),
            "--json",
        ]
    )
    took = time.monotonic() - started
    assert code == 0, capsys.readouterr().err
    got = json.loads(capsys.readouterr().out)
    assert set(got["joints"]) == set(FITTED)
    for j in FITTED:
        for p, truth in TRUTH[j].items():
            value = got["joints"][j][p]
            assert value == pytest.approx(truth, rel=0.2), (j, p, value, truth)
            assert got["nominal"][j][p] != pytest.approx(truth, rel=0.2)  # the start was not the answer
            assert 0 < got["uncertainty"][j][p] <= 0.2  # told well enough to be reported
            assert abs(got["timing"][j][p]) <= got["uncertainty"][j][p]
        assert got["rms_deg"][j] < got["rms_deg_nominal"][j]
    assert got["written"]["robot"] == str(out) and out.with_suffix(".xml").is_file()
    with capsys.disabled():
        print(f"fit of {len(FITTED)} joints, 8 s: {took:.0f} s, {got['evaluations']} replays: {got['joints']}")

    def check(robot: Path) -> dict[str, dict[str, float]]:
        assert main(["twin", "check", str(recordings["held"]), "--robot", str(robot), "--json"]) == 0
        return json.loads(capsys.readouterr().out)["joints"]

    nominal, fitted = check(ARM), check(out)
    with capsys.disabled():
        print({j: (round(nominal[j]["rms_deg"], 4), round(fitted[j]["rms_deg"], 4)) for j in FITTED})
    for j in FITTED:
        assert fitted[j]["rms_deg"] <= 0.5 * nominal[j]["rms_deg"], (j, fitted[j], nominal[j])
        assert fitted[j]["max_deg"] < nominal[j]["max_deg"]


def test_a_joint_the_recording_does_not_move_is_refused(
    recordings: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["twin", "fit", str(recordings["held"]), "--robot", str(ARM), "--joints", "elbow,shoulder"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "joint 'shoulder'" in err[0] and "does not excite its frictionloss" in err[0] and "--joints" in err[0]
    assert main(["twin", "fit", str(recordings["held"]), "--robot", str(ARM), "--joints", "knee"]) == 2
    assert "'knee' is not a joint" in capsys.readouterr().err
    assert main(["twin", "fit", str(recordings["tmp"] / "none.mcap"), "--robot", str(ARM)]) == 2
    assert "none.mcap" in capsys.readouterr().err


def test_check_draws_robot_and_twin(recordings: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    page = recordings["tmp"] / "check.html"
    assert (
        main(["twin", "check", str(recordings["held"]), "--robot", str(recordings["real"]), "--plot", str(page)]) == 0
    )
    text = capsys.readouterr().out
    assert "largest RMS position error" in text and "wrote" in text
    html = page.read_text()
    assert html.count("<svg") == 6 * 3 and html.count("<polyline") == 2 * 6 * 3 and "<script" not in html
    # the truth's own twin replays its recording closely
    assert main(["twin", "check", str(recordings["held"]), "--robot", str(recordings["real"]), "--json"]) == 0
    truth = json.loads(capsys.readouterr().out)["joints"]
    assert all(row["rms_deg"] < 0.1 for row in truth.values()), truth


def test_a_parameter_not_told_well_enough_is_refused_and_can_be_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The fit's uncertainty of each parameter decides: beyond ``--max-error`` (here set just under the
    largest found), that parameter is refused in one line naming the joint and the parameter; ``--fixed``
    keeps it at the robot file's value and fits the rest."""
    assert NOISE.position > 0
    real = truth_robot(tmp_path, {"wrist_pitch": TRUTH["wrist_pitch"]})
    rec = record(real, tmp_path / "wrist.mcap", 6.0, joints=["wrist_pitch"])
    argv = ["twin", "fit", str(rec), "--robot", str(ARM), "--joints", "wrist_pitch", "--json"]
    assert main(argv) == 0, capsys.readouterr().err
    got = json.loads(capsys.readouterr().out)
    uncertain, timing = got["uncertainty"]["wrist_pitch"], got["timing"]["wrist_pitch"]
    assert set(uncertain) == set(TRUTH["wrist_pitch"]) and all(0 < u <= 0.2 for u in uncertain.values())
    assert all(abs(timing[p]) <= uncertain[p] for p in uncertain)
    worst = max(uncertain, key=lambda p: uncertain[p])
    limit = max(0.001, round(0.9 * uncertain[worst], 4))
    assert main([*argv, "--max-error", str(limit)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip().splitlines()
    assert len(err) == 1, err
    assert f"joint 'wrist_pitch': the recording does not excite its {worst} enough to fit it (uncertain by" in err[0]
    assert f"per ms of timing error; needs <= {100 * limit:g} %" in err[0]
    fixed = err[0].rsplit("--fixed ", 1)[1].split(",")
    assert fixed[0] == f"wrist_pitch.{worst}"
    # kept at the robot file's value, the rest is fitted
    assert main([*argv, "--fixed", ",".join(fixed)]) == 0, capsys.readouterr().err
    got = json.loads(capsys.readouterr().out)
    values, nominal = got["joints"]["wrist_pitch"], got["nominal"]["wrist_pitch"]
    for p, truth in TRUTH["wrist_pitch"].items():
        if f"wrist_pitch.{p}" in fixed:
            assert values[p] == nominal[p] and p not in got["uncertainty"]["wrist_pitch"]
        else:
            assert values[p] == pytest.approx(truth, rel=0.2), (p, values[p], truth)
    assert main([*argv, "--fixed", "wrist_pitch.stiffness"]) == 2
    assert "fixed 'wrist_pitch.stiffness': expected JOINT.PARAMETER" in capsys.readouterr().err
