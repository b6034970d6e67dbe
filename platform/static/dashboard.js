// The admin study page's live dashboard: re-reads the dashboard and per-worker JSON (the same
// numbers and rows the page was rendered with) periodically, and reloads the page once a running
// training has finished.
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

  // The cells of one worker-table row, as the page renders them (templates/admin_study.html);
  // completed HITs get the approve/reject override form with the session's CSRF token.
  function workerCells(w, csrf) {
    const cells = [
      w.worker, w.source, w.status, w.decision || "", w.answered + "/" + w.questions,
      String(w.control_errors), String(w.training_attempts),
      (w.median_seconds === null || w.median_seconds === undefined) ? "" : w.median_seconds.toFixed(1),
    ];
    if (w.status !== "completed") return cells.concat([""]);
    const form = document.createElement("form");
    form.method = "post";
    form.action = "/admin/studies/" + encodeURIComponent(study) + "/decision";
    const hidden = (name, value) => {
      const input = document.createElement("input");
      input.type = "hidden";
      input.name = name;
      input.value = value;
      form.appendChild(input);
    };
    hidden("csrf", csrf);
    hidden("assignment", String(w.assignment));
    for (const decision of ["approved", "rejected"]) {
      const button = document.createElement("button");
      button.name = "decision";
      button.value = decision;
      button.textContent = decision === "approved" ? "approve" : "reject";
      form.appendChild(button);
    }
    return cells.concat([form]);
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
      const workers = document.getElementById("workers");
      // Not while the admin is pressing an override button: rebuilding would swallow the click.
      if (!workers.contains(document.activeElement)) {
        const list = await getJson("/workers");
        rows(workers, list, w => workerCells(w, workers.dataset.csrf), 1,
          (tr, w) => { tr.dataset.assignment = String(w.assignment); });
      }
      status.textContent = "Live: updated " + new Date().toLocaleTimeString() + ".";
      if (document.querySelector('#model-list tr[data-status="running"]')) {
        const models = await getJson("/models");
        if (!models.some(x => x.status === "running")) location.reload();
      }
    } catch (e) {
      status.textContent = "Live refresh failed (" + e.message + "); retrying.";
    }
  }

  // `?refresh=S` sets the period in seconds (1–600).
  const asked = Number(new URLSearchParams(location.search).get("refresh"));
  const period = (asked >= 1 && asked <= 600) ? asked : 10;
  status.textContent = "Live: these numbers and the worker table refresh every " + period + " seconds.";
  setInterval(refresh, period * 1000);
})();
