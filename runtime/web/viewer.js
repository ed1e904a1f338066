// eomc viewer: one model's motion in a three.js scene, with a time slider, play/pause,
// speed, orbit camera, traces and the model's outputs plotted with a cursor.
// Everything it needs is in the page (window.THREE, the JSON in #eomc-data): no network.
(function () {
  "use strict";
  const status = document.getElementById("eomc-status");
  const errors = [];
  function report(msg) {
    errors.push(String(msg));
    status.setAttribute("data-errors", JSON.stringify(errors));
  }
  window.addEventListener("error", (e) => report(e.message || e));
  const origError = console.error;
  console.error = function () { report(Array.from(arguments).join(" ")); origError.apply(console, arguments); };

  const dataElement = document.getElementById("eomc-data");
  const D = JSON.parse(dataElement.textContent);
  dataElement.textContent = "";   // parsed once: a robot's megabytes of text need not stay in the DOM
  const T = window.THREE;

  function f32(b64) {
    const bin = atob(b64), n = bin.length, buf = new Uint8Array(n);
    for (let i = 0; i < n; i++) buf[i] = bin.charCodeAt(i);
    return buf.buffer;
  }
  const times = new Float32Array(f32(D.t));
  const poses = new Float32Array(f32(D.poses));   // per frame: frames (12 each), points (3 each)
  const nf = D.frames.length, np_ = D.points.length, stride = 12 * nf + 3 * np_, nt = times.length;
  const outputs = D.outputs.map((o) => ({ name: o.name, v: new Float32Array(f32(o.values)) }));

  // ---- scene ------------------------------------------------------------------------------
  const view = document.getElementById("eomc-view");
  const renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  view.appendChild(renderer.domElement);
  const scene = new T.Scene();
  scene.background = new T.Color(0xf4f5f7);
  scene.add(new T.HemisphereLight(0xffffff, 0x667788, 2.2));
  const sun = new T.DirectionalLight(0xffffff, 1.6);
  sun.position.set(1, 2, 3);
  scene.add(sun);
  const up = new T.Vector3().fromArray(D.camera.up);
  T.Object3D.DEFAULT_UP.copy(up);
  const camera = new T.PerspectiveCamera(35, 1, D.scale * 0.01, D.camera.far || D.scale * 100);
  camera.up.copy(up);
  camera.position.fromArray(D.camera.position);
  const controls = new T.OrbitControls(camera, renderer.domElement);
  controls.target.fromArray(D.camera.target);
  controls.update();

  const grid = new T.GridHelper(D.camera.gridSize || D.scale * 4, D.camera.gridDivisions || 20, 0xbbbbbb, 0xdddddd);
  if (D.camera.grid === "xy") grid.rotation.x = Math.PI / 2;
  else if (D.camera.grid === "yz") grid.rotation.z = Math.PI / 2;
  grid.position.fromArray(D.camera.floor);
  scene.add(grid);

  function color(c, i) {
    if (c) return new T.Color(c[0], c[1], c[2]);
    const palette = D.palette;
    const p = palette[i % palette.length];
    return new T.Color(p[0], p[1], p[2]);
  }
  function material(c) {
    return new T.MeshStandardMaterial({ color: c, roughness: 0.55, metalness: 0.1 });
  }
  const meshCache = {};
  function meshGeometry(k) {
    if (meshCache[k]) return meshCache[k];
    const m = D.meshes[k];
    const q = new Uint16Array(f32(m.v)), f = new Uint32Array(f32(m.f));
    const pos = new Float32Array(q.length);
    for (let i = 0; i < q.length; i++) {
      const a = i % 3;
      pos[i] = m.lo[a] + (q[i] / 65535) * (m.hi[a] - m.lo[a]);
    }
    const g = new T.BufferGeometry();
    g.setAttribute("position", new T.BufferAttribute(pos, 3));
    g.setIndex(new T.BufferAttribute(f, 1));
    g.computeVertexNormals();
    return (meshCache[k] = g);
  }
  function shapeObject(s, c, forced) {
    let g;
    if (s.kind === "sphere") g = new T.SphereGeometry(s.size[0], 24, 16);
    else if (s.kind === "box") g = new T.BoxGeometry(s.size[0], s.size[1], s.size[2]);
    else if (s.kind === "cylinder") {
      g = new T.CylinderGeometry(s.size[0], s.size[0], s.size[1], 24);
      g.rotateX(Math.PI / 2);   // URDF's cylinders are along z, three.js's along y
    } else if (s.kind === "mesh") g = meshGeometry(s.mesh);
    else return null;
    const obj = new T.Mesh(g, material(s.color && !forced ? new T.Color(s.color[0], s.color[1], s.color[2]) : c));
    const m = new T.Matrix4().fromArray(s.origin).transpose();   // row-major -> three.js
    obj.matrixAutoUpdate = false;
    obj.matrix.copy(m);
    return obj;
  }

  const geometry = D.geometry;
  const frameObjects = [], axesObjects = [];
  D.frames.forEach((name, i) => {
    const group = new T.Group();
    group.matrixAutoUpdate = false;
    const c = color(D.colors[name], i);
    const shapes = geometry[name];
    if (shapes) shapes.forEach((s) => { const o = shapeObject(s, c, !!D.colors[name]); if (o) group.add(o); });
    else if (!Object.keys(geometry).length || D.colors[name]) group.add(new T.Mesh(new T.SphereGeometry(D.radius, 24, 16), material(c)));
    const axes = new T.AxesHelper(D.scale * 0.08);
    axes.visible = !!D.axes;   // off for a robot drawn by its meshes: the toggle in the bar
    axesObjects.push(axes);
    group.add(axes);
    scene.add(group);
    frameObjects.push(group);
  });
  if (geometry.world && D.frames.indexOf("world") < 0) {
    const group = new T.Group();
    geometry.world.forEach((s) => { const o = shapeObject(s, new T.Color(0.55, 0.55, 0.6)); if (o) group.add(o); });
    scene.add(group);
  }
  // what touches (the contacts the model computes with): translucent, in the body's frame
  const collisionObjects = [];
  const touchMaterial = new T.MeshBasicMaterial({ color: 0xff8c00, transparent: true, opacity: 0.35, depthWrite: false });
  const touchWire = new T.MeshBasicMaterial({ color: 0xd35400, wireframe: true, transparent: true, opacity: 0.6 });
  Object.keys(D.collision || {}).forEach((name) => {
    const k = D.frames.indexOf(name);
    if (k < 0) return;
    D.collision[name].forEach((s) => {
      let g;
      // 1 % larger than the shape: a visual sphere of the same size would hide it half
      if (s.kind === "sphere") g = new T.SphereGeometry(s.size[0] * 1.01, 48, 32);
      else if (s.kind === "ellipsoid") { g = new T.SphereGeometry(1.01, 48, 32); g.scale(s.size[0], s.size[1], s.size[2]); }
      else g = new T.SphereGeometry(D.scale * 0.008, 8, 6);   // a point contact: a dot
      const obj = new T.Group();
      obj.add(new T.Mesh(g, touchMaterial));
      if (s.kind !== "point") obj.add(new T.Mesh(g, touchWire));
      obj.matrixAutoUpdate = false;
      obj.matrix.copy(new T.Matrix4().fromArray(s.origin).transpose());
      obj.visible = !!D.show_collision;
      obj.userData.contact = s.contact;
      frameObjects[k].add(obj);
      collisionObjects.push(obj);
    });
  });
  // contact forces: an arrow per contact from its touching point, hidden while it is open
  const arrowData = (D.arrows || []).map((a) => new Float32Array(f32(a.values)));
  const arrowObjects = (D.arrows || []).map(() => {
    const h = new T.ArrowHelper(new T.Vector3(0, 0, 1), new T.Vector3(), 1, 0x00a000, D.scale * 0.04, D.scale * 0.02);
    h.visible = false;
    // drawn over everything: a force at a foot points into the leg, at a ball into the ball
    [h.line, h.cone].forEach((o) => { o.material.depthTest = false; o.material.transparent = true; o.renderOrder = 10; });
    scene.add(h);
    return h;
  });
  let showForces = !!D.show_forces;
  const arrowShown = arrowObjects.map(() => 0);
  function placeArrows(i) {
    arrowObjects.forEach((h, a) => {
      const v = arrowData[a], o = 6 * i;
      const d = new T.Vector3(v[o + 3], v[o + 4], v[o + 5]), len = d.length();
      arrowShown[a] = len > 0 ? 1 : 0;
      h.visible = showForces && len > 0;
      if (len > 0) {
        h.position.set(v[o], v[o + 1], v[o + 2]);
        h.setDirection(d.divideScalar(len));
        const head = Math.min(D.scale * 0.04, 0.4 * len);
        h.setLength(len, head, head * 0.5);
      }
    });
  }
  const pointObjects = [];
  D.points.forEach((name, j) => {
    const c = color(D.colors[name], nf + j);
    const group = new T.Group();
    const shapes = geometry[name];
    if (shapes) shapes.forEach((s) => { const o = shapeObject(s, c, !!D.colors[name]); if (o) group.add(o); });
    else if (D.meshes.length && !D.colors[name]) { /* a robot with meshes: its points are the lines' ends only */ }
    else if (!D.fixed[j]) group.add(new T.Mesh(new T.SphereGeometry(D.radius, 24, 16), material(c)));
    else group.add(new T.Mesh(new T.SphereGeometry(D.radius * 0.4, 12, 8), material(new T.Color(0.3, 0.3, 0.3))));
    scene.add(group);
    pointObjects.push(group);
  });
  const lineGeometry = new T.BufferGeometry();
  const linePos = new Float32Array(D.lines.length * 6);
  lineGeometry.setAttribute("position", new T.BufferAttribute(linePos, 3));
  const lines = new T.LineSegments(lineGeometry, new T.LineBasicMaterial({ color: 0x333333 }));
  lines.frustumCulled = false;
  scene.add(lines);

  // traces: the whole path of chosen points (frame origins or points), drawn once
  D.traces.forEach((tr, k) => {
    const g = new T.BufferGeometry();
    const a = new Float32Array(nt * 3);
    for (let i = 0; i < nt; i++) for (let c = 0; c < 3; c++) a[3 * i + c] = poses[i * stride + tr.offset + c];
    g.setAttribute("position", new T.BufferAttribute(a, 3));
    // the body's colour, paler: a trace never has the body's own colour
    const c = color(D.colors[tr.name], D.frames.indexOf(tr.name) >= 0 ? D.frames.indexOf(tr.name) : nf + D.points.indexOf(tr.name));
    const line = new T.Line(g, new T.LineBasicMaterial({ color: c.lerp(new T.Color(1, 1, 1), 0.5) }));
    line.frustumCulled = false;
    scene.add(line);
  });

  // the camera follows the robot (a fall, a walk): per-frame targets; the user's orbit is kept
  const follow = D.camera.follow ? new Float32Array(f32(D.camera.follow)) : null;
  function aim(i) {
    if (!follow) return;
    const d = new T.Vector3(follow[3 * i], follow[3 * i + 1], follow[3 * i + 2]).sub(controls.target);
    controls.target.add(d);
    camera.position.add(d);
    camera.updateMatrixWorld();
  }

  function place(i) {
    aim(i);
    const base = i * stride;
    for (let k = 0; k < nf; k++) {
      const o = base + 12 * k, R = poses.subarray(o + 3, o + 12);
      frameObjects[k].matrix.set(R[0], R[1], R[2], poses[o], R[3], R[4], R[5], poses[o + 1],
                                 R[6], R[7], R[8], poses[o + 2], 0, 0, 0, 1);
      frameObjects[k].matrixWorldNeedsUpdate = true;
    }
    const pbase = base + 12 * nf;
    for (let j = 0; j < np_; j++) pointObjects[j].position.set(poses[pbase + 3 * j], poses[pbase + 3 * j + 1], poses[pbase + 3 * j + 2]);
    D.lines.forEach((pair, n) => {
      for (let e = 0; e < 2; e++) for (let c = 0; c < 3; c++) linePos[6 * n + 3 * e + c] = poses[pbase + 3 * pair[e] + c];
    });
    lineGeometry.attributes.position.needsUpdate = true;
    placeArrows(i);
  }

  // ---- outputs plot -------------------------------------------------------------------
  const plot = document.getElementById("eomc-plot");
  const ctx = plot.getContext("2d");
  const plotColors = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"];
  const strips = D.strips || outputs.map((o, k) => ({ label: o.name, series: [k] }));
  function drawPlot(i) {
    const w = plot.width, h = plot.height;
    ctx.clearRect(0, 0, w, h);
    if (!strips.length) return;
    const foot = D.strips_left_off || D.idle_contacts ? 16 : 0;
    const rows = strips.length, rh = (h - foot) / rows, t0 = times[0], t1 = times[nt - 1] || 1;
    const X = (t) => 40 + ((t - t0) / (t1 - t0 || 1)) * (w - 50);
    strips.forEach((strip, k) => {
      let lo = Infinity, hi = -Infinity;
      strip.series.forEach((s) => { for (const v of outputs[s].v) { if (v < lo) lo = v; if (v > hi) hi = v; } });
      // a conserved quantity's float32 noise is not a signal: show at least 1e-4 of its size
      const least = Math.max(1e-4 * Math.max(Math.abs(lo), Math.abs(hi)), 1e-12);
      if (hi - lo < least) { const mid = (hi + lo) / 2; lo = mid - least / 2; hi = mid + least / 2; }
      const Y = (v) => k * rh + rh - 6 - ((v - lo) / (hi - lo)) * (rh - 22);
      const texts = [];
      strip.series.forEach((s, c) => {
        const o = outputs[s];
        ctx.strokeStyle = plotColors[(strip.series.length > 1 ? c : k) % plotColors.length];
        ctx.lineWidth = 1.5;
        ctx.beginPath();
        for (let n = 0; n < nt; n++) { const x = X(times[n]), y = Y(o.v[n]); n ? ctx.lineTo(x, y) : ctx.moveTo(x, y); }
        ctx.stroke();
        texts.push(strip.series.length > 1 ? `${o.name.slice(o.name.lastIndexOf(".") + 1)} ${o.v[i].toPrecision(4)}` : `${o.name} = ${o.v[i].toPrecision(6)}`);
      });
      ctx.fillStyle = "#222";
      ctx.font = "12px sans-serif";
      ctx.fillText(strip.series.length > 1 ? `${strip.label}: ${texts.join(", ")}` : texts[0], 44, k * rh + 14);
    });
    if (foot) {     // short: the strips' column is ~360 px wide on a 1000 px page
      const more = D.strips_left_off, idle = D.idle_contacts;
      const text = !idle ? `${more} more outputs not drawn (outputs=[...] picks them)`
        : !more ? `${idle} contacts that never touched not drawn (outputs=[...])`
          : `${more} more outputs, ${idle} untouched contacts not drawn (outputs=[...])`;
      ctx.fillStyle = "#666";
      ctx.fillText(text, 44, h - 4);
    }
    ctx.strokeStyle = "#000";
    ctx.lineWidth = 1;
    ctx.beginPath();
    ctx.moveTo(X(times[i]), 0);
    ctx.lineTo(X(times[i]), h);
    ctx.stroke();
  }

  // ---- controls -----------------------------------------------------------------------
  const slider = document.getElementById("eomc-slider");
  const label = document.getElementById("eomc-time");
  const playButton = document.getElementById("eomc-play");
  const speedSelect = document.getElementById("eomc-speed");
  const axesBox = document.getElementById("eomc-axes");
  axesBox.checked = !!D.axes;
  status.setAttribute("data-axes", D.axes ? "1" : "0");
  axesBox.addEventListener("change", () => {
    axesObjects.forEach((a) => { a.visible = axesBox.checked; });
    status.setAttribute("data-axes", axesBox.checked ? "1" : "0");
    renderer.render(scene, camera);
  });
  const collisionBox = document.getElementById("eomc-collision");
  const forcesBox = document.getElementById("eomc-forces");
  collisionBox.checked = !!D.show_collision;
  forcesBox.checked = showForces;
  if (D.newtons_per_metre) document.getElementById("eomc-force-scale").textContent =
    ` (1 m = ${Number(D.newtons_per_metre).toPrecision(3)} N)`;
  function flags() {
    status.setAttribute("data-collision", collisionBox.checked ? String(collisionObjects.length) : "0");
    status.setAttribute("data-forces", showForces ? String(arrowShown.reduce((a, b) => a + b, 0)) : "0");
  }
  collisionBox.addEventListener("change", () => {
    collisionObjects.forEach((o) => { o.visible = collisionBox.checked; });
    flags();
    renderer.render(scene, camera);
  });
  forcesBox.addEventListener("change", () => {
    showForces = forcesBox.checked;
    placeArrows(current);
    flags();
    renderer.render(scene, camera);
  });
  // #collision=1/0, #forces=1/0 set the toggles (links and screenshots)
  const hashFlag = (key) => { const r = new RegExp(`[#&]${key}=([01])`).exec(location.hash); return r ? r[1] === "1" : null; };
  if (hashFlag("collision") !== null) { collisionBox.checked = hashFlag("collision"); collisionObjects.forEach((o) => { o.visible = collisionBox.checked; }); }
  if (hashFlag("forces") !== null) { forcesBox.checked = showForces = hashFlag("forces"); }
  slider.max = String(nt - 1);
  let playing = true, current = 0, clock = times[0], last = null;

  function index(t) {   // last frame at or before t
    let lo = 0, hi = nt - 1;
    while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (times[mid] <= t) lo = mid; else hi = mid - 1; }
    return lo;
  }
  function show(i) {
    current = i;
    slider.value = String(i);
    label.textContent = `t = ${times[i].toFixed(3)} s`;
    place(i);
    drawPlot(i);
    renderer.render(scene, camera);
    describe();
  }
  // for tests and tools: the frame shown, the camera's projection and the canvas's place
  function describe() {
    camera.updateMatrixWorld();
    const pv = new T.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse);
    const rect = renderer.domElement.getBoundingClientRect();
    status.setAttribute("data-frame", String(current));
    flags();
    status.setAttribute("data-view", JSON.stringify({ pv: pv.elements, left: rect.left, top: rect.top, width: rect.width, height: rect.height }));
  }
  function resize() {
    const w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h, false);
    renderer.domElement.style.width = w + "px";
    renderer.domElement.style.height = h + "px";
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    plot.width = plot.clientWidth;
    plot.height = plot.clientHeight;
    show(current);
  }
  slider.addEventListener("input", () => { playing = false; playButton.textContent = "play"; clock = times[+slider.value]; show(+slider.value); });
  playButton.addEventListener("click", () => {
    playing = !playing;
    playButton.textContent = playing ? "pause" : "play";
    if (playing && current >= nt - 1) clock = times[0];
    last = null;
  });
  controls.addEventListener("change", () => { renderer.render(scene, camera); describe(); });
  if (/[#&]grid=0/.test(location.hash)) grid.visible = false;   // for screenshots that measure the robot
  window.addEventListener("resize", resize);

  // #t=1.5 shows that time, paused (for screenshots and links); &size=800x450 fixes the scene's size
  const sized = /[#&]size=(\d+)x(\d+)/.exec(location.hash);
  if (sized) {
    const main = document.getElementById("eomc-main");
    main.style.height = sized[2] + "px";
    view.style.flex = "none";
    view.style.width = sized[1] + "px";
  }
  const m = /(?:^#|[#&])t=([0-9.eE+-]+)/.exec(location.hash);
  if (m) { playing = false; playButton.textContent = "play"; clock = parseFloat(m[1]); current = index(clock); }
  resize();

  function tick(now) {
    if (playing) {
      if (last !== null) clock += ((now - last) / 1000) * parseFloat(speedSelect.value);
      last = now;
      if (clock >= times[nt - 1]) { clock = times[nt - 1]; playing = false; playButton.textContent = "play"; }
      const i = index(clock);
      if (i !== current) show(i);
    } else last = null;
    requestAnimationFrame(tick);
  }
  requestAnimationFrame(tick);

  // #bench=N: draw N frames back to back (each finished on the GPU) and record the times
  const bench = /[#&]bench=(\d+)/.exec(location.hash);
  if (bench) {
    playing = false;
    const gl = renderer.getContext(), times_ms = [];
    for (let k = 0; k < +bench[1]; k++) {
      const t0 = performance.now();
      show(k % nt);
      gl.finish();
      times_ms.push(performance.now() - t0);
    }
    times_ms.sort((a, b) => a - b);
    status.setAttribute("data-bench", JSON.stringify({ n: times_ms.length, median_ms: times_ms[times_ms.length >> 1],
      p90_ms: times_ms[Math.floor(times_ms.length * 0.9)], width: renderer.domElement.width, height: renderer.domElement.height }));
  }
  status.setAttribute("data-ready", "1");
})();
