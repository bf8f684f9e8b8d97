// creatio scene viewer. Reads the scene's data from #scene-data (written by
// creatio.scenes.page from scene.nc) and draws it with three.js: no network, no server.
//
// The membrane is drawn from the phases of each frame with c(alpha, R) of docs/model.md s.1.1
// (surfacePoint below); everything else (centre, orientation, normal, velocity, readouts) is
// the dataset's own numbers. Between two frames positions and readouts are interpolated
// linearly and the orientation spherically; at a frame time the page draws the frame exactly.
// An explorable scene also carries its family (one member per value of its axes): a slider
// per axis switches the drawn member, a chart shows each member's headline figures.
// #scene-state holds what was drawn last (time, frame, member, positions), for tests.
// Text from the data (titles, labels, reasons) is always set as text, never parsed as HTML.
(function () {
  "use strict";
  const T = window.THREE;
  const D = JSON.parse(document.getElementById("scene-data").textContent);
  const A = {};
  for (const [name, a] of Object.entries(D.arrays)) A[name] = decode(a);
  const state = { t: 0, playing: false, speed: D.attrs.playback_speed || 1, last: null };

  // float64 (b64), or 16-bit codes over [low, high] (u16: creatio.scenes.page._coded).
  function decode(a) {
    const bin = atob(a.u16 !== undefined ? a.u16 : a.b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    let v;
    if (a.u16 !== undefined) {
      const codes = new Uint16Array(bytes.buffer);
      const scale = (a.high - a.low) / 65534;  // creatio.scenes.page.CODES; 65535 is NaN
      v = new Float64Array(codes.length);
      for (let i = 0; i < codes.length; i++) v[i] = codes[i] > 65534 ? NaN : a.low + codes[i] * scale;
    } else v = new Float64Array(bytes.buffer);
    v.shape = a.shape;
    return v;
  }

  function showError(message) {
    const box = document.getElementById("errors");
    box.hidden = false;
    box.textContent = message;
    window.creatioErrors.push(message);
  }

  // A message for the reader (a URL value the page cannot use): shown, not an error.
  function notice(message) {
    const box = document.getElementById("notice");
    box.hidden = false;
    box.appendChild(el("div", {}, message));
  }

  // ------------------------------------------------------------------------ the surface
  // c(alpha, R) at phases (phr, pha) and inclination gam (docs/model.md s.1.1); also W.
  // A rib surface (g.skin: its splines S_c, S_s at the mesh angles, creatio.model.ribs)
  // replaces cos(Ka alpha + phi_a) by cos(phi_a) S_c - sin(phi_a) S_s at mesh angle i.
  function surfacePoint(g, alpha, R, phr, pha, gam, out, i) {
    const k = 2 * Math.PI * g.Kr / g.dR;
    const H = g.skin && i !== undefined
      ? Math.cos(pha) * g.skin.c[i] - Math.sin(pha) * g.skin.s[i] : Math.cos(g.Ka * alpha + pha);
    const W = g.A * Math.sin(k * R + phr) * H;
    const cg = Math.cos(gam), sg = Math.sin(gam);
    const rho = g.R0 + R * cg - W * sg;
    out[0] = rho * Math.cos(alpha);
    out[1] = rho * Math.sin(alpha);
    out[2] = R * sg + W * cg;
    return W;
  }

  const COLD = [0.16, 0.35, 0.62], MID = [0.86, 0.87, 0.85], WARM = [0.72, 0.45, 0.20];
  function heightColour(w, out, i) {  // W / A in [-1, 1]: cavity blue, crest brown
    const s = Math.max(-1, Math.min(1, w));
    const [a, b, f] = s < 0 ? [MID, COLD, -s] : [MID, WARM, s];
    for (let c = 0; c < 3; c++) out[3 * i + c] = a[c] + (b[c] - a[c]) * f;
  }
  const css = (c) => `rgb(${c.map((x) => Math.round(255 * x)).join(",")})`;

  // An arrow of solid shaft and cone (thick enough to read at any zoom), from its origin.
  class Arrow {
    constructor(colour, radius) {
      const mat = new T.MeshStandardMaterial({ color: colour, roughness: 0.5 });
      this.group = new T.Group();
      this.shaft = new T.Mesh(new T.CylinderGeometry(radius, radius, 1, 12), mat);
      this.head = new T.Mesh(new T.ConeGeometry(2.4 * radius, 1, 16), mat);
      this.group.add(this.shaft, this.head);
      this.radius = radius;
      this.up = new T.Vector3(0, 1, 0);
    }
    set(origin, direction, length) {
      this.group.visible = length > 1e-9;
      if (!this.group.visible) return;
      const head = Math.min(6 * this.radius, 0.4 * length);
      this.group.position.copy(origin);
      this.group.quaternion.setFromUnitVectors(this.up, direction.clone().normalize());
      this.shaft.scale.set(1, length - head, 1);
      this.shaft.position.set(0, (length - head) / 2, 0);
      this.head.scale.set(1, head, 1);
      this.head.position.set(0, length - head / 2, 0);
    }
  }

  class Membrane {
    constructor(g, nA, nR, opacity) {
      this.g = g; this.nA = nA; this.nR = nR;
      const n = nA * nR;
      this.pos = new Float32Array(3 * n);
      this.col = new Float32Array(3 * n);
      const idx = [];
      for (let i = 0; i < nA - 1; i++) {
        for (let j = 0; j < nR - 1; j++) {
          const a = i * nR + j, b = (i + 1) * nR + j;
          idx.push(a, b, a + 1, b, b + 1, a + 1);
        }
      }
      const geo = new T.BufferGeometry();
      geo.setAttribute("position", new T.BufferAttribute(this.pos, 3));
      geo.setAttribute("color", new T.BufferAttribute(this.col, 3));
      geo.setIndex(idx);
      this.geo = geo;
      this.mesh = new T.Mesh(geo, new T.MeshStandardMaterial({
        vertexColors: true, side: T.DoubleSide, roughness: 0.85, metalness: 0.0,
        transparent: opacity < 1, opacity: opacity,
      }));
      this.key = null;
    }
    alpha(i) { return 2 * Math.PI * i / (this.nA - 1); }
    radius(j) { return this.g.dR * j / (this.nR - 1); }
    // paint: null (colour by height) or { key, colour(v, out) } colouring vertex v.
    update(phr, pha, gam, paint) {
      const key = phr + "," + pha + "," + gam + "," + (paint ? paint.key : "");
      if (key === this.key) return;
      this.key = key;
      const p = [0, 0, 0];
      for (let i = 0; i < this.nA; i++) {
        for (let j = 0; j < this.nR; j++) {
          const v = i * this.nR + j;
          const W = surfacePoint(this.g, this.alpha(i), this.radius(j), phr, pha, gam, p, i);
          this.pos[3 * v] = p[0]; this.pos[3 * v + 1] = p[1]; this.pos[3 * v + 2] = p[2];
          if (paint) paint.colour(v, this.col);
          else heightColour(this.g.A > 0 ? W / this.g.A : 0, this.col, v);
        }
      }
      this.geo.attributes.position.needsUpdate = true;
      this.geo.attributes.color.needsUpdate = true;
      this.geo.computeVertexNormals();
      this.geo.computeBoundingSphere();
    }
    points() {  // the drawn inner, middle and outer rims (what the camera frames)
      const out = [];
      for (let i = 0; i < this.nA; i += 2) {
        for (const j of [0, Math.floor(this.nR / 2), this.nR - 1]) {
          const v = i * this.nR + j;
          out.push([this.pos[3 * v], this.pos[3 * v + 1], this.pos[3 * v + 2]]);
        }
      }
      return out;
    }
    // A few drawn vertices with their (alpha, R): what tests compare with the model. Two of
    // them off the radii where sin(2 pi Kr R / dR) vanishes, so that every phase shows.
    probeIndices() {
      return [[0, 0], [Math.floor(this.nA / 3), Math.floor(this.nR / 2)],
              [this.nA - 2, this.nR - 1], [Math.floor(this.nA / 5), 1],
              [Math.floor(this.nA / 7), Math.floor(this.nR / 3)]];
    }
    probe() {
      const out = [];
      for (const [i, j] of this.probeIndices()) {
        const v = i * this.nR + j;
        out.push({ alpha: this.alpha(i), R: this.radius(j),
                   xyz: [this.pos[3 * v], this.pos[3 * v + 1], this.pos[3 * v + 2]] });
      }
      return out;
    }
  }

  // ------------------------------------------------------------------------- a 3D view
  // One canvas with orbit controls, an axes triad, a scale bar at the orbit centre, and a
  // camera that frames a box (the annulus, the surface at its inclination) until the reader
  // moves it; "reset view" frames it again.
  const HOME = new T.Vector3(0.2, -2.5, 1.9).normalize();
  const VIEWS = [];
  class View {
    constructor(title, subtitle, unit) {
      VIEWS.push(this);
      this.unit = unit || "m";
      const box = el("div", { class: "view" });
      document.getElementById("views").appendChild(box);
      this.el = box;
      this.label = el("div", { class: "label" });
      if (title) this.label.appendChild(el("b", {}, title));
      this.sub = el("div", { class: "direction" }, subtitle || "");
      this.label.appendChild(this.sub);
      box.appendChild(this.label);
      if (!title && !subtitle) this.label.hidden = true;
      const canvas = document.createElement("canvas");
      box.appendChild(canvas);
      this.triad = el("canvas", { class: "triad", width: "84", height: "84",
                                  "aria-label": "axes x y z" });
      box.appendChild(this.triad);
      this.scaleBox = el("div", { class: "scale" });
      this.scaleBar = el("div", { class: "bar" });
      this.scaleText = el("div", { class: "text" });
      this.scaleBox.append(this.scaleBar, this.scaleText);
      box.appendChild(this.scaleBox);
      this.refusal = el("div", { class: "refused" });
      this.refusal.hidden = true;
      box.appendChild(this.refusal);
      this.renderer = new T.WebGLRenderer({ canvas: canvas, antialias: true,
                                            preserveDrawingBuffer: true });
      this.renderer.setPixelRatio(window.devicePixelRatio || 1);
      this.renderer.setClearColor(0xffffff, 1);
      this.scene = new T.Scene();
      this.camera = new T.PerspectiveCamera(35, 1, 0.005, 100);
      this.camera.up.set(0, 0, 1);
      this.scene.add(new T.HemisphereLight(0xffffff, 0x8a8f99, 1.6));
      const sun = new T.DirectionalLight(0xffffff, 1.6);
      sun.position.set(2, -3, 5);
      this.scene.add(sun);
      this.controls = new T.OrbitControls(this.camera, canvas);
      this.touched = false;   // the reader moved the camera: no automatic framing
      this.quiet = false;     // a change made here, not by the reader
      this.frame = null;      // the points to frame: [[x, y, z], ...]
      this.followed = null;   // the point the camera follows (the sphere), or null
      this.onUser = null;     // called after the reader moved this camera (linked views)
      this.controls.addEventListener("change", () => {
        this.render();
        if (!this.quiet && this.onUser) this.onUser(this);
      });
      this.controls.addEventListener("start", () => { this.touched = true; });
      new ResizeObserver(() => this.resize()).observe(box);
      this.resize();
    }
    update() {
      this.quiet = true;
      this.controls.update();
      this.quiet = false;
    }
    resize() {
      const w = Math.max(1, this.el.clientWidth), h = Math.max(1, this.el.clientHeight);
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
      if (!this.touched) this.fit();
      this.render();
    }
    setFrame(points) {
      this.frame = points.map((p) => new T.Vector3(p[0], p[1], p[2]));
      if (!this.touched && !this.followed) this.fit();
    }
    // The closest camera along HOME, aimed at the middle of the frame's points, that shows
    // every one of them within 92 % of the view (bisection on the distance).
    fit() {
      if (!this.frame) return;
      if (this.followed) { this.follow(this.followed.point, this.followed.size, true); return; }
      const lo = this.frame[0].clone(), hi = this.frame[0].clone();
      for (const p of this.frame) { lo.min(p); hi.max(p); }
      const c = lo.add(hi).multiplyScalar(0.5);
      const corners = this.frame;
      const cam = this.camera, v = new T.Vector3();
      const fits = (d) => {
        cam.position.copy(c).addScaledVector(HOME, d);
        cam.lookAt(c);
        cam.updateMatrixWorld();
        return corners.every((p) => {
          v.copy(p).project(cam);
          return Math.abs(v.x) <= 0.92 && Math.abs(v.y) <= 0.92 && v.z < 1;
        });
      };
      let a = 1e-3, b = 1e3;
      for (let k = 0; k < 60; k++) { const m = Math.sqrt(a * b); if (fits(m)) b = m; else a = m; }
      cam.position.copy(c).addScaledVector(HOME, b);
      this.controls.target.copy(c);
      this.update();
    }
    // Keep a point (the sphere) at the orbit centre; the first call places the camera so
    // that an object of the given size fills about a quarter of the view's height.
    follow(point, size, place) {
      const first = !this.followed || place;
      this.followed = { point: point.clone(), size: size };
      if (first) {
        const d = size / (0.25 * 2 * Math.tan(this.camera.fov * Math.PI / 360));
        this.camera.position.copy(point).addScaledVector(HOME, d);
      } else {
        this.camera.position.add(point.clone().sub(this.controls.target));
      }
      this.controls.target.copy(point);
      this.update();
    }
    unfollow() { this.followed = null; this.touched = false; this.fit(); this.render(); }
    state() {  // where the camera is and looks (read by tests)
      return { position: this.camera.position.toArray(), target: this.controls.target.toArray(),
               fov: this.camera.fov, height: this.el.clientHeight, width: this.el.clientWidth };
    }
    reset() { this.touched = false; this.fit(); this.render(); }
    render() {
      this.renderer.render(this.scene, this.camera);
      this.drawTriad();
      this.drawScale();
    }
    // x, y, z of the world as the camera sees them (red, green, blue), nearest drawn last.
    drawTriad() {
      const ctx = this.triad.getContext("2d");
      const s = this.triad.width, c = s / 2, L = s * 0.32;
      ctx.clearRect(0, 0, s, s);
      const inv = this.camera.quaternion.clone().invert();
      const axes = [["x", 1, 0, 0, "#d1342f"], ["y", 0, 1, 0, "#2a9d4b"], ["z", 0, 0, 1, "#2d6cdf"]]
        .map(([n, x, y, z, col]) => [n, new T.Vector3(x, y, z).applyQuaternion(inv), col])
        .sort((p, q) => p[1].z - q[1].z);
      ctx.lineWidth = 2.2;
      ctx.font = "bold 12px system-ui, sans-serif";
      ctx.textAlign = "center";
      ctx.textBaseline = "middle";
      for (const [n, v, col] of axes) {
        ctx.strokeStyle = col;
        ctx.fillStyle = col;
        ctx.beginPath();
        ctx.moveTo(c, c);
        ctx.lineTo(c + L * v.x, c - L * v.y);
        ctx.stroke();
        ctx.fillText(n, c + (L + 9) * v.x, c - (L + 9) * v.y);
      }
    }
    // A bar of a round length at the depth of the orbit centre (perspective: nearer things
    // look larger, farther ones smaller).
    drawScale() {
      const d = this.camera.position.distanceTo(this.controls.target);
      const px = this.el.clientHeight / (2 * d * Math.tan(this.camera.fov * Math.PI / 360));
      if (!(px > 0) || !Number.isFinite(px)) { this.scaleBox.hidden = true; return; }
      this.scaleBox.hidden = false;
      const want = 90 / px, p = Math.pow(10, Math.floor(Math.log10(want)));
      const len = [1, 2, 5, 10].map((m) => m * p).filter((x) => x <= want).pop() || p;
      this.scaleBar.style.width = `${Math.round(len * px)}px`;
      this.scaleText.textContent = `${length(len, this.unit)} at the orbit centre`;
    }
    addNote(cls, text) {
      const d = el("div", { class: cls }, text);
      this.el.appendChild(d);
      return d;
    }
  }

  // Points on the rim of an annulus of outer radius R1, at heights -h and +h.
  function rim(R1, h) {
    const out = [];
    for (let k = 0; k < 48; k++) {
      const a = 2 * Math.PI * k / 48;
      out.push([R1 * Math.cos(a), R1 * Math.sin(a), -h], [R1 * Math.cos(a), R1 * Math.sin(a), h]);
    }
    return out;
  }

  function length(x, unit) {
    if (unit !== "m") return `${+x.toPrecision(3)} ${unit}`;
    if (x >= 1) return `${+x.toPrecision(3)} m`;
    if (x >= 0.01) return `${+(x * 100).toPrecision(3)} cm`;
    return `${+(x * 1000).toPrecision(3)} mm`;
  }

  // --------------------------------------------------------------------- common helpers
  // The block of a (d0, d1, ..., rest) array at the leading indices idx.
  function at(a, ...idx) {
    const shape = a.shape;
    let size = 1;
    for (let d = idx.length; d < shape.length; d++) size *= shape[d];
    let off = 0, stride = size;
    for (let d = idx.length - 1; d >= 0; d--) { off += idx[d] * stride; stride *= shape[d]; }
    return a.subarray(off, off + size);
  }
  function row(a, r, i) { return at(a, r, i); }  // frame i of run r
  function lerp(a, b, w) { return a + (b - a) * w; }
  function fmt(x, digits) {
    if (!Number.isFinite(x)) return "–";
    const d = digits === undefined ? 4 : digits;
    const ax = Math.abs(x);
    if (ax === 0) return (0).toFixed(d - 1);
    if (ax < 1e-3 || ax >= 1e5) return x.toExponential(d - 1);
    return x.toFixed(Math.max(0, d - 1 - Math.floor(Math.log10(Math.max(ax, 1e-12)))));
  }
  function el(tag, attrs, text) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  const SVG = "http://www.w3.org/2000/svg";
  function svg(tag, attrs, text) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, String(v));
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function hashParams() {
    const out = {};
    for (const part of location.hash.replace(/^#/, "").split("&")) {
      if (!part) continue;
      const [k, v] = part.split("=");
      try {
        out[decodeURIComponent(k)] = v === undefined ? true : decodeURIComponent(v);
      } catch (e) {
        notice(`the URL part "${part}" is not readable: ignored`);
      }
    }
    return out;
  }
  // A number from the URL, or undefined (with a visible notice) when it is not one.
  function hashNumber(h, key, unit) {
    if (h[key] === undefined) return undefined;
    const text = h[key] === true ? "" : String(h[key]);
    const v = text.trim() === "" ? NaN : Number(text);
    if (!Number.isFinite(v)) {
      notice(`#${key}=${text} is not a number${unit ? ` of ${unit}` : ""}: ignored`);
      return undefined;
    }
    return v;
  }
  // A scene follows its URL's hash: each part of it registers what it reads there, applied
  // again whenever the hash changes (#t=30, #sphere.mu=0.1 typed or linked: no reload).
  const HASH_READERS = [];
  function onHash(reader) { HASH_READERS.push(reader); }
  window.addEventListener("hashchange", () => {
    const box = document.getElementById("notice");
    box.replaceChildren();
    box.hidden = true;
    const h = hashParams();
    HASH_READERS.forEach((f) => f(h));
  });
  function publish(obj) {
    document.getElementById("scene-state").textContent = JSON.stringify(obj);
  }
  function section(title) {
    const box = el("div", { class: "section" });
    box.appendChild(el("h2", {}, title));
    document.getElementById("extras").appendChild(box);
    return box;
  }

  // Reset and (for sphere scenes) the camera preset, for every view at once.
  function viewControls(views, follow) {
    const c = document.getElementById("controls");
    const r = el("div", { class: "row" });
    const reset = el("button", { id: "reset-view", type: "button",
                                 title: "frame the scene again" }, "Reset view");
    r.append(reset);
    let select = null;
    if (follow) {
      select = el("select", { id: "camera", "aria-label": "camera" });
      select.append(el("option", { value: "overview" }, "whole annulus"),
                    el("option", { value: "follow" }, "follow the sphere"));
      r.append(el("label", { for: "camera" }, "camera"), select);
      select.addEventListener("change", () => follow(select.value === "follow"));
    }
    reset.addEventListener("click", () => {
      views.forEach((v) => v.reset());
      if (follow && select.value === "follow") follow(true, true);
    });
    c.append(r);
    return select;
  }

  // Cameras that move together: the reader's orbit and zoom in one view (its offset from
  // its orbit centre) is applied to the others around their own centres.
  function linkCameras(views) {
    if (views.length < 2) return;
    let busy = false;
    for (const v of views) {
      v.onUser = (src) => {
        if (busy) return;
        busy = true;
        const offset = src.camera.position.clone().sub(src.controls.target);
        for (const o of views) {
          if (o === src) continue;
          o.touched = true;
          o.camera.position.copy(o.controls.target).add(offset);
          o.update();
          o.render();
        }
        busy = false;
      };
    }
  }

  // A clock over [0, tEnd] with frames every dt: play/pause, slider, playback speed.
  function clockControls(tEnd, dt, speeds, onTime) {
    const c = document.getElementById("controls");
    const r1 = el("div", { class: "row" });
    const play = el("button", { id: "play", type: "button" }, "Play");
    const speed = el("select", { id: "speed", title: "playback speed" });
    for (const s of speeds) {
      const o = el("option", { value: String(s) }, "x" + s);
      if (s === state.speed) o.selected = true;
      speed.appendChild(o);
    }
    const tlabel = el("span", { id: "clock" }, "");
    r1.append(play, speed, tlabel);
    const r2 = el("div", { class: "row" });
    const slider = el("input", { id: "time", type: "range", min: "0", max: String(tEnd),
                                 step: String(dt), value: "0", "aria-label": "time" });
    r2.append(el("label", { for: "time" }, "time"), slider);
    c.append(r1, r2);
    const set = (t, fromSlider) => {
      state.t = Math.max(0, Math.min(tEnd, t));
      if (!fromSlider) slider.value = String(state.t);
      tlabel.textContent = `t = ${state.t.toFixed(1)} s / ${tEnd.toFixed(0)} s`;
      onTime(state.t);
    };
    const setPlaying = (on) => {
      state.playing = on;
      play.textContent = on ? "Pause" : "Play";
      state.last = null;
      if (on) requestAnimationFrame(tick);
    };
    play.addEventListener("click", () => {
      if (!state.playing && state.t >= tEnd) set(0);
      setPlaying(!state.playing);
    });
    speed.addEventListener("change", () => { state.speed = Number(speed.value); });
    slider.addEventListener("input", () => { setPlaying(false); set(Number(slider.value), true); });
    function tick(now) {
      if (!state.playing) return;
      if (state.last !== null) {
        const t = state.t + (now - state.last) / 1000 * state.speed;
        if (t >= tEnd) { set(tEnd); setPlaying(false); return; }
        set(t);
      }
      state.last = now;
      requestAnimationFrame(tick);
    }
    // at load: #t stops the clock there (#play plays from it), no #t plays from 0; a later
    // hash moves the clock only if it names a time (or #play)
    const fromHash = (h, first) => {
      const t0 = hashNumber(h, "t", "seconds");
      if (t0 !== undefined && (t0 < 0 || t0 > tEnd)) {
        notice(`#t=${h.t}: the run spans 0 to ${tEnd.toFixed(0)} s; showing the nearest end`);
      }
      if (first || t0 !== undefined) set(t0 !== undefined ? t0 : state.t);
      if (first) setPlaying(h.t === undefined || h.play !== undefined);
      else if (t0 !== undefined || h.play !== undefined) setPlaying(h.play !== undefined);
    };
    fromHash(hashParams(), true);
    onHash((h) => fromHash(h, false));
    return set;
  }

  function readoutTable(columns) {
    const table = document.getElementById("readouts");
    if (columns.length > 1) {
      const head = el("tr");
      head.append(el("th", {}, ""));
      for (const c of columns) head.append(el("th", {}, c));
      head.append(el("th", {}, ""));
      table.append(head);
    }
    const cells = {};
    return {
      set(key, label, values, unit) {
        if (!cells[key]) {
          const tr = el("tr", { "data-readout": key });
          tr.append(el("td", {}, label));
          cells[key] = values.map(() => { const td = el("td"); tr.append(td); return td; });
          tr.append(el("td", { class: "unit" }, unit || ""));
          table.append(tr);
        }
        values.forEach((v, i) => { cells[key][i].textContent = v; });
      },
    };
  }

  // ----------------------------------------------------------------------- sphere scenes
  const RUN_COLOURS = ["#2d6cdf", "#d1342f", "#2a9d4b", "#8e44ad"];

  function sphereScene() {
    const runs = D.coords.run;
    const time = A.time;
    const n = time.length;
    const dt = D.attrs.frame_interval;
    const draw = new Set(D.attrs.draw);
    const F = D.family || null;
    const FA = {};
    if (F) for (const [k, a] of Object.entries(F.arrays)) FA[k] = decode(a);
    // A source's geometry of run r: its shape numbers and, for a rib surface, its splines.
    const geometry = (get, r, skin) => ({ R0: get("R0", r), dR: get("dR", r), A: get("A", r),
                                          Kr: get("Kr", r), Ka: get("Ka", r),
                                          skin: skin ? skin(r) : null });
    const strain = A.strain ? strainColours() : null;
    // What is drawn: the scene's own frames, or one member of its family (or its refusal).
    const own = {
      member: F ? F.base : null, refused: "",
      frame: (name, r, i) => row(A[name], r, i),
      scalar: (name, r) => A[name][r],
      skin: A.skin_c ? (r) => ({ c: at(A.skin_c, r), s: at(A.skin_s, r) }) : null,
      status: D.strings.status, direction: D.strings.direction,
    };
    function memberSource(m) {
      const k = F.rows[m];
      const base = { member: m, refused: k < 0 ? F.message[m] : "", status: F.status[m],
                     direction: F.direction[m] };
      if (k < 0) return base;
      return Object.assign(base, {
        frame: (name, r, i) => at(FA[name], k, r, i),
        scalar: (name, r) => at(FA[name], k)[r],
        // a member of the ideal surface has NaN splines: drawn from cos(Ka alpha + phi_a)
        skin: FA.skin_c ? (r) => (Number.isFinite(at(FA.skin_c, k, r)[0])
          ? { c: at(FA.skin_c, k, r), s: at(FA.skin_s, k, r) } : null) : null,
      });
    }
    const table = readoutTable(runs.map((r) => r.toUpperCase()));
    const b0 = runs.map((_, r) => A.sphere_radius[r]);
    const objs = runs.map((name, r) => {
      const g = geometry((k, q) => A[k][q], r, own.skin);
      const view = new View(name.toUpperCase(), D.strings.direction[r]);
      const key = JSON.stringify(g, (_, v) => (ArrayBuffer.isView(v) ? Array.from(v) : v));
      const o = { view: view, g: g, geoKey: key, ownKey: key };
      if (draw.has("membrane")) {
        o.membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 1.0);
        view.scene.add(o.membrane.mesh);
      }
      const b = b0[r];
      o.body = new T.Group();
      if (draw.has("sphere")) {
        o.body.add(new T.Mesh(new T.SphereGeometry(b, 40, 24), new T.MeshStandardMaterial({
          color: 0xd8dce3, roughness: 0.35, metalness: 0.1, transparent: true, opacity: 0.82 })));
      }
      if (draw.has("marker")) {
        const marker = new Arrow(0xd1342f, 0.07 * b);
        marker.set(new T.Vector3(0, 0, 0), new T.Vector3(0, 0, 1), 2.0 * b);
        o.body.add(marker.group);
      }
      if (draw.has("band")) {
        o.body.add(new T.Mesh(new T.TorusGeometry(1.005 * b, 0.06 * b, 10, 64),
                              new T.MeshStandardMaterial({ color: 0x1f6fd1, roughness: 0.5 })));
      }
      view.scene.add(o.body);
      if (draw.has("trace")) {
        const pos = new Float32Array(3 * n), col = new Float32Array(3 * n);
        for (let i = 0; i < n; i++) viridis(time[i] / time[n - 1], col, i);
        const geo = new T.BufferGeometry();
        geo.setAttribute("position", new T.BufferAttribute(pos, 3));
        geo.setAttribute("color", new T.BufferAttribute(col, 3));
        o.trace = new T.Group();
        // Drawn over the membrane (no depth test): the path stays readable behind crests.
        o.trace.add(new T.Line(geo, new T.LineBasicMaterial({ vertexColors: true,
                                                              depthTest: false })));
        o.trace.add(new T.Points(geo, new T.PointsMaterial({ vertexColors: true, size: 4,
                                                             sizeAttenuation: false,
                                                             depthTest: false })));
        o.trace.renderOrder = 2;
        o.trace.children.forEach((c) => { c.renderOrder = 2; });
        o.tracePos = pos;
        o.traceGeometry = geo;
        view.scene.add(o.trace);
      }
      view.setFrame(rim(g.R0 + g.dR, g.A + 2 * b));
      return o;
    });
    const views = objs.map((o) => o.view);
    linkCameras(views);
    const readouts = D.attrs.readouts;
    const q0 = new T.Quaternion(), q1 = new T.Quaternion();
    let src = own;
    let following = false;

    // Why mu matters in this run or not, in words, from the drawn run's own frames: the
    // largest friction over the normal reaction beside mu (the friction cone's edge).
    const frictionNote = readouts.includes("friction_magnitude")
      && readouts.includes("normal_reaction")
      ? document.getElementById("notes").appendChild(el("p", { id: "friction-note" })) : null;
    function explainFriction(s) {
      if (!frictionNote) return;
      if (s.refused) { frictionNote.textContent = ""; return; }
      const values = F ? F.values(s.member) : {};
      const mu = values["sphere.mu"] !== undefined ? Number(values["sphere.mu"]) : NaN;
      const T = values["phases.T"] !== undefined ? ` (cycle T = ${values["phases.T"]} s)` : "";
      frictionNote.textContent = runs.map((name, r) => {
        let ratio = -1, tMax = 0, slip = -1;
        const last = s.scalar("frames_run", r) - 1;
        for (let i = 0; i <= last; i++) {
          const f = s.frame("friction_magnitude", r, i)[0], N = s.frame("normal_reaction", r, i)[0];
          if (Number.isFinite(f) && Number.isFinite(N) && N > 0 && f / N > ratio) { ratio = f / N; tMax = time[i]; }
          if (readouts.includes("slip_speed")) {
            const v = s.frame("slip_speed", r, i)[0];
            if (Number.isFinite(v)) slip = Math.max(slip, v);
          }
        }
        if (ratio < 0) return "";
        const head = `${runs.length > 1 ? name.toUpperCase() + ": " : ""}the friction the `
          + `sphere needs is at most ${fmt(ratio)} of the normal reaction N (|f|/N at `
          + `t = ${fmt(tMax)} s over the drawn frames)`;
        const slipText = slip >= 0 ? ` (slip speed at most ${fmt(slip)} m/s)` : "";
        if (!Number.isFinite(mu) || mu <= 0) {
          return `${head}${T}.` + (Number.isFinite(mu) ? " With mu = 0 the contact cannot "
            + "carry any tangential force: the sphere slides." : "");
        }
        const used = ratio / mu;
        let why;
        if (used < 0.1) {
          why = `Far from that limit the sphere rolls with the pattern almost without slipping${slipText}: `
            + "the force it needs is set by the motion, not by mu, so mu barely moves it. "
            + "A shorter cycle needs more force and brings mu into play.";
        } else if (used < 0.9) {
          why = `The sphere still rolls${slipText}, but the contact gives a good part of what it `
            + "can: a lower mu would make it slip.";
        } else {
          why = `At that limit the sphere slips${slipText}: the contact gives all it can, so mu `
            + "sets how far the pattern drags it.";
        }
        return `${head}: ${fmt(100 * used, 3)} % of the limit mu N at mu = ${values["sphere.mu"]}${T}. ${why}`;
      }).filter((x) => x).join(" ");
    }

    // Draw another source: its geometry, sphere size, trace and labels; or its refusal.
    function setSource(s) {
      src = s;
      explainFriction(s);
      objs.forEach((o, r) => {
        o.view.sub.textContent = s.direction[r] || "";
        o.view.refusal.hidden = !s.refused;
        o.view.refusal.textContent = s.refused ? `${F.label(s.member)}: refused by the `
          + `validation, not computed. ${s.refused}` : "";
        o.body.visible = !s.refused;
        if (o.trace) o.trace.visible = !s.refused;
        if (s.refused) return;
        const g = geometry(s.scalar, r, s.skin);
        const key = JSON.stringify(g, (_, v) => (ArrayBuffer.isView(v) ? Array.from(v) : v));
        if (o.membrane && key !== o.geoKey) {
          o.view.scene.remove(o.membrane.mesh);
          o.membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 1.0);
          o.view.scene.add(o.membrane.mesh);
          o.geoKey = key;
          o.view.setFrame(rim(g.R0 + g.dR, g.A + 2 * s.scalar("sphere_radius", r)));
        }
        o.body.scale.setScalar(s.scalar("sphere_radius", r) / b0[r]);
        if (o.trace) {  // past the run's end (NaN frames) the path stays at its last point
          const last = s.scalar("frames_run", r) - 1;
          for (let i = 0; i < n; i++) {
            const x = s.frame("centre", r, Math.min(i, last));
            o.tracePos[3 * i] = x[0]; o.tracePos[3 * i + 1] = x[1];
            o.tracePos[3 * i + 2] = x[2] + 0.002;
          }
          o.traceGeometry.attributes.position.needsUpdate = true;
          o.traceGeometry.computeBoundingSphere();
        }
      });
    }

    const setTime = (t) => {
      const f = Math.min(n - 1, Math.max(0, t / dt));
      let i = Math.floor(f + 1e-9);
      if (i >= n - 1) i = n - 1;
      const w = i >= n - 1 ? 0 : Math.max(0, f - i);
      const j = Math.min(n - 1, i + 1);
      const out = { time: t, frame: i, weight: w, member: src.member, refused: src.refused,
                    runs: {} };
      if (F) out.values = F.values(src.member);
      const vals = {};
      objs.forEach((o, r) => {
        // A refused member has no frames of its own: the membrane keeps the scene's phases;
        // past the end of a member's shorter run it keeps its last ones.
        const ph_src = src.refused ? own : src;
        const end = src.refused ? n - 1 : src.scalar("frames_run", r) - 1;
        const pi = Number.isFinite(ph_src.frame("phase_a", r, i)[0]) ? i : Math.min(i, end);
        const pj = Number.isFinite(ph_src.frame("phase_a", r, j)[0]) ? j : Math.min(j, end);
        const ph = ["phase_r", "phase_a", "inclination"].map(
          (k) => lerp(ph_src.frame(k, r, pi)[0], ph_src.frame(k, r, pj)[0], pi === pj ? 0 : w));
        // Strain colours where the drawn surface is the scene's own (its geometry and
        // phases, as a refused member keeps them): another member's is coloured by height.
        const paint = strain && o.geoKey === o.ownKey && (src === own || src.refused
          || ["phase_r", "phase_a", "inclination"].every((k, c) => Math.abs(
            ph[c] - lerp(own.frame(k, r, i)[0], own.frame(k, r, j)[0], w)) < 1e-12))
          ? strain.paint(r, i, j, i === j ? 0 : w) : null;
        if (o.membrane) o.membrane.update(ph[0], ph[1], ph[2], paint);
        out.runs[runs[r]] = { status: src.status[r], phases: ph,
                              colour: paint ? "strain" : "height" };
        if (paint && o.membrane) out.runs[runs[r]].strain = o.membrane.probeIndices().map(
          ([a, q]) => paint.value(a * o.membrane.nR + q));
        if (o.membrane) out.runs[runs[r]].surface = o.membrane.probe();
        if (src.refused) {
          for (const key of readouts) if (key !== "time") (vals[key] = vals[key] || []).push("refused");
          o.view.render();
          return;
        }
        const last = src.scalar("frames_run", r) - 1;
        const ii = Math.min(i, last), jj = Math.min(j, last), ww = i >= last ? 0 : w;
        const xa = src.frame("centre", r, ii), xb = src.frame("centre", r, jj);
        o.body.position.set(lerp(xa[0], xb[0], ww), lerp(xa[1], xb[1], ww),
                            lerp(xa[2], xb[2], ww));
        if (A.quaternion) {
          const qa = src.frame("quaternion", r, ii), qb = src.frame("quaternion", r, jj);
          q0.set(qa[1], qa[2], qa[3], qa[0]).normalize();
          q1.set(qb[1], qb[2], qb[3], qb[0]).normalize();
          o.body.quaternion.slerpQuaternions(q0, q1, ww);
        }
        if (o.trace) o.traceGeometry.setDrawRange(0, ii + 1);
        o.body.updateMatrixWorld(true);
        const p = new T.Vector3();
        o.body.getWorldPosition(p);
        out.runs[runs[r]].drawn = [p.x, p.y, p.z];
        out.runs[runs[r]].frame = ii;
        if (following) o.view.follow(p, 2 * src.scalar("sphere_radius", r));
        out.runs[runs[r]].camera = o.view.state();
        for (const key of readouts) {
          if (key === "time") continue;
          const a = src.frame(key, r, ii)[0], b = src.frame(key, r, jj)[0];
          (vals[key] = vals[key] || []).push(fmt(lerp(a, b, ww)));
        }
        o.view.render();
      });
      table.set("time", "time", runs.map(() => fmt(t)), "s");
      for (const key of readouts) {
        if (key === "time") continue;
        table.set(key, D.labels[key], vals[key], D.units[key]);
      }
      if (chart) chart.mark();
      publish(out);
    };

    let chart = null;
    if (F) chart = familyControls(F, (m) => { setSource(m === F.base ? own : memberSource(m));
                                              setTime(state.t); });
    const camera = viewControls(views, (on) => {
      following = on;
      objs.forEach((o, r) => {
        if (!on) { o.view.unfollow(); return; }
        if (src.refused) return;
        const p = new T.Vector3();
        o.body.getWorldPosition(p);
        o.view.follow(p, 2 * src.scalar("sphere_radius", r), true);
        o.view.render();
      });
      setTime(state.t);
    });
    const h = hashParams();
    if (F) chart.fromHash(h);
    else setSource(own);
    clockControls(time[n - 1], dt, [1, 2, 4, 8, 16, 32], setTime);
    const cameraFromHash = (hh) => {
      if (hh.camera === undefined) return;
      if (hh.camera === "follow" || hh.camera === "overview") {
        camera.value = hh.camera;
        camera.dispatchEvent(new Event("change"));
      } else notice(`#camera=${hh.camera}: use follow or overview; ignored`);
    };
    cameraFromHash(h);
    onHash((hh) => { if (F) chart.fromHash(hh); cameraFromHash(hh); });
    sphereLegend(draw, time[n - 1], b0[0], strain);
    const notes = document.getElementById("notes");
    runs.forEach((r, k) => notes.appendChild(el("p", {},
      `${r.toUpperCase()}: status ${D.strings.status[k]}; ${D.strings.source[k]}.`)));
    if (strain) notes.appendChild(el("p", { id: "strain-note" }, strain.note()));
    notes.appendChild(el("p", {}, "Drag to orbit, scroll to zoom. Frames every "
      + `${dt} s of simulated time, played at x${D.attrs.playback_speed} by default.`
      + (runs.length > 1 ? " The views' cameras move together." : "")));
  }

  // The strain colouring of a strain scene (creatio.scenes.strain): per run, frame and mesh
  // vertex the dataset's strain, interpolated linearly between frames, mapped through the
  // dataset's own colour stops over the legend's range; and its legend, ticks in percent.
  function strainColours() {
    const S = A.strain, [nRun, nFrame, nA, nR] = S.shape, nV = nA * nR;
    const [low, high] = D.attrs.strain_legend;
    const stops = D.attrs.strain_colours, ticks = D.attrs.strain_ticks;
    if (nA !== D.attrs.mesh[0] || nR !== D.attrs.mesh[1] || nRun !== D.coords.run.length) {
      throw new Error("the strain field does not match the scene's mesh and runs");
    }
    function rgb(s, out, v) {
      const x = Math.max(0, Math.min(1, (s - low) / (high - low))) * (stops.length - 1);
      const k = Math.min(stops.length - 2, Math.floor(x)), f = x - k;
      for (let c = 0; c < 3; c++) out[3 * v + c] = lerp(stops[k][c], stops[k + 1][c], f);
    }
    const pct = (x) => `${parseFloat((100 * x).toPrecision(6))} %`;
    // the last frame of each run with a strain (a longer member pads the frames with NaN)
    const last = D.coords.run.map((_, r) => {
      let f = nFrame - 1;
      while (f > 0 && !Number.isFinite(S[(r * nFrame + f) * nV])) f--;
      return f;
    });
    let top = 0, arg = 0;
    for (let k = 0; k < S.length; k++) if (S[k] > top) { top = S[k]; arg = k; }
    const where = { run: Math.floor(arg / (nFrame * nV)), frame: Math.floor(arg / nV) % nFrame,
                    alpha: Math.floor(arg / nR) % nA, R: arg % nR };
    return {
      paint(r, i, j, w) {  // past the last frame with a strain, the membrane keeps its last
        [i, j] = [Math.min(i, last[r]), Math.min(j, last[r])];
        const a = (r * nFrame + i) * nV, b = (r * nFrame + j) * nV;
        const value = (v) => lerp(S[a + v], S[b + v], w);
        return { key: `${r},${i},${j},${w}`, value: value,
                 colour: (v, out) => rgb(value(v), out, v) };
      },
      // What the colours rest on, and the largest drawn value: where and when.
      note() {
        const alpha = 360 * where.alpha / (nA - 1), R = A.dR[where.run] * where.R / (nR - 1);
        return `Strain: largest drawn value ${pct(top)} (${D.coords.run[where.run]
          .toUpperCase()}, t = ${fmt(A.time[where.frame])} s, α = ${fmt(alpha)}°, `
          + `R = ${fmt(R)} m), over the `
          + "drawn vertices and frames (the EN-06 report refines the maximum over the "
          + "membrane and the cycle). Material coordinates: (α, R) label material points; "
          + "the reference is the same surface without corrugation.";
      },
      legend(box) {
        const item = el("div", { class: "item" });
        const bar = el("span", { class: "swatch strain-bar", style: "background: "
          + `linear-gradient(to right, ${stops.map(css).join(", ")})` });
        item.append(el("span", {}, `membrane: ${D.attrs.strain_label} (dimensionless, `
          + "in %), interpolated linearly between frames"
          + (D.family ? "; a member of another surface or phase laws is coloured by "
             + "height W instead" : "")));
        box.append(item);
        box.append(bar);
        const scale = el("div", { class: "strain-ticks" });
        for (const tk of ticks) {
          scale.append(el("span", { style: `left: ${100 * (tk - low) / (high - low)}%` },
                          pct(tk)));
        }
        box.append(scale);
      },
    };
  }

  // What each colour and shape of a sphere scene means.
  function sphereLegend(draw, tEnd, b, strain) {
    const box = section("Legend");
    const item = (swatch, text) => {
      const r = el("div", { class: "item" });
      r.append(swatch, el("span", {}, text));
      box.append(r);
    };
    const grad = (stops) => el("span", { class: "swatch", style:
      `background: linear-gradient(to right, ${stops.join(", ")})` });
    if (draw.has("membrane") && strain) {
      strain.legend(box);
    } else if (draw.has("membrane")) {
      item(grad([css(COLD), css(MID), css(WARM)]),
           "membrane: height W along the normal, blue cavity (−A), grey 0, brown crest (+A)");
    }
    if (draw.has("sphere")) {
      item(el("span", { class: "swatch round", style: "background: #d8dce3" }),
           `sphere (radius ${length(b, "m")}), at its computed centre`);
    }
    if (draw.has("marker")) {
      item(el("span", { class: "swatch", style: "background: #d1342f; height: 4px" }),
           "marker: a body-fixed arrow, turns with the sphere's computed orientation");
    }
    if (draw.has("band")) {
      item(el("span", { class: "swatch ring", style: "border-color: #1f6fd1" }),
           "band: the sphere's equator, turns with it");
    }
    if (draw.has("trace")) {
      item(grad(VIRIDIS.filter((_, k) => k % 2 === 0).map(css)),
           `trace: the centre's path, coloured by time from 0 s to ${tEnd.toFixed(0)} s`);
    }
    item(el("span", { class: "swatch triad-key" }, "xyz"),
         "axes triad: x red, y green, z blue (z up); the bar is a length at the orbit centre");
  }

  // The family's controls: a slider per axis, a chart of the headline figures against one
  // axis (the others at their current values), the current member marked and refused
  // members drawn as such. Returns { mark, fromHash }.
  function familyControls(F, onMember) {
    const axes = F.axes;
    const shape = axes.map((a) => a.labels.length);
    const idx = axes.map((a) => a.base);
    const ravel = (ix) => ix.reduce((flat, i, d) => flat * shape[d] + i, 0);
    const unravel = (m) => {
      const out = [];
      for (let d = shape.length - 1; d >= 0; d--) { out.unshift(m % shape[d]); m = Math.floor(m / shape[d]); }
      return out;
    };
    F.values = (m) => Object.fromEntries(unravel(m).map((i, d) => [axes[d].key, axes[d].labels[i]]));
    F.label = (m) => unravel(m).map((i, d) => `${axes[d].key} = ${axes[d].labels[i]}`).join(", ");
    const c = document.getElementById("controls");
    const box = el("div", { class: "family", id: "family" });
    const sliders = axes.map((a, d) => {
      const r = el("div", { class: "row" });
      const s = el("input", { id: `axis-${d}`, type: "range", min: "0",
                              max: String(a.labels.length - 1), step: "1",
                              value: String(a.base), "aria-label": a.key,
                              "data-key": a.key });
      const v = el("span", { class: "axis-value", id: `axis-${d}-value` }, "");
      r.append(el("label", { for: `axis-${d}` }, a.key), s, v);
      box.append(r);
      s.addEventListener("input", () => select(d, Number(s.value)));
      return { input: s, value: v };
    });
    c.append(box);
    const numeric = (d) => axes[d].labels.every((x) => Number.isFinite(Number(x)));
    // The chart: one small panel per figure.
    const sec = section(`Family: ${F.size} members`);
    let against = 0;
    if (axes.length > 1) {
      const r = el("div", { class: "row" });
      const sel = el("select", { id: "chart-axis", "aria-label": "chart against" });
      axes.forEach((a, d) => sel.append(el("option", { value: String(d) }, a.key)));
      r.append(el("label", { for: "chart-axis" }, "chart against"), sel);
      sec.append(r);
      sel.addEventListener("change", () => { against = Number(sel.value); draw(); mark(); });
    }
    const runs = D.coords.run;
    if (runs.length > 1) {
      const keys = el("div", { class: "chart-key" });
      runs.forEach((r, k) => {
        keys.append(el("span", { class: "dot", style: `background: ${RUN_COLOURS[k]}` }),
                    el("span", {}, r.toUpperCase() + " "));
      });
      sec.append(keys);
    }
    const grid = el("div", { class: "charts" });
    sec.append(grid);
    sec.append(el("p", { class: "hint" }, "× refused by the validation (hover for the "
      + "reason); ○ a run that stopped early (its status). Click a chart to choose a member."));
    const panels = Object.entries(F.figures).map(([name, fig]) => {
      const p = svg("svg", { class: "chart", viewBox: "0 0 150 100", "data-figure": name,
                             role: "img" });
      p.append(svg("title", {}, `${fig.label} (${fig.unit}): ${fig.meaning}`));
      grid.append(p);
      return { name: name, fig: fig, svg: p };
    });
    const W = 150, H = 100, L = 34, R = 6, TOP = 26, BOT = 18;
    function members() {  // the members along the chart axis, the others at their index
      return axes[against].labels.map((_, i) => { const ix = idx.slice(); ix[against] = i; return ravel(ix); });
    }
    function xOf(i) {
      const labels = axes[against].labels;
      if (labels.length === 1) return (L + W - R) / 2;
      if (numeric(against)) {
        const xs = labels.map(Number), lo = Math.min(...xs), hi = Math.max(...xs);
        return L + (W - L - R) * (hi > lo ? (xs[i] - lo) / (hi - lo) : 0.5);
      }
      return L + (W - L - R) * i / (labels.length - 1);
    }
    function draw() {
      const ms = members();
      for (const pan of panels) {
        const s = pan.svg;
        while (s.childNodes.length > 1) s.removeChild(s.lastChild);
        const ys = [];
        ms.forEach((m) => (pan.fig.values[m] || []).forEach((y) => {
          if (y !== null && Number.isFinite(y)) ys.push(y);
        }));
        let lo = ys.length ? Math.min(...ys) : 0, hi = ys.length ? Math.max(...ys) : 1;
        // differences below 1e-4 of the figure's size are drawn flat (a final radius that
        // moves by 1e-7 m is not a trend); a figure that does not move at all is centred
        const floor = 1e-4 * Math.max(Math.abs(lo), Math.abs(hi));
        if (hi - lo < floor) { const mid = (hi + lo) / 2; lo = mid - floor / 2; hi = mid + floor / 2; }
        if (!(hi > lo)) { const pad = 0.05 * Math.abs(hi) || 0.5; lo -= pad; hi += pad; }
        const yOf = (y) => TOP + (H - TOP - BOT) * (1 - (y - lo) / (hi - lo));
        s.append(svg("text", { x: 3, y: 11, class: "ctitle" }, `${pan.fig.label} (${pan.fig.unit})`));
        s.append(svg("line", { x1: L, y1: H - BOT, x2: W - R, y2: H - BOT, class: "axis" }));
        s.append(svg("line", { x1: L, y1: TOP, x2: L, y2: H - BOT, class: "axis" }));
        // enough digits that the two ends of the axis read differently (at most 5)
        const digits = Math.min(5, Math.max(3, 2 + Math.ceil(Math.log10(
          Math.max(Math.abs(hi), Math.abs(lo), 1e-300) / (hi - lo)))));
        s.append(svg("text", { x: L - 2, y: TOP + 3, class: "tick", "text-anchor": "end" }, fmt(hi, digits)));
        s.append(svg("text", { x: L - 2, y: H - BOT, class: "tick", "text-anchor": "end" }, fmt(lo, digits)));
        const labels = axes[against].labels;
        s.append(svg("text", { x: L, y: H - 5, class: "tick" }, labels[0]));
        s.append(svg("text", { x: (L + W - R) / 2, y: H - 5, class: "tick", "text-anchor": "middle" },
                     axes[against].key));
        s.append(svg("text", { x: W - R, y: H - 5, class: "tick", "text-anchor": "end" },
                     labels[labels.length - 1]));
        runs.forEach((_, r) => {
          let d = "", pen = false;  // a polyline broken where a member has no value
          ms.forEach((m, i) => {
            const y = (pan.fig.values[m] || [])[r];
            if (F.rows[m] < 0 || y === null || !Number.isFinite(y)) { pen = false; return; }
            d += `${pen ? "L" : "M"}${xOf(i).toFixed(1)},${yOf(y).toFixed(1)}`;
            pen = true;
          });
          if (d) s.append(svg("path", { d: d, class: "series", stroke: RUN_COLOURS[r] }));
          ms.forEach((m, i) => {
            const y = (pan.fig.values[m] || [])[r];
            if (F.rows[m] < 0) {
              if (r > 0) return;
              const x = xOf(i), yy = H - BOT - 3;
              const g = svg("g", { class: "refused-mark" });
              g.append(svg("title", {}, `${F.label(m)}: refused: ${F.message[m]}`));
              g.append(svg("path", { d: `M${x - 2.5},${yy - 2.5}L${x + 2.5},${yy + 2.5}M${x - 2.5},${yy + 2.5}L${x + 2.5},${yy - 2.5}` }));
              s.append(g);
              return;
            }
            if (y === null || !Number.isFinite(y)) return;
            const ok = F.status[m][r] === "ok";
            const dot = svg("circle", { cx: xOf(i), cy: yOf(y), r: 1.6,
                                        fill: ok ? RUN_COLOURS[r] : "#fff",
                                        stroke: RUN_COLOURS[r], "stroke-width": 0.8 });
            dot.append(svg("title", {}, `${F.label(m)}: ${fmt(y)} ${pan.fig.unit}`
                                        + (ok ? "" : ` (${F.status[m][r]})`)));
            s.append(dot);
          });
        });
        pan.cursor = svg("line", { y1: TOP - 2, y2: H - BOT, class: "cursor" });
        s.append(pan.cursor);
        pan.value = svg("text", { y: 22, x: W - 3, class: "cvalue", "text-anchor": "end" }, "");
        s.append(pan.value);
      }
    }
    function mark() {
      const m = ravel(idx);
      const x = xOf(idx[against]);
      for (const pan of panels) {
        pan.cursor.setAttribute("x1", x);
        pan.cursor.setAttribute("x2", x);
        const ys = pan.fig.values[m] || [];
        pan.value.textContent = F.rows[m] < 0 ? "refused"
          : ys.map((y) => (y === null ? "–" : fmt(y, 3))).join(" / ");
      }
    }
    let drawnFor = null;
    function select(d, i) {
      idx[d] = i;
      axes.forEach((a, k) => {
        sliders[k].input.value = String(idx[k]);
        sliders[k].value.textContent = a.labels[idx[k]];
      });
      const key = idx.filter((_, k) => k !== against).join(",");
      if (key !== drawnFor) { draw(); drawnFor = key; }
      onMember(ravel(idx));
      mark();
    }
    for (const pan of panels) {
      pan.svg.addEventListener("click", (ev) => {
        const r = pan.svg.getBoundingClientRect();
        const x = (ev.clientX - r.left) / r.width * W;
        let best = 0;
        axes[against].labels.forEach((_, i) => {
          if (Math.abs(xOf(i) - x) < Math.abs(xOf(best) - x)) best = i;
        });
        select(against, best);
      });
    }
    function fromHash(h) {
      axes.forEach((a, d) => {
        if (h[a.key] === undefined) return;
        const text = String(h[a.key]);
        let i = a.labels.indexOf(text);
        if (i < 0 && numeric(d) && Number.isFinite(Number(text))) {
          const xs = a.labels.map(Number);
          i = xs.reduce((b, x, k) => (Math.abs(x - Number(text)) < Math.abs(xs[b] - Number(text)) ? k : b), 0);
          if (xs[i] !== Number(text)) notice(`#${a.key}=${text} is not on the axis: showing ${a.labels[i]}`);
        }
        if (i < 0) { notice(`#${a.key}=${text} is not a value of the axis: ignored`); return; }
        idx[d] = i;
      });
      select(0, idx[0]);
    }
    return { mark: mark, fromHash: fromHash, select: select };
  }

  const VIRIDIS = [[0.267, 0.005, 0.329], [0.283, 0.141, 0.458], [0.254, 0.265, 0.530],
    [0.207, 0.372, 0.553], [0.164, 0.471, 0.558], [0.128, 0.567, 0.551],
    [0.135, 0.659, 0.518], [0.267, 0.749, 0.441], [0.478, 0.821, 0.318],
    [0.741, 0.873, 0.150], [0.993, 0.906, 0.144]];
  function viridis(s, out, i) {
    const x = Math.max(0, Math.min(1, s)) * (VIRIDIS.length - 1);
    const k = Math.min(VIRIDIS.length - 2, Math.floor(x)), f = x - k;
    for (let c = 0; c < 3; c++) out[3 * i + c] = lerp(VIRIDIS[k][c], VIRIDIS[k + 1][c], f);
  }

  // --------------------------------------------------------------------- surface family
  function surfaceFamilyScene() {
    const g = { R0: D.attrs.R0, dR: D.attrs.dR, A: D.attrs.A, Kr: D.attrs.Kr, Ka: D.attrs.Ka };
    const incl = A.inclination;
    const view = new View("", "", "u");
    const big = view.addNote("big", "");
    const membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 1.0);
    view.scene.add(membrane.mesh);
    const c = document.getElementById("controls");
    const r1 = el("div", { class: "row" });
    const slider = el("input", { id: "gamma", type: "range", min: "0",
                                 max: String(incl.length - 1), step: "1", value: "0",
                                 "aria-label": "inclination" });
    const lab = el("span", { id: "gamma-value" }, "");
    r1.append(el("label", { for: "gamma" }, "inclination γ"), slider, lab);
    c.append(r1);
    viewControls([view], null);
    const table = readoutTable([""]);
    const set = (k) => {
      const gamma = incl[k] * Math.PI / 180;
      membrane.update(A.phase_r[0], A.phase_a[0], gamma);
      // the camera follows the surface as it turns from annulus to cylinder
      view.setFrame(membrane.points());
      const cls = D.strings.surface_class[k];
      big.textContent = cls;
      lab.textContent = `${incl[k].toFixed(0)}°`;
      table.set("gamma", "inclination γ", [incl[k].toFixed(1)], "deg");
      table.set("class", "surface class", [cls], "");
      table.set("phr", "radial phase φr", [fmt(A.phase_r[0] * 180 / Math.PI)], "deg");
      table.set("pha", "angular phase φa", [fmt(A.phase_a[0] * 180 / Math.PI)], "deg");
      view.render();
      publish({ inclination: incl[k], surface_class: cls, surface: membrane.probe(),
                camera: view.state() });
    };
    slider.addEventListener("input", () => set(Number(slider.value)));
    const gammaFromHash = (h, first) => {
      let k0 = first ? 0 : Number(slider.value);
      const want = hashNumber(h, "gamma", "degrees");
      if (want !== undefined) {
        let best = Infinity;
        incl.forEach((v, k) => { if (Math.abs(v - want) < best) { best = Math.abs(v - want); k0 = k; } });
        if (best > 1e-9) notice(`#gamma=${h.gamma}: the nearest stop is ${incl[k0]}°`);
      }
      slider.value = String(k0);
      set(k0);
    };
    gammaFromHash(hashParams(), true);
    onHash((h) => gammaFromHash(h, false));
    const box = section("Legend");
    const r = el("div", { class: "item" });
    r.append(el("span", { class: "swatch", style:
      `background: linear-gradient(to right, ${css(COLD)}, ${css(MID)}, ${css(WARM)})` }),
      el("span", {}, "corrugation W along the normal: blue cavity, brown crest"));
    box.append(r);
    unitLegend(box);
    document.getElementById("notes").appendChild(el("p", {}, "γ = 0: corrugated flat "
      + "annulus; 0 < γ < 90°: corrugated cone; γ = 90°: corrugated cylinder (docs/model.md "
      + `s.1.1). Phases φr = ${fmt(A.phase_r[0] * 180 / Math.PI)}°, φa = `
      + `${fmt(A.phase_a[0] * 180 / Math.PI)}°. The camera frames the surface at each γ until `
      + "you move it (Reset view frames it again). Drag to orbit, scroll to zoom."));
  }

  // What "u" means where a scene measures lengths in it (a legend entry and a note).
  function unitLegend(box) {
    const r = el("div", { class: "item", id: "unit-u" });
    r.append(el("span", { class: "swatch unit-key" }, "u"),
             el("span", {}, "u: the notebook's model length unit, not metres: the surface is "
               + `R0 = ${D.attrs.R0} u, dR = ${D.attrs.dR} u, A = ${D.attrs.A} u; every length `
               + "shown here (and the axes triad's bar) is a multiple of u, a velocity is in u/s"));
    box.append(r);
  }

  // -------------------------------------------------------------------- velocity/normal
  function velocityNormalScene() {
    const g = { R0: D.attrs.R0, dR: D.attrs.dR, A: D.attrs.A, Kr: D.attrs.Kr, Ka: D.attrs.Ka };
    const modes = D.coords.mode;
    const time = A.time;
    const n = time.length;
    const view = new View("", "", "u");
    view.setFrame(rim(g.R0 + g.dR, g.A + D.attrs.normal_length));
    const membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 0.9);
    view.scene.add(membrane.mesh);
    const point = new T.Mesh(new T.SphereGeometry(0.035, 20, 12),
                             new T.MeshStandardMaterial({ color: 0x111111 }));
    view.scene.add(point);
    const normalArrow = new Arrow(0x1f6fd1, 0.014);
    const velArrow = new Arrow(0xd1342f, 0.014);
    view.scene.add(normalArrow.group, velArrow.group);
    const c = document.getElementById("controls");
    const r0 = el("div", { class: "row" });
    const modeSel = el("select", { id: "mode", "aria-label": "mode" });
    modes.forEach((m, k) => modeSel.appendChild(el("option", { value: String(k) }, m)));
    const mag = el("input", { id: "magnification", type: "range", min: "0.25", max: "20",
                              step: "0.25", value: String(D.attrs.magnification),
                              "aria-label": "magnification" });
    const magLabel = el("span", { id: "magnification-value" }, "");
    r0.append(el("label", { for: "mode" }, "mode"), modeSel);
    const r0b = el("div", { class: "row" });
    r0b.append(el("label", { for: "magnification" }, "magnification"), mag, magLabel);
    c.append(r0, r0b);
    viewControls([view], null);
    const table = readoutTable([""]);
    let mode = 0;
    const modeFromHash = (h) => {
      if (h.mode !== undefined) {
        mode = modes.indexOf(String(h.mode));
        if (mode < 0) { notice(`#mode=${h.mode}: one of ${modes.join(", ")}; showing ${modes[0]}`); mode = 0; }
      }
      modeSel.value = String(mode);
      const m0 = hashNumber(h, "magnification", "");
      if (m0 !== undefined) mag.value = String(m0);
    };
    modeFromHash(hashParams());
    const dt = time[1] - time[0];
    const vec = (a, m, i) => row(a, m, i);
    const setTime = (t) => {
      const f = Math.min(n - 1, Math.max(0, t / dt));
      const i = Math.min(n - 1, Math.floor(f + 1e-9)), j = Math.min(n - 1, i + 1);
      const w = i >= n - 1 ? 0 : Math.max(0, f - i);
      const L = (name, k) => lerp(vec(A[name], mode, i)[k], vec(A[name], mode, j)[k], w);
      const ph = ["phase_r", "phase_a", "inclination"].map((k) => L(k, 0));
      membrane.update(ph[0], ph[1], ph[2]);
      const p = [0, 1, 2].map((k) => L("position", k));
      const nv = new T.Vector3(L("normal", 0), L("normal", 1), L("normal", 2));
      const vv = new T.Vector3(L("velocity", 0), L("velocity", 1), L("velocity", 2));
      const speed = L("speed", 0);
      const m = Number(mag.value);
      magLabel.textContent = "x" + m;
      point.position.set(p[0], p[1], p[2]);
      normalArrow.set(point.position, nv, D.attrs.normal_length);
      const vlen = speed * D.attrs.velocity_scale * m;
      velArrow.set(point.position, vv, vlen);
      view.render();
      const v3 = (x) => `(${fmt(x.x, 3)}, ${fmt(x.y, 3)}, ${fmt(x.z, 3)})`;
      table.set("time", "time", [fmt(t)], "s");
      table.set("velocity", "velocity c_t", [v3(vv)], "u/s");
      table.set("speed", "speed |c_t|", [fmt(speed)], "u/s");
      table.set("normal", "unit normal n", [v3(nv)], "");
      table.set("drawn", "drawn velocity", [fmt(vlen)], "u");
      point.updateMatrixWorld(true);
      const tipN = nv.clone().normalize().multiplyScalar(D.attrs.normal_length)
        .add(new T.Vector3(...p));
      const tipV = vv.lengthSq() > 0 ? vv.clone().normalize().multiplyScalar(vlen)
        .add(new T.Vector3(...p)) : new T.Vector3(...p);
      publish({ time: t, frame: i, weight: w, mode: modes[mode], magnification: m,
                point: [point.position.x, point.position.y, point.position.z],
                normal_tip: [tipN.x, tipN.y, tipN.z], velocity_tip: [tipV.x, tipV.y, tipV.z],
                phases: ph, surface: membrane.probe() });
    };
    const set = clockControls(time[n - 1], dt, [0.25, 0.5, 1, 2, 4], setTime);
    onHash((h) => { modeFromHash(h); set(state.t); });
    modeSel.addEventListener("change", () => { mode = Number(modeSel.value); set(state.t); });
    mag.addEventListener("input", () => set(state.t));
    const box = section("Legend");
    for (const [colour, text] of [
      ["#1f6fd1", `unit normal n (drawn ${D.attrs.normal_length} u long)`],
      ["#d1342f", `velocity c_t (${D.attrs.velocity_scale} u per u/s × magnification)`],
      ["#111111", "the surface point (α, R)"]]) {
      const r = el("div", { class: "item" });
      r.append(el("span", { class: "swatch", style: `background: ${colour}` }), el("span", {}, text));
      box.append(r);
    }
    unitLegend(box);
    document.getElementById("notes").appendChild(el("p", {}, `Point α = ${D.attrs.alpha_deg}°, `
      + `R = ${D.attrs.R} u. Modes: ${modes.join(", ")} (one period each). The velocity is `
      + "c_t, the velocity of the surface point that keeps its coordinates (docs/model.md "
      + "s.1.3); the normal is (c_R × c_α)/J (s.1.4). Drag to orbit, scroll to zoom."));
  }

  try {
    if (!T || !T.WebGLRenderer) throw new Error("three.js is missing from the page");
    const probe = document.createElement("canvas");
    if (!(probe.getContext("webgl2") || probe.getContext("webgl"))) {
      throw new Error("this browser has no WebGL: the 3D view cannot be drawn");
    }
    window.creatio = { state: state, views: VIEWS };
    ({ sphere: sphereScene, surface_family: surfaceFamilyScene,
       velocity_normal: velocityNormalScene })[D.kind]();
  } catch (e) {
    showError(String(e && e.message ? e.message : e));
    throw e;
  }
})();
