// The episode viewer (dcmppi.render.viewer): draws one control instant of an episode in 2-D on
// a canvas from the data in <script id=episode>, with a time slider, play and pause, speed,
// layers, zoom (wheel) and pan (drag). dcmppi's own code, no library.
(() => {
  const D = JSON.parse(document.getElementById("episode").textContent);
  const TYPES = { f4: Float32Array, u1: Uint8Array, u2: Uint16Array, i2: Int16Array };
  const A = {};
  for (const [name, a] of Object.entries(D.arrays)) {
    const text = atob(a.b64);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
    const array = new TYPES[a.dtype](bytes.buffer);
    A[name] = a.scale ? Float32Array.from(array, (v) => v * a.scale) : array; // cm to m
  }
  const n = D.frames;
  // offsets of the ragged arrays: the polylines of frame i start at start[i]
  const starts = (counts) => {
    const s = new Uint32Array(n + 1);
    for (let i = 0; i < n; i++) s[i + 1] = s[i] + counts[i];
    return s;
  };
  const rolloutStart = starts(A.rollout_count), futureStart = starts(A.future_count);
  const planStart = starts(A.plan_count);
  const rgb = (c, alpha) => `rgba(${c.map((v) => Math.round(255 * v)).join(",")},${alpha})`;
  const C = D.colours;

  const canvas = document.getElementById("stage");
  const ctx = canvas.getContext("2d");
  const slider = document.getElementById("slider");
  const play = document.getElementById("play");
  const speed = document.getElementById("speed");
  const layers = {};
  document.querySelectorAll(".layers input").forEach((el) => {
    layers[el.name] = el;
    el.addEventListener("change", () => draw());
  });
  slider.max = n - 1;

  // the view: the world region D.view fitted into the canvas, then zoomed and panned
  let scale = 1, ox = 0, oy = 0, dpr = 1;
  function fit() {
    const v = D.view;
    dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth;
    const h = Math.max(240, Math.min((w * (v[3] - v[1])) / (v[2] - v[0]), window.innerHeight - 160));
    canvas.style.height = `${h}px`;
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(h * dpr);
    scale = Math.min(canvas.width / (v[2] - v[0]), canvas.height / (v[3] - v[1]));
    ox = canvas.width / 2 - (scale * (v[0] + v[2])) / 2;
    oy = canvas.height / 2 + (scale * (v[1] + v[3])) / 2;
  }
  const px = (x) => ox + scale * x;
  const py = (y) => oy - scale * y;

  function polyline(array, offset, points, style, width) {
    ctx.beginPath();
    for (let j = 0; j < points; j++) {
      const x = px(array[offset + 2 * j]), y = py(array[offset + 2 * j + 1]);
      if (j === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    }
    ctx.strokeStyle = style;
    ctx.lineWidth = width * dpr;
    ctx.stroke();
  }
  function disc(x, y, r, fill, stroke, alpha = 1) {
    ctx.beginPath();
    ctx.arc(px(x), py(y), Math.max(scale * r, 1.5 * dpr), 0, 2 * Math.PI);
    ctx.globalAlpha = alpha;
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    ctx.globalAlpha = 1;
    if (stroke) { ctx.strokeStyle = stroke; ctx.lineWidth = dpr; ctx.stroke(); }
  }

  function drawWorld() {
    const W = D.world;
    ctx.fillStyle = "#fbfbf8";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    const [bx0, by0, bx1, by1] = W.bounds;
    ctx.strokeStyle = "#999";
    ctx.lineWidth = 2 * dpr;
    ctx.strokeRect(px(bx0), py(by1), scale * (bx1 - bx0), scale * (by1 - by0));
    for (const [x0, y0, x1, y1] of W.walls) {
      ctx.beginPath();
      ctx.moveTo(px(x0), py(y0));
      ctx.lineTo(px(x1), py(y1));
      ctx.strokeStyle = "#555";
      ctx.lineWidth = 3 * dpr;
      ctx.stroke();
    }
    for (const [x, y, r] of W.static) disc(x, y, r, C.static);
    disc(W.goal[0], W.goal[1], W.goal_tolerance, "rgba(40,160,60,0.15)", "rgba(40,160,60,0.9)");
    disc(W.start[0], W.start[1], 0.12, null, "#444");
  }

  function draw() {
    const i = +slider.value;
    drawWorld();
    const pose = A.pose;
    if (layers.trail.checked && i > 0) {
      ctx.beginPath();
      for (let j = 0; j <= i; j++) {
        if (j === 0) ctx.moveTo(px(pose[0]), py(pose[1]));
        else ctx.lineTo(px(pose[3 * j]), py(pose[3 * j + 1]));
      }
      ctx.strokeStyle = rgb(C.trail, 0.9);
      ctx.lineWidth = 2 * dpr;
      ctx.stroke();
    }
    if (layers.rollouts.checked) {
      const S = D.points.rollout;
      for (let k = rolloutStart[i]; k < rolloutStart[i + 1]; k++) {
        const c = A.rollout_colour[k];
        const colour = (c & 15) < C.palette.length ? C.palette[c & 15] : C.grey;
        polyline(A.rollout, 2 * S * k, S, rgb(colour, c & 16 ? 0.85 : 0.35), 1);
      }
    }
    if (layers.futures.checked) {
      const S = D.points.future;
      for (let k = futureStart[i]; k < futureStart[i + 1]; k++) {
        polyline(A.future, 2 * S * k, S, rgb(C.future, 0.45), 1);
      }
    }
    const L = D.people;
    for (let l = 0; l < L; l++) {
      const o = 3 * (i * L + l);
      if (A.people[o + 2] > 0) disc(A.people[o], A.people[o + 1], A.people[o + 2], C.people, C.people, 0.5);
    }
    if (layers.plan.checked && planStart[i + 1] > planStart[i]) {
      const S = D.points.plan;
      polyline(A.plan, 2 * S * planStart[i], S, "rgba(90,70,0,0.8)", 5);
      polyline(A.plan, 2 * S * planStart[i], S, rgb(C.plan, 1), 3);
    }
    const [x, y, yaw] = [pose[3 * i], pose[3 * i + 1], pose[3 * i + 2]];
    disc(x, y, D.world.robot_radius, C.robot, "#0b2740");
    const r = Math.max(scale * D.world.robot_radius, 1.5 * dpr);
    ctx.beginPath();
    ctx.moveTo(px(x) + 0.45 * r * Math.cos(yaw), py(y) - 0.45 * r * Math.sin(yaw));
    ctx.lineTo(px(x) + r * Math.cos(yaw), py(y) - r * Math.sin(yaw));
    ctx.strokeStyle = "#fff";
    ctx.lineWidth = 2 * dpr;
    ctx.stroke();
    if (i === n - 1 && D.meta.outcome === "collision") {
      disc(x, y, D.world.robot_radius * 1.8, null, "#d00");
    }
    figures(i);
    chart(i);
  }

  const fmt = (v, d) => (Number.isFinite(v) ? v.toFixed(d) : "-");
  function figures(i) {
    document.getElementById("clock").textContent =
      `step ${i} of ${n - 1}, t = ${(i * D.dt).toFixed(1)} s`;
    const rows = [];
    const nu = D.controls.length;
    D.controls.forEach((name, j) => rows.push([`control ${name}`, fmt(A.control[i * nu + j], 3)]));
    rows.push(["minimum gap [m]", fmt(A.gap[i], 3)]);
    const cost = [A.cost[3 * i], A.cost[3 * i + 1], A.cost[3 * i + 2]];
    rows.push(["plan cost: goal", fmt(cost[0], 1)]);
    rows.push(["plan cost: static", fmt(cost[1], 1)]);
    rows.push(["plan cost: moving", fmt(cost[2], 1)]);
    rows.push(["plan cost J", fmt(cost[0] + cost[1] + cost[2], 1)]);
    rows.push(["ESS", fmt(A.ess[i], 1)]);
    rows.push(["robot x, y, yaw", `${fmt(A.pose[3 * i], 2)}, ${fmt(A.pose[3 * i + 1], 2)}, ${fmt(A.pose[3 * i + 2], 2)}`]);
    document.getElementById("figures").innerHTML =
      rows.map(([k, v]) => `<tr><td>${k}</td><td class=num>${v}</td></tr>`).join("");
  }

  // the minimum gap over the episode, the current instant marked
  const chartCanvas = document.getElementById("chart");
  const top = Math.min(2, Math.max(0.5, ...Array.from(A.gap).filter(Number.isFinite)));  // [m]
  function chart(i) {
    const c = chartCanvas.getContext("2d");
    const w = (chartCanvas.width = chartCanvas.clientWidth * dpr);
    const h = (chartCanvas.height = chartCanvas.clientHeight * dpr);
    const X = (j) => (w * j) / Math.max(1, n - 1);
    const Y = (g) => h - 4 * dpr - ((h - 8 * dpr) * Math.min(Math.max(g, 0), top)) / top;
    c.strokeStyle = "#d33";
    c.beginPath(); c.moveTo(0, Y(0)); c.lineTo(w, Y(0)); c.stroke();
    c.strokeStyle = "#1f5fa8";
    c.lineWidth = 1.5 * dpr;
    c.beginPath();
    for (let j = 0; j < n; j++) {
      if (j === 0) c.moveTo(X(j), Y(A.gap[j])); else c.lineTo(X(j), Y(A.gap[j]));
    }
    c.stroke();
    c.fillStyle = "#333";
    c.fillRect(X(i) - dpr, 0, 2 * dpr, h);
    c.font = `${10 * dpr}px sans-serif`;
    c.fillText(`${top.toFixed(1)} m`, 3 * dpr, 11 * dpr);
    c.fillText("0", 3 * dpr, Y(0) - 2 * dpr);
  }
  chartCanvas.addEventListener("click", (e) => {
    seek(Math.round(((n - 1) * e.offsetX) / chartCanvas.clientWidth));
  });

  // playback: the slider follows the clock at the chosen speed
  let playing = false, last = null, clock = 0;
  function frame(now) {
    if (!playing) return;
    if (last !== null) clock += ((now - last) / 1000) * +speed.value;
    last = now;
    const i = Math.min(n - 1, Math.floor(clock / D.dt));
    if (i !== +slider.value) { slider.value = i; draw(); }
    if (i >= n - 1) { toggle(false); return; }
    requestAnimationFrame(frame);
  }
  function toggle(on) {
    playing = on;
    play.textContent = on ? "Pause" : "Play";
    if (on) {
      if (+slider.value >= n - 1) slider.value = 0;
      clock = +slider.value * D.dt;
      last = null;
      requestAnimationFrame(frame);
    }
  }
  function seek(i) {
    slider.value = Math.max(0, Math.min(n - 1, i));
    clock = +slider.value * D.dt;
    draw();
  }
  play.addEventListener("click", () => toggle(!playing));
  slider.addEventListener("input", () => { clock = +slider.value * D.dt; draw(); });
  document.addEventListener("keydown", (e) => {
    if (["INPUT", "SELECT", "BUTTON"].includes(e.target.tagName)) return; // their own keys
    if (e.key === " ") { e.preventDefault(); toggle(!playing); }
    if (e.key === "ArrowRight") seek(+slider.value + 1);
    if (e.key === "ArrowLeft") seek(+slider.value - 1);
  });

  // zoom around the cursor, pan by dragging, a double click fits the view again
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const f = e.deltaY > 0 ? 1 / 1.2 : 1.2, mx = e.offsetX * dpr, my = e.offsetY * dpr;
    scale *= f;
    ox = mx - (mx - ox) * f;
    oy = my - (my - oy) * f;
    draw();
  }, { passive: false });
  let drag = null;
  canvas.addEventListener("mousedown", (e) => { drag = [e.clientX, e.clientY]; });
  window.addEventListener("mouseup", () => { drag = null; });
  window.addEventListener("mousemove", (e) => {
    if (!drag) return;
    ox += (e.clientX - drag[0]) * dpr;
    oy += (e.clientY - drag[1]) * dpr;
    drag = [e.clientX, e.clientY];
    draw();
  });
  canvas.addEventListener("dblclick", () => { fit(); draw(); });
  window.addEventListener("resize", () => { fit(); draw(); });

  fit();
  draw();
  // for scripts and tests: the frame shown, seek, and a world point's canvas pixel
  window.viewer = {
    frames: n,
    frame: () => +slider.value,
    seek,
    pixel: (x, y) => [px(x), py(y)],
    pose: (i) => [A.pose[3 * i], A.pose[3 * i + 1], A.pose[3 * i + 2]],
    robotColour: C.robot,
  };
})();
