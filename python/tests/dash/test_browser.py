"""The dashboard in a real headless Chromium against simulated motors."""

from __future__ import annotations

import csv
import io
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from drempower.protocol.enums import AxisState

from .conftest import Served


def eventually(cond: Callable[[], bool], limit: float = 5.0) -> bool:
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


def scan(page: Any) -> None:
    page.get_by_role("tab", name="Bus").click()
    # the page scans by itself when it finds no motors: let that scan end first, else its end ("done") could
    # arrive after the click below reset the progress, while this scan still waits behind it
    page.wait_for_function("document.querySelectorAll('#pw-names option').length > 0")  # the server's hello
    page.wait_for_function("!document.querySelector('#scan-text').textContent.startsWith('scanning')")
    page.get_by_role("button", name="Rescan ids 1-63").click()
    page.wait_for_function(
        "document.querySelector('#scan-progress').value === 63"
        " && document.querySelector('#scan-text').textContent.startsWith('done')"
    )
    page.wait_for_function("document.querySelectorAll('.card').length === 3")


def tab(page: Any, name: str) -> None:
    page.get_by_role("tab", name=name).click()


def reset(served: Served) -> None:
    """Motors back to closed loop at rest, errors cleared, nothing commanded (state left by an earlier test)."""
    for i in (1, 2, 3):
        m = served.bus.motor(i)
        m.clear_error()
        m.set_mode(2)
        m.set_speed(0)
    served.hub.commanded.clear()


def test_page_loads_and_scans(page: Any, served: Served, shots: Path) -> None:
    assert page.title() == "drempower dashboard"
    scan(page)
    assert page.locator("#scan-progress").evaluate("e => e.value") == 63
    assert page.locator("#scan-text").inner_text() == "done: 3 motor(s): motor_1, motor_2, motor_3"
    cards = page.locator(".card h3").all_inner_texts()
    assert cards == ["motor_1", "motor_2", "motor_3"]  # the naming rule, as every command names them
    page.wait_for_function("document.querySelector('.card').innerText.includes('closed_loop')")
    assert page.get_by_role("button", name="ESTOP").is_visible()
    page.screenshot(path=str(shots / "dash-bus.png"))


def test_plots_receive_every_sample(page: Any, served: Served, shots: Path) -> None:
    scan(page)
    tab(page, "Plots")
    for ch in ("speed", "torque"):
        page.locator(f"#plot-channels input[value={ch}]").check()
    served.bus.motor(2).set_speed(40)
    served.hub.commanded.add(2)
    page.wait_for_function("window.dashStats.received > 150")
    page.wait_for_function("window.dashStats.fps > 0")
    time.sleep(0.5)
    stats = page.evaluate("window.dashStats")
    # every sample the server sent since this page's first batch arrived (none lost)
    assert stats["received"] == stats["serverTotal"] - stats["firstTotal"]
    per = page.locator("#plot-per-motor").inner_text()
    assert "motor_1:" in per and "motor_3:" in per
    # the plot shows samples of all three motors: one series per motor and channel; a target only once one
    # is drawn (none was commanded here), one y axis per unit, one colour per motor
    labels = page.locator(".u-legend .u-series .u-label").all_inner_texts()
    assert "motor_2 speed" in labels and not any("target" in label for label in labels), labels
    axes = page.evaluate("window.dashPlot.axes.map(a => a.label)")
    assert axes == ["t / s", "angle / deg", "speed / r/min", "torque / Nm"], axes
    colours = page.evaluate(
        "[...document.querySelectorAll('#plot .u-legend .u-series .u-marker')].map(e => e.style.borderColor)"
    )
    by_motor = {label.split()[0]: c for label, c in zip(labels, colours, strict=False) if label != "t"}
    assert len(set(by_motor.values())) == len(by_motor) == 3, by_motor
    with page.expect_download() as dl:
        page.get_by_role("button", name="Export CSV").click()
    rows = list(csv.DictReader(io.StringIO(Path(dl.value.path()).read_text())))
    assert len(rows) > 100
    assert any(r["name"] == "motor_2" and r["id"] == "2" and abs(float(r["speed_rpm"]) - 40) < 2 for r in rows)
    assert {r["name"] for r in rows} == {"motor_1", "motor_2", "motor_3"}
    # a parameter polled at a chosen rate, on the same chart
    page.locator("#pw-motor").select_option("1")
    page.get_by_label("parameter to plot").fill("vbus_voltage")
    page.get_by_label("readings per second").select_option("10")
    page.get_by_role("button", name="Plot parameter").click()
    page.wait_for_function(
        "[...document.querySelectorAll('.u-legend .u-label')].some(e => e.textContent === 'motor_1 vbus_voltage')"
    )
    t0 = time.monotonic()
    page.wait_for_function("(() => { const d = window.dashParams('1:vbus_voltage'); return d && d.v.length >= 8; })()")
    assert time.monotonic() - t0 < 3
    assert page.evaluate("window.dashParams('1:vbus_voltage').v[0]") == served.sim.motors[1].param("vbus_voltage")
    page.screenshot(path=str(shots / "dash-plots.png"))
    page.get_by_role("button", name="stop plotting vbus_voltage").click()
    page.wait_for_function("document.querySelector('#pw-list').textContent === ''")
    served.bus.motor(2).set_speed(0)
    reset(served)


def test_move_from_the_page_reaches_the_motor(page: Any, served: Served, shots: Path) -> None:
    reset(served)
    scan(page)
    tab(page, "Control")
    page.locator("#ctl-motor").select_option("2")
    page.locator("#pos-angle").fill("45")
    page.locator("#pos-speed").fill("60")
    page.locator("#pos-param").fill("100")
    page.get_by_role("button", name="Move", exact=True).click()
    m2 = served.sim.motors[2]
    assert eventually(lambda: abs(m2.position - 45.0) < 0.1, 8), m2.position
    # the move's answer is on the page before the next input (a late one would overwrite the refusal below)
    page.wait_for_function("document.querySelector('#msg').textContent.includes('move to 45 deg')", timeout=10000)
    limits = page.locator("#ctl-limits").inner_text()
    assert limits == "limits of motor_2: speed ±300 r/min, torque ±12 Nm, current 15 A; T bandwidth 0..300 1/s"
    assert served.hub.commanded == {2}
    # an input outside its domain is refused in the page and nothing is sent
    page.locator("#pos-speed").fill("500")
    page.locator("#pos-mode").dispatch_event("change")  # the limits applied again (as a card arriving does)
    assert page.locator("#pos-speed").input_value() == "500"  # what the user typed is never changed by the page
    page.get_by_role("button", name="Move", exact=True).click()
    msg = page.locator("#msg").inner_text()
    assert "Position: speed r/min 500 is outside -300..300" in msg and "pos-speed" not in msg  # as labelled
    time.sleep(0.3)
    assert served.hub.targets[2][0] == 45.0  # no new command
    assert abs(served.sim.motors[2].position - 45.0) < 0.2
    page.locator("#pos-speed").fill("60")
    page.screenshot(path=str(shots / "dash-control.png"))
    # a synchronised move of the three motors
    for i, a in ((1, 10), (2, 20), (3, 30)):
        page.locator(f'.sync-angle[data-id="{i}"]').fill(str(a))
    page.get_by_role("button", name="Move selected together").click()
    assert eventually(lambda: all(abs(served.sim.motors[i].position - 10 * i) < 0.2 for i in (1, 2, 3)), 8)


def test_parameter_edit_round_trips(page: Any, served: Served, shots: Path) -> None:
    scan(page)
    tab(page, "Parameters")
    page.locator("#par-motor").select_option("1")
    page.get_by_role("button", name="Read all").click()
    name = "axis0.controller.config.pos_gain"
    value = page.locator(f'span[data-val="{name}"]')
    page.wait_for_function(f"document.querySelector('span[data-val=\"{name}\"]').textContent !== '-'")
    old = float(value.inner_text())
    new = old + 7.5
    page.get_by_label(name, exact=True).fill(str(new))
    page.locator(f'button[data-set="{name}"]').click()
    page.wait_for_function(f"document.querySelector('span[data-val=\"{name}\"]').textContent === '{new:g}'")
    assert served.sim.motors[1].param(name) == new
    row = page.locator(f'tr[data-name="{name}"]')
    assert "changed" in (row.get_attribute("class") or "")
    assert "changed this session" in (row.get_attribute("title") or "")  # not "since saved": flash is not read
    assert "changed this session" in page.locator("#par-status").inner_text()
    # a value outside the parameter's range: named in the message, nothing written
    hb = "can.config.heartbeat_ms"
    page.get_by_label(hb, exact=True).fill("-1")
    page.locator(f'button[data-set="{hb}"]').click()
    page.wait_for_function("document.querySelector('#msg').textContent.includes('heartbeat_ms')")
    assert served.sim.motors[1].param(hb) == 0
    page.locator("#par-filter").fill("controller.config")
    page.evaluate("window.scrollTo(0, 0)")
    page.screenshot(path=str(shots / "dash-params.png"))
    served.sim.motors[1].set_param(name, old)


def test_parameter_domains_bound_the_edits_and_force_crosses_a_soft_one(page: Any, served: Served) -> None:
    scan(page)
    tab(page, "Parameters")
    page.locator("#par-motor").select_option("2")
    gain, baud = "axis0.controller.config.pos_gain", "can.config.baud_rate"
    row = page.locator(f'tr[data-name="{gain}"]')
    assert row.locator("td.domain").inner_text().startswith("0..1000 (soft")
    old = served.sim.motors[2].param(gain)
    # outside the soft domain without force: refused, named, nothing written
    page.get_by_label(gain, exact=True).fill("1500")
    page.locator(f'button[data-set="{gain}"]').click()
    assert page.locator("#msg").inner_text() == (
        f"{gain}=1500 is outside its domain: 0..1000 (soft, inferred); tick force to write it anyway"
    )
    time.sleep(0.2)
    assert served.sim.motors[2].param(gain) == old
    # with force ticked: written and read back
    page.get_by_label(f"force {gain}").check()
    page.locator(f'button[data-set="{gain}"]').click()
    page.wait_for_function(f"document.querySelector('span[data-val=\"{gain}\"]').textContent === '1500'")
    assert served.sim.motors[2].param(gain) == 1500
    assert not page.get_by_label(f"force {gain}").is_checked()  # force is for one write
    # a hard domain offers no force
    assert page.locator(f'tr[data-name="{baud}"] input[data-force]').count() == 0
    page.get_by_label(baud, exact=True).fill("123")
    page.locator(f'button[data-set="{baud}"]').click()
    assert "is outside its domain: one of 125000" in page.locator("#msg").inner_text()
    assert served.sim.motors[2].param(baud) == 1000000
    served.sim.motors[2].set_param(gain, old)


def test_restore_shows_a_diff_before_writing(page: Any, served: Served, tmp_path: Path) -> None:
    scan(page)
    tab(page, "Parameters")
    page.locator("#par-motor").select_option("3")
    with page.expect_download() as dl:
        page.get_by_role("button", name="Download backup").click()
    backup = tmp_path / "m3.json"
    dl.value.save_as(backup)
    name = "axis0.controller.config.vel_gain"
    saved = served.sim.motors[3].param(name)
    served.sim.motors[3].set_param(name, saved * 2)
    page.locator("#par-restore").set_input_files(str(backup))
    page.wait_for_selector("#diff-write")
    assert name in page.locator("#par-diff").inner_text()
    assert abs(served.sim.motors[3].param(name) - saved * 2) < 1e-6  # nothing written yet
    page.locator("#diff-write").click()
    assert eventually(lambda: abs(served.sim.motors[3].param(name) - saved) < 1e-6, 5)


def test_estop_button_space_and_escape_keys_stop_a_moving_motor(page: Any, served: Served) -> None:
    reset(served)
    scan(page)
    tab(page, "Control")
    m1 = served.sim.motors[1]
    for how in ("button", "Space", "Escape"):
        page.locator("#ctl-motor").select_option("1")
        page.get_by_role("button", name="Clear errors").click()
        page.get_by_role("button", name="Enable").click()
        time.sleep(0.2)
        page.locator("#vel-speed").fill("60")
        page.get_by_role("button", name="Run").click()
        assert eventually(lambda: abs(m1.speed) > 50, 5), m1.speed
        if how == "button":
            page.get_by_role("button", name="ESTOP").click()
        else:
            page.locator("#view-control fieldset legend").first.click()  # focus outside any input
            page.keyboard.press(how)
        assert eventually(lambda: abs(m1.speed) < 1 and m1.state != AxisState.CLOSED_LOOP_CONTROL, 2), how
        if how == "button":  # the motor's card says what happened and what to do
            tab(page, "Bus")
            page.wait_for_function("document.querySelector('.card[data-id=\"1\"]').innerText.includes('ESTOP')")
            assert "Clear errors" in page.locator('.card[data-id="1"] .err').inner_text()
            tab(page, "Control")
    reset(served)


def test_tuning_step_response(page: Any, served: Served, shots: Path) -> None:
    reset(served)
    scan(page)
    tab(page, "Tuning")
    page.locator("#tun-motor").select_option("1")
    page.wait_for_selector("#tun-gains input[data-gain]")
    page.locator("#tun-amp").fill("20")
    page.locator("#tun-dur").fill("0.8")
    page.get_by_role("button", name="Run step").click()
    page.wait_for_selector("#tun-runs tbody tr")
    page.get_by_role("button", name="Run step").click()
    page.wait_for_selector("#tun-runs tbody tr:nth-child(2)")
    cells = page.locator("#tun-runs tbody tr").first.locator("td").all_inner_texts()
    assert cells[3] != "-" and float(cells[3]) > 0  # rise time
    page.screenshot(path=str(shots / "dash-tuning.png"))
    reset(served)


def test_closing_the_page_idles_the_motors_it_moved(browser: Any, served: Served) -> None:
    reset(served)
    ctx = browser.new_context()
    p = ctx.new_page()
    p.goto(served.url)
    p.wait_for_function("window.dashStats && window.dashStats.connected")
    scan(p)
    tab(p, "Control")
    p.locator("#ctl-motor").select_option("3")
    p.locator("#vel-speed").fill("30")
    p.get_by_role("button", name="Run").click()
    m3 = served.sim.motors[3]
    assert eventually(lambda: abs(m3.speed) > 20, 5)
    time.sleep(1.0)  # the page's heartbeat keeps it running
    assert abs(m3.speed) > 20 and served.hub.commanded == {3}
    ctx.close()
    assert eventually(lambda: m3.state == AxisState.IDLE, 3), m3.state
    assert served.hub.commanded == set()
    reset(served)


def test_the_read_only_page_offers_no_control_but_estop(browser: Any) -> None:
    from drempower import open_bus

    from .conftest import serve_in_thread

    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus, read_only=True)
    sim = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
    ctx = browser.new_context()
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        p.locator("#ro").wait_for(state="visible")  # shown once the server's hello says read-only
        p.get_by_role("button", name="Rescan ids 1-63").click()  # watching: scanning is allowed
        p.wait_for_function("document.querySelectorAll('.card').length === 1")
        for b in p.locator(".card button").all():
            assert b.is_disabled()
        tab(p, "Control")
        controls = p.locator("#view-control button, #view-control input, #view-control select")
        assert controls.count() > 10
        assert all(c.is_disabled() for c in controls.all())
        tab(p, "Parameters")
        assert p.locator("#par-table button[data-set], #par-table input").count() == 0
        assert p.locator("#par-save").is_disabled() and p.locator("#par-restore").is_disabled()
        tab(p, "Tuning")
        assert p.get_by_role("button", name="Run step").is_disabled()
        p.wait_for_selector("#tun-apply")  # the gains, read: shown, not writable
        assert p.locator("#tun-apply").is_disabled() and p.locator("#tun-gains input").first.is_disabled()
        # ESTOP is still there and reaches the motor
        bus.motor(1).set_speed(30)
        assert eventually(lambda: abs(sim.speed) > 20, 5)
        estop = p.get_by_role("button", name="ESTOP")
        assert estop.is_enabled()
        estop.click()
        assert eventually(lambda: abs(sim.speed) < 1 and sim.state != AxisState.CLOSED_LOOP_CONTROL, 2)
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def test_the_page_shows_what_is_on_the_bus_at_once(page: Any, served: Served) -> None:
    # no click: the dashboard scanned when it started, and the page shows the cards it found
    page.wait_for_function("document.querySelectorAll('.card').length === 3")
    fw, hw = served.sim.motors[1].param("fw_version"), served.sim.motors[1].param("hw_version")
    page.wait_for_function(f"document.querySelector('.card').innerText.includes('{fw}/{hw}')")
    assert "-/-" not in page.locator("#cards").inner_text()
    # the header names the CAN bit rate the load is reckoned against (the simulator delivers instantly)
    assert page.locator("#load-of").inner_text() == "of 1 Mbit/s (assumed)"
    assert "the CAN bit rate is unknown" in (page.locator("#load-of").get_attribute("title") or "")
    assert page.get_by_role("button", name="Rescan ids 1-63").is_visible()


def test_the_control_view_plots_the_selected_motor(page: Any, served: Served) -> None:
    reset(served)
    page.wait_for_function("document.querySelectorAll('.card').length === 3")
    tab(page, "Control")
    page.locator("#ctl-motor").select_option("2")
    page.wait_for_function("window.dashStats.controlMotor === 2 && window.dashStats.controlPoints > 20")
    labels = page.locator("#ctl-plot .u-legend .u-label").all_inner_texts()
    assert labels[1:] == ["motor_2 angle", "motor_2 angle target", "motor_2 speed", "motor_2 speed target"]


def test_a_move_to_an_idle_motor_shows_an_error_not_success(page: Any, served: Served) -> None:
    reset(served)
    served.bus.motor(3).set_mode(1)
    at = served.sim.motors[3].position
    page.wait_for_function("document.querySelectorAll('.card').length === 3")
    tab(page, "Control")
    page.locator("#ctl-motor").select_option("3")
    page.locator("#pos-angle").fill("90")
    page.get_by_role("button", name="Move", exact=True).click()
    page.wait_for_function("document.querySelector('#msg').textContent.includes('idle')")
    msg = page.locator("#msg")
    assert msg.inner_text().startswith("motor 3 is idle (not in closed loop): enable it first")
    assert "info" not in (msg.get_attribute("class") or "")  # shown as an error, never green
    assert served.hub.targets.get(3) is None and abs(served.sim.motors[3].position - at) < 0.5
    # the synchronised move too: an error in the message line, none in the page (the fixture checks)
    page.evaluate("document.querySelector('#msg').textContent = ''")
    page.get_by_role("button", name="Move selected together").click()
    page.wait_for_function("document.querySelector('#msg').textContent.includes('motor 3 is idle')")
    assert served.hub.targets.get(3) is None
    reset(served)


def test_a_set_counts_as_changed_this_session(page: Any, served: Served) -> None:
    page.wait_for_function("document.querySelectorAll('.card').length === 3")
    tab(page, "Parameters")
    page.locator("#par-motor").select_option("3")
    page.get_by_role("button", name="Read all").click()
    page.wait_for_function(
        "(t => t.startsWith('motor_3:') && t.includes('changed this session'))"
        "(document.querySelector('#par-status').textContent)"
    )
    before = int(page.locator("#par-status").inner_text().split("; ")[-1].split()[0])
    name = "axis0.controller.config.vel_integrator_gain"
    old = served.sim.motors[3].param(name)
    page.get_by_label(name, exact=True).fill(str(old + 1))
    page.locator(f'button[data-set="{name}"]').click()
    page.wait_for_function("document.querySelector('#par-status').textContent.includes('written')")
    assert page.locator("#par-status").inner_text().endswith(f"; {before + 1} changed this session")
    served.sim.motors[3].set_param(name, old)


def test_tuning_axes_carry_units_and_the_step_uses_the_bandwidth_shown(page: Any, served: Served) -> None:
    reset(served)
    page.wait_for_function("document.querySelectorAll('.card').length === 3")
    tab(page, "Tuning")
    page.locator("#tun-motor").select_option("2")
    bw = "axis0.controller.config.input_filter_bandwidth"
    box = page.locator(f'#tun-gains[data-motor="2"] input[data-gain="{bw}"]')
    box.wait_for()
    assert float(box.input_value()) == served.sim.motors[2].param(bw)
    box.fill("25")
    page.locator("#tun-amp").fill("10")
    page.locator("#tun-dur").fill("0.5")
    page.get_by_role("button", name="Run step").click()
    page.wait_for_selector("#tun-runs tbody tr")
    assert served.sim.motors[2].param(bw) == 25  # the T frame carried the box's bandwidth
    assert page.evaluate("window.dashStats.tuningAxes") == ["angle change from start / deg"]
    assert page.locator("#tun-runs tbody tr td").nth(2).inner_text().endswith("deg")
    page.locator("#tun-mode").select_option("velocity")
    assert page.locator("#tun-amp-label").inner_text() == "amplitude r/min"
    page.get_by_role("button", name="Run step").click()
    page.wait_for_selector("#tun-runs tbody tr:nth-child(2)")
    assert page.evaluate("window.dashStats.tuningAxes") == [
        "angle change from start / deg",
        "speed change from start / r/min",
    ]
    assert eventually(lambda: abs(served.sim.motors[2].speed) < 0.5, 2)  # the velocity step ended
    reset(served)
