// legend: what the colours mean, a box in the picture's bottom-left corner (app/viewer/legend.py says what each colour
// mode shows and sends it in the scene): a gradient with its ends, or swatches with labels, and a note.
const Legend = (() => {
  function fitText(ctx, text, width) {
    let t = text || "";
    while (t.length > 4 && ctx.measureText(t).width > width) t = t.slice(0, -2) + "\u2026";
    return t;
  }
  function draw(ctx, sc, W, H) {
    // what the colours mean, in the bottom-left corner; returns what was drawn (window.moattnPlayer.legend) or null
    const lg = sc && !sc.preview ? sc.legend : null;
    if (!lg) return null;
    ctx.save();
    const font = "12px sans-serif", pad = 6, lh = 16, sw = 11, maxW = Math.min(W - 24, Math.max(220, W * 0.62));
    ctx.font = font;
    const rows = [{text: fitText(ctx, lg.title, maxW - 2 * pad), bold: true}];
    let boxW = 0;
    if (lg.kind === "gradient") {
      rows.push({gradient: lg.stops, low: lg.low, high: lg.high});
      boxW = ctx.measureText(lg.low).width + ctx.measureText(lg.high).width + 168;
    } else {
      let row = [], w = 0;
      const items = (lg.items || []).map((it) => ({label: fitText(ctx, it.label, maxW * 0.8), color: it.color}));
      if (lg.more) items.push({label: `+${lg.more} more`, color: null});
      for (const it of items) {
        const iw = (it.color ? sw + 4 : 0) + ctx.measureText(it.label).width + 12;
        if (row.length && w + iw > maxW - 2 * pad) { rows.push({items: row}); boxW = Math.max(boxW, w); row = []; w = 0; }
        row.push({...it, x: w}); w += iw;
      }
      if (row.length) { rows.push({items: row}); boxW = Math.max(boxW, w); }
    }
    if (lg.note) rows.push({text: fitText(ctx, lg.note, maxW - 2 * pad), small: true});
    for (const r of rows) if (r.text !== undefined) {
      ctx.font = r.bold ? "bold " + font : r.small ? "11px sans-serif" : font;
      boxW = Math.max(boxW, ctx.measureText(r.text).width);
    }
    ctx.font = font;
    boxW = Math.min(boxW + 2 * pad, maxW);
    const boxH = rows.length * lh + 2 * pad - 3, x0 = 10, y0 = H - boxH - 10;
    ctx.fillStyle = "rgba(255,255,255,0.85)"; ctx.fillRect(x0, y0, boxW, boxH);
    ctx.strokeStyle = "rgba(110,120,140,0.55)"; ctx.lineWidth = 1; ctx.strokeRect(x0 + 0.5, y0 + 0.5, boxW - 1, boxH - 1);
    let y = y0 + pad + 11;
    for (const r of rows) {
      if (r.text !== undefined) {
        ctx.font = r.bold ? "bold " + font : r.small ? "11px sans-serif" : font;
        ctx.fillStyle = r.small ? "#556" : "#223"; ctx.fillText(r.text, x0 + pad, y); ctx.font = font;
      } else if (r.gradient) {
        const gx = x0 + pad + ctx.measureText(r.low).width + 5, gw = 150;
        ctx.fillStyle = "#223"; ctx.fillText(r.low, x0 + pad, y);
        const grad = ctx.createLinearGradient(gx, 0, gx + gw, 0);
        r.gradient.forEach((c, i) => grad.addColorStop(i / Math.max(1, r.gradient.length - 1), c));
        ctx.fillStyle = grad; ctx.fillRect(gx, y - 10, gw, 11);
        ctx.fillStyle = "#223"; ctx.fillText(r.high, gx + gw + 5, y);
      } else {
        for (const it of r.items) {
          const sx = x0 + pad + it.x;
          if (it.color) {
            ctx.fillStyle = it.color; ctx.fillRect(sx, y - 10, sw, sw);
            ctx.strokeStyle = "rgba(0,0,0,0.35)"; ctx.strokeRect(sx + 0.5, y - 9.5, sw - 1, sw - 1);
          }
          ctx.fillStyle = "#223"; ctx.fillText(it.label, sx + (it.color ? sw + 4 : 0), y);
        }
      }
      y += lh;
    }
    ctx.restore();
    return {kind: lg.kind, title: lg.title, items: (lg.items || []).length, box: [x0, y0, boxW, boxH]};
  }
  return {draw};
})();
