// Shared by the experimenter's and the participant's page: the WebSocket
// that brings each frame (its overlay as JSON, then the JPEG), the event
// log and the question. Each frame is acknowledged on the socket once
// taken (drawn or not): the view sends the next, the newest, only then,
// so a slow page draws fewer frames and hears of a question at once. A
// connection that drops (the view took the page for gone, the network
// failed) is made again, the view sending the question again; only the
// view's word that the session has ended, or a view refusing the page's
// token (another session's), stops it.
const TOKEN = new URLSearchParams(location.search).get("token") || "";
window.lmFrames = 0;
// Connections opened (for scripts and tests).
window.lmConnects = 0;
// The view's close code and reason when the session has ended (feed.rs).
const ENDED = "the session has ended";
// What a page of an earlier session says once the view refuses it.
const REFUSED = "disconnected: this page is of an earlier session; open the address lmhost printed";

function connect(role, onFrame, onLog, onQuestion) {
  const status = (t) => {
    const s = document.getElementById("status");
    if (s) s.textContent = t;
  };
  const RECONNECTING = "reconnecting to the session…";
  let delay = 250;
  const open = () => {
    const ws = new WebSocket(`ws://${location.host}/ws?role=${role}&token=${encodeURIComponent(TOKEN)}`);
    window.lmSocket = ws;
    ws.binaryType = "blob";
    let meta = null;
    let opened = false;
    ws.onopen = () => {
      opened = true;
      delay = 250;
      window.lmConnects += 1;
      const s = document.getElementById("status");
      if (s && s.textContent === RECONNECTING) s.textContent = "";
    };
    ws.onmessage = async (ev) => {
      if (typeof ev.data === "string") {
        const m = JSON.parse(ev.data);
        if (m.type === "frame") meta = m;
        else if (m.type === "log" && onLog) onLog(m.lines, m.whole === true);
        else if (m.type === "question" && onQuestion) onQuestion(m.question, m.answered === true);
        return;
      }
      const m = meta;
      meta = null;
      if (!m) return;
      let drawn = false;
      try {
        const bmp = await createImageBitmap(ev.data);
        try {
          onFrame(bmp, m);
        } finally {
          bmp.close();
        }
        drawn = true;
        window.lmFrames += 1;
        window.lmLastSeq = m.seq;
      } catch (e) {
        // Not drawn (a JPEG the browser could not decode): taken all the
        // same, the next one comes.
      } finally {
        if (ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify({ type: "took", seq: m.seq, drawn }));
      }
    };
    ws.onclose = async (ev) => {
      if (ev.code === 1000 && ev.reason === ENDED) {
        status("disconnected: the session has ended");
        return;
      }
      // Refused before it opened: lmhost may have started again on this
      // address, a new session with a new token, which refuses this
      // page's (403). Said once, and no more attempts; a view that is
      // not there (yet) is tried again.
      if (!opened) {
        const r = await fetch(`/state.json?token=${encodeURIComponent(TOKEN)}`, { cache: "no-store" }).catch(() => null);
        if (r && r.status === 403) {
          status(REFUSED);
          window.lmRefused = true;
          return;
        }
      }
      status(RECONNECTING);
      setTimeout(open, delay);
      delay = Math.min(delay * 2, 4000);
    };
  };
  open();
}

// Strokes a polyline given in colour-image pixels, mapped by
// x' = (x - ox) * k, y' = (y - oy) * k.
function stroke(ctx, pts, ox, oy, k, colour, width, closed) {
  if (!pts || pts.length < 2) return;
  ctx.strokeStyle = colour;
  ctx.lineWidth = width;
  ctx.beginPath();
  pts.forEach((p, i) => {
    const x = (p[0] - ox) * k, y = (p[1] - oy) * k;
    if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
  });
  if (closed) ctx.closePath();
  ctx.stroke();
}
