// The interactive parts of a coopsat run report: the 3D view, the network over time and the
// time series, all driven by one time slider. The page embeds its data as JSON
// (#coopsat-data; bulk arrays as base64 little-endian float32) and Plotly itself, so it works
// offline. window.coopsatReport exposes the current frame for tests and scripts.
(function () {
  "use strict";
  const data = JSON.parse(document.getElementById("coopsat-data").textContent);
  const PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf"];
  const AXIS_COLORS = ["#d62728", "#2ca02c", "#1f77b4"];
  const LINK_COLORS = { up: "#2ca02c", lost: "#d62728", relayed: "#7f7f7f" };
  const DASHES = ["solid", "dash", "dot", "dashdot"];  // components of one spacecraft share its colour
  const CONFIG = { displaylogo: false, responsive: true };

  function decode(b64) {
    if (b64 === null || b64 === undefined) return null;
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Float32Array(bytes.buffer);
  }

  function finite(v) { return Number.isFinite(v) ? v : null; }

  const names = data.names;
  const n = names.length;
  const times = decode(data.times);
  const nFrames = times.length;
  const color = (i) => PALETTE[i % PALETTE.length];

  // ---- 3D view -------------------------------------------------------------------------------
  const scene = data.scene;
  const pos = decode(scene.positions);
  const axes = decode(scene.body_axes);
  const targets = decode(scene.targets);
  const trails = decode(scene.trails);
  const nTrail = trails.length / (n * 3);

  function at(f, i, c) { return pos[(f * n + i) * 3 + c]; }

  function sphere(radius) {
    const x = [], y = [], z = [], flat = [];
    for (let a = 0; a <= 24; a++) {
      const lat = -Math.PI / 2 + Math.PI * a / 24;
      const rx = [], ry = [], rz = [];
      for (let b = 0; b <= 48; b++) {
        const lon = 2 * Math.PI * b / 48;
        rx.push(radius * Math.cos(lat) * Math.cos(lon));
        ry.push(radius * Math.cos(lat) * Math.sin(lon));
        rz.push(radius * Math.sin(lat));
      }
      x.push(rx); y.push(ry); z.push(rz); flat.push(rx.map(() => 0));
    }
    // one colour, translucent: a spacecraft behind the body stays visible
    return { type: "surface", x: x, y: y, z: z, surfacecolor: flat, cmin: 0, cmax: 1, showscale: false, opacity: 0.45,
      hoverinfo: "skip", colorscale: [[0, "#5b8fd6"], [1, "#5b8fd6"]], name: scene.central_body[0] };
  }

  function staticTraces() {
    const traces = [];
    for (let i = 0; i < n; i++) {
      const x = [], y = [], z = [];
      for (let k = 0; k < nTrail; k++) {
        x.push(trails[(k * n + i) * 3]); y.push(trails[(k * n + i) * 3 + 1]); z.push(trails[(k * n + i) * 3 + 2]);
      }
      traces.push({ type: "scatter3d", mode: "lines", x: x, y: y, z: z, name: names[i] + " path",
        line: { color: color(i), width: 2 }, opacity: 0.45, hoverinfo: "skip", showlegend: false });
    }
    if (scene.central_body !== null) traces.push(sphere(scene.central_body[1]));
    return traces;
  }

  function dynamicTraces(f) {
    const traces = [{ type: "scatter3d", mode: "markers+text", name: "spacecraft", text: names,
      x: names.map((_, i) => at(f, i, 0)), y: names.map((_, i) => at(f, i, 1)), z: names.map((_, i) => at(f, i, 2)),
      marker: { size: 5, color: names.map((_, i) => color(i)) }, textposition: "top center",
      hovertemplate: "%{text}<br>%{x:.4g}, %{y:.4g}, %{z:.4g}<extra></extra>" }];
    if (axes !== null) {
      const L = scene.axis_length;
      for (let a = 0; a < 3; a++) {
        const x = [], y = [], z = [];
        for (let i = 0; i < n; i++) {
          const base = ((f * n + i) * 3 + a) * 3;
          x.push(at(f, i, 0), at(f, i, 0) + L * axes[base], null);
          y.push(at(f, i, 1), at(f, i, 1) + L * axes[base + 1], null);
          z.push(at(f, i, 2), at(f, i, 2) + L * axes[base + 2], null);
        }
        traces.push({ type: "scatter3d", mode: "lines", x: x, y: y, z: z, name: "body " + "xyz"[a],
          line: { color: AXIS_COLORS[a], width: 5 }, hoverinfo: "skip" });
      }
    }
    if (targets !== null) {
      const x = [], y = [], z = [], tx = [], ty = [], tz = [];
      for (let i = 0; i < n; i++) {
        const base = (f * n + i) * 3;
        tx.push(finite(targets[base])); ty.push(finite(targets[base + 1])); tz.push(finite(targets[base + 2]));
        x.push(at(f, i, 0), finite(targets[base]), null);
        y.push(at(f, i, 1), finite(targets[base + 1]), null);
        z.push(at(f, i, 2), finite(targets[base + 2]), null);
      }
      traces.push({ type: "scatter3d", mode: "lines", x: x, y: y, z: z, name: "line of sight",
        line: { color: "#444", width: 2, dash: "dash" }, hoverinfo: "skip" });
      traces.push({ type: "scatter3d", mode: "markers", x: tx, y: ty, z: tz, name: "ground target",
        marker: { size: 4, color: "#000", symbol: "x" } });
    }
    return traces;
  }

  const sceneDiv = document.getElementById("scene");
  const nStatic = n + (scene.central_body !== null ? 1 : 0);
  const firstDynamic = dynamicTraces(0);
  const dynamicIndex = firstDynamic.map((_, k) => nStatic + k);
  const title = (t) => ({ text: t });

  // With a central body, look from the spacecraft's side of it (their mean direction at t = 0).
  function cameraEye() {
    if (scene.central_body === null) return { x: 1.25, y: 1.25, z: 1.25 };
    const mean = [0, 1, 2].map((c) => names.reduce((sum, _, i) => sum + at(0, i, c), 0) / n);
    const norm = Math.hypot(mean[0], mean[1], mean[2]) || 1;
    return { x: 1.6 * mean[0] / norm, y: 1.6 * mean[1] / norm, z: 1.6 * mean[2] / norm + 0.4 };
  }
  Plotly.newPlot(sceneDiv, staticTraces().concat(firstDynamic), {
    margin: { l: 0, r: 0, t: 30, b: 0 }, uirevision: "keep", legend: { x: 0, y: 1 },
    title: { text: scene.frame, font: { size: 14 } },
    scene: { aspectmode: "data", camera: { eye: cameraEye() }, xaxis: { title: title(scene.axis_titles[0]) },
      yaxis: { title: title(scene.axis_titles[1]) }, zaxis: { title: title(scene.axis_titles[2]) } },
  }, CONFIG);

  function drawScene(f) {
    const update = { x: [], y: [], z: [] };
    for (const trace of dynamicTraces(f)) { update.x.push(trace.x); update.y.push(trace.y); update.z.push(trace.z); }
    Plotly.restyle(sceneDiv, update, dynamicIndex);
  }

  // ---- network -------------------------------------------------------------------------------
  const net = data.network;
  const netDiv = document.getElementById("network");
  const tau = net.tau_s === null ? null : decode(net.tau_s);
  const flags = Object.fromEntries(Object.entries(net.flags).map(([k, v]) => [k, decode(v)]));

  function epochAt(t) {
    let e = 0;
    for (let k = 0; k < net.epoch_start_s.length; k++) if (net.epoch_start_s[k] <= t) e = k;
    return e;
  }

  function fmt(v) { return Number(v.toPrecision(3)).toString(); }

  function linkAnnotations(f) {
    const e = epochAt(times[f]);
    const notes = [];
    for (const [tx, rx, state, hops, delay] of net.epochs[e]) {
      const [x0, y0] = net.xy[tx], [x1, y1] = net.xy[rx];
      const len = Math.hypot(x1 - x0, y1 - y0) || 1;
      const ox = -(y1 - y0) / len * 0.04, oy = (x1 - x0) / len * 0.04;  // i->j and j->i side by side
      notes.push({ x: x1 + ox, y: y1 + oy, ax: x0 + ox, ay: y0 + oy, xref: "x", yref: "y", axref: "x", ayref: "y",
        showarrow: true, arrowhead: 2, arrowsize: 1.2, arrowwidth: state === "up" ? 2 : 1.2, standoff: 24,
        startstandoff: 24, arrowcolor: LINK_COLORS[state], opacity: state === "lost" ? 0.55 : 1, text: "",
        hovertext: `${names[tx]} → ${names[rx]}: ${state}` });
      const late = state === "lost" ? 0 : delay + (tau === null ? 0 : hops * tau[f]);
      let label = late > 0 ? fmt(late) + " s" : "";
      if (state === "relayed") label = `${hops} hops` + (late > 0 ? `, ${fmt(late)} s` : "");
      if (label) {
        // 40 % of the way from the receiver: crossing diagonals keep their labels apart
        notes.push({ x: 0.6 * x1 + 0.4 * x0 + 2.2 * ox, y: 0.6 * y1 + 0.4 * y0 + 2.2 * oy, xref: "x", yref: "y", text: label,
          showarrow: false, font: { size: 10, color: LINK_COLORS[state] } });
      }
    }
    return notes;
  }

  function nodeText(f) {
    return names.map((name, i) => {
      const lines = [name];
      for (const [k, v] of Object.entries(flags)) lines.push(`${k}: ${fmt(v[f * n + i])}`);
      return lines.join("<br>");
    });
  }

  function networkTitle(f) {
    const e = epochAt(times[f]);
    let text = `graph ${e + 1} of ${net.epochs.length} (from t = ${fmt(net.epoch_start_s[e])} s)`;
    if (tau !== null) text += `, τ = ${fmt(tau[f])} s per hop`;
    if (net.dropout_probability > 0) text += `, loss ${fmt(100 * net.dropout_probability)} % per hop`;
    return text;
  }

  Plotly.newPlot(netDiv, [{ type: "scatter", mode: "markers+text", x: net.xy.map((p) => p[0]),
    y: net.xy.map((p) => p[1]), text: names, textposition: "middle center", hovertext: nodeText(0), hoverinfo: "text",
    textfont: { color: "#fff", size: 11 },
    marker: { size: 44, color: names.map((_, i) => color(i)), line: { color: "#333", width: 1 } } }], {
    margin: { l: 10, r: 10, t: 40, b: 10 }, showlegend: false, annotations: linkAnnotations(0),
    title: { text: networkTitle(0), font: { size: 13 } },
    xaxis: { visible: false, range: [-1.45, 1.45], fixedrange: true },
    yaxis: { visible: false, range: [-1.35, 1.45], scaleanchor: "x", fixedrange: true },
  }, CONFIG);

  function drawNetwork(f) {
    Plotly.relayout(netDiv, { annotations: linkAnnotations(f), "title.text": networkTitle(f) });
    Plotly.restyle(netDiv, { hovertext: [nodeText(f)] }, [0]);
  }

  // ---- time series ---------------------------------------------------------------------------
  const seriesDivs = [];
  for (const s of data.series) {
    const div = document.createElement("div");
    div.className = "series";
    document.getElementById("series").appendChild(div);
    const t = decode(s.t);
    const traces = s.traces.map((tr, k) => ({ type: "scatter", mode: "lines", name: tr.name, x: t, y: decode(tr.y),
      line: { width: 1.2, color: color(tr.color), dash: DASHES[(tr.dash || 0) % DASHES.length] }, hovertemplate: `%{y:.4g} ${s.unit}<extra>${tr.name}</extra>` }));
    Plotly.newPlot(div, traces, {
      height: 300, margin: { l: 70, r: 10, t: 30, b: 40 }, title: { text: s.label, font: { size: 13 } },
      xaxis: { title: { text: "time (s)" } },
      yaxis: { title: { text: `(${s.unit})` }, type: s.log ? "log" : "linear", exponentformat: "power" },
      shapes: [cursor(times[0])].concat(level(s.threshold)),
    }, CONFIG);
    div.dataset.threshold = s.threshold === null ? "" : String(s.threshold);
    seriesDivs.push(div);
  }

  // the [analysis] threshold a series is judged against (synchronisation), dotted
  function level(y) {
    return y === null ? [] : [{ type: "line", xref: "paper", x0: 0, x1: 1, y0: y, y1: y,
      line: { color: "#d62728", width: 1, dash: "dot" } }];
  }

  function cursor(t) {
    return { type: "line", x0: t, x1: t, yref: "paper", y0: 0, y1: 1, line: { color: "#888", width: 1, dash: "dot" } };
  }

  // ---- the slider ----------------------------------------------------------------------------
  const slider = document.getElementById("frame");
  const label = document.getElementById("frame-time");
  const report = { frame: 0, frames: nFrames, setFrame: null };
  let pending = null;

  function setFrame(f) {
    f = Math.max(0, Math.min(nFrames - 1, Math.round(f)));
    report.frame = f;
    slider.value = String(f);
    label.textContent = `t = ${fmt(times[f])} s`;
    drawScene(f);
    drawNetwork(f);
    for (const div of seriesDivs) {
      const y = div.dataset.threshold === "" ? null : Number(div.dataset.threshold);
      Plotly.relayout(div, { shapes: [cursor(times[f])].concat(level(y)) });
    }
    document.body.dataset.frame = String(f);
  }

  report.setFrame = setFrame;
  slider.max = String(nFrames - 1);
  slider.addEventListener("input", () => {
    if (pending !== null) cancelAnimationFrame(pending);
    pending = requestAnimationFrame(() => { pending = null; setFrame(Number(slider.value)); });
  });
  let timer = null;
  document.getElementById("play").addEventListener("click", (ev) => {
    if (timer !== null) { clearInterval(timer); timer = null; ev.target.textContent = "play"; return; }
    ev.target.textContent = "pause";
    timer = setInterval(() => {
      if (report.frame >= nFrames - 1) { clearInterval(timer); timer = null; ev.target.textContent = "play"; return; }
      setFrame(report.frame + 1);
    }, 80);
  });
  setFrame(0);
  window.coopsatReport = report;
})();
