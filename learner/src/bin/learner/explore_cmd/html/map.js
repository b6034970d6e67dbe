// A static style map: the points of points.js (window.STYLE_MAP) on a canvas, dots when zoomed
// out and thumbnails from the atlases when a point's cell is big enough to show one (level of
// detail, so 200,000 points stay smooth), zoom with the wheel or a pinch, pan by dragging,
// a search box that dims the points whose id and label do not match.
(function () {
  'use strict';
  const data = window.STYLE_MAP;
  const canvas = document.getElementById('map');
  const ctx = canvas.getContext('2d');
  const search = document.getElementById('search');
  const status = document.getElementById('status');
  const details = document.getElementById('details');
  const n = data.ids.length;
  const thumb = data.thumb; // pixels per atlas cell
  const atlases = data.atlases.map(function (src) { const img = new Image(); img.src = src; img.onload = draw; return img; });
  const palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f', '#bcbd22', '#17becf'];
  let match = null; // null: everything matches; else a Uint8Array
  let view = { x: 0, y: 0, scale: 1 };

  // Points are stored in [0, 1]²; a grid of buckets finds what is under the cursor.
  const buckets = 128;
  const grid = new Map();
  for (let i = 0; i < n; i++) {
    const key = Math.min(buckets - 1, Math.floor(data.x[i] * buckets)) * buckets + Math.min(buckets - 1, Math.floor(data.y[i] * buckets));
    if (!grid.has(key)) grid.set(key, []);
    grid.get(key).push(i);
  }

  function size() {
    const r = canvas.getBoundingClientRect();
    canvas.width = Math.round(r.width * devicePixelRatio);
    canvas.height = Math.round(r.height * devicePixelRatio);
  }
  function reset() {
    const side = Math.min(canvas.width, canvas.height) * 0.92;
    view = { scale: side, x: (canvas.width - side) / 2, y: (canvas.height - side) / 2 };
    draw();
  }
  function toScreen(i) { return [view.x + data.x[i] * view.scale, view.y + data.y[i] * view.scale]; }

  function draw() {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    // Size a thumbnail may take: the map's scale over the square root of the point count.
    const cell = view.scale / Math.sqrt(n) * 0.8;
    const shown = Math.max(2, Math.min(cell, thumb * devicePixelRatio * 1.5));
    const thumbs = cell >= 12 * devicePixelRatio;
    let visible = 0;
    for (let pass = 0; pass < 2; pass++) {
      for (let i = 0; i < n; i++) {
        const hit = match === null || match[i] === 1;
        if ((pass === 0) === hit && match !== null) continue; // dimmed points first
        const [sx, sy] = toScreen(i);
        if (sx < -shown || sy < -shown || sx > canvas.width + shown || sy > canvas.height + shown) continue;
        visible++;
        ctx.globalAlpha = hit ? 1 : 0.12;
        const atlas = atlases[data.atlas[i]];
        if (thumbs && atlas && atlas.complete && atlas.naturalWidth > 0) {
          const per = data.per_row;
          const cellIndex = data.cell[i];
          ctx.drawImage(atlas, (cellIndex % per) * thumb, Math.floor(cellIndex / per) * thumb, thumb, thumb, sx - shown / 2, sy - shown / 2, shown, shown);
        } else {
          ctx.fillStyle = palette[data.label[i] % palette.length];
          const r = Math.max(1.5, Math.min(4, cell / 4)) * devicePixelRatio;
          ctx.fillRect(sx - r / 2, sy - r / 2, r, r);
        }
      }
      if (match === null) break;
    }
    ctx.globalAlpha = 1;
    const found = match === null ? n : match.reduce(function (a, b) { return a + b; }, 0);
    status.textContent = (match === null ? n + ' items' : found + ' of ' + n + ' match') + ' · ' + visible + ' in view';
  }

  function zoomAt(px, py, factor) {
    const s = Math.max(50, Math.min(view.scale * factor, 2e6));
    const k = s / view.scale;
    view = { scale: s, x: px - (px - view.x) * k, y: py - (py - view.y) * k };
    draw();
  }
  function pointer(e) { const r = canvas.getBoundingClientRect(); return [(e.clientX - r.left) * devicePixelRatio, (e.clientY - r.top) * devicePixelRatio]; }

  canvas.addEventListener('wheel', function (e) {
    e.preventDefault();
    const [px, py] = pointer(e);
    zoomAt(px, py, Math.exp(-e.deltaY * 0.0015));
  }, { passive: false });

  const active = new Map();
  let last = null, moved = false, pinch = null;
  canvas.addEventListener('pointerdown', function (e) {
    canvas.setPointerCapture(e.pointerId);
    active.set(e.pointerId, pointer(e));
    last = pointer(e); moved = false;
    canvas.classList.add('dragging');
  });
  canvas.addEventListener('pointermove', function (e) {
    if (!active.has(e.pointerId)) return;
    const p = pointer(e);
    active.set(e.pointerId, p);
    if (active.size === 2) {
      const [a, b] = Array.from(active.values());
      const d = Math.hypot(a[0] - b[0], a[1] - b[1]);
      if (pinch) zoomAt((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, d / pinch);
      pinch = d; moved = true; return;
    }
    if (Math.abs(p[0] - last[0]) + Math.abs(p[1] - last[1]) > 3) moved = true;
    view.x += p[0] - last[0]; view.y += p[1] - last[1]; last = p;
    draw();
  });
  function release(e) {
    active.delete(e.pointerId);
    if (active.size < 2) pinch = null;
    canvas.classList.remove('dragging');
    if (!moved && e.type === 'pointerup') pick(pointer(e));
  }
  canvas.addEventListener('pointerup', release);
  canvas.addEventListener('pointercancel', release);

  function pick(p) {
    const u = (p[0] - view.x) / view.scale, v = (p[1] - view.y) / view.scale;
    const bu = Math.floor(u * buckets), bv = Math.floor(v * buckets);
    let best = -1, bestD = Infinity;
    for (let du = -1; du <= 1; du++) for (let dv = -1; dv <= 1; dv++) {
      for (const i of grid.get((bu + du) * buckets + (bv + dv)) || []) {
        const [sx, sy] = toScreen(i);
        const d = Math.hypot(sx - p[0], sy - p[1]);
        if (d < bestD) { bestD = d; best = i; }
      }
    }
    if (best < 0 || bestD > 30 * devicePixelRatio) { details.hidden = true; return; }
    show(best);
  }
  function show(i) {
    const img = document.getElementById('details-image');
    const c = document.createElement('canvas');
    c.width = thumb; c.height = thumb;
    const per = data.per_row;
    const atlas = atlases[data.atlas[i]];
    if (atlas && atlas.complete) c.getContext('2d').drawImage(atlas, (data.cell[i] % per) * thumb, Math.floor(data.cell[i] / per) * thumb, thumb, thumb, 0, 0, thumb, thumb);
    img.src = c.toDataURL();
    img.alt = data.ids[i];
    document.getElementById('details-id').textContent = data.ids[i];
    document.getElementById('details-label').textContent = data.labels[data.label[i]];
    details.hidden = false;
  }

  search.addEventListener('input', function () {
    const q = search.value.trim().toLowerCase();
    if (q === '') { match = null; draw(); return; }
    match = new Uint8Array(n);
    for (let i = 0; i < n; i++) {
      if (data.ids[i].toLowerCase().includes(q) || data.labels[data.label[i]].toLowerCase().includes(q)) match[i] = 1;
    }
    draw();
  });
  // The legend: the dot colour of each label (the palette repeats after ten labels).
  const legend = document.getElementById('legend');
  const counts = new Array(data.labels.length).fill(0);
  for (let i = 0; i < n; i++) counts[data.label[i]]++;
  data.labels.forEach(function (name, l) {
    if (counts[l] === 0) return;
    const li = document.createElement('li');
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = palette[l % palette.length];
    li.append(swatch, document.createTextNode(name + ' (' + counts[l] + ')'));
    legend.append(li);
  });
  document.getElementById('reset').addEventListener('click', reset);
  window.addEventListener('resize', function () { size(); reset(); });
  size();
  reset();
})();
