// tmpc plan viewer: a compact WebGL2 renderer for the page tmpc.runtime.viewer writes.
// Data (the <script id="plan-data"> JSON): meshes (uint16-quantized vertices, indices, base64),
// parts (node, mesh, colour, local 4x4 column-major), frames (times, float32 positions and int16
// quaternions per node), states (time, index, action). Shading is flat Lambert with normals
// from screen-space derivatives, so the meshes carry no normals.
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("plan-data").textContent);
  const $ = (id) => document.getElementById(id);

  function b64(s, Type) {
    const bin = atob(s);
    const buf = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) buf[i] = bin.charCodeAt(i);
    return new Type(buf.buffer);
  }

  // ---- frames ------------------------------------------------------------------------------
  const K = D.frames.count, N = D.nodes.length;
  const times = b64(D.frames.t, Float32Array);
  const fpos = b64(D.frames.pos, Float32Array);
  const frot = b64(D.frames.rot, Int16Array);
  const T_END = K ? times[K - 1] : 0;

  function nodeMatrix(k, a, n, out) {
    // pose of node n between frames k and k+1 (fraction a): position lerp, quaternion nlerp
    const k1 = Math.min(k + 1, K - 1);
    const p0 = (k * N + n) * 3, p1 = (k1 * N + n) * 3;
    const q0 = (k * N + n) * 4, q1 = (k1 * N + n) * 4;
    let x0 = frot[q0] / 32767, y0 = frot[q0 + 1] / 32767, z0 = frot[q0 + 2] / 32767,
      w0 = frot[q0 + 3] / 32767;
    let x1 = frot[q1] / 32767, y1 = frot[q1 + 1] / 32767, z1 = frot[q1 + 2] / 32767,
      w1 = frot[q1 + 3] / 32767;
    if (x0 * x1 + y0 * y1 + z0 * z1 + w0 * w1 < 0) { x1 = -x1; y1 = -y1; z1 = -z1; w1 = -w1; }
    let x = x0 + a * (x1 - x0), y = y0 + a * (y1 - y0), z = z0 + a * (z1 - z0),
      w = w0 + a * (w1 - w0);
    const l = Math.hypot(x, y, z, w) || 1;
    x /= l; y /= l; z /= l; w /= l;
    out[0] = 1 - 2 * (y * y + z * z); out[1] = 2 * (x * y + z * w); out[2] = 2 * (x * z - y * w);
    out[3] = 0;
    out[4] = 2 * (x * y - z * w); out[5] = 1 - 2 * (x * x + z * z); out[6] = 2 * (y * z + x * w);
    out[7] = 0;
    out[8] = 2 * (x * z + y * w); out[9] = 2 * (y * z - x * w); out[10] = 1 - 2 * (x * x + y * y);
    out[11] = 0;
    out[12] = fpos[p0] + a * (fpos[p1] - fpos[p0]);
    out[13] = fpos[p0 + 1] + a * (fpos[p1 + 1] - fpos[p0 + 1]);
    out[14] = fpos[p0 + 2] + a * (fpos[p1 + 2] - fpos[p0 + 2]);
    out[15] = 1;
    return out;
  }

  function frameAt(t) {
    let lo = 0, hi = K - 1;
    if (K < 2 || t <= times[0]) return [0, 0];
    if (t >= times[K - 1]) return [K - 1, 0];
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (times[mid] <= t) lo = mid; else hi = mid;
    }
    const span = times[lo + 1] - times[lo];
    return [lo, span > 0 ? (t - times[lo]) / span : 0];
  }

  // ---- 4x4 column-major matrices -----------------------------------------------------------
  function mul(a, b, out) {
    for (let c = 0; c < 4; c++) {
      for (let r = 0; r < 4; r++) {
        out[c * 4 + r] = a[r] * b[c * 4] + a[4 + r] * b[c * 4 + 1] + a[8 + r] * b[c * 4 + 2] +
          a[12 + r] * b[c * 4 + 3];
      }
    }
    return out;
  }
  function perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1,
      0, 0, 2 * far * near * nf, 0]);
  }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function norm(a) { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function lookAt(eye, target, up) {
    const f = norm(sub(target, eye)), s = norm(cross(f, up)), u = cross(s, f);
    return new Float32Array([s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -dot(s, eye), -dot(u, eye), dot(f, eye), 1]);
  }

  // ---- GL setup ------------------------------------------------------------------------------
  const canvas = $("view");
  const gl = canvas.getContext("webgl2", { antialias: true });
  if (!gl) {
    $("label").textContent = "This browser has no WebGL2: the plan cannot be drawn.";
    return;
  }
  const VS = `#version 300 es
in vec3 pos;
uniform mat4 model, viewProj;
out vec3 wpos;
void main() { vec4 w = model * vec4(pos, 1.0); wpos = w.xyz; gl_Position = viewProj * w; }`;
  const FS = `#version 300 es
precision highp float;
in vec3 wpos;
uniform vec3 color, eye;
uniform float unlit;
out vec4 outColor;
void main() {
  if (unlit > 0.5) { outColor = vec4(color, 1.0); return; }
  vec3 n = normalize(cross(dFdx(wpos), dFdy(wpos)));
  vec3 v = normalize(eye - wpos);
  if (dot(n, v) < 0.0) n = -n;
  vec3 l1 = normalize(vec3(0.35, -0.45, 0.82)), l2 = normalize(vec3(-0.6, 0.5, 0.35));
  float d = 0.32 + 0.5 * max(dot(n, l1), 0.0) + 0.18 * max(dot(n, l2), 0.0) + 0.12 * max(dot(n, v), 0.0);
  outColor = vec4(min(color * d, vec3(1.0)), 1.0);
}`;
  function shader(type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  }
  const prog = gl.createProgram();
  gl.attachShader(prog, shader(gl.VERTEX_SHADER, VS));
  gl.attachShader(prog, shader(gl.FRAGMENT_SHADER, FS));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  const U = {};
  for (const name of ["model", "viewProj", "color", "eye", "unlit"]) {
    U[name] = gl.getUniformLocation(prog, name);
  }
  const aPos = gl.getAttribLocation(prog, "pos");

  function vao(vertices, indices) {
    const va = gl.createVertexArray();
    gl.bindVertexArray(va);
    const vb = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vb);
    gl.bufferData(gl.ARRAY_BUFFER, vertices, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(aPos);
    gl.vertexAttribPointer(aPos, 3, gl.FLOAT, false, 0, 0);
    if (indices) {
      const ib = gl.createBuffer();
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    }
    gl.bindVertexArray(null);
    return va;
  }

  const meshes = D.meshes.map((m) => {
    const q = b64(m.v, Uint16Array);
    const v = new Float32Array(q.length);
    for (let i = 0; i < q.length; i++) {
      const c = i % 3;
      v[i] = m.lo[c] + (q[i] / 65535) * (m.hi[c] - m.lo[c]);
    }
    const idx = b64(m.i, m.i32 ? Uint32Array : Uint16Array);
    return { vao: vao(v, idx), count: idx.length, type: m.i32 ? gl.UNSIGNED_INT : gl.UNSIGNED_SHORT };
  });
  const parts = D.parts.map((p) => ({ node: p.node, mesh: meshes[p.mesh], color: p.color,
    T: new Float32Array(p.T) }));

  // floor grid over the scene's bounds
  const grid = (function () {
    const [[x0, x1], [y0, y1]] = D.bounds;
    const ext = Math.max(x1 - x0, y1 - y0);
    const step = ext > 12 ? 1 : ext > 4 ? 0.5 : 0.25;
    const pts = [];
    for (let x = Math.ceil(x0 / step) * step; x <= x1 + 1e-9; x += step) pts.push(x, y0, 0, x, y1, 0);
    for (let y = Math.ceil(y0 / step) * step; y <= y1 + 1e-9; y += step) pts.push(x0, y, 0, x1, y, 0);
    const frame = [x0, y0, 0, x1, y0, 0, x1, y0, 0, x1, y1, 0, x1, y1, 0, x0, y1, 0, x0, y1, 0, x0, y0, 0];
    return { lines: vao(new Float32Array(pts), null), n: pts.length / 3,
      frame: vao(new Float32Array(frame), null), nf: frame.length / 3 };
  })();

  // ---- camera --------------------------------------------------------------------------------
  const cam = { target: D.focus.slice(0, 3), dist: D.focus[3] * 2.8, yaw: D.yaw, pitch: 0.55 };
  function eyePos() {
    const c = Math.cos(cam.pitch);
    return [cam.target[0] + cam.dist * c * Math.cos(cam.yaw),
      cam.target[1] + cam.dist * c * Math.sin(cam.yaw),
      cam.target[2] + cam.dist * Math.sin(cam.pitch)];
  }
  let drag = null;
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("pointerdown", (e) => {
    drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button !== 0 };
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) {
      const eye = eyePos(), f = norm(sub(cam.target, eye)), s = norm(cross(f, [0, 0, 1])),
        u = cross(s, f), k = cam.dist * 0.0016;
      for (let i = 0; i < 3; i++) cam.target[i] += (-s[i] * dx + u[i] * dy) * k;
    } else {
      cam.yaw -= dx * 0.008;
      cam.pitch = Math.max(-1.5, Math.min(1.5, cam.pitch + dy * 0.008));
    }
    dirty = true;
  });
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    cam.dist *= Math.exp(e.deltaY * 0.001);
    dirty = true;
  }, { passive: false });

  // ---- timeline --------------------------------------------------------------------------------
  let t = 0, playing = false, last = null, dirty = true;
  const slider = $("slider"), track = $("track");
  for (const s of D.states) {
    if (!s.action || T_END <= 0) continue;
    const tick = document.createElement("div");
    tick.className = "tick";
    tick.style.left = (100 * s.t / T_END) + "%";
    tick.dataset.label = `state ${s.index}: ${s.action}`;
    tick.addEventListener("click", () => seek(s.t));
    track.appendChild(tick);
  }
  function stateAt(time) {
    let i = 0;
    while (i + 1 < D.states.length && D.states[i + 1].t <= time + 1e-6) i++;
    return i;
  }
  function seek(time) { t = Math.max(0, Math.min(T_END, time)); dirty = true; }
  function setPlaying(p) {
    playing = p;
    if (p && t >= T_END) t = 0;
    last = null;
    $("play").innerHTML = p ? "&#10074;&#10074;" : "&#9654;";
  }
  $("play").addEventListener("click", () => setPlaying(!playing));
  slider.addEventListener("input", () => { setPlaying(false); seek(slider.value / 1000 * T_END); });
  document.addEventListener("keydown", (e) => {
    if (e.key === " ") { e.preventDefault(); setPlaying(!playing); }
    const i = stateAt(t);
    if (e.key === "ArrowRight" && i + 1 < D.states.length) { setPlaying(false); seek(D.states[i + 1].t); }
    if (e.key === "ArrowLeft") {
      setPlaying(false);
      seek(D.states[D.states[i].t < t - 1e-6 ? i : Math.max(0, i - 1)].t);
    }
  });
  function label() {
    const i = stateAt(t), s = D.states[i], n = D.states.length - 1;
    let text = `state ${s.index} / ${D.states[n].index}`;
    if (s.action) text += ` \u2014 ${s.action}`;
    else {
      for (let k = i - 1; k >= 0; k--) {
        if (D.states[k].action) { text += ` \u2014 after ${D.states[k].action}`; break; }
      }
    }
    $("label").textContent = text;
    $("time").textContent = `${t.toFixed(1)} / ${T_END.toFixed(1)} s`;
    if (document.activeElement !== slider) slider.value = T_END > 0 ? Math.round(1000 * t / T_END) : 0;
  }

  // ---- drawing ---------------------------------------------------------------------------------
  const nodeM = Array.from({ length: N }, () => new Float32Array(16));
  const model = new Float32Array(16), viewProj = new Float32Array(16);
  function draw() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(canvas.clientWidth * dpr), h = Math.round(canvas.clientHeight * dpr);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, w, h);
    gl.clearColor(0.933, 0.941, 0.953, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(prog);
    const eye = eyePos();
    mul(perspective(0.8, w / Math.max(h, 1), cam.dist * 0.01, cam.dist * 60),
      lookAt(eye, cam.target, [0, 0, 1]), viewProj);
    gl.uniformMatrix4fv(U.viewProj, false, viewProj);
    gl.uniform3fv(U.eye, eye);
    const identity = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    gl.uniform1f(U.unlit, 1);
    gl.uniformMatrix4fv(U.model, false, identity);
    gl.uniform3fv(U.color, [0.78, 0.8, 0.83]);
    gl.bindVertexArray(grid.lines);
    gl.drawArrays(gl.LINES, 0, grid.n);
    gl.uniform3fv(U.color, [0.45, 0.48, 0.55]);
    gl.bindVertexArray(grid.frame);
    gl.drawArrays(gl.LINES, 0, grid.nf);
    gl.uniform1f(U.unlit, 0);
    if (K) {
      const [k, a] = frameAt(t);
      for (let n = 0; n < N; n++) nodeMatrix(k, a, n, nodeM[n]);
    }
    for (const p of parts) {
      gl.uniformMatrix4fv(U.model, false, mul(nodeM[p.node], p.T, model));
      gl.uniform3fv(U.color, p.color);
      gl.bindVertexArray(p.mesh.vao);
      gl.drawElements(gl.TRIANGLES, p.mesh.count, p.mesh.type, 0);
    }
    gl.bindVertexArray(null);
  }
  // ---- object labels: a tag above each movable object, where the camera sees it -----------
  const tags = (D.labels || []).map((l) => {
    const el = document.createElement("div");
    el.className = "objlabel";
    el.textContent = l.name;
    document.body.appendChild(el);
    return { node: l.node, el: el };
  });
  function placeTags() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    for (const tag of tags) {
      const m = nodeM[tag.node], x = m[12], y = m[13], z = m[14];
      const cx = viewProj[0] * x + viewProj[4] * y + viewProj[8] * z + viewProj[12];
      const cy = viewProj[1] * x + viewProj[5] * y + viewProj[9] * z + viewProj[13];
      const cw = viewProj[3] * x + viewProj[7] * y + viewProj[11] * z + viewProj[15];
      if (cw <= 1e-6) { tag.el.style.display = "none"; continue; }
      tag.el.style.display = "";
      tag.el.style.left = `${(cx / cw * 0.5 + 0.5) * w}px`;
      tag.el.style.top = `${(0.5 - cy / cw * 0.5) * h}px`;
    }
  }
  const speed = $("speed");
  function tick(now) {
    if (playing) {
      if (last !== null) t += (now - last) / 1000 * parseFloat(speed.value);
      last = now;
      if (t >= T_END) { t = T_END; setPlaying(false); }
      dirty = true;
    }
    if (dirty) { draw(); placeTags(); label(); dirty = false; }
    requestAnimationFrame(tick);
  }
  window.addEventListener("resize", () => { dirty = true; });
  // #state=I or #t=SECONDS in the address opens the page there
  const m = /(state|t)=([0-9.]+)/.exec(window.location.hash);
  if (m) {
    const s = D.states.find((x) => x.index === parseInt(m[2], 10));
    seek(m[1] === "t" ? parseFloat(m[2]) : (s ? s.t : 0));
  }
  window.tmpcViewer = { seek: seek, play: setPlaying, duration: T_END, states: D.states };
  requestAnimationFrame(tick);
})();
