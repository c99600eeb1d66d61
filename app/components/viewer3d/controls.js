// controls: the viewer's elements: the canvas, the player bar (play, scrub, frame, speed, loop, reset view, PNG), the
// denoising-step bar (shown when a scene has the sampling history) and the mouse hint. Only elements: main.js wires them.
const Controls = (() => {
  function mk(tag, cls, text, title) {
    const e = document.createElement(tag); e.className = cls;
    if (tag === "button") e.type = "button";
    if (text !== undefined) e.textContent = text;
    if (title) e.title = title;
    return e;
  }
  function canvas() {
    const c = mk("canvas", "moattn-viewer3d-canvas");
    c.tabIndex = 0;
    c.style.width = "100%"; c.style.display = "block"; c.style.cursor = "grab";
    c.style.touchAction = "none";
    return c;
  }
  function playerBar(loop) {
    const bar = mk("div", "moattn-player-bar");
    const play = mk("button", "moattn-play", "\u25B6 Play");
    const slider = mk("input", "moattn-scrub"); slider.type = "range"; slider.min = 0; slider.step = 1; slider.value = 0;
    const label = mk("span", "moattn-frame-label");
    const speed = mk("select", "moattn-speed", undefined, "playback speed");
    for (const s of [0.25, 0.5, 1, 2]) { const o = document.createElement("option"); o.value = s; o.textContent = `${s}\u00D7`; speed.append(o); }
    speed.value = "1";
    const loopBox = mk("label", "moattn-loop", undefined, "loop playback");
    const loopInput = document.createElement("input"); loopInput.type = "checkbox"; loopInput.checked = loop;
    loopBox.append(loopInput, document.createTextNode(" loop"));
    const reset = mk("button", "moattn-reset-view", "\u21BA view", "reset the camera (or double-click the picture)");
    const save = mk("button", "moattn-save-png", "\u2913 PNG", "save the current view as a PNG (in the browser, nothing is sent to the server)");
    bar.append(play, slider, label, speed, loopBox, reset, save);
    return {bar, play, slider, label, speed, loopInput, reset, save};
  }
  function stepBar() {
    const bar = mk("div", "moattn-step-bar");
    bar.style.display = "none";
    const label = mk("span", "moattn-step-label");
    const slider = mk("input", "moattn-step-scrub", undefined, "denoising step: the model's clean-motion estimate x\u03020 after that step");
    slider.type = "range"; slider.min = 0; slider.step = 1;
    const ticks = document.createElement("datalist"); ticks.id = `moattn-steps-${Math.random().toString(36).slice(2)}`;
    slider.setAttribute("list", ticks.id);
    bar.append(mk("span", "moattn-step-name", "denoising step"), slider, label, ticks);
    return {bar, label, slider, ticks};
  }
  function build(loop) {
    const root = mk("div", "moattn-viewer3d");
    const ui = {root, canvas: canvas(), player: playerBar(loop), steps: stepBar()};
    const hint = mk("div", "moattn-viewer-hint", "drag: orbit \u00B7 shift/right-drag: pan \u00B7 wheel: zoom \u00B7 double-click: reset");
    root.append(ui.canvas, ui.player.bar, ui.steps.bar, hint);
    return ui;
  }
  function showSteps(ui, d) {
    // the step bar for the denoising history d (null: hidden); the slider starts at the final step
    const s = ui.steps;
    s.bar.style.display = d ? "" : "none";
    if (!d) return;
    s.slider.max = d.steps.length - 1; s.slider.value = d.steps.length - 1;
    s.ticks.replaceChildren(...d.steps.map((_, i) => { const o = document.createElement("option"); o.value = i; return o; }));
    s.label.textContent = `${d.steps[d.steps.length - 1]} / ${d.numSteps} (final)` +
      (d.recorded.length ? ` \u00B7 attention recorded at steps ${d.recorded.join(", ")}` : "");
  }
  function stepText(d, i) {
    return `${d.steps[i]} / ${d.numSteps}` + (i === d.steps.length - 1 ? " (final)" : "") +
      (d.recorded.includes(d.steps[i]) ? " \u00B7 attention recorded at this step" : "");
  }
  function savePng(canvas, name, done) {
    // the canvas as a PNG download, made in the browser
    canvas.toBlob((blob) => {
      if (!blob) return;
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = name;
      document.body.appendChild(a); a.click(); a.remove();
      setTimeout(() => URL.revokeObjectURL(a.href), 1000);
      done();
    }, "image/png");
  }
  return {build, showSteps, stepText, savePng};
})();
