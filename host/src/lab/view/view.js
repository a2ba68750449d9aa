// Shared by the experimenter's and the participant's page: the WebSocket
// that brings each frame (its overlay as JSON, then the JPEG), the event
// log and the question; each drawn frame is acknowledged so the view can
// measure its latency and frame rate.
const TOKEN = new URLSearchParams(location.search).get("token") || "";
const PAGE = Math.floor(Math.random() * 1e9);
window.lmFrames = 0;

function connect(role, onFrame, onLog, onQuestion) {
  const ws = new WebSocket(`ws://${location.host}/ws?role=${role}&token=${encodeURIComponent(TOKEN)}`);
  ws.binaryType = "blob";
  let meta = null;
  ws.onmessage = async (ev) => {
    if (typeof ev.data === "string") {
      const m = JSON.parse(ev.data);
      if (m.type === "frame") meta = m;
      else if (m.type === "log" && onLog) onLog(m.lines);
      else if (m.type === "question" && onQuestion) onQuestion(m.question);
      return;
    }
    const m = meta;
    meta = null;
    if (!m) return;
    const bmp = await createImageBitmap(ev.data);
    onFrame(bmp, m);
    bmp.close();
    window.lmFrames += 1;
    window.lmLastSeq = m.seq;
    fetch(`/drawn?token=${encodeURIComponent(TOKEN)}&page=${PAGE}&seq=${m.seq}`, { method: "POST" }).catch(() => {});
  };
  ws.onclose = () => {
    const s = document.getElementById("status");
    if (s) s.textContent = "disconnected: the session has ended or the view stopped";
  };
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
