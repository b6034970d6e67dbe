// The question page: measures the time to answer and lets the worker answer with the keyboard
// (← / 1 for the left picture, → / 2 for the right one). Served as a file because the page's
// Content-Security-Policy allows no inline script.
(function () {
  "use strict";
  const form = document.getElementById("answer-form");
  if (!form) return;
  const t0 = Date.now();
  form.addEventListener("submit", function () {
    document.getElementById("elapsed").value = String(Date.now() - t0);
  });
  document.addEventListener("keydown", function (e) {
    // Typing into a field (none on this page today) must not answer the question.
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLTextAreaElement) return;
    if (e.key === "ArrowLeft" || e.key === "1") document.getElementById("left").click();
    if (e.key === "ArrowRight" || e.key === "2") document.getElementById("right").click();
  });
})();
