// The cell in 3D (issue 24, item 2): the arms, the objects of the knowledge base with their
// sizes, the people's hands — drawn with three.js (vendored, static/vendor/three, MIT) from the
// `scene` part of the panel's state. Frame: x forward (towards the person), y left, z up, metres
// (the robot model's world frame, docs/action.md). An arm whose joint state is known is drawn
// link by link (forward kinematics of the project's robot model, done by the server); the
// others as a two-link arm from the base to the hand.
import * as THREE from "./vendor/three/three.module.min.js";

const box = document.getElementById("scene3d");
const renderer = new THREE.WebGLRenderer({ antialias: false });
renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
box.append(renderer.domElement);
renderer.domElement.setAttribute("aria-label", "the cell in 3D");
renderer.domElement.setAttribute("role", "img");

const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f5f7);
scene.up = new THREE.Vector3(0, 0, 1);
const camera = new THREE.PerspectiveCamera(45, 1, 0.05, 50);
camera.up.set(0, 0, 1);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8f99, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(1.5, 1.0, 3.0);
scene.add(sun);
const table = new THREE.Mesh(new THREE.BoxGeometry(2.4, 1.6, 0.02),
                             new THREE.MeshLambertMaterial({ color: 0xd8cbb3 }));
table.position.set(0.6, 0, -0.011);
scene.add(table);

// a simple orbit: drag to turn, wheel to zoom (no controls library: one less vendored file)
// seen from the person's side of the table (x points at them), a little to their right
const view = { az: -0.45, el: 0.6, r: 2.2, target: new THREE.Vector3(0.4, 0, 0.2) };
function placeCamera() {
  const c = Math.cos(view.el);
  camera.position.set(view.target.x + view.r * c * Math.cos(view.az),
                      view.target.y + view.r * c * Math.sin(view.az),
                      view.target.z + view.r * Math.sin(view.el));
  camera.lookAt(view.target);
}
let drag = null;
renderer.domElement.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; });
window.addEventListener("pointerup", () => { drag = null; });
window.addEventListener("pointermove", (e) => {
  if (!drag) return;
  view.az -= (e.clientX - drag[0]) * 0.01;
  view.el = Math.min(1.45, Math.max(0.05, view.el + (e.clientY - drag[1]) * 0.01));
  drag = [e.clientX, e.clientY];
  placeCamera(); draw();
});
renderer.domElement.addEventListener("wheel", (e) => {
  e.preventDefault();
  view.r = Math.min(8, Math.max(0.8, view.r * (e.deltaY > 0 ? 1.1 : 0.9)));
  placeCamera(); draw();
}, { passive: false });

const MAT = {
  link: new THREE.MeshLambertMaterial({ color: 0xe8eaee }),
  joint: new THREE.MeshLambertMaterial({ color: 0x3b4252 }),
  hand: new THREE.MeshLambertMaterial({ color: 0x2f6fd6 }),
  person: new THREE.MeshLambertMaterial({ color: 0xf59e0b }),
  fixed: new THREE.MeshLambertMaterial({ color: 0x2e9d5b }),
  part: new THREE.MeshLambertMaterial({ color: 0x8b5e3c }),
  place: new THREE.MeshLambertMaterial({ color: 0x9aa3af, transparent: true, opacity: 0.6 }),
  ghost: new THREE.MeshLambertMaterial({ color: 0x2f6fd6, transparent: true, opacity: 0.4,
                                         depthWrite: false }),
  path: new THREE.LineDashedMaterial({ color: 0x1d4fa8, dashSize: 0.03, gapSize: 0.02 }),
  pathTube: new THREE.MeshLambertMaterial({ color: 0x1d4fa8 }),
  whatIfTube: new THREE.MeshLambertMaterial({ color: 0xc2410c }),
  whatIf: new THREE.MeshLambertMaterial({ color: 0xf97316, transparent: true, opacity: 0.3,
                                          depthWrite: false }),
  whatIfPath: new THREE.LineDashedMaterial({ color: 0xc2410c, dashSize: 0.03, gapSize: 0.02 }),
};
const dynamic = new THREE.Group();
scene.add(dynamic);

const v3 = (p) => new THREE.Vector3(p[0], p[1], p[2]);
function rod(a, b, radius, mat) {
  const d = new THREE.Vector3().subVectors(b, a), len = d.length();
  const m = new THREE.Mesh(new THREE.CylinderGeometry(radius, radius, Math.max(len, 1e-3), 12), mat);
  m.position.copy(a).addScaledVector(d, 0.5);
  m.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), d.normalize());
  return m;
}
function ball(p, radius, mat) {
  const m = new THREE.Mesh(new THREE.SphereGeometry(radius, 16, 12), mat);
  m.position.copy(p);
  return m;
}
// an arm without a joint state: shoulder -> elbow -> hand, the elbow raised (two equal links)
function twoLink(base, hand, reach) {
  const d = new THREE.Vector3().subVectors(hand, base), dist = d.length();
  const link = Math.max((reach || dist) / 2, dist / 2 + 1e-3);
  const up = Math.sqrt(Math.max(link * link - (dist / 2) ** 2, 0));
  const side = new THREE.Vector3(0, 0, 1).addScaledVector(d.clone().normalize(), -d.z / Math.max(dist, 1e-6)).normalize();
  const elbow = base.clone().addScaledVector(d, 0.5).addScaledVector(side, up);
  return [base, elbow, hand];
}

// a size as the knowledge base gives it: {length, width, height} or {x, y, z} or
// {width, depth} (a slab) or {length, diameter} (a rod: upright once fixed, else lying)
function size3(o) {
  const s = o.size || {};
  return [s.length ?? s.depth ?? s.x, s.width ?? s.y, s.height ?? s.z].map((x) => +x || 0);
}
function objectMesh(o) {
  const s = o.size || {};
  const [x, y, z] = o.position;
  if (+s.diameter > 0) {
    const len = +s.length || +s.diameter;
    const m = new THREE.Mesh(new THREE.CylinderGeometry(s.diameter / 2, s.diameter / 2, len, 16),
                             o.fixed ? MAT.fixed : MAT.part);
    if (o.fixed) { m.rotation.x = Math.PI / 2; m.position.set(x, y, z - len / 2); }
    else { m.rotation.z = Math.PI / 2; m.position.set(x, y, z + s.diameter / 2); }
    return m;
  }
  const [l, w, h] = size3(o);
  if (l > 0 && w > 0) {
    const hh = Math.max(h, 0.02);
    const m = new THREE.Mesh(new THREE.BoxGeometry(l, w, hh), o.fixed ? MAT.fixed : MAT.part);
    m.position.set(x, y, z + hh / 2);
    return m;
  }
  // no size: a marker (a place, a point)
  const m = new THREE.Mesh(new THREE.CylinderGeometry(0.03, 0.03, 0.004, 20),
                           o.type === "place" ? MAT.place : MAT.part);
  m.rotation.x = Math.PI / 2;
  m.position.set(x, y, z + 0.002);
  return m;
}

let lastKey = null;
let movers = [];  // hand markers travelling a planned path, animated frame by frame
let whatIf = null;  // the robots of the last "what if I do this?" answer, drawn as orange ghosts
export function update(s) {
  const sc = s.scene;
  if (!sc) return;
  const key = JSON.stringify([sc, whatIf]);
  if (key === lastKey) return;
  lastKey = key;
  for (const c of [...dynamic.children]) { dynamic.remove(c); c.geometry?.dispose(); }
  movers = [];
  for (const r of sc.robots || []) {
    if (!r.base) continue;
    const base = v3(r.base);
    const pts = r.chain ? r.chain.map(v3) : r.hand ? twoLink(base, v3(r.hand), r.reach) : [base];
    dynamic.add(rod(new THREE.Vector3(base.x, base.y, 0), base, 0.05, MAT.joint));  // the column
    for (let i = 0; i + 1 < pts.length; i++) dynamic.add(rod(pts[i], pts[i + 1], 0.035, MAT.link));
    pts.slice(0, -1).forEach((p) => dynamic.add(ball(p, 0.045, MAT.joint)));
    dynamic.add(ball(pts[pts.length - 1], 0.04, MAT.hand));
    if (r.planned && r.planned.path && r.planned.path.length > 1) {
      // the next motion before it happens: the planned hand path, dashed, and a ghost of the
      // arm at its end
      const path = r.planned.path.map(v3);
      const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(path), MAT.path);
      line.computeLineDistances();
      line.userData.planned = r.name;
      dynamic.add(line);
      for (let i = 0; i + 1 < path.length; i++) dynamic.add(rod(path[i], path[i + 1], 0.007, MAT.pathTube));
      const ghost = twoLink(base, path[path.length - 1], r.reach);
      for (let i = 0; i + 1 < ghost.length; i++) {
        const g = rod(ghost[i], ghost[i + 1], 0.03, MAT.ghost);
        g.userData.ghost = r.name;
        dynamic.add(g);
      }
      const end = ball(path[path.length - 1], 0.045, MAT.ghost);
      end.userData.ghost = r.name;
      dynamic.add(end);
      if (r.planned.start !== null && r.planned.expected_s > 0) {
        // the hand travels the planned path over the command's expected time: the view moves
        // between the events (the cell reports only each command's start and end)
        const marker = ball(path[0], 0.04, MAT.hand);
        marker.userData.moving = { path, start: r.planned.start, duration: r.planned.expected_s };
        dynamic.add(marker);
        movers.push(marker);
      }
    }
  }
  for (const w of (whatIf || [])) {
    const r = (sc.robots || []).find((x) => x.name === w.agent);
    if (!r || !r.base || !w.path || w.path.length < 2) continue;
    const path = w.path.map(v3);
    const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(path), MAT.whatIfPath);
    line.computeLineDistances();
    line.userData.whatIf = w.agent;
    dynamic.add(line);
    for (let i = 0; i + 1 < path.length; i++) dynamic.add(rod(path[i], path[i + 1], 0.007, MAT.whatIfTube));
    const ghost = twoLink(v3(r.base), path[path.length - 1], r.reach);
    for (let i = 0; i + 1 < ghost.length; i++) dynamic.add(rod(ghost[i], ghost[i + 1], 0.03, MAT.whatIf));
  }
  for (const p of sc.people || []) if (p.hand) dynamic.add(ball(v3(p.hand), 0.05, MAT.person));
  for (const o of sc.objects || []) {
    if (!o.position) continue;
    const m = objectMesh(o);
    m.userData.id = o.id;
    dynamic.add(m);
  }
  draw();
  if (movers.length && !animating) { animating = true; requestAnimationFrame(animate); }
}

// the cell's time now, as the page's clock keeps it between events (panel.js)
const cellTime = () => window.__panel.clockNow();
// A hand is animated only until it reaches the end of its path (an idle page draws nothing):
// twenty open pages on one small machine share its CPU, software WebGL included, with their
// websockets (benchmarks/panel_latency.py, live cell). For the same reason no antialiasing.
let animating = false, travelling = 0;
function animate() {
  const t = cellTime();
  travelling = 0;
  for (const m of movers) {
    const { path, start, duration } = m.userData.moving;
    const f = Math.min(1, Math.max(0, (t - start) / duration));
    if (f < 1) travelling += 1;
    const seg = f * (path.length - 1), i = Math.min(Math.floor(seg), path.length - 2);
    m.position.lerpVectors(path[i], path[i + 1], seg - i);
  }
  draw();
  if (travelling) requestAnimationFrame(animate);
  else animating = false;  // every hand is at its path's end: the next state starts it again
}

function resize() {
  const w = box.clientWidth || 600, h = Math.min(440, Math.max(260, Math.round(w * 0.5)));
  renderer.setSize(w, h, false);
  renderer.domElement.style.width = "100%";
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  draw();
}
// drawn on demand (a change of state, a turn of the view): an idle page costs nothing
let frames = 0;
function draw() { renderer.render(scene, camera); frames += 1; window.__panel.frames = frames; }
new ResizeObserver(resize).observe(box);
placeCamera();
resize();
// what the tests read: the planned paths and ghosts now drawn, by arm
function planned() {
  const out = {};
  for (const c of dynamic.children) {
    if (c.userData.planned) out[c.userData.planned] = c.geometry.attributes.position.count;
    if (c.userData.whatIf) out["what if " + c.userData.whatIf] = c.geometry.attributes.position.count;
  }
  return out;
}
window.__scene3d = { update, draw, scene, planned, moving: () => (animating ? travelling : 0) };
window.addEventListener("panel-state", (e) => update(e.detail));
window.addEventListener("panel-whatif", (e) => {
  whatIf = e.detail ? e.detail.robots : null;
  if (window.__panel.state) update(window.__panel.state);
});
if (window.__panel.state) update(window.__panel.state);
