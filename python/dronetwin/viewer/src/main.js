// The replay viewer of a dronetwin run (docs/viewer.md). `dronetwin view RUN_DIR` writes one
// HTML page with this bundle and the run's data inline; nothing is fetched at run time.
//
// The data (python/dronetwin/view.py builds it): vehicles with their sampled times, positions,
// attitudes (w, x, y, z), rotor speeds and, for closed-loop runs, the reference; the scene's gates
// (frame corners) and obstacles. World frame z up, as in the logs.
//
// For tests and scripted screenshots the page reports itself in #status (data-frames,
// data-errors, data-time) and honours ?t=SECONDS (show that instant, paused).

import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import uPlot from "uplot";
import uplotCss from "uplot/dist/uPlot.min.css";

const PALETTE = [0x1f77b4, 0xd62728, 0x2ca02c, 0x9467bd, 0xff7f0e, 0x17becf];

// ---- errors are counted, not swallowed: the tests require none -----------------------------
let errorCount = 0;
const status = document.getElementById("status");
function reportError(message) {
  errorCount += 1;
  status.dataset.errors = String(errorCount);
  const box = document.getElementById("errors");
  box.textContent += message + "\n";
  box.hidden = false;
}
window.addEventListener("error", (e) => reportError(String(e.message)));
window.addEventListener("unhandledrejection", (e) => reportError(String(e.reason)));

const style = document.createElement("style");
style.textContent = uplotCss;
document.head.appendChild(style);

const data = JSON.parse(document.getElementById("run-data").textContent);

// ---- time base: the frames of the vehicle that flies longest (RL episodes end at different
// times); the others are looked up by time and stay at their last frame once they end ---------
const base = data.vehicles.reduce((a, v) => (v.t[v.t.length - 1] > a.t[a.t.length - 1] ? v : a));
const times = base.t;
const frameCount = times.length;
status.dataset.frames = String(frameCount);

function frameAt(vehicle, t) {
  // Last sample at or before t (binary search).
  const ts = vehicle.t;
  let lo = 0;
  let hi = ts.length - 1;
  if (t <= ts[0]) return 0;
  if (t >= ts[hi]) return hi;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (ts[mid] <= t) lo = mid;
    else hi = mid;
  }
  return lo;
}

// ---- the 3-D scene ----------------------------------------------------------------------
const view = document.getElementById("view");
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f5f7);
const camera = new THREE.PerspectiveCamera(50, 1, 0.01, 1000);
camera.up.set(0, 0, 1);
scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, -5, 10);
scene.add(sun);

const bounds = new THREE.Box3();
for (const v of data.vehicles) for (const p of v.p) bounds.expandByPoint(new THREE.Vector3(...p));

function addGround() {
  const size = Math.max(4, Math.ceil(bounds.getSize(new THREE.Vector3()).length() * 1.5));
  const grid = new THREE.GridHelper(size, size, 0x999999, 0xcccccc);
  grid.rotation.x = Math.PI / 2; // the helper lies in x-z; the ground is x-y
  const c = bounds.getCenter(new THREE.Vector3());
  grid.position.set(Math.round(c.x), Math.round(c.y), 0);
  scene.add(grid);
  scene.add(new THREE.AxesHelper(0.5));
}

function addScene() {
  const gateMaterial = new THREE.MeshStandardMaterial({ color: 0xff8c1a });
  for (const gate of data.scene.gates) {
    const corners = gate.corners.map((c) => new THREE.Vector3(...c));
    for (let i = 0; i < 4; i++) {
      const a = corners[i];
      const b = corners[(i + 1) % 4];
      const length = a.distanceTo(b);
      const bar = new THREE.Mesh(
        new THREE.CylinderGeometry(gate.bar_m / 2, gate.bar_m / 2, length, 12),
        gateMaterial,
      );
      bar.position.copy(a).add(b).multiplyScalar(0.5);
      bar.quaternion.setFromUnitVectors(
        new THREE.Vector3(0, 1, 0),
        b.clone().sub(a).normalize(),
      );
      scene.add(bar);
      bounds.expandByPoint(a);
    }
  }
  const obstacleMaterial = new THREE.MeshStandardMaterial({
    color: 0x8a8f99,
    transparent: true,
    opacity: 0.85,
  });
  for (const o of data.scene.obstacles) {
    const [hx, hy, hz] = o.half_size;
    let geometry;
    if (o.type === "box") geometry = new THREE.BoxGeometry(2 * hx, 2 * hy, 2 * hz);
    else if (o.type === "sphere") geometry = new THREE.SphereGeometry(hx, 32, 16);
    else {
      geometry = new THREE.CylinderGeometry(hx, hx, 2 * hz, 32);
      geometry.rotateX(Math.PI / 2); // three's cylinders stand on y; ours on z
    }
    const mesh = new THREE.Mesh(geometry, obstacleMaterial);
    mesh.position.set(...o.center);
    scene.add(mesh);
    bounds.expandByPoint(new THREE.Vector3(...o.center));
  }
}

// A vehicle: its arms from the centre to each rotor hub and a disc per rotor, in its colour.
function makeVehicle(v, color) {
  const body = new THREE.Group();
  const material = new THREE.MeshStandardMaterial({ color });
  const rotorMaterial = new THREE.MeshStandardMaterial({
    color,
    transparent: true,
    opacity: 0.45,
    side: THREE.DoubleSide,
  });
  body.add(new THREE.Mesh(new THREE.BoxGeometry(0.08, 0.08, 0.04), material));
  for (const hub of v.rotors) {
    const end = new THREE.Vector3(...hub);
    const arm = new THREE.Mesh(
      new THREE.CylinderGeometry(0.008, 0.008, end.length(), 8),
      material,
    );
    arm.position.copy(end).multiplyScalar(0.5);
    arm.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), end.clone().normalize());
    body.add(arm);
    const disc = new THREE.Mesh(new THREE.CircleGeometry(v.rotor_radius_m, 24), rotorMaterial);
    disc.position.copy(end);
    body.add(disc);
  }
  scene.add(body);
  return body;
}

function addLine(points, color, dashed) {
  const geometry = new THREE.BufferGeometry().setFromPoints(
    points.map((p) => new THREE.Vector3(...p)),
  );
  const material = dashed
    ? new THREE.LineDashedMaterial({ color, dashSize: 0.05, gapSize: 0.05 })
    : new THREE.LineBasicMaterial({ color });
  const line = new THREE.Line(geometry, material);
  if (dashed) line.computeLineDistances();
  scene.add(line);
}

addScene();
addGround();
const bodies = data.vehicles.map((v, i) => {
  const color = PALETTE[i % PALETTE.length];
  addLine(v.p, color, false);
  if (v.ref) addLine(v.ref, 0x333333, true);
  return makeVehicle(v, color);
});

// Camera: from the south-west and above, far enough to hold the paths and the scene.
const center = bounds.getCenter(new THREE.Vector3());
const radius = Math.max(1.0, bounds.getSize(new THREE.Vector3()).length() / 2);
camera.position.copy(center).add(new THREE.Vector3(-1.2, -1.6, 1.0).multiplyScalar(radius * 1.3));
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.copy(center);
controls.update();

// ---- plots ------------------------------------------------------------------------------
let currentTime = times[0];
const cursorPlugin = {
  hooks: {
    draw: (u) => {
      const x = u.valToPos(currentTime, "x", true);
      const ctx = u.ctx;
      ctx.save();
      ctx.strokeStyle = "#000";
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(x, u.bbox.top);
      ctx.lineTo(x, u.bbox.top + u.bbox.height);
      ctx.stroke();
      ctx.restore();
    },
  },
};

const plots = [];
function addPlot(title, seriesNames, columns, units, t) {
  const element = document.createElement("div");
  document.getElementById("plots").appendChild(element);
  const colors = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#555"];
  const opts = {
    title,
    width: 460,
    height: 190,
    plugins: [cursorPlugin],
    scales: { x: { time: false } },
    axes: [{ label: "t (s)" }, { label: units }],
    series: [{}].concat(
      seriesNames.map((name, i) => ({ label: name, stroke: colors[i % colors.length] })),
    ),
  };
  plots.push(new uPlot(opts, [t].concat(columns), element));
}

const first = data.vehicles[0];
const column = (rows, k) => rows.map((r) => r[k]);
if (first.ref) {
  addPlot(
    `${first.name}: position and reference`,
    ["x", "y", "z", "ref x", "ref y", "ref z"],
    [0, 1, 2].map((k) => column(first.p, k)).concat([0, 1, 2].map((k) => column(first.ref, k))),
    "m",
    first.t,
  );
} else {
  addPlot(
    `${first.name}: position`,
    ["x", "y", "z"],
    [0, 1, 2].map((k) => column(first.p, k)),
    "m",
    first.t,
  );
}
addPlot(
  `${first.name}: rotor speeds`,
  first.omega[0].map((_, i) => `ω${i}`),
  first.omega[0].map((_, i) => column(first.omega, i)),
  "rad/s",
  first.t,
);

// ---- timeline ---------------------------------------------------------------------------
const scrubber = document.getElementById("scrubber");
scrubber.max = String(frameCount - 1);
const clock = document.getElementById("clock");
const playButton = document.getElementById("play");
let playing = false;
let speed = 1;

function show(t) {
  currentTime = t;
  data.vehicles.forEach((v, i) => {
    const k = frameAt(v, t);
    const [w, x, y, z] = v.q[k];
    bodies[i].position.set(...v.p[k]);
    bodies[i].quaternion.set(x, y, z, w);
  });
  const frame = frameAt(base, t);
  scrubber.value = String(frame);
  const text = `t = ${t.toFixed(3)} s · frame ${frame + 1} / ${frameCount}`;
  clock.textContent = text;
  status.dataset.time = t.toFixed(3);
  status.dataset.frame = String(frame + 1);
  for (const p of plots) p.redraw(false, false);
  renderer.render(scene, camera);
}

function resize() {
  const width = view.clientWidth;
  const height = view.clientHeight;
  renderer.setSize(width, height, false);
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
  renderer.render(scene, camera);
}
window.addEventListener("resize", resize);
controls.addEventListener("change", () => renderer.render(scene, camera));

scrubber.addEventListener("input", () => {
  playing = false;
  playButton.textContent = "▶";
  show(times[Number(scrubber.value)]);
});
playButton.addEventListener("click", () => {
  playing = !playing;
  playButton.textContent = playing ? "❚❚" : "▶";
  if (playing && currentTime >= times[frameCount - 1]) currentTime = times[0];
  last = performance.now();
  if (playing) requestAnimationFrame(tick);
});
document.getElementById("speed").addEventListener("change", (e) => {
  speed = Number(e.target.value);
});

let last = performance.now();
function tick(now) {
  if (!playing) return;
  const t = Math.min(times[frameCount - 1], currentTime + ((now - last) / 1000) * speed);
  last = now;
  show(t);
  if (t >= times[frameCount - 1]) {
    playing = false;
    playButton.textContent = "▶";
    return;
  }
  requestAnimationFrame(tick);
}

const asked = new URLSearchParams(window.location.search).get("t");
resize();
show(asked !== null ? Math.min(Math.max(Number(asked), times[0]), times[frameCount - 1]) : times[0]);
document.getElementById("title").textContent = data.title;
status.dataset.ready = "1";
