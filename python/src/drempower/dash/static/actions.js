// The Actions view: every row of the table of actions (drempower.actions), as the server's hello lists
// them: a select of the actions, an input for each argument (units and domain beside it), Run, and the
// result or the refusal. The server validates with the table's words; nothing is checked here.
"use strict";
(function () {
  window.dashListeners = window.dashListeners || [];
  const A = { rows: [], readOnly: false, motors: [] };
  const esc = (t) => String(t).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
  const writes = (row) => row.safety === "configure" || row.safety === "motion";

  function build() {
    const view = document.querySelector("#view-actions");
    view.innerHTML = `<div class="bar"><label>action <select id="act-name" aria-label="action"></select></label>
      <span id="act-help" class="dim"></span></div>
      <fieldset id="act-args" style="max-width: 640px"><legend>arguments</legend></fieldset>
      <div class="bar"><button id="act-run">Run</button><span id="act-class" class="dim"></span></div>
      <pre id="act-result" role="status"></pre>`;
    const sel = view.querySelector("#act-name");
    sel.innerHTML = A.rows.map((r) => `<option value="${esc(r.name)}"${A.readOnly && writes(r) ? " disabled" : ""}>` +
      `${esc(r.name)} (${esc(r.safety)})</option>`).join("");
    const first = A.rows.find((r) => !(A.readOnly && writes(r)));
    if (first) sel.value = first.name;
    sel.addEventListener("change", fields);
    view.querySelector("#act-run").addEventListener("click", () => { run().catch(() => {}); });
    fields();
  }

  function row() {
    const name = document.querySelector("#act-name").value;
    return A.rows.find((r) => r.name === name);
  }

  function fields() {
    const r = row();
    const box = document.querySelector("#act-args");
    document.querySelector("#act-help").textContent = r ? r.help : "";
    document.querySelector("#act-class").textContent = r ? `safety class: ${r.safety}` : "";
    document.querySelector("#act-run").disabled = !r || (A.readOnly && writes(r));
    if (!r) { box.innerHTML = "<legend>arguments</legend>"; return; }
    box.innerHTML = "<legend>arguments</legend>" + r.args.map((a) => {
      const id = `act-arg-${esc(a.name)}`;
      const ranged = a.kind === "int" || a.kind === "float" || (a.choices && a.choices.length);
      const hint = `${esc(a.help)}${ranged ? " (" + esc(a.domain) + ")" : ""}`;
      if (a.kind === "bool") {
        return `<label title="${hint}">${esc(a.name)} <input type="checkbox" id="${id}" data-arg="${esc(a.name)}"` +
          `${a.default ? " checked" : ""}></label><div class="dim" style="margin: -3px 0 6px; font-size: 12px">${hint}</div>`;
      }
      let value = "";
      if (a.name === "id") value = A.motors.length ? A.motors[0] : "";
      const list = a.name === "name" && a.kind === "str" ? ' list="pw-names"' : "";
      const placeholder = a.required ? "required" : a.default === null ? "none" : String(a.default);
      return `<label title="${hint}">${esc(a.name)}${a.unit ? " " + esc(a.unit) : ""} ` +
        `<input type="text" id="${id}" data-arg="${esc(a.name)}" value="${esc(value)}" placeholder="${esc(placeholder)}"` +
        `${list} aria-label="${esc(a.name)}" size="10"></label>` +
        `<div class="dim" style="margin: -3px 0 6px; font-size: 12px">${hint}</div>`;
    }).join("");
  }

  // what the form holds: numbers as numbers where they read as one, else the text as typed (the server
  // refuses it naming the field); empty optional fields are left out (the table's default applies)
  function values(r) {
    const out = {};
    for (const a of r.args) {
      const e = document.querySelector(`#act-args [data-arg="${CSS.escape(a.name)}"]`);
      if (!e) continue;
      if (a.kind === "bool") { out[a.name] = e.checked; continue; }
      const text = e.value.trim();
      if (text === "") continue;
      const n = Number(text);
      out[a.name] = (a.kind === "int" || a.kind === "float") && Number.isFinite(n) ? n : text;
    }
    return out;
  }

  async function run() {
    const r = row();
    const out = document.querySelector("#act-result");
    if (!r) return;
    const args = values(r);
    out.className = "";
    out.style.color = "";
    out.textContent = `${r.name}: running...`;
    try {
      // the server words what the row came to as the command line does (a command is "sent", never
      // "done"; a number named in its unit); a record or a list is shown as JSON
      const { result, said } = await window.dashCall("action", { action: r.name, args });
      out.textContent = said === null ? `${r.name}: ${JSON.stringify(result, null, 1)}` : said;
      window.dashSay(`${r.name} ${r.safety === "read" ? "read" : "sent"}`, true);
    } catch (e) {
      out.className = "err";
      out.style.color = "#b71c1c";
      out.textContent = `${r.name} refused: ${e.message || e}`;
      window.dashSay(String(e.message || e));
      throw e;
    }
  }

  window.dashListeners.push((m) => {
    if (m.t === "hello") {
      A.rows = m.actions || [];
      A.readOnly = !!m.read_only;
      A.motors = m.motors || [];
      build();
    } else if (m.t === "scanned" && !A.motors.length && m.found && m.found.length) {
      A.motors = m.found.map((f) => f.id);
      const e = document.querySelector("#act-arg-id");
      if (e && !e.value) e.value = A.motors[0];
    }
  });
})();
