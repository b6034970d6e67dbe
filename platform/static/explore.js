// The Explore pages (Garces et al. 2016 §6.5): follow a taxonomy job until it ends, and open
// the pop-up of a grid node that hides images. No inline script: the CSP forbids it.
"use strict";

(function () {
  const job = document.getElementById("job");
  if (job && (job.dataset.status === "queued" || job.dataset.status === "running")) {
    const url = job.dataset.statusUrl;
    const stage = document.getElementById("job-stage");
    const bar = document.getElementById("job-bar");
    const count = document.getElementById("job-count");
    const poll = async function () {
      let body;
      try {
        const r = await fetch(url, { credentials: "same-origin", headers: { accept: "application/json" } });
        if (!r.ok) {
          throw new Error("HTTP " + r.status);
        }
        body = await r.json();
      } catch (e) {
        window.setTimeout(poll, 2000);
        return;
      }
      if (body.status === "done" || body.status === "failed") {
        window.location.reload();
        return;
      }
      if (stage) stage.textContent = body.stage;
      if (bar) {
        bar.max = Math.max(1, body.total);
        bar.value = body.done;
      }
      if (count) count.textContent = body.done + "/" + body.total;
      window.setTimeout(poll, 500);
    };
    window.setTimeout(poll, 300);
  }

  // Any image with data-drag-item (a grid node's shown or hidden image, the map's picked
  // thumbnail) can be dragged onto a mash-up canvas open in another window or tab
  // (mashup.js): the item and its library as application/x-stylekit-item, the canvas link
  // with the item as text/uri-list (dropped on the address bar, it opens that canvas).
  document.addEventListener("dragstart", function (e) {
    const el = e.target instanceof Element ? e.target.closest("[data-drag-item]") : null;
    if (!el || !e.dataTransfer) return;
    const item = Number(el.dataset.dragItem);
    e.dataTransfer.setData("application/x-stylekit-item",
      JSON.stringify({ item: item, library: el.dataset.library || "" }));
    e.dataTransfer.setData("text/uri-list", new URL("/admin/mashup?item=" + item, window.location.href).href);
    e.dataTransfer.effectAllowed = "copy";
  });

  for (const cell of document.querySelectorAll(".explore-cell.has-hidden")) {
    cell.addEventListener("click", function () {
      const dialog = document.getElementById(cell.dataset.dialog);
      if (dialog && !dialog.open) dialog.showModal();
    });
  }
})();
