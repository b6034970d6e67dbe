// The worker pages' script. Served as a file because the pages' Content-Security-Policy allows
// no inline script; every page works without it.
//
// The question page: the first input locks the question (a second tap, click or key press is
// ignored and both buttons are disabled, so a fast double input cannot replace the answer),
// the time to answer is measured, and ← / 1 and → / 2 answer from the keyboard.
// Forms marked `lock-on-submit` (practice, reasons) are sent once: a double click does not
// submit the same attempt twice.
(function () {
  "use strict";
  const form = document.getElementById("answer-form");
  if (form) {
    const t0 = Date.now();
    const buttons = Array.from(form.querySelectorAll("button[name=choice]"));
    let locked = false;
    form.addEventListener("submit", function (e) {
      if (locked) {
        e.preventDefault();
        return;
      }
      locked = true;
      document.getElementById("elapsed").value = String(Date.now() - t0);
      // The chosen button's value travels in a hidden field: a disabled button would not be
      // sent, and the buttons are disabled so that nothing else can be chosen.
      const chosen = e.submitter || buttons.find(b => b === document.activeElement) || buttons[0];
      const field = document.createElement("input");
      field.type = "hidden";
      field.name = "choice";
      field.value = chosen.value;
      form.appendChild(field);
      for (const b of buttons) {
        b.removeAttribute("name");
        b.disabled = true;
        if (b === chosen) b.classList.add("chosen");
      }
      form.classList.add("locked");
    });
    document.addEventListener("keydown", function (e) {
      if (locked || e.repeat) return;
      if (e.target instanceof HTMLInputElement || e.target instanceof HTMLTextAreaElement) return;
      if (e.key === "ArrowLeft" || e.key === "1") document.getElementById("left").click();
      if (e.key === "ArrowRight" || e.key === "2") document.getElementById("right").click();
    });
  }
  for (const f of document.querySelectorAll("form.lock-on-submit")) {
    let sent = false;
    f.addEventListener("submit", function (e) {
      if (sent) {
        e.preventDefault();
        return;
      }
      sent = true;
      // Disabled after the form's data is taken (this handler runs first).
      setTimeout(function () {
        for (const b of f.querySelectorAll("button")) b.disabled = true;
      }, 0);
    });
  }
})();
