// The admin study page's live dashboard: re-reads the dashboard and per-worker JSON (the same
// numbers and rows the page was rendered with) periodically, and reloads the page once a running
// training has finished. Worker rows are rebuilt with the same forms the page renders (approve/
// reject, block/unblock, bonus), except the rows the admin is using.
// Served as a file because the page's Content-Security-Policy allows no inline script; the
// study id comes from the page's `data-study` attribute. Values go in with textContent only.
(function () {
  "use strict";
  const page = document.getElementById("study-page");
  if (!page) return;
  const study = page.dataset.study;
  const api = "/api/v1/admin/studies/" + encodeURIComponent(study);
  const ratios = new Set(["rejection_rate", "agreement_with_majority", "noise_ceiling", "median_seconds_per_question"]);
  const fmt = (v, k) => (v === null || v === undefined) ? "—" : (ratios.has(k) ? v.toFixed(3) : String(v));
  const hour = ms => new Date(ms).toISOString().slice(0, 13).replace("T", " ") + ":00 UTC";
  const status = document.getElementById("live-status");

  // Replaces a table's rows after the first `keep` (header rows) with one row per item;
  // `mark(tr, item)` may set the row's attributes.
  function rows(table, data, cells, keep = 0, mark = null) {
    while (table.rows.length > keep) table.deleteRow(keep);
    for (const item of data) {
      const tr = table.insertRow();
      if (mark) mark(tr, item);
      for (const c of cells(item)) {
        const td = tr.insertCell();
        if (c instanceof Node) td.appendChild(c); else td.textContent = c;
      }
    }
  }

  async function getJson(path) {
    const r = await fetch(api + path, {credentials: "same-origin"});
    if (!r.ok) throw new Error("HTTP " + r.status);
    return r.json();
  }

  const minute = ms => new Date(ms).toISOString().slice(0, 16).replace("T", " ") + " UTC";
  const cents = c => c > 0 ? (c / 100).toFixed(2) : "";
  const studyPath = "/admin/studies/" + encodeURIComponent(study);

  // A worker id masked until clicked, as the page renders it (templates/study/macros.html).
  function workerId(id, masked) {
    const details = document.createElement("details");
    details.className = "worker-id";
    const summary = document.createElement("summary");
    summary.title = "Show the id";
    summary.textContent = masked;
    const code = document.createElement("code");
    code.textContent = id;
    details.append(summary, code);
    return details;
  }

  // A form posting to `action` with the session's CSRF token and hidden `fields`.
  function postForm(className, action, csrf, fields) {
    const form = document.createElement("form");
    form.className = className;
    form.method = "post";
    form.action = action;
    for (const [name, value] of [["csrf", csrf]].concat(fields)) {
      const input = document.createElement("input");
      input.type = "hidden";
      input.name = name;
      input.value = value;
      form.appendChild(input);
    }
    return form;
  }

  function button(name, value, text) {
    const b = document.createElement("button");
    if (name) { b.name = name; b.value = value; }
    b.textContent = text;
    return b;
  }

  function labelled(text, input) {
    const label = document.createElement("label");
    label.append(text + " ", input);
    return label;
  }

  // The actions cell of a worker row, as templates/study/workers.html renders it: approve/reject
  // (completed HITs), block/unblock, and the bonus form (finished HITs).
  function workerActions(w, csrf) {
    const cell = document.createElement("div");
    const row = "#worker-" + w.assignment;
    if (w.status === "completed") {
      const form = postForm("decision-form", studyPath + "/decision" + row, csrf,
        [["assignment", String(w.assignment)]]);
      form.append(button("decision", "approved", "approve"), button("decision", "rejected", "reject"));
      cell.appendChild(form);
    }
    const block = postForm("block-form", studyPath + "/workers/" + w.assignment + "/block" + row, csrf, []);
    if (w.blocked) {
      const tag = document.createElement("span");
      tag.className = "tag";
      tag.textContent = "blocked";
      block.append(tag, " ", button("action", "unblock", "unblock"));
    } else {
      block.appendChild(button("action", "block", "block"));
    }
    cell.appendChild(block);
    if (w.status !== "training" && w.status !== "active") {
      const details = document.createElement("details");
      details.className = "bonus";
      const summary = document.createElement("summary");
      summary.textContent = "bonus";
      const form = postForm("bonus-form", studyPath + "/workers/" + w.assignment + "/bonus" + row, csrf, []);
      const amount = document.createElement("input");
      Object.assign(amount, {name: "amount", inputMode: "decimal", size: 6, placeholder: "1.50", required: true});
      const reason = document.createElement("input");
      Object.assign(reason, {name: "reason", size: 24, maxLength: 500, required: true});
      form.append(labelled("amount", amount), " ", labelled("reason", reason), " ", button(null, null, "record bonus"));
      details.append(summary, form);
      cell.appendChild(details);
    }
    return cell;
  }

  // The plain-text cells after the worker id, in the page's column order.
  function workerText(w) {
    return [
      w.source, w.status, w.decision || "", w.answered + "/" + w.questions,
      String(w.control_errors), String(w.training_attempts),
      (w.median_seconds === null || w.median_seconds === undefined) ? "" : w.median_seconds.toFixed(1),
      minute(w.started_at), cents(w.bonus_cents),
    ];
  }

  function workerRow(w, csrf) {
    const tr = document.createElement("tr");
    tr.id = "worker-" + w.assignment;
    tr.dataset.assignment = String(w.assignment);
    if (w.blocked) tr.className = "blocked";
    tr.insertCell().appendChild(workerId(w.worker_id, w.worker_id_masked));
    for (const text of workerText(w)) tr.insertCell().textContent = text;
    tr.cells[8].className = "when";
    const actions = tr.insertCell();
    actions.className = "actions";
    actions.append(...workerActions(w, csrf).childNodes);
    return tr;
  }

  // A row the admin is using — a revealed id, an open or filled-in bonus form, a form's error,
  // the focus — keeps its id and actions cells (only its numbers are updated), so that a
  // refresh neither hides what they revealed nor throws away what they typed.
  function busy(tr) {
    if (tr.contains(document.activeElement) || tr.querySelector("details[open], .form-error")) return true;
    return Array.from(tr.querySelectorAll("input:not([type=hidden])")).some(i => i.value !== i.defaultValue);
  }

  // Puts the rows in the order of `list` (newest first) without moving the rows already in
  // place: a moved element loses the focus, and with it the click the admin is making. New
  // workers' rows go in above them.
  function refreshWorkers(table, list) {
    const old = new Map();
    table.querySelectorAll("tr[data-assignment]").forEach(tr => old.set(tr.dataset.assignment, tr));
    const body = table.tBodies[0] || table;
    let cursor = body.querySelector("tr[data-assignment]");
    for (const w of list) {
      const key = String(w.assignment);
      const existing = old.get(key);
      old.delete(key);
      let tr = existing;
      if (existing && busy(existing)) {
        workerText(w).forEach((text, i) => { existing.cells[i + 1].textContent = text; });
      } else {
        tr = workerRow(w, table.dataset.csrf);
        if (existing) existing.replaceWith(tr);
      }
      if (existing && existing === cursor) {
        cursor = tr.nextElementSibling;
      } else {
        body.insertBefore(tr, cursor);
      }
    }
    for (const tr of old.values()) tr.remove();
  }

  async function refresh() {
    try {
      const d = await getJson("/dashboard");
      document.querySelectorAll("[data-k]").forEach(el => { el.textContent = fmt(d[el.dataset.k], el.dataset.k); });
      const max = Math.max(1, ...d.control_error_histogram.map(bin => bin.count));
      rows(document.getElementById("histogram"), d.control_error_histogram, ({ errors: e, count: n }) => {
        const bar = document.createElement("meter");
        bar.className = "bar";
        bar.min = 0;
        bar.max = max;
        bar.value = n;
        bar.textContent = String(n);
        return [String(e), String(n), bar];
      });
      rows(document.getElementById("per-hour"), d.answers_per_hour, ({ hour: h, count: n }) => [hour(h), String(n)]);
      refreshWorkers(document.getElementById("workers"), await getJson("/workers"));
      status.textContent = "Live: updated " + new Date().toISOString().slice(11, 19) + " UTC.";
      if (document.querySelector('#model-list tr[data-status="running"]')) {
        const models = await getJson("/models");
        if (!models.some(x => x.status === "running")) location.reload();
      }
    } catch (e) {
      status.textContent = "Live refresh failed (" + e.message + "); retrying.";
    }
  }

  // A tuple pool still being written: its progress every second, and the whole page once it
  // is complete (or failed).
  const pool = document.getElementById("pool-status");
  if (pool && pool.dataset.status === "creating") {
    const follow = setInterval(async () => {
      try {
        const s = await getJson("");
        if (s.status !== "creating") {
          clearInterval(follow);
          location.reload();
          return;
        }
        document.getElementById("pool-done").textContent = String(s.rows_done);
        document.getElementById("pool-percent").textContent =
          String(s.rows_total > 0 ? Math.floor(s.rows_done * 100 / s.rows_total) : 100);
        document.getElementById("pool-progress").value = s.rows_done;
      } catch (e) {
        status.textContent = "Following the pool failed (" + e.message + "); retrying.";
      }
    }, 1000);
  }

  // `?refresh=S` sets the period in seconds (1–600).
  const asked = Number(new URLSearchParams(location.search).get("refresh"));
  const period = (asked >= 1 && asked <= 600) ? asked : 10;
  status.textContent = "Live: these numbers and the worker table refresh every " + period + " seconds.";
  setInterval(refresh, period * 1000);
})();
