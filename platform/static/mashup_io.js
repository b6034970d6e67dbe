// The mash-up canvas's files (Garces et al. 2014 §5.7.3): exports through the server's render,
// saved compositions, a worker's submission. mashup.js draws and edits the canvas and calls
// window.mashupIO(api) once it is set up, with api = { root, cfg, $, headers, status, errorOf,
// showError, document() (the current document), replaceDocument(d) (a loaded document, one
// undoable step), clearCanvas() (no pieces, one undoable step) }. The data-* attributes it
// reads (data-render-url, data-save-url, data-submit-url, data-done-url) are documented at
// the top of mashup.js; it sets the root's data-last-export and data-composition-id.
"use strict";
window.mashupIO = function (api) {
  const { root, cfg, $, headers, status, errorOf, showError } = api;
  let currentId = null;

  // ---- export ----
  async function exportAs(format) {
    const resp = await fetch(cfg.renderUrl + "?format=" + format, {
      method: "POST", headers: headers(), body: JSON.stringify({ library: cfg.library, document: api.document() }) });
    if (!resp.ok) { status("Export failed: " + await errorOf(resp)); return; }
    const blob = await resp.blob();
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = ($("mashup-name").value.trim() || "composition") + "." + format;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 10000);
    root.dataset.lastExport = format + ":" + blob.size;
    status("Exported " + format.toUpperCase() + " (" + Math.round(blob.size / 1024) + " KB).");
  }
  if (cfg.renderUrl) {
    $("mashup-export-png").addEventListener("click", () => exportAs("png"));
    $("mashup-export-svg").addEventListener("click", () => exportAs("svg"));
  } else {
    $("mashup-export-png").hidden = true;
    $("mashup-export-svg").hidden = true;
  }

  // ---- save / load ----
  async function refreshSaved() {
    const resp = await fetch(cfg.saveUrl + "?" + new URLSearchParams({ library: cfg.library }));
    if (!resp.ok) return;
    const saved = $("mashup-saved");
    saved.replaceChildren(new Option("—", ""));
    for (const c of (await resp.json()).compositions) {
      saved.add(new Option(c.name + " (" + c.pieces + " pieces)", String(c.id), false, String(c.id) === String(currentId)));
    }
  }
  async function save(asNew) {
    const name = $("mashup-name").value.trim();
    if (!name) { status("Give the composition a name first."); $("mashup-name").focus(); return; }
    const update = currentId && !asNew;
    const resp = await fetch(update ? cfg.saveUrl + "/" + currentId : cfg.saveUrl, {
      method: update ? "PUT" : "POST", headers: headers(),
      body: JSON.stringify(update ? { name: name, document: api.document() } : { library: cfg.library, name: name, document: api.document() }) });
    if (!resp.ok) { status("Not saved: " + await errorOf(resp)); return; }
    currentId = (await resp.json()).id;
    root.dataset.compositionId = String(currentId);
    status("Saved “" + name + "”.");
    refreshSaved();
  }
  async function load() {
    const id = $("mashup-saved").value;
    if (!id) return;
    const resp = await fetch(cfg.saveUrl + "/" + id);
    if (!resp.ok) { status("Not loaded: " + await errorOf(resp)); return; }
    const c = await resp.json();
    api.replaceDocument(c.document);
    currentId = c.id;
    root.dataset.compositionId = String(currentId);
    $("mashup-name").value = c.name;
    status("Loaded “" + c.name + "”.");
  }
  if (cfg.saveUrl) {
    $("mashup-save").addEventListener("submit", (e) => { e.preventDefault(); save(false); });
    $("mashup-save-new").addEventListener("click", () => save(true));
    $("mashup-load").addEventListener("click", load);
    $("mashup-new").addEventListener("click", () => {
      api.clearCanvas();
      currentId = null; delete root.dataset.compositionId; $("mashup-name").value = "";
    });
    refreshSaved();
  } else {
    $("mashup-save").hidden = true;
  }

  // ---- a worker's submission ----
  if (cfg.submitUrl) {
    $("mashup-submit").addEventListener("click", async () => {
      const button = $("mashup-submit");
      button.disabled = true;
      const resp = await fetch(cfg.submitUrl, { method: "POST", headers: headers(), body: JSON.stringify({ document: api.document() }) });
      if (resp.ok) { location.href = cfg.doneUrl; return; }
      showError(await errorOf(resp));
      button.disabled = false;
    });
  }
};
