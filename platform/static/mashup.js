// The mash-up canvas (Garces et al. 2014 §5.7.3): search results sorted by style to what is on
// the canvas, dragged onto an HTML5 canvas, arranged, exported and saved. No framework. The
// exports, saved compositions and a worker's submission are mashup_io.js (loaded first).
//
// Configuration: data-* attributes of the root element `#mashup`:
//   data-library     the library's name (required)
//   data-search-url  GET endpoint taking library, q, category, model, near (comma-separated item
//                    ids), limit; answers {results:[{id,name,url,style,distance}], uniform,
//                    categories, models, matched} (required)
//   data-save-url    optional: compositions endpoint (POST {library,name,document}; GET
//                    ?library= lists; GET/PUT /{id}); without it the save form is hidden
//   data-render-url  optional: POST {library,document} ?format=svg|png answers the file; without
//                    it the export buttons are hidden
//   data-log-url     optional: POST JSON events {"event":"search","seq":N,"q":..,"category":..,
//                    "results":[ids…]} for every result list shown, {"event":"add","item":ID,
//                    "search_seq":N,"position":P} (P: 1-based position in the list the piece came
//                    from), {"event":"remove","item":ID}, {"event":"undo"|"redo","items":[ids
//                    on the canvas after, bottom to top],"background":NAME}, {"event":"layer",
//                    "item":ID,"from":I,"to":J} (0 = bottom), {"event":"background",
//                    "background":NAME}
//   data-background  optional: a fixed background name (the drop-down is hidden)
//   data-csrf        optional: sent as the x-csrf-token header of every POST/PUT
//   data-max-near    most reference items of one search (default 20)
//   data-worker      set on a worker's mash-up task (study kind `mashup`): the search URL is
//                    the assignment's own (no library or model parameter; its answers carry the
//                    server's search number `seq`, which events then name), and the summary
//                    does not say how results are ordered (the worker's condition is blind)
//   data-submit-url  optional: POST {document} submits the composition (#mashup-submit); on
//                    success the page goes to data-done-url
// Items dragged from the Explore pages (explore.js) drop onto the canvas (not on a worker's
// task): application/x-stylekit-item {"item": ID, "library": NAME}; another library's item is
// refused with a message.
// The page's state is exposed for tests and the host page: the root's data-document (the JSON
// document), data-selected (the selected piece's index or -1), data-search-seq, data-logged
// (events posted and answered), and on the
// results list data-ids (the ids in the order shown).
"use strict";
(function () {
  const root = document.getElementById("mashup");
  if (!root) return;
  const $ = (id) => document.getElementById(id);
  const cfg = root.dataset;
  const maxNear = Number(cfg.maxNear || 20);
  const canvas = $("mashup-canvas");
  const ctx = canvas.getContext("2d");
  const list = $("mashup-results");
  const bgSelect = $("mashup-background");
  const PIECE = 160; // side of the square an item fits at scale 1 (mashup::document::PIECE_SIZE)

  let doc = { version: 1, width: canvas.width, height: canvas.height,
    background: cfg.background || "blank", pieces: [] };
  let selected = -1;
  let undo = [], redo = [];
  let searchSeq = 0;
  let searchTimer = null;
  const images = new Map(); // item id → Image (its SVG, or its PNG when it has none)
  const bgImages = new Map();

  function headers() {
    const h = { "content-type": "application/json" };
    if (cfg.csrf) h["x-csrf-token"] = cfg.csrf;
    return h;
  }
  function status(text) { $("mashup-status").textContent = text; }
  function showError(text) {
    const e = $("mashup-error");
    e.textContent = text || "";
    e.hidden = !text;
  }
  async function errorOf(resp) {
    try { return (await resp.json()).error || resp.statusText; } catch (_) { return resp.statusText; }
  }
  // Events are posted one after another, so the server numbers them in the order they were
  // made; data-logged counts those answered.
  let logQueue = Promise.resolve(), logged = 0;
  function log(event) {
    if (!cfg.logUrl) return;
    logQueue = logQueue
      .then(() => fetch(cfg.logUrl, { method: "POST", headers: headers(), body: JSON.stringify(event) }))
      .then((resp) => { if (!resp.ok) status("could not record an event"); })
      .catch(() => status("could not record an event"))
      .then(() => { root.dataset.logged = String(++logged); });
  }

  // ---- drawing ----
  function itemImage(id) {
    let img = images.get(id);
    if (img) return img;
    img = new Image();
    img.onload = draw;
    img.onerror = () => { // raster items have no SVG: their PNG with its transparency
      if (!img.src.endsWith(".png")) img.src = "/media/items/" + id + ".cutout.png";
    };
    img.src = "/media/items/" + id + ".svg";
    images.set(id, img);
    return img;
  }
  function size(p) { // displayed width and height of a piece, in canvas pixels
    const img = itemImage(p.item);
    const w = img.naturalWidth || 1, h = img.naturalHeight || 1;
    const k = PIECE * p.scale / Math.max(w, h);
    return [w * k, h * k];
  }
  function backgroundImage() {
    const opt = Array.from(bgSelect.options).find((o) => o.value === doc.background);
    const url = opt ? opt.dataset.url : "";
    if (!url) return null;
    let img = bgImages.get(url);
    if (!img) { img = new Image(); img.onload = draw; img.src = url; bgImages.set(url, img); }
    return img.complete && img.naturalWidth ? img : null;
  }
  function handleRadius() { return 9 * canvas.width / Math.max(1, canvas.getBoundingClientRect().width); }
  function handles(p) { // [scale handle, rotate handle] in canvas coordinates
    const [w, h] = size(p);
    const r = handleRadius();
    const a = p.rotation * Math.PI / 180, c = Math.cos(a), s = Math.sin(a);
    const at = (lx, ly) => [p.x + lx * c - ly * s, p.y + lx * s + ly * c];
    return [at(w / 2, h / 2), at(0, -h / 2 - 3 * r)];
  }
  function draw() {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    const bg = backgroundImage();
    if (bg) { // cover, centred (the server's preserveAspectRatio="xMidYMid slice")
      const k = Math.max(canvas.width / bg.naturalWidth, canvas.height / bg.naturalHeight);
      const w = bg.naturalWidth * k, h = bg.naturalHeight * k;
      ctx.drawImage(bg, (canvas.width - w) / 2, (canvas.height - h) / 2, w, h);
    }
    doc.pieces.forEach((p) => {
      const img = itemImage(p.item);
      if (!img.complete || !img.naturalWidth) return;
      const [w, h] = size(p);
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.translate(p.x, p.y);
      ctx.rotate(p.rotation * Math.PI / 180);
      ctx.drawImage(img, -w / 2, -h / 2, w, h);
    });
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    const p = doc.pieces[selected];
    if (p) {
      const [w, h] = size(p);
      const r = handleRadius();
      ctx.save();
      ctx.translate(p.x, p.y);
      ctx.rotate(p.rotation * Math.PI / 180);
      ctx.strokeStyle = "#1a56db";
      ctx.lineWidth = r / 4;
      ctx.setLineDash([r / 2, r / 3]);
      ctx.strokeRect(-w / 2, -h / 2, w, h);
      ctx.setLineDash([]);
      ctx.beginPath(); ctx.moveTo(0, -h / 2); ctx.lineTo(0, -h / 2 - 3 * r); ctx.stroke();
      ctx.restore();
      const [sh, rh] = handles(p);
      ctx.fillStyle = "#1a56db";
      ctx.fillRect(sh[0] - r, sh[1] - r, 2 * r, 2 * r);
      ctx.beginPath(); ctx.arc(rh[0], rh[1], r, 0, 2 * Math.PI); ctx.fill();
    }
    root.dataset.document = JSON.stringify(doc);
    root.dataset.selected = String(selected);
    const none = selected < 0;
    for (const id of ["mashup-top", "mashup-up", "mashup-down", "mashup-bottom", "mashup-delete"]) $(id).disabled = none;
    $("mashup-undo").disabled = undo.length === 0;
    $("mashup-redo").disabled = redo.length === 0;
  }

  // ---- history ----
  // A step is the document before it and the piece then selected: undoing a layer change
  // selects the piece that moved back, not whichever piece now has its old index.
  function snapshot() { return JSON.stringify(doc); }
  function remember(before, sel) {
    if (before === snapshot()) return;
    undo.push({ doc: before, selected: sel });
    if (undo.length > 200) undo.shift();
    redo = [];
  }
  function itemsOnCanvas() { return doc.pieces.map((p) => p.item).join(","); }
  function change(fn) {
    const before = snapshot(), sel = selected, items = itemsOnCanvas();
    fn();
    remember(before, sel);
    draw();
    if (items !== itemsOnCanvas()) search();
  }
  function restore(from, to) {
    if (!from.length) return;
    const items = itemsOnCanvas();
    to.push({ doc: snapshot(), selected: selected });
    const step = from.pop();
    doc = JSON.parse(step.doc);
    bgSelect.value = doc.background;
    selected = step.selected < doc.pieces.length ? step.selected : -1;
    draw();
    log({ event: from === undo ? "undo" : "redo", items: doc.pieces.map((p) => p.item), background: doc.background });
    if (items !== itemsOnCanvas()) search();
  }

  // ---- search ----
  let results = [];
  function nearIds() { // distinct items, top-most first, at most maxNear
    const ids = [];
    for (let i = doc.pieces.length - 1; i >= 0; i--) {
      const id = doc.pieces[i].item;
      if (!ids.includes(id)) ids.push(id);
    }
    return ids;
  }
  async function search() {
    const all = nearIds(), near = all.slice(0, maxNear);
    const params = new URLSearchParams({ limit: "48" });
    if (!cfg.worker) params.set("library", cfg.library);
    const q = $("mashup-q").value.trim(), category = $("mashup-category").value;
    if (q) params.set("q", q);
    if (category) params.set("category", category);
    const model = $("mashup-model");
    if (model && model.value) params.set("model", model.value);
    if (near.length) params.set("near", near.join(","));
    const resp = await fetch(cfg.searchUrl + "?" + params, { headers: { accept: "application/json" } });
    if (!resp.ok) { showError(await errorOf(resp)); return; }
    showError("");
    const answer = await resp.json();
    // A worker's searches are numbered by the server (responses may arrive out of order).
    searchSeq = typeof answer.seq === "number" ? answer.seq : searchSeq + 1;
    results = answer.results;
    fillChoices($("mashup-category"), answer.categories.map((c) => [c, c]));
    if (model) fillChoices(model, (answer.models || []).map((m) => [String(m.id), "model " + m.id + " (" + m.study + ")"]));
    if ($("uniform-notice")) $("uniform-notice").hidden = !answer.uniform;
    let summary = results.length + " of " + answer.matched + " matching items" + (cfg.worker ? "." : ", ");
    if (cfg.worker) { /* blind: no word on the order */ }
    else if (!near.length) summary += "dealt across the library's style clusters (the canvas is empty).";
    else if (all.length > near.length) summary += "nearest in style to the " + near.length + " top-most of the " + all.length + " different items on the canvas.";
    else summary += "nearest in style to the " + near.length + " item" + (near.length > 1 ? "s" : "") + " on the canvas.";
    $("mashup-summary").textContent = summary;
    list.replaceChildren(...results.map((r, i) => {
      const li = document.createElement("li");
      const b = document.createElement("button");
      b.type = "button";
      b.className = "mashup-result";
      b.dataset.item = r.id;
      b.dataset.position = i + 1;
      b.title = "Drag onto the canvas, or tap to add";
      const img = document.createElement("img");
      img.src = r.url; img.alt = r.name; img.width = 96; img.height = 96; img.draggable = false;
      b.append(img);
      const name = document.createElement("span");
      name.className = "result-name"; name.textContent = r.name;
      li.append(b, name);
      return li;
    }));
    list.dataset.ids = results.map((r) => r.id).join(",");
    root.dataset.searchSeq = String(searchSeq);
    log({ event: "search", seq: searchSeq, q: q, category: category, results: results.map((r) => r.id) });
  }
  function fillChoices(select, pairs) {
    const keep = select.value;
    while (select.options.length > (select.id === "mashup-model" ? 2 : 1)) select.remove(select.options.length - 1);
    for (const [value, label] of pairs) select.add(new Option(label, value, false, value === keep));
  }

  // ---- pointer: results → canvas, and pieces on the canvas ----
  function toCanvas(e) {
    const r = canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * canvas.width / r.width, (e.clientY - r.top) * canvas.height / r.height];
  }
  function add(item, position, x, y) {
    change(() => {
      doc.pieces.push({ item: item, x: Math.round(x), y: Math.round(y), scale: 1, rotation: 0 });
      selected = doc.pieces.length - 1;
    });
    log({ event: "add", item: item, search_seq: searchSeq, position: position });
    const r = results.find((x) => x.id === item);
    status("Added " + (r ? r.name : "item " + item) + ".");
  }
  list.addEventListener("pointerdown", (e) => {
    const b = e.target.closest(".mashup-result");
    if (!b || e.button !== 0) return;
    e.preventDefault();
    const item = Number(b.dataset.item), position = Number(b.dataset.position);
    const start = [e.clientX, e.clientY];
    const ghost = b.querySelector("img").cloneNode();
    ghost.className = "mashup-ghost";
    let moved = false;
    const move = (ev) => {
      if (!moved && Math.hypot(ev.clientX - start[0], ev.clientY - start[1]) < 6) return;
      if (!moved) { moved = true; document.body.append(ghost); }
      ghost.style.setProperty("--x", ev.clientX + "px");
      ghost.style.setProperty("--y", ev.clientY + "px");
    };
    const up = (ev) => {
      document.removeEventListener("pointermove", move);
      document.removeEventListener("pointerup", up);
      ghost.remove();
      if (!moved) { add(item, position, canvas.width / 2, canvas.height / 2); return; }
      const r = canvas.getBoundingClientRect();
      if (ev.clientX >= r.left && ev.clientX <= r.right && ev.clientY >= r.top && ev.clientY <= r.bottom) {
        const [x, y] = toCanvas(ev);
        add(item, position, x, y);
      }
    };
    document.addEventListener("pointermove", move);
    document.addEventListener("pointerup", up);
  });
  list.addEventListener("keydown", (e) => { // keyboard: Enter/Space on a result adds it
    const b = e.target.closest(".mashup-result");
    if (b && (e.key === "Enter" || e.key === " ")) {
      e.preventDefault();
      add(Number(b.dataset.item), Number(b.dataset.position), canvas.width / 2, canvas.height / 2);
    }
  });
  function hit(x, y) { // top-most piece under (x, y)
    for (let i = doc.pieces.length - 1; i >= 0; i--) {
      const p = doc.pieces[i], [w, h] = size(p);
      const a = -p.rotation * Math.PI / 180, dx = x - p.x, dy = y - p.y;
      const lx = dx * Math.cos(a) - dy * Math.sin(a), ly = dx * Math.sin(a) + dy * Math.cos(a);
      if (Math.abs(lx) <= w / 2 && Math.abs(ly) <= h / 2) return i;
    }
    return -1;
  }
  canvas.addEventListener("pointerdown", (e) => {
    const [x, y] = toCanvas(e);
    const r = handleRadius() * 1.6;
    let mode = null;
    const p0 = doc.pieces[selected];
    if (p0) {
      const [sh, rh] = handles(p0);
      if (Math.hypot(x - sh[0], y - sh[1]) <= r) mode = "scale";
      else if (Math.hypot(x - rh[0], y - rh[1]) <= r) mode = "rotate";
    }
    if (!mode) {
      selected = hit(x, y);
      mode = selected >= 0 ? "move" : null;
    }
    draw();
    canvas.focus();
    if (!mode) return;
    e.preventDefault();
    canvas.setPointerCapture(e.pointerId);
    const p = doc.pieces[selected], sel = selected, before = snapshot();
    const start = { x: x, y: y, px: p.x, py: p.y, scale: p.scale, d: Math.max(1, Math.hypot(x - p.x, y - p.y)) };
    const move = (ev) => {
      const [mx, my] = toCanvas(ev);
      if (mode === "move") {
        p.x = clamp(Math.round(start.px + mx - start.x), -doc.width, 2 * doc.width);
        p.y = clamp(Math.round(start.py + my - start.y), -doc.height, 2 * doc.height);
      } else if (mode === "scale") {
        p.scale = clamp(round3(start.scale * Math.hypot(mx - p.x, my - p.y) / start.d), 0.05, 20);
      } else {
        p.rotation = round3(Math.atan2(mx - p.x, p.y - my) * 180 / Math.PI);
      }
      draw();
    };
    const up = () => {
      canvas.removeEventListener("pointermove", move);
      canvas.removeEventListener("pointerup", up);
      canvas.removeEventListener("pointercancel", up);
      remember(before, sel);
      draw();
    };
    canvas.addEventListener("pointermove", move);
    canvas.addEventListener("pointerup", up);
    canvas.addEventListener("pointercancel", up);
  });
  function clamp(v, lo, hi) { return Math.min(hi, Math.max(lo, v)); }
  function round3(v) { return Math.round(v * 1000) / 1000; }

  // ---- tools ----
  function layer(to) {
    if (selected < 0) return;
    const from = selected, item = doc.pieces[from].item;
    change(() => {
      const [p] = doc.pieces.splice(selected, 1);
      const n = doc.pieces.length;
      selected = to === "top" ? n : to === "bottom" ? 0 : clamp(selected + (to === "up" ? 1 : -1), 0, n);
      doc.pieces.splice(selected, 0, p);
    });
    if (selected !== from) log({ event: "layer", item: item, from: from, to: selected });
  }
  function remove() {
    if (selected < 0) return;
    const item = doc.pieces[selected].item;
    change(() => { doc.pieces.splice(selected, 1); selected = -1; });
    log({ event: "remove", item: item });
  }
  $("mashup-top").addEventListener("click", () => layer("top"));
  $("mashup-up").addEventListener("click", () => layer("up"));
  $("mashup-down").addEventListener("click", () => layer("down"));
  $("mashup-bottom").addEventListener("click", () => layer("bottom"));
  $("mashup-delete").addEventListener("click", remove);
  $("mashup-undo").addEventListener("click", () => restore(undo, redo));
  $("mashup-redo").addEventListener("click", () => restore(redo, undo));
  document.addEventListener("keydown", (e) => {
    const typing = e.target.closest("input, select, textarea");
    const mod = e.ctrlKey || e.metaKey;
    if (mod && e.key.toLowerCase() === "z" && !typing) {
      e.preventDefault();
      if (e.shiftKey) restore(redo, undo); else restore(undo, redo);
    } else if (mod && e.key.toLowerCase() === "y" && !typing) {
      e.preventDefault();
      restore(redo, undo);
    } else if ((e.key === "Delete" || e.key === "Backspace") && !typing && selected >= 0) {
      e.preventDefault();
      remove();
    }
  });
  if (cfg.background) {
    bgSelect.value = cfg.background;
    $("mashup-background-label").hidden = true;
  }
  bgSelect.addEventListener("change", () => {
    change(() => { doc.background = bgSelect.value; });
    log({ event: "background", background: doc.background });
  });
  $("mashup-search").addEventListener("submit", (e) => { e.preventDefault(); search(); });
  $("mashup-category").addEventListener("change", search);
  if ($("mashup-model")) $("mashup-model").addEventListener("change", search);
  $("mashup-q").addEventListener("input", () => { clearTimeout(searchTimer); searchTimer = setTimeout(search, 300); });
  const librarySelect = $("mashup-library");
  if (librarySelect) librarySelect.addEventListener("change", () => {
    location.search = "?" + new URLSearchParams({ library: librarySelect.value });
  });

  // ---- files: export, save and load, a worker's submission (mashup_io.js) ----
  window.mashupIO({
    root, cfg, $, headers, status, errorOf, showError,
    document: () => doc,
    replaceDocument: (d) => {
      change(() => { doc = d; selected = -1; });
      bgSelect.value = doc.background;
      canvas.width = doc.width; canvas.height = doc.height;
      draw();
    },
    clearCanvas: () => change(() => { doc.pieces = []; selected = -1; }),
  });

  // ---- items dragged from the Explore pages (explore.js), in another window or tab ----
  // Not on a worker's task: a worker composes from the assignment's own searches only.
  const ITEM_TYPE = "application/x-stylekit-item";
  if (!cfg.worker) {
    canvas.addEventListener("dragover", (e) => {
      if (e.dataTransfer && Array.from(e.dataTransfer.types).includes(ITEM_TYPE)) {
        e.preventDefault();
        e.dataTransfer.dropEffect = "copy";
      }
    });
    canvas.addEventListener("drop", (e) => {
      const raw = e.dataTransfer ? e.dataTransfer.getData(ITEM_TYPE) : "";
      if (!raw) return;
      e.preventDefault();
      let d = null;
      try { d = JSON.parse(raw); } catch (_) { d = null; }
      if (!d || !Number.isSafeInteger(d.item) || d.item <= 0) {
        showError("What was dropped is not an item of a library.");
        return;
      }
      if (d.library !== cfg.library) {
        showError("Item " + d.item + " is in the library \u201c" + d.library + "\u201d; this canvas composes \u201c" +
          cfg.library + "\u201d. Choose that library first.");
        return;
      }
      showError("");
      const [x, y] = toCanvas(e);
      add(d.item, 0, x, y);
    });
  }

  bgSelect.value = doc.background;
  // An item sent from the Explore pages ("Use in mash-up") starts the canvas.
  if (root.dataset.startItem) add(Number(root.dataset.startItem), 0, canvas.width / 2, canvas.height / 2);
  draw();
  search();
})();
