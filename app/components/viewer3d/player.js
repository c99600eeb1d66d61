// player: the playhead in time. pos is in frames (fractional while playing, so poses are interpolated and playback is
// as smooth as the display); play / pause / loop / seek; the attention views' frame cursors (Bokeh Spans) moved in
// the page, with no server round trip per frame.
const Player = (() => {
  function create() { return {pos: 0, playing: false, t0: 0, p0: 0, lastInt: -1}; }

  function frame(pl, n) { return Math.max(0, Math.min(Math.round(pl.pos), n - 1)); }

  function setPlaying(pl, on, n, loop, now) {
    // start (from the top when a motion that does not loop is at its end) or stop on a whole frame
    pl.playing = on;
    if (on) {
      if (pl.pos >= n - 1 && !loop) pl.pos = 0;
      pl.t0 = now; pl.p0 = pl.pos;
    } else pl.pos = Math.round(pl.pos);
  }
  function seek(pl, p, now) {
    pl.pos = p;
    if (pl.playing) { pl.t0 = now; pl.p0 = pl.pos; }
  }
  function advance(pl, now, n, rate, loop) {
    // move the playhead to the time now (rate: frames a second); returns "end" when a motion that does not loop ends
    let p = pl.p0 + (now - pl.t0) * rate / 1000;
    if (p > n - 1) {
      if (loop) { p = p % n; pl.t0 = now; pl.p0 = p; }
      else { pl.pos = n - 1; return "end"; }
    }
    pl.pos = p;
    return null;
  }
  function crossed(pl) {
    // the whole frame the playhead is on, when it has changed since the last call (else -1)
    const k = Math.round(pl.pos);
    if (k === pl.lastInt) return -1;
    pl.lastInt = k;
    return k;
  }
  function moveCursors(ids, view, k) {
    // the Bokeh Spans with these ids go to frame k, in this page only (sync: false: not sent to the server, which
    // sets them itself when its frame changes; 20 patches a second per cursor while playing were traffic for
    // nothing, and a page closing mid-playback sent them to a session already gone); returns how many moved
    if (!ids.length || !view || !view.model || !view.model.document) return 0;
    let moved = 0;
    for (const id of ids) {
      const m = view.model.document.get_model_by_id(id);
      if (m && m.location !== k) { m.setv({location: k}, {sync: false}); moved += 1; }
    }
    return moved;
  }
  return {create, frame, setPlaying, seek, advance, crossed, moveCursors};
})();
