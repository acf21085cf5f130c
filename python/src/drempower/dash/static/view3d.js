// drempower dashboard, 3D view: the robot's model drawn with three.js and posed by the live joint states.
// The scene (bodies, joints, geoms) comes from GET /model; the states from the page's sample stream.
import * as THREE from "./vendor/three.min.js";

const $ = (s) => document.querySelector(s);
const say = (text, info) => (window.dashSay ? window.dashSay(text, info) : console.log(text));
const ERROR_GLOW = new THREE.Color(0.9, 0.05, 0.0);

const V = {
  doc: null, world: null, renderer: null, camera: null, controls: null, three: null,
  joints: new Map(), // model joint name -> {rot, axis, type, ref, body}
  mapping: new Map(), // motor key -> {joint, model_joint, gear, offset}
  meshes: new Map(), // body index -> [mesh]
  errors: new Set(), // motor keys whose last state had the error bit
  angles: {}, // motor key -> the angle (deg) of its last state
  drawn: false,
  ghost: null, // the shadow's twin: {world, joints, meshes}, drawn translucent beside the robot
};
const GHOST = new THREE.Color(0.95, 0.55, 0.1);

// ------------------------------------------------------------ scene
const quat = (q) => new THREE.Quaternion(q[1], q[2], q[3], q[0]); // MuJoCo w x y z -> three x y z w

function geometry(g) {
  const s = g.size;
  switch (g.type) {
    case "sphere": return new THREE.SphereGeometry(s[0], 24, 16);
    case "ellipsoid": return new THREE.SphereGeometry(1, 24, 16).scale(s[0], s[1], s[2]);
    case "capsule": return new THREE.CapsuleGeometry(s[0], 2 * s[1], 8, 20).rotateX(Math.PI / 2);
    case "cylinder": return new THREE.CylinderGeometry(s[0], s[0], 2 * s[1], 24).rotateX(Math.PI / 2);
    case "box": return new THREE.BoxGeometry(2 * s[0], 2 * s[1], 2 * s[2]);
    case "plane": return new THREE.PlaneGeometry(2 * (s[0] || 2), 2 * (s[1] || 2));
    case "mesh":
      if (g.vertices) {
        const geo = new THREE.BufferGeometry();
        geo.setAttribute("position", new THREE.Float32BufferAttribute(g.vertices, 3));
        geo.setIndex(g.faces);
        geo.computeVertexNormals();
        return geo;
      }
      return null; // loaded from its file below
    default: return null;
  }
}

function material(g) {
  const [r, gr, b, a] = g.rgba;
  return new THREE.MeshStandardMaterial({
    color: new THREE.Color(r, gr, b), opacity: a, transparent: a < 1, roughness: 0.6, metalness: 0.1,
    side: g.type === "plane" ? THREE.DoubleSide : THREE.FrontSide,
  });
}

function loadMesh(g, mesh) {
  const url = "/model/file/" + g.url.split("/").map(encodeURIComponent).join("/") + location.search;
  const done = (geo) => {
    mesh.geometry = geo;
    mesh.scale.fromArray(g.scale);
  };
  const fail = (e) => say(`3D view: mesh ${g.url} could not be loaded (${e.message || e})`);
  if (g.format === "stl") new THREE.STLLoader().load(url, done, undefined, fail);
  else new THREE.OBJLoader().load(url, (obj) => {
    const child = obj.children.find((c) => c.isMesh);
    if (child) done(child.geometry);
  }, undefined, fail);
}

// the model's scene as three.js groups; its joints and meshes go into `into` (the robot's, or the shadow's)
function build(doc, into = V) {
  const sc = doc.scene;
  const inner = []; // each body's innermost group (after its joints)
  const world = new THREE.Group();
  sc.bodies.forEach((b, i) => {
    const outer = i === 0 ? world : new THREE.Group();
    outer.name = b.name;
    if (i > 0) {
      outer.position.fromArray(b.pos);
      outer.quaternion.copy(quat(b.quat));
      inner[b.parent].add(outer);
    }
    let node = outer;
    for (const j of sc.joints.filter((jj) => jj.body === i)) {
      if (j.type !== "hinge" && j.type !== "slide") continue; // free and ball joints: drawn at the modelled pose
      const pivot = new THREE.Group(), rot = new THREE.Group(), back = new THREE.Group();
      pivot.position.fromArray(j.pos);
      back.position.fromArray(j.pos).negate();
      node.add(pivot); pivot.add(rot); rot.add(back);
      rot.name = "joint:" + j.name;
      into.joints.set(j.name, { rot, axis: new THREE.Vector3().fromArray(j.axis).normalize(), type: j.type, ref: j.ref, body: i });
      node = back;
    }
    inner[i] = node;
  });
  for (const g of sc.geoms) {
    const geo = geometry(g);
    const mesh = new THREE.Mesh(geo || new THREE.BufferGeometry(), material(g));
    mesh.name = g.name || g.type;
    mesh.position.fromArray(g.pos);
    mesh.quaternion.copy(quat(g.quat));
    if (g.type === "mesh" && !g.vertices) loadMesh(g, mesh);
    inner[g.body].add(mesh);
    if (!into.meshes.has(g.body)) into.meshes.set(g.body, []);
    into.meshes.get(g.body).push(mesh);
  }
  return world;
}

// the joint's position (rad, or m for a slide joint) -> the drawn transform
function pose(name, q, of = V) {
  const j = of.joints.get(name);
  if (!j) return;
  if (j.type === "hinge") j.rot.quaternion.setFromAxisAngle(j.axis, q - j.ref);
  else j.rot.position.copy(j.axis).multiplyScalar(q - j.ref);
}

// read back from the three.js objects: hinge joints in degrees, slide joints in metres
function jointAngles(of = V) {
  const out = {};
  for (const [name, j] of of.joints) {
    if (j.type === "hinge") {
      const q = j.rot.quaternion;
      const s = q.x * j.axis.x + q.y * j.axis.y + q.z * j.axis.z;
      out[name] = (2 * Math.atan2(s, q.w) + j.ref) * 180 / Math.PI;
    } else {
      out[name] = j.rot.position.dot(j.axis) + j.ref;
    }
  }
  return out;
}

function highlighted() {
  const out = [];
  for (const [name, j] of V.joints) {
    const ms = V.meshes.get(j.body) || [];
    if (ms.length && ms.every((m) => m.material.emissive.equals(ERROR_GLOW))) out.push(name);
  }
  return out;
}

function setErrors() {
  const bad = new Set();
  for (const k of V.errors) {
    const m = V.mapping.get(k);
    if (m && V.joints.has(m.model_joint)) bad.add(V.joints.get(m.model_joint).body);
  }
  for (const [body, ms] of V.meshes) {
    for (const m of ms) m.material.emissive.copy(bad.has(body) ? ERROR_GLOW : new THREE.Color(0, 0, 0));
  }
  const names = [...V.errors].map((k) => V.mapping.get(k)).filter(Boolean).map((m) => m.joint);
  $("#v3d-errors").textContent = names.length ? "error: " + names.join(", ") : "";
}

// ------------------------------------------------------------ the shadow twin
function ghost() {
  const g = { joints: new Map(), meshes: new Map() };
  g.world = build(V.doc, g);
  g.world.name = "shadow twin";
  for (const ms of g.meshes.values()) {
    for (const m of ms) {
      m.material.transparent = true;
      m.material.opacity = 0.35;
      m.material.color.lerp(GHOST, 0.6);
      m.material.depthWrite = false;
    }
  }
  if (V.three) V.three.add(g.world);
  V.ghost = g;
  $("#v3d-shadow").textContent = "shadow twin: translucent orange";
  window.drempowerView.shadow = true;
}

function onShadow(m) {
  if (!V.ghost) ghost();
  for (const j of V.doc.joints) {
    if (m.q[j.joint] !== undefined) pose(j.model_joint, m.q[j.joint], V.ghost);
  }
  V.shadowRes = m.res;
  V.drawn = false;
}

// ------------------------------------------------------------ live states
function onMessage(m) {
  if (m.t === "shadow" && V.world) { onShadow(m); return; }
  if (m.t === "divergence") { $("#v3d-shadow").textContent = m.text; return; }
  if (m.t !== "samples" || !V.world) return;
  const last = new Map();
  for (const row of m.s) last.set(row[0], row);
  let errorsChanged = false;
  for (const [key, row] of last) {
    const map = V.mapping.get(key);
    if (!map) continue;
    // a robot joint's samples are at the joint (deg there, gear and offset applied by the server)
    const q = row[2] * Math.PI / 180;
    V.angles[key] = (q - map.offset) * map.gear * 180 / Math.PI; // the motor's angle, as it reads it
    pose(map.model_joint, q);
    const bad = (row[5] & 2) !== 0;
    if (bad !== V.errors.has(key)) { bad ? V.errors.add(key) : V.errors.delete(key); errorsChanged = true; }
  }
  if (errorsChanged) setErrors();
  if (V.push) followPush();
  V.drawn = false;
}

// ------------------------------------------------------------ a push, shown
// while a push lasts (and a second after), its force is drawn as an arrow at the body it pushes and the
// joints' deflection from where they were when it began is written beside the hand (largest first)
function showPush(args) {
  endPush();
  const now = performance.now();
  const P = { args, start: jointAngles(), peak: {}, until: now + (args.duration + 1) * 1000, arrow: null, body: null };
  if (args.kind === "body" && V.world) {
    const f = new THREE.Vector3().fromArray(args.force);
    const n = f.length();
    let body = null;
    V.world.traverse((o) => { if (!body && o.name === args.target && !o.isMesh) body = o; });
    if (body && n > 0) {
      // length grows with the force: 0.1 m, and 0.1 m more per 20 N, up to 0.6 m; drawn where it pulls
      const len = Math.min(0.6, 0.1 + n / 200);
      P.arrow = new THREE.ArrowHelper(f.clone().normalize(), new THREE.Vector3(), len, 0xd62728, 0.25 * len, 0.12 * len);
      P.arrow.name = "push:" + args.target;
      P.arrow.userData.len = len;
      P.body = body;
      V.world.add(P.arrow);
    }
  }
  V.push = P;
  followPush();
  P.timer = setInterval(() => { followPush(); if (performance.now() > P.until) endPush(); }, 100);
}

function followPush() {
  const P = V.push;
  if (!P) return;
  if (P.arrow && P.body) { // the arrow's head on the body, its tail where the force comes from
    V.world.updateMatrixWorld(true);
    const at = V.world.worldToLocal(P.body.getWorldPosition(new THREE.Vector3()));
    const dir = new THREE.Vector3().fromArray(P.args.force).normalize();
    P.arrow.position.copy(at).addScaledVector(dir, -P.arrow.userData.len || 0);
  }
  const now = jointAngles();
  for (const [name, a] of Object.entries(now)) {
    const d = a - (P.start[name] ?? a);
    if (Math.abs(d) > Math.abs(P.peak[name] ?? 0)) P.peak[name] = d;
  }
  const moved = Object.entries(P.peak).filter(([, d]) => Math.abs(d) >= 0.05).sort((a, b) => Math.abs(b[1]) - Math.abs(a[1]));
  const what = P.args.kind === "body" ? `force (${P.args.force.join(", ")}) N on ${P.args.target}` : `torque ${P.args.torque} Nm on ${P.args.target}`;
  $("#hand-deflection").textContent = `${what}: ` + (moved.length
    ? "deflection " + moved.map(([n, d]) => `${n} ${d > 0 ? "+" : ""}${d.toFixed(1)} deg`).join(", ")
    : "no joint deflected yet");
  window.drempowerView.push = { arrow: !!P.arrow, force: P.args.force || null, deflection: { ...P.peak } };
  V.drawn = false;
}

function endPush() {
  const P = V.push;
  if (!P) return;
  clearInterval(P.timer);
  if (P.arrow) { V.world.remove(P.arrow); P.arrow.dispose && P.arrow.dispose(); }
  V.push = null;
  if (window.drempowerView.push) window.drempowerView.push.arrow = false;
  V.drawn = false;
}

// ------------------------------------------------------------ rendering
function visible() {
  const sec = $("#view-view3d");
  return !sec.hidden || sec.classList.contains("pinned");
}

function startRenderer() {
  const box = $("#v3d-canvas");
  try {
    V.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  } catch (e) {
    $("#v3d-note").textContent = "this browser cannot draw WebGL: the model is posed but not shown";
    return;
  }
  V.renderer.setPixelRatio(window.devicePixelRatio || 1);
  box.appendChild(V.renderer.domElement);
  V.three = new THREE.Scene();
  V.three.background = new THREE.Color(0xf4f6f8);
  V.three.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(2, -3, 5);
  V.three.add(sun);
  V.three.add(V.world);
  if (V.ghost) V.three.add(V.ghost.world);
  // frame the robot (planes left out: a floor would dwarf it)
  const bbox = new THREE.Box3();
  V.world.updateMatrixWorld(true);
  V.world.traverse((o) => { if (o.isMesh && o.geometry.type !== "PlaneGeometry") bbox.expandByObject(o); });
  const size = bbox.isEmpty() ? 1 : bbox.getSize(new THREE.Vector3()).length();
  const centre = bbox.isEmpty() ? new THREE.Vector3() : bbox.getCenter(new THREE.Vector3());
  const grid = new THREE.GridHelper(Math.max(1, Math.ceil(size * 2)), 20, 0x999999, 0xdddddd);
  grid.rotateX(Math.PI / 2); // three's grid lies in x-z; the model's floor is x-y (z up)
  V.three.add(grid);
  V.camera = new THREE.PerspectiveCamera(40, 1, size / 100, size * 50);
  V.camera.up.set(0, 0, 1);
  V.camera.position.copy(centre).add(new THREE.Vector3(0.85 * size, -1.15 * size, 0.65 * size));
  V.controls = new THREE.OrbitControls(V.camera, V.renderer.domElement);
  V.controls.target.copy(centre);
  V.controls.addEventListener("change", () => { V.drawn = false; });
  V.controls.update();
  new ResizeObserver(() => resize()).observe(box);
  resize();
  const frame = () => {
    if (visible() && !V.drawn) { V.renderer.render(V.three, V.camera); V.drawn = true; }
    requestAnimationFrame(frame);
  };
  requestAnimationFrame(frame);
}

function resize() {
  const box = $("#v3d-canvas");
  const w = box.clientWidth, h = box.clientHeight;
  if (!w || !h || !V.renderer) return;
  V.renderer.setSize(w, h);
  V.camera.aspect = w / h;
  V.camera.updateProjectionMatrix();
  V.drawn = false;
}

// ------------------------------------------------------------ the hand from outside
function number(id, lo, hi, unit, openLow) {
  const el = $("#" + id), v = Number(el.value);
  const name = fieldName(el);
  if (el.value.trim() === "" || !Number.isFinite(v)) throw new Error(`${name}: ${JSON.stringify(el.value)} is not a number`);
  if (v > hi || v < lo || (openLow && v === lo)) throw new Error(`${name}: ${v} is outside ${openLow ? "above " : ""}${lo}..${hi} ${unit}`);
  return v;
}

// a field as the page labels it ("force N z"), not by its element id
function fieldName(el) {
  if (el.getAttribute("aria-label")) return el.getAttribute("aria-label");
  const words = { "hand-fx": "force N x", "hand-fy": "force N y", "hand-fz": "force N z",
    "hand-torque": "torque Nm", "hand-duration": "duration s" };
  return words[el.id] || el.id;
}

function handKind() {
  const kind = $("#hand-kind").value;
  const sc = V.doc.scene;
  const names = kind === "body" ? sc.bodies.slice(1).map((b) => b.name) : V.doc.joints.map((j) => j.joint);
  $("#hand-target").replaceChildren(...names.map((n) => new Option(n, n)));
  if (kind === "body") { // the default body is one that moves: the last body a joint turns (not the fixed base)
    const moving = sc.joints.map((j) => sc.bodies[j.body] && sc.bodies[j.body].name).filter(Boolean);
    if (moving.length) $("#hand-target").value = moving[moving.length - 1];
  }
  for (const e of document.querySelectorAll(".hand-body")) e.hidden = kind !== "body";
  for (const e of document.querySelectorAll(".hand-joint")) e.hidden = kind !== "joint";
}

async function push() {
  const L = V.doc.limits;
  const kind = $("#hand-kind").value;
  const args = { kind, target: $("#hand-target").value, duration: number("hand-duration", 0, L.duration, "s", true) };
  if (kind === "body") args.force = ["hand-fx", "hand-fy", "hand-fz"].map((id) => number(id, -L.force, L.force, "N"));
  else args.torque = number("hand-torque", -L.torque, L.torque, "Nm");
  const done = await window.dashCall("push", args);
  say(done, true);
  showPush(args);
}

function setupHand(doc) {
  const ok = doc.twin && !doc.read_only;
  for (const e of document.querySelectorAll("#hand input, #hand select, #hand button")) e.disabled = !ok;
  $("#hand-note").textContent = doc.read_only ? "read-only dashboard" : doc.twin ? "" : doc.hand;
  if (!doc.scene) return;
  handKind();
  $("#hand-kind").addEventListener("change", handKind);
  $("#hand-go").addEventListener("click", () => {
    push().catch((e) => say(String(e.message || e)));
  });
}

// ------------------------------------------------------------ start
async function start() {
  window.drempowerView = {
    ready: false, error: null, twin: false, shadow: false,
    jointAngles: () => jointAngles(), shadowAngles: () => (V.ghost ? jointAngles(V.ghost) : null), highlighted, joints: () => [...V.joints.keys()], motorAngles: () => ({ ...V.angles }),
  };
  $("#v3d-pin").addEventListener("change", (e) => {
    $("#view-view3d").classList.toggle("pinned", e.target.checked);
    document.body.classList.toggle("v3d-pinned", e.target.checked);
    resize();
  });
  let doc;
  try {
    const r = await fetch("/model" + location.search);
    if (!r.ok) throw new Error(`GET /model: ${r.status}`);
    doc = await r.json();
  } catch (e) {
    $("#v3d-note").textContent = String(e.message || e);
    window.drempowerView.error = String(e.message || e);
    return;
  }
  V.doc = doc;
  window.drempowerView.twin = doc.twin;
  setupHand(doc);
  if (!doc.scene) {
    $("#v3d-note").textContent = doc.error;
    window.drempowerView.error = doc.error;
    return;
  }
  for (const j of doc.joints) V.mapping.set(j.key, j);
  V.world = build(doc);
  window.drempowerView.world = V.world;
  const missing = doc.joints.filter((j) => !V.joints.has(j.model_joint)).map((j) => `${j.joint} (model joint ${j.model_joint})`);
  $("#v3d-note").textContent = `${doc.scene.file} (${doc.scene.engine}): ${V.joints.size} joint(s)` +
    (missing.length ? `; not in the model: ${missing.join(", ")}` : "");
  (window.dashListeners = window.dashListeners || []).push(onMessage);
  const waiting = $("#v3d-waiting");
  const hint = setInterval(() => {
    const some = Object.keys(V.angles).length > 0;
    waiting.textContent = some ? "" : "no joint states yet: scan the bus (Bus view) to start reading the motors";
    if (some) clearInterval(hint);
  }, 2000);
  startRenderer();
  window.drempowerView.ready = true;
}

start();
