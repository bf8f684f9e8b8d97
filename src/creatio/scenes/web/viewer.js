// creatio scene viewer. Reads the scene's data from #scene-data (written by
// creatio.scenes.page from scene.nc) and draws it with three.js: no network, no server.
//
// The membrane is drawn from the phases of each frame with c(alpha, R) of docs/model.md s.1.1
// (surfacePoint below); everything else (centre, orientation, normal, velocity, readouts) is
// the dataset's own numbers. Between two frames positions and readouts are interpolated
// linearly and the orientation spherically; at a frame time the page draws the frame exactly.
// #scene-state holds what was drawn last (time, frame, positions), for tests and for reading.
(function () {
  "use strict";
  const T = window.THREE;
  const D = JSON.parse(document.getElementById("scene-data").textContent);
  const A = {};
  for (const [name, a] of Object.entries(D.arrays)) A[name] = decode(a);
  const state = { t: 0, playing: false, speed: D.attrs.playback_speed || 1, last: null };

  function decode(a) {
    const bin = atob(a.b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    const v = new Float64Array(bytes.buffer);
    v.shape = a.shape;
    return v;
  }

  function showError(message) {
    const el = document.getElementById("errors");
    el.hidden = false;
    el.textContent = message;
    window.creatioErrors.push(message);
  }

  // ------------------------------------------------------------------------ the surface
  // c(alpha, R) at phases (phr, pha) and inclination gam (docs/model.md s.1.1); also W.
  function surfacePoint(g, alpha, R, phr, pha, gam, out) {
    const k = 2 * Math.PI * g.Kr / g.dR;
    const W = g.A * Math.sin(k * R + phr) * Math.cos(g.Ka * alpha + pha);
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
    update(phr, pha, gam) {
      const key = phr + "," + pha + "," + gam;
      if (key === this.key) return;
      this.key = key;
      const p = [0, 0, 0];
      for (let i = 0; i < this.nA; i++) {
        for (let j = 0; j < this.nR; j++) {
          const v = i * this.nR + j;
          const W = surfacePoint(this.g, this.alpha(i), this.radius(j), phr, pha, gam, p);
          this.pos[3 * v] = p[0]; this.pos[3 * v + 1] = p[1]; this.pos[3 * v + 2] = p[2];
          heightColour(this.g.A > 0 ? W / this.g.A : 0, this.col, v);
        }
      }
      this.geo.attributes.position.needsUpdate = true;
      this.geo.attributes.color.needsUpdate = true;
      this.geo.computeVertexNormals();
      this.geo.computeBoundingSphere();
    }
    // A few drawn vertices with their (alpha, R): what tests compare with the model.
    probe() {
      const out = [];
      for (const [i, j] of [[0, 0], [Math.floor(this.nA / 3), Math.floor(this.nR / 2)],
                            [this.nA - 2, this.nR - 1]]) {
        const v = i * this.nR + j;
        out.push({ alpha: this.alpha(i), R: this.radius(j),
                   xyz: [this.pos[3 * v], this.pos[3 * v + 1], this.pos[3 * v + 2]] });
      }
      return out;
    }
  }

  // ------------------------------------------------------------------------- a 3D view
  class View {
    constructor(title, extent) {
      const el = document.createElement("div");
      el.className = "view";
      document.getElementById("views").appendChild(el);
      const label = document.createElement("div");
      label.className = "label";
      label.innerHTML = title;
      el.appendChild(label);
      this.el = el; this.label = label;
      const canvas = document.createElement("canvas");
      el.appendChild(canvas);
      this.renderer = new T.WebGLRenderer({ canvas: canvas, antialias: true,
                                            preserveDrawingBuffer: true });
      this.renderer.setPixelRatio(window.devicePixelRatio || 1);
      this.renderer.setClearColor(0xffffff, 1);
      this.scene = new T.Scene();
      this.camera = new T.PerspectiveCamera(35, 1, 0.01, 100);
      this.camera.up.set(0, 0, 1);
      this.home = new T.Vector3(0.2, -2.5, 1.9).multiplyScalar(extent);
      this.touched = false;
      this.camera.position.copy(this.home);
      this.scene.add(new T.HemisphereLight(0xffffff, 0x8a8f99, 1.6));
      const sun = new T.DirectionalLight(0xffffff, 1.6);
      sun.position.set(2, -3, 5);
      this.scene.add(sun);
      this.controls = new T.OrbitControls(this.camera, canvas);
      this.controls.target.set(0, 0, 0);
      this.controls.update();
      this.controls.addEventListener("change", () => this.render());
      this.controls.addEventListener("start", () => { this.touched = true; });
      new ResizeObserver(() => this.resize()).observe(el);
      this.resize();
    }
    resize() {
      const w = Math.max(1, this.el.clientWidth), h = Math.max(1, this.el.clientHeight);
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / h;
      if (!this.touched) {  // fit the annulus across a narrow view
        this.camera.position.copy(this.home).multiplyScalar(Math.max(1, 1.1 / this.camera.aspect));
        this.controls.update();
      }
      this.camera.updateProjectionMatrix();
      this.render();
    }
    render() { this.renderer.render(this.scene, this.camera); }
    addNote(cls, html) {
      const d = document.createElement("div");
      d.className = cls;
      d.innerHTML = html;
      this.el.appendChild(d);
      return d;
    }
  }

  // --------------------------------------------------------------------- common helpers
  function row(a, r, i) {  // row i of a (runs, frames, ...) or (frames, ...) array slice
    const shape = a.shape;
    const inner = shape.slice(2).reduce((x, y) => x * y, 1);
    const off = (r * shape[1] + i) * inner;
    return a.subarray(off, off + inner);
  }
  function lerp(a, b, w) { return a + (b - a) * w; }
  function fmt(x, digits) {
    if (!Number.isFinite(x)) return "–";
    const d = digits === undefined ? 4 : digits;
    const ax = Math.abs(x);
    if (ax === 0) return (0).toFixed(d - 1);
    if (ax < 1e-3 || ax >= 1e5) return x.toExponential(d - 1);
    return x.toFixed(Math.max(0, d - 1 - Math.floor(Math.log10(Math.max(ax, 1e-12)))));
  }
  function el(tag, attrs, html) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (html !== undefined) e.innerHTML = html;
    return e;
  }
  function hashParams() {
    const out = {};
    for (const part of location.hash.replace(/^#/, "").split("&")) {
      if (!part) continue;
      const [k, v] = part.split("=");
      out[decodeURIComponent(k)] = v === undefined ? true : decodeURIComponent(v);
    }
    return out;
  }
  function publish(obj) {
    document.getElementById("scene-state").textContent = JSON.stringify(obj);
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
    const h = hashParams();
    set(h.t !== undefined ? Number(h.t) : 0);
    setPlaying(h.t === undefined || h.play !== undefined);
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
  function sphereScene() {
    const runs = D.coords.run;
    const time = A.time;
    const n = time.length;
    const dt = D.attrs.frame_interval;
    const draw = new Set(D.attrs.draw);
    const table = readoutTable(runs.map((r) => r.toUpperCase()));
    const objs = runs.map((name, r) => {
      const g = { R0: A.R0[r], dR: A.dR[r], A: A.A[r], Kr: A.Kr[r], Ka: A.Ka[r] };
      const R1 = g.R0 + g.dR;
      const view = new View(`<b>${name.toUpperCase()}</b><br>${D.strings.direction[r]}`, R1);
      const o = { view: view, g: g, frames: A.frames_run[r] };
      if (draw.has("membrane")) {
        o.membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 1.0);
        view.scene.add(o.membrane.mesh);
      }
      const b = A.sphere_radius[r];
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
        for (let i = 0; i < n; i++) {
          const x = row(A.centre, r, i);
          pos[3 * i] = x[0]; pos[3 * i + 1] = x[1]; pos[3 * i + 2] = x[2] + 0.002;
          viridis(time[i] / time[n - 1], col, i);
        }
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
        o.traceGeometry = geo;
        view.scene.add(o.trace);
        view.addNote("legend", "trace coloured by time: purple 0 s → yellow "
                     + `${time[n - 1].toFixed(0)} s`);
      }
      return o;
    });
    const readouts = D.attrs.readouts;
    const q0 = new T.Quaternion(), q1 = new T.Quaternion();
    const setTime = (t) => {
      const f = Math.min(n - 1, Math.max(0, t / dt));
      let i = Math.floor(f + 1e-9);
      if (i >= n - 1) i = n - 1;
      const w = i >= n - 1 ? 0 : Math.max(0, f - i);
      const j = Math.min(n - 1, i + 1);
      const out = { time: t, frame: i, weight: w, runs: {} };
      const vals = {};
      objs.forEach((o, r) => {
        const last = o.frames - 1;
        const ii = Math.min(i, last), jj = Math.min(j, last), ww = i >= last ? 0 : w;
        const ph = ["phase_r", "phase_a", "inclination"].map(
          (k) => lerp(row(A[k], r, i)[0], row(A[k], r, j)[0], w));
        if (o.membrane) o.membrane.update(ph[0], ph[1], ph[2]);
        const xa = row(A.centre, r, ii), xb = row(A.centre, r, jj);
        o.body.position.set(lerp(xa[0], xb[0], ww), lerp(xa[1], xb[1], ww),
                            lerp(xa[2], xb[2], ww));
        if (A.quaternion) {
          const qa = row(A.quaternion, r, ii), qb = row(A.quaternion, r, jj);
          q0.set(qa[1], qa[2], qa[3], qa[0]).normalize();
          q1.set(qb[1], qb[2], qb[3], qb[0]).normalize();
          o.body.quaternion.slerpQuaternions(q0, q1, ww);
        }
        if (o.trace) o.traceGeometry.setDrawRange(0, ii + 1);
        o.body.updateMatrixWorld(true);
        const p = new T.Vector3();
        o.body.getWorldPosition(p);
        out.runs[runs[r]] = { drawn: [p.x, p.y, p.z], frame: ii,
                              status: D.strings.status[r] };
        if (o.membrane) out.runs[runs[r]].surface = o.membrane.probe();
        out.runs[runs[r]].phases = ph;
        for (const key of readouts) {
          if (key === "time") continue;
          const a = row(A[key], r, ii)[0], b = row(A[key], r, jj)[0];
          (vals[key] = vals[key] || []).push(fmt(lerp(a, b, ww)));
        }
        o.view.render();
      });
      table.set("time", "time", runs.map(() => fmt(t)), "s");
      for (const key of readouts) {
        if (key === "time") continue;
        table.set(key, D.labels[key], vals[key], D.units[key]);
      }
      publish(out);
    };
    clockControls(time[n - 1], dt, [1, 2, 4, 8, 16, 32], setTime);
    const notes = document.getElementById("notes");
    notes.innerHTML = runs.map((r, k) => `<p><b>${r.toUpperCase()}</b>: status `
      + `${D.strings.status[k]}; ${D.strings.source[k]}.</p>`).join("")
      + `<p>Drag to orbit, scroll to zoom. Frames every ${dt} s of simulated time, `
      + `played at x${D.attrs.playback_speed} by default.</p>`;
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
    const view = new View("", g.R0 + g.dR);
    view.label.remove();
    const big = view.addNote("big", "");
    const membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 1.0);
    view.scene.add(membrane.mesh);
    view.addNote("legend", "colour: corrugation W along e_n, blue cavity, brown crest");
    const c = document.getElementById("controls");
    const r1 = el("div", { class: "row" });
    const slider = el("input", { id: "gamma", type: "range", min: "0",
                                 max: String(incl.length - 1), step: "1", value: "0",
                                 "aria-label": "inclination" });
    const lab = el("span", { id: "gamma-value" }, "");
    r1.append(el("label", { for: "gamma" }, "inclination γ"), slider, lab);
    c.append(r1);
    const table = readoutTable([""]);
    const set = (k) => {
      const gamma = incl[k] * Math.PI / 180;
      membrane.update(A.phase_r[0], A.phase_a[0], gamma);
      const cls = D.strings.surface_class[k];
      big.textContent = cls;
      lab.textContent = `${incl[k].toFixed(0)}°`;
      table.set("gamma", "inclination γ", [incl[k].toFixed(1)], "deg");
      table.set("class", "surface class", [cls], "");
      table.set("phr", "radial phase φr", [fmt(A.phase_r[0] * 180 / Math.PI)], "deg");
      table.set("pha", "angular phase φa", [fmt(A.phase_a[0] * 180 / Math.PI)], "deg");
      view.render();
      publish({ inclination: incl[k], surface_class: cls, surface: membrane.probe() });
    };
    slider.addEventListener("input", () => set(Number(slider.value)));
    const h = hashParams();
    let k0 = 0;
    if (h.gamma !== undefined) {
      let best = Infinity;
      incl.forEach((v, k) => { if (Math.abs(v - h.gamma) < best) { best = Math.abs(v - h.gamma); k0 = k; } });
    }
    slider.value = String(k0);
    set(k0);
    document.getElementById("notes").innerHTML = "<p>γ = 0: corrugated flat annulus; "
      + "0 &lt; γ &lt; 90°: corrugated cone; γ = 90°: corrugated cylinder (docs/model.md "
      + "s.1.1). Phases φr = " + fmt(A.phase_r[0] * 180 / Math.PI) + "°, φa = "
      + fmt(A.phase_a[0] * 180 / Math.PI) + "°. Drag to orbit, scroll to zoom.</p>";
  }

  // -------------------------------------------------------------------- velocity/normal
  function velocityNormalScene() {
    const g = { R0: D.attrs.R0, dR: D.attrs.dR, A: D.attrs.A, Kr: D.attrs.Kr, Ka: D.attrs.Ka };
    const modes = D.coords.mode;
    const time = A.time;
    const n = time.length;
    const view = new View("", g.R0 + g.dR);
    const membrane = new Membrane(g, D.attrs.mesh[0], D.attrs.mesh[1], 0.9);
    view.scene.add(membrane.mesh);
    const point = new T.Mesh(new T.SphereGeometry(0.035, 20, 12),
                             new T.MeshStandardMaterial({ color: 0x111111 }));
    view.scene.add(point);
    const normalArrow = new Arrow(0x1f6fd1, 0.014);
    const velArrow = new Arrow(0xd1342f, 0.014);
    view.scene.add(normalArrow.group, velArrow.group);
    view.addNote("legend", "<span style='color:#1f6fd1'>■</span> unit normal n (drawn "
      + `${D.attrs.normal_length} u) &nbsp; <span style='color:#d1342f'>■</span> velocity c_t `
      + `(${D.attrs.velocity_scale} u per u/s × magnification)`);
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
    const table = readoutTable([""]);
    const h = hashParams();
    let mode = h.mode !== undefined ? Math.max(0, modes.indexOf(h.mode)) : 0;
    modeSel.value = String(mode);
    if (h.magnification !== undefined) mag.value = String(h.magnification);
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
    modeSel.addEventListener("change", () => { mode = Number(modeSel.value); set(state.t); });
    mag.addEventListener("input", () => set(state.t));
    document.getElementById("notes").innerHTML = `<p>Point α = ${D.attrs.alpha_deg}°, `
      + `R = ${D.attrs.R} u. Modes: ${modes.join(", ")} (one period each). The velocity is `
      + "c_t, the velocity of the surface point that keeps its coordinates (docs/model.md "
      + "s.1.3); the normal is (c_R × c_α)/J (s.1.4). Drag to orbit, scroll to zoom.</p>";
  }

  try {
    if (!T || !T.WebGLRenderer) throw new Error("three.js is missing from the page");
    const probe = document.createElement("canvas");
    if (!(probe.getContext("webgl2") || probe.getContext("webgl"))) {
      throw new Error("this browser has no WebGL: the 3D view cannot be drawn");
    }
    ({ sphere: sphereScene, surface_family: surfaceFamilyScene,
       velocity_normal: velocityNormalScene })[D.kind]();
    window.creatio = { state: state };
  } catch (e) {
    showError(String(e && e.message ? e.message : e));
    throw e;
  }
})();
