// The frame player's front end (anywidget ESM): plays a clip in the browser at its fps.
//
// The kernel sends each clip's frames once, as JPEG buffers in custom messages
// ({type: "frames", clip, start} + buffers); this side keeps them, decodes them to
// bitmaps and draws them on a canvas on a requestAnimationFrame clock: playing,
// scrubbing and looping never ask the kernel for anything. Only the user's own acts go
// back (play / pause, a scrub, an fps typed, the loop box), one message each. A view
// that finds frames missing (a page reload, messages sent before this module was
// ready) asks for them: {type: "want", clip, have}.
//
// Each drawn frame is announced with a bubbling "fluidnb-frame" event on the canvas
// ({clip, frame, t}) and counted in the canvas's data-drawn attribute: the tests and
// benchmarks measure what the user sees with them.

const DECODED_BYTES = 384 * 2 ** 20; // bitmaps kept decoded; beyond, decoded near the playhead
const GROUPS = (globalThis.__fluidnbPlayerGroups ??= new Map());

function store() {
  // Frames of the current clip, shared by every view of this model.
  return {
    clip: -1,
    blobs: [],
    bitmaps: new Map(),
    pending: new Map(),
    have: 0, // frames 0..have-1 received
    lastMessage: 0,
    views: new Set(),
  };
}

function reset(s, clip) {
  for (const b of s.bitmaps.values()) b.close?.();
  s.clip = clip;
  s.blobs = [];
  s.bitmaps = new Map();
  s.pending = new Map();
  s.have = 0;
  s.timeline = null;
}

function decode(s, i) {
  // A promise of frame i's bitmap (null when its data has not come yet).
  if (s.bitmaps.has(i)) return Promise.resolve(s.bitmaps.get(i));
  if (s.pending.has(i)) return s.pending.get(i);
  const blob = s.blobs[i];
  if (!blob) return Promise.resolve(null);
  const clip = s.clip;
  const p = createImageBitmap(blob).then(
    (bmp) => {
      s.pending.delete(i);
      if (s.clip !== clip) {
        bmp.close?.();
        return null;
      }
      s.bitmaps.set(i, bmp);
      return bmp;
    },
    () => {
      s.pending.delete(i);
      return null;
    },
  );
  s.pending.set(i, p);
  return p;
}

function evict(s, around, n) {
  // Keep the decoded frames within budget: drop those farthest from the playhead.
  let bytes = 0;
  for (const b of s.bitmaps.values()) bytes += 4 * b.width * b.height;
  if (bytes <= DECODED_BYTES) return;
  const dist = (i) => Math.min(Math.abs(i - around), n - Math.abs(i - around));
  const order = [...s.bitmaps.keys()].sort((a, b) => dist(b) - dist(a));
  for (const i of order) {
    if (bytes <= DECODED_BYTES * 0.8 || dist(i) < 8) break;
    const b = s.bitmaps.get(i);
    bytes -= 4 * b.width * b.height;
    b.close?.();
    s.bitmaps.delete(i);
  }
}

function initialize(s, model) {
  const ask = () => {
    const clip = model.get("clip_id");
    if (clip > 0) model.send({ type: "want", clip, have: clip === s.clip ? s.have : 0 });
  };
  model.on("msg:custom", (msg, buffers) => {
    if (!msg || msg.type !== "frames") return;
    if (msg.clip !== s.clip) {
      if (msg.clip < s.clip) return; // an old clip's frames
      reset(s, msg.clip);
    }
    s.lastMessage = performance.now();
    if (msg.start === 0 && msg.sent)
      s.timeline = { ...(msg.timeline || {}), sent: msg.sent, arrived: performance.timeOrigin + s.lastMessage };
    buffers.forEach((buf, k) => {
      const i = msg.start + k;
      if (!s.blobs[i]) s.blobs[i] = new Blob([buf], { type: msg.mime || "image/jpeg" });
    });
    while (s.blobs[s.have]) s.have += 1;
    // Decode ahead while the budget allows (the first frames first). The first frame
    // is on screen before the others are decoded: they would share the cores with it.
    const first = s.bitmaps.has(0) ? null : s.pending.get(0);
    for (let i = msg.start; i < msg.start + buffers.length; i++) {
      if (i < 16 || s.bitmaps.size * 4 * model.get("width") * model.get("height") < DECODED_BYTES)
        if (first && i > 0) first.then(() => decode(s, i));
        else decode(s, i);
    }
    for (const v of s.views) v.arrived();
  });
  model.on("change:clip_id", () => {
    if (model.get("clip_id") !== s.clip) reset(s, model.get("clip_id"));
    for (const v of s.views) v.newClip();
  });
  // Missing frames (sent before this side listened, or a reload): ask for them.
  const timer = setInterval(() => {
    const ready = Math.min(model.get("ready"), model.get("n_frames"));
    if (model.get("clip_id") > 0 && s.have < ready && performance.now() - s.lastMessage > 1000) {
      s.lastMessage = performance.now();
      ask();
    }
  }, 500);
  ask();
  return () => clearInterval(timer);
}

function el(tag, cls, props = {}) {
  const e = document.createElement(tag);
  if (cls) e.className = cls;
  Object.assign(e, props);
  return e;
}

function render(s, model, root) {
  root.classList.add("fluidnb-player-view");
  const canvas = el("canvas", "fluidnb-frame");
  const ctx = canvas.getContext("2d");
  const bar = el("div", "fluidnb-player-bar");
  const play = el("button", "fluidnb-play", { type: "button", title: "play / pause" });
  const slider = el("input", "fluidnb-frame-slider", { type: "range", min: 0, max: 0, step: 1 });
  const readout = el("span", "fluidnb-frame-readout");
  const loopLabel = el("label", "fluidnb-loop", { title: "play the clip over and over" });
  const loop = el("input", "", { type: "checkbox" });
  loopLabel.append(loop, document.createTextNode("loop"));
  const fpsLabel = el("label", "fluidnb-fps", { title: "frames per second" });
  const fps = el("input", "", { type: "number", min: 0.5, max: 60, step: 0.5 });
  fpsLabel.append(fps, document.createTextNode("fps"));
  bar.append(play, slider, readout, loopLabel, fpsLabel);
  root.append(canvas, bar);
  // Keys typed in the player (arrows on the frame slider, digits in the fps box) are
  // the player's: JupyterLab's notebook shortcuts would take them otherwise.
  bar.addEventListener("keydown", (e) => e.stopPropagation());

  let shown = -1; // index on the canvas
  let shownClip = -1;
  let drawn = 0;
  let t0 = 0; // clock: frame f is due at t0 + f / fps
  let base = 0; // the frame the clock started from
  let following = 0; // until then, a group member's frames are shown, not our clock's
  let raf = 0;
  let group = null;

  const n = () => Math.min(model.get("ready"), model.get("n_frames"));
  const available = () => Math.min(n(), s.have);
  const rate = () => Math.max(0.5, Math.min(model.get("fps") || 8, 60));

  function layout() {
    const w = model.get("width");
    const h = model.get("height");
    const has = model.get("clip_id") > 0 && w > 0;
    canvas.style.display = has ? "" : "none";
    if (has && (canvas.width !== w || canvas.height !== h)) {
      canvas.width = w;
      canvas.height = h;
      shown = -1;
    }
    canvas.style.width = `${model.get("display_width")}px`;
    // Enlarged 2x or more, a simulation grid keeps its cells crisp; a photo (or any
    // picture drawn smaller) is smoothed.
    const enlarged = w > 0 && model.get("display_width") >= 2 * w;
    canvas.style.imageRendering = enlarged && !model.get("smooth") ? "pixelated" : "auto";
    root.style.maxWidth = `${Math.max(model.get("display_width"), 300)}px`;
    slider.style.width = model.get("slider_width") || "";
    for (const c of [play, slider, loop, fps]) c.disabled = !has;
    loop.checked = model.get("loop");
    if (document.activeElement !== fps) fps.value = has ? String(model.get("fps")) : "";
    fps.placeholder = "—";
    controls();
  }

  function controls() {
    const k = n();
    slider.max = String(Math.max(k - 1, 0));
    if (shown >= 0) slider.value = String(shown);
    const total = model.get("n_frames");
    readout.textContent = k ? `${Math.max(shown, 0) + 1} / ${k < total ? `${k} of ${total}` : total}` : "";
    play.textContent = model.get("playing") ? "❚❚" : "▶";
    play.setAttribute("aria-label", model.get("playing") ? "pause" : "play");
    play.classList.toggle("fluidnb-playing", !!model.get("playing"));
  }

  function draw(i, fromClock) {
    const clip = s.clip;
    const bmp = s.bitmaps.get(i);
    if (!bmp) {
      decode(s, i).then((b) => {
        if (b && s.clip === clip && want === i) draw(i, fromClock);
      });
      want = i;
      return false;
    }
    if (i === shown && clip === shownClip) return true;
    ctx.drawImage(bmp, 0, 0, canvas.width, canvas.height);
    shown = i;
    shownClip = clip;
    drawn += 1;
    canvas.dataset.frame = String(i);
    canvas.dataset.clip = String(clip);
    canvas.dataset.drawn = String(drawn);
    canvas.dispatchEvent(
      new CustomEvent("fluidnb-frame", {
        bubbles: true,
        detail: {
          clip,
          frame: i,
          t: performance.now(),
          playing: !!model.get("playing"),
          // The kernel's times of this clip's making and its first frame's trip (ms
          // since the epoch; see FramePlayer.show_timed), when it said them.
          timeline: s.timeline,
        },
      }),
    );
    if (model.get("tell_drawn") && s.timeline?.made !== undefined && s.acked !== clip) {
      // A preview's picture is on screen: the kernel sends what it held back for it
      // (the video-database app's map; FramePlayer.wait_drawn). One word per preview.
      s.acked = clip;
      model.send({ type: "drawn", clip });
    }
    controls();
    if (group && fromClock !== "group") {
      for (const other of group) if (other !== view) other.follow(i);
    }
    // Decode a few ahead (clips beyond the decoding budget).
    const k = available();
    for (let d = 1; d <= 6 && k; d++) decode(s, (i + d) % k);
    evict(s, i, k);
    return true;
  }
  let want = -1;

  function start(from) {
    base = from;
    t0 = performance.now();
  }

  function tick() {
    raf = requestAnimationFrame(tick);
    if (!model.get("playing") || performance.now() < following) return;
    const k = available();
    if (!k) return;
    const total = model.get("n_frames");
    let f = base + Math.floor(((performance.now() - t0) * rate()) / 1000);
    if (f >= k) {
      if (k < total || (!model.get("loop") && f < total)) {
        // Still streaming in (or frames on their way): wait on the last one made.
        if (shown !== k - 1) draw(k - 1, true);
        start(k - 1);
        return;
      }
      if (!model.get("loop")) {
        draw(total - 1, true);
        model.set({ playing: false, frame: total - 1 });
        model.save_changes();
        controls();
        return;
      }
      f %= total;
      if (f < base) start(f); // a new lap: the clock restarts there (no drift)
    }
    if (f !== shown || s.clip !== shownClip) {
      if (!draw(f, true)) start(Math.max(shown, 0)); // not decoded yet: hold the clock
    }
  }

  const view = {
    arrived() {
      layout();
      if (shown < 0 || shownClip !== s.clip) {
        const f = Math.min(model.get("frame"), Math.max(available() - 1, 0));
        if (available()) draw(model.get("playing") ? 0 : f, false);
      }
      controls();
    },
    newClip() {
      shown = -1;
      want = -1;
      start(0);
      layout();
      view.arrived();
    },
    follow(i) {
      following = performance.now() + 400;
      if (i < available()) draw(i, "group");
    },
  };
  s.views.add(view);

  function joinGroup() {
    if (group) group.delete(view);
    const name = model.get("group");
    group = null;
    if (name) {
      if (!GROUPS.has(name)) GROUPS.set(name, new Set());
      group = GROUPS.get(name);
      group.add(view);
    }
  }

  play.addEventListener("click", () => {
    const on = !model.get("playing");
    const k = available();
    if (on && k && shown >= k - 1 && !model.get("loop")) start(0);
    else start(Math.max(shown, 0));
    model.set(on ? { playing: true } : { playing: false, frame: Math.max(shown, 0) });
    model.save_changes();
    controls();
  });
  slider.addEventListener("input", () => {
    const i = Number(slider.value);
    start(i);
    draw(i, false);
    model.set("frame", i);
    model.save_changes(); // ipywidgets sends the latest value when the kernel is free
  });
  loop.addEventListener("change", () => {
    model.set("loop", loop.checked);
    model.save_changes();
  });
  fps.addEventListener("change", () => {
    const v = Number(fps.value);
    if (!(v >= 0.5 && v <= 60)) {
      fps.value = String(model.get("fps"));
      return;
    }
    start(Math.max(shown, 0));
    model.set("fps", v);
    model.save_changes();
  });

  const onPlaying = () => {
    start(Math.max(shown, 0) >= available() - 1 && !model.get("loop") ? 0 : Math.max(shown, 0));
    controls();
  };
  const onFrame = () => {
    const i = model.get("frame");
    if (!model.get("playing") && i !== shown && i < available()) {
      draw(i, false);
    }
    if (model.get("playing")) start(i);
  };
  const onFps = () => {
    start(Math.max(shown, 0));
    layout();
  };
  const handlers = [
    ["change:playing", onPlaying],
    ["change:frame", onFrame],
    ["change:fps", onFps],
    ["change:ready change:n_frames", view.arrived],
    ["change:width change:height change:display_width change:loop change:slider_width", layout],
    ["change:smooth", layout],
    ["change:group", joinGroup],
  ];
  for (const [events, fn] of handlers) model.on(events, fn);
  joinGroup();
  layout();
  view.arrived();
  raf = requestAnimationFrame(tick);

  return () => {
    cancelAnimationFrame(raf);
    s.views.delete(view);
    if (group) group.delete(view);
    for (const [events, fn] of handlers) model.off(events, fn);
  };
}

// One store per widget (anywidget calls this factory once per model): its views share it.
export default () => {
  const s = store();
  return {
    initialize: ({ model }) => initialize(s, model),
    render: ({ model, el }) => render(s, model, el),
  };
};
