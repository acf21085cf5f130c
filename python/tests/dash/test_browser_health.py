"""The dashboard's health in headless Chromium: temperatures, the effective limit and derating on the cards, the
Health view's levels and trends, a fault decoded with its fix."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from drempower.sim.thermal import ThermalModel

from .conftest import Served
from .test_browser import scan, tab


def _warm(served: Served, node: int, degc: float) -> None:
    """Motor ``node`` in a room as warm as ``degc``: its winding and board stay there while the page watches."""
    t = served.sim.motors[node].thermal
    t.model = ThermalModel(ambient_c=degc, board_idle_w=0.0)
    t.winding = t.board = degc


def test_cards_and_health_view_show_heat_derating_and_a_fault_with_its_fix(
    page: Any, served: Served, shots: Path
) -> None:
    _warm(served, 2, 97.5)  # derating: half the current left
    _warm(served, 3, 101.0)  # beyond the upper limit: the firmware trips
    try:
        scan(page)
        page.wait_for_function(
            "[...document.querySelectorAll('.card')].some(c => c.innerText.includes('derating 50 %'))", timeout=10000
        )
        card2 = page.locator('.card[data-id="2"]').inner_text()
        assert "motor 97.5" in card2 and "limit 7.50 A" in card2
        assert "derating 0 %" in page.locator('.card[data-id="1"]').inner_text()
        tab(page, "Health")
        page.wait_for_function(
            "document.querySelectorAll('#health-table tbody tr').length === 3"
            " && document.querySelectorAll('#health-table polyline.winding').length === 3",
            timeout=10000,
        )
        rows = {r.get_attribute("data-id"): r for r in page.locator("#health-table tbody tr").all()}
        assert rows["1"].get_attribute("class") == "health-ok"
        assert rows["2"].get_attribute("class") == "health-warn"
        page.wait_for_function(
            "document.querySelector('#health-table tr[data-id=\"3\"]').className === 'health-error'", timeout=10000
        )
        text3 = page.locator('#health-table tr[data-id="3"]').inner_text()
        assert "axis0.motor_thermistor.error OVER_TEMP" in text3 and "Fix: Let it cool" in text3
        # the trend holds one point per card refresh: it grows while the page watches
        n0 = page.evaluate("document.querySelector('#health-table tr[data-id=\"2\"] polyline.winding')"
                           ".getAttribute('points').split(' ').length")  # fmt: skip
        page.wait_for_function(
            f"document.querySelector('#health-table tr[data-id=\"2\"] polyline.winding')"
            f".getAttribute('points').split(' ').length > {n0}",
            timeout=10000,
        )
        page.screenshot(path=str(shots / "dash-health.png"))
    finally:
        for node in (2, 3):
            _warm(served, node, ThermalModel().ambient_c)
            served.sim.motors[node].thermal.model = ThermalModel()
            served.bus.motor(node).clear_error()
            served.bus.motor(node).set_mode(2)
