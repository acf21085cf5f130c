"""The Tuning view's "Propose gains" in a real headless Chromium against simulated motors: asked before the
joint moves, the proposal shown beside the present gains' step, written only when confirmed."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from drempower.motion.tune import GAIN_NAMES

from .conftest import Served
from .test_browser import reset, scan, tab


def test_propose_gains_asks_shows_and_writes_only_on_confirmation(page: Any, served: Served, shots: Path) -> None:
    reset(served)
    scan(page)
    tab(page, "Tuning")
    page.locator("#tun-motor").select_option("2")
    page.wait_for_selector("#tun-gains input[data-gain]")
    factory = [served.bus.motor(2).read_property(n) for n in GAIN_NAMES]
    answers = [False, True, False, True]  # no to the first proposal, yes; no to the first write, yes
    asked: list[str] = []

    def dialog(d: Any) -> None:
        asked.append(d.message)
        d.accept() if answers.pop(0) else d.dismiss()

    page.on("dialog", dialog)
    page.locator("#prop-bw").fill("2")
    page.get_by_role("button", name="Propose gains").click()
    page.wait_for_timeout(300)
    assert len(asked) == 1 and "it is excited" in asked[0] and page.locator("#prop-table").is_hidden()
    page.get_by_role("button", name="Propose gains").click()
    page.wait_for_selector("#prop-table tbody tr:nth-child(2)", timeout=30_000)
    assert [served.bus.motor(2).read_property(n) for n in GAIN_NAMES] == factory  # nothing written yet
    proposed = page.locator("#prop-table tbody tr").nth(1).locator("td").all_inner_texts()
    assert proposed[0] == "proposed" and float(proposed[1]) == round(4 * math.pi, 4)
    assert "inertia" in page.locator("#prop-what").inner_text()
    page.get_by_role("button", name="Write proposed gains").click()
    page.wait_for_timeout(300)
    assert [served.bus.motor(2).read_property(n) for n in GAIN_NAMES] == factory  # the write was declined
    page.get_by_role("button", name="Write proposed gains").click()
    page.wait_for_function(
        "document.querySelector('#prop-table tbody tr:nth-child(2) td').textContent.startsWith('written')",
        timeout=20_000,
    )
    written = [served.bus.motor(2).read_property(n) for n in GAIN_NAMES]
    assert written[0] == round(4 * math.pi, 4) or abs(written[0] - 4 * math.pi) < 1e-4
    after = page.locator("#prop-table tbody tr").nth(1).locator("td").all_inner_texts()
    assert after[5] != "-" and after[7] != "never"  # the step after: a rise time and a settling time
    assert len(asked) == 4 and page.locator("#prop-write").is_disabled()
    page.screenshot(path=str(shots / "dash-propose.png"))
    for name, value in zip(GAIN_NAMES, factory, strict=True):
        served.bus.motor(2).write_property(name, value)
    reset(served)
