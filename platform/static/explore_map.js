// The style map (Garces et al. 2016 §6.5): zoom (wheel, pinch) and pan (drag) a t-SNE map.
// The server chooses what to draw for the viewport — at most one thumbnail per screen cell and
// dots for the rest — so a map of 200,000 items stays smooth; nothing is computed here.
"use strict";

(function () {
  const canvas = document.getElementById("map");
  if (!canvas) return;
  const ctx = canvas.getContext("2d");
  const url = canvas.dataset.viewUrl;
  const CELL = 48; // screen pixels per thumbnail cell
  const THUMB = 40;
  const count = document.getElementById("map-count");
  const images = new Map();
  let view = null; // {cx, cy, scale}: map point at the centre, pixels per map unit
  let data = null;
  let pending = null;
  let serial = 0;

  function viewport() {
    const w = canvas.width / view.scale, h = canvas.height / view.scale;
    return { x0: view.cx - w / 2, x1: view.cx + w / 2, y0: view.cy - h / 2, y1: view.cy + h / 2 };
  }

  function toScreen(x, y) {
    return [(x - view.cx) * view.scale + canvas.width / 2, (y - view.cy) * view.scale + canvas.height / 2];
  }

  function draw() {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    if (!data) return;
    ctx.fillStyle = "#1565c0";
    for (const d of data.dots) {
      const [sx, sy] = toScreen(d[0], d[1]);
      ctx.fillRect(sx - 1.5, sy - 1.5, 3, 3);
    }
    for (const t of data.thumbnails) {
      const [sx, sy] = toScreen(t.x, t.y);
      let img = images.get(t.url);
      if (!img) {
        img = new Image();
        img.src = t.url;
        img.addEventListener("load", draw);
        images.set(t.url, img);
      }
      if (img.complete && img.naturalWidth > 0) {
        ctx.drawImage(img, sx - THUMB / 2, sy - THUMB / 2, THUMB, THUMB);
      } else {
        ctx.strokeRect(sx - THUMB / 2, sy - THUMB / 2, THUMB, THUMB);
      }
    }
    canvas.dataset.firstThumbnail = "";
    if (data.thumbnails.length) {
      const [fx, fy] = toScreen(data.thumbnails[0].x, data.thumbnails[0].y);
      canvas.dataset.firstThumbnail = fx.toFixed(1) + "," + fy.toFixed(1);
    }
    canvas.dataset.thumbnails = String(data.thumbnails.length);
    canvas.dataset.dots = String(data.dots.length);
    if (count) {
      count.textContent = data.in_view + " of " + data.total + " items in view, " +
        data.thumbnails.length + " as thumbnails";
    }
  }

  async function fetchView() {
    const v = viewport();
    const cols = Math.max(1, Math.min(200, Math.floor(canvas.width / CELL)));
    const rows = Math.max(1, Math.min(200, Math.floor(canvas.height / CELL)));
    const q = new URLSearchParams({ x0: v.x0, x1: v.x1, y0: v.y0, y1: v.y1, cols: cols, rows: rows });
    const mine = ++serial;
    const r = await fetch(url + "?" + q.toString(), { credentials: "same-origin" });
    if (!r.ok || mine !== serial) return;
    data = await r.json();
    canvas.dataset.scale = String(view.scale);
    draw();
  }

  function refresh() {
    draw();
    if (pending) window.clearTimeout(pending);
    pending = window.setTimeout(fetchView, 60);
  }

  function zoomAt(sx, sy, factor) {
    const mx = view.cx + (sx - canvas.width / 2) / view.scale;
    const my = view.cy + (sy - canvas.height / 2) / view.scale;
    view.scale = Math.min(1e6, Math.max(1e-6, view.scale * factor));
    view.cx = mx - (sx - canvas.width / 2) / view.scale;
    view.cy = my - (sy - canvas.height / 2) / view.scale;
    refresh();
  }

  function canvasPoint(e) {
    const r = canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * canvas.width / r.width, (e.clientY - r.top) * canvas.height / r.height];
  }

  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    if (!view) return;
    const [sx, sy] = canvasPoint(e);
    zoomAt(sx, sy, Math.exp(-e.deltaY * 0.002));
  }, { passive: false });

  // A click (no drag) on a thumbnail offers it to the mash-up canvas.
  const selected = document.getElementById("map-selected");
  function pick(p) {
    if (!data || !selected) return;
    const hit = data.thumbnails.find(function (t) {
      const [sx, sy] = toScreen(t.x, t.y);
      return Math.abs(sx - p[0]) <= THUMB / 2 && Math.abs(sy - p[1]) <= THUMB / 2;
    });
    selected.replaceChildren();
    if (!hit) return;
    const img = document.createElement("img");
    img.src = hit.url;
    img.width = 64;
    img.height = 64;
    img.alt = "item " + hit.id;
    img.draggable = true;
    img.dataset.dragItem = String(hit.id);
    img.dataset.library = canvas.dataset.library || "";
    img.title = "Drag onto a mash-up canvas";
    const a = document.createElement("a");
    a.id = "map-mashup";
    a.href = "/admin/mashup?item=" + hit.id;
    a.textContent = "Use item " + hit.id + " in the mash-up canvas";
    selected.append(img, " ", a);
  }

  const pointers = new Map();
  let pinch = 0;
  let pressed = null;
  canvas.addEventListener("pointerdown", function (e) {
    if (canvas.setPointerCapture) {
      try { canvas.setPointerCapture(e.pointerId); } catch (err) { /* synthetic pointer */ }
    }
    pointers.set(e.pointerId, canvasPoint(e));
    pressed = pointers.size === 1 ? canvasPoint(e) : null;
  });
  canvas.addEventListener("pointermove", function (e) {
    if (!view || !pointers.has(e.pointerId)) return;
    const p = canvasPoint(e);
    const prev = pointers.get(e.pointerId);
    pointers.set(e.pointerId, p);
    if (pointers.size === 1) {
      view.cx -= (p[0] - prev[0]) / view.scale;
      view.cy -= (p[1] - prev[1]) / view.scale;
      refresh();
    } else if (pointers.size === 2) {
      const [a, b] = Array.from(pointers.values());
      const dist = Math.hypot(a[0] - b[0], a[1] - b[1]);
      if (pinch > 0) zoomAt((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, dist / pinch);
      pinch = dist;
    }
  });
  const up = function (e) {
    const p = canvasPoint(e);
    if (pressed && pointers.size === 1 && Math.hypot(p[0] - pressed[0], p[1] - pressed[1]) < 4) pick(p);
    pressed = null;
    pointers.delete(e.pointerId);
    pinch = 0;
  };
  canvas.addEventListener("pointerup", up);
  canvas.addEventListener("pointercancel", up);

  // The first view: the whole map (bounds from a first request over a huge viewport).
  (async function () {
    view = { cx: 0, cy: 0, scale: 1e-6 };
    await fetchView();
    if (!data) return;
    const [x0, y0, x1, y1] = data.bounds;
    const w = Math.max(1e-6, x1 - x0), h = Math.max(1e-6, y1 - y0);
    view = { cx: (x0 + x1) / 2, cy: (y0 + y1) / 2, scale: 0.9 * Math.min(canvas.width / w, canvas.height / h) };
    await fetchView();
  })();
})();
