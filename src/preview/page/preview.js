// shatter preview: polls /api/state, fetches each new frame of the current run as a binary
// message (see src/preview/run_folder.rs), draws its particles with WebGL2, and sends edits.
'use strict';

const preview = {
  mode: 'preview', // whose frames are shown: 'preview' (the live run) or 'review' (review.js)
  generation: 0, // the run whose frames are held ('review' for the scene's output folder)
  frames: [], // its frames: see decode()
  leadIn: 0, // the run's lead-in frames, as the frames held were fetched
  handoff: null, // its simulation's last frame before the follow-through's, once known
  framesDrawn: 0, // draws since the page loaded (tests watch it)
  shown: 0, // the frame number drawn last
  errors: [], // uncaught errors and console.error calls (tests check there are none)
  state: null, // the last /api/state
  editError: '', // why the last edit was refused
  fetching: false,
};
window.shatterPreview = preview;
window.addEventListener('error', (event) => preview.errors.push(String(event.message)));
const consoleError = console.error.bind(console);
console.error = (...args) => { preview.errors.push(args.map(String).join(' ')); consoleError(...args); };

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const gl = canvas.getContext('webgl2', { preserveDrawingBuffer: true, antialias: true });

// ---- drawing --------------------------------------------------------------------------------

const VERTEX = `#version 300 es
in vec3 position;
in float value;
uniform mat4 viewProjection;
uniform float pointScale;
uniform float valueScale;
out float shade;
void main() {
  gl_Position = viewProjection * vec4(position, 1.0);
  gl_PointSize = clamp(pointScale / gl_Position.w, 1.0, 24.0);
  shade = valueScale > 0.0 ? clamp(value * valueScale, 0.0, 1.0) : value;
}`;
const FRAGMENT = `#version 300 es
precision mediump float;
in float shade;
uniform int mode;
out vec4 colour;
// a fragment's colour: its id's hue by the golden ratio, so that neighbouring ids differ
vec3 fragmentColour(float id) {
  float hue = fract(id * 0.618034 + 0.08);
  vec3 k = clamp(abs(mod(hue * 6.0 + vec3(0.0, 4.0, 2.0), 6.0) - 3.0) - 1.0, 0.0, 1.0);
  return mix(vec3(0.9), k, id == 0.0 ? 0.15 : 0.7);
}
void main() {
  vec2 p = gl_PointCoord * 2.0 - 1.0;
  if (dot(p, p) > 1.0) discard;
  vec3 low = mode == 0 ? vec3(0.82, 0.84, 0.86) : vec3(0.15, 0.3, 0.85);
  vec3 high = mode == 0 ? vec3(0.9, 0.15, 0.1) : vec3(1.0, 0.85, 0.2);
  vec3 base = mode == 2 ? fragmentColour(shade) : mix(low, high, shade);
  colour = vec4(base * (0.75 + 0.25 * (1.0 - dot(p, p))), 1.0);
}`;

function compile(type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
  return shader;
}

const program = gl.createProgram();
gl.attachShader(program, compile(gl.VERTEX_SHADER, VERTEX));
gl.attachShader(program, compile(gl.FRAGMENT_SHADER, FRAGMENT));
gl.linkProgram(program);
if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
const uniform = (name) => gl.getUniformLocation(program, name);
const positionBuffer = gl.createBuffer();
const valueBuffer = gl.createBuffer();
const vao = gl.createVertexArray();
gl.bindVertexArray(vao);
for (const [buffer, name, size] of [[positionBuffer, 'position', 3], [valueBuffer, 'value', 1]]) {
  const location = gl.getAttribLocation(program, name);
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.enableVertexAttribArray(location);
  gl.vertexAttribPointer(location, size, gl.FLOAT, false, 0, 0);
}

// lines: the floor, the projectiles and indenters, the render camera's frustum
const LINE_VERTEX = `#version 300 es
in vec3 position;
uniform mat4 viewProjection;
void main() { gl_Position = viewProjection * vec4(position, 1.0); gl_PointSize = 3.0; }`;
const LINE_FRAGMENT = `#version 300 es
precision mediump float;
uniform vec3 tint;
out vec4 colour;
void main() { colour = vec4(tint, 1.0); }`;
const lineProgram = gl.createProgram();
gl.attachShader(lineProgram, compile(gl.VERTEX_SHADER, LINE_VERTEX));
gl.attachShader(lineProgram, compile(gl.FRAGMENT_SHADER, LINE_FRAGMENT));
gl.linkProgram(lineProgram);
if (!gl.getProgramParameter(lineProgram, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(lineProgram));
const lineBuffer = gl.createBuffer();
const lineVao = gl.createVertexArray();
gl.bindVertexArray(lineVao);
gl.bindBuffer(gl.ARRAY_BUFFER, lineBuffer);
gl.enableVertexAttribArray(gl.getAttribLocation(lineProgram, 'position'));
gl.vertexAttribPointer(gl.getAttribLocation(lineProgram, 'position'), 3, gl.FLOAT, false, 0, 0);

// line segments (pairs of points) of the floor's grid under the body, at `time` seconds
function floorLines(height, size) {
  const lines = [];
  const [cx, , cz] = camera.target;
  for (let k = -10; k <= 10; k++) {
    const along = (k / 10) * size;
    lines.push([cx + along, height, cz - size], [cx + along, height, cz + size]);
    lines.push([cx - size, height, cz + along], [cx + size, height, cz + along]);
  }
  return lines;
}

// three great circles of each sphere where it is at `time`
function sphereLines(spheres, time) {
  const lines = [];
  for (const sphere of spheres) {
    const c = sphere.center_m.map((v, a) => v + sphere.velocity_m_s[a] * time);
    for (const [u, v] of [[0, 1], [1, 2], [2, 0]]) {
      for (let k = 0; k < 24; k++) {
        const point = (angle) => {
          const p = c.slice();
          p[u] += sphere.radius_m * Math.cos(angle);
          p[v] += sphere.radius_m * Math.sin(angle);
          return p;
        };
        lines.push(point((k / 24) * 2 * Math.PI), point(((k + 1) / 24) * 2 * Math.PI));
      }
    }
  }
  return lines;
}

// the render camera's frustum, out to the point it looks at
function frustumLines(view) {
  const eye = view.position_m;
  const ahead = view.look_at_m.map((v, a) => v - eye[a]);
  const distance = Math.hypot(...ahead);
  const f = normalise(ahead);
  const right = normalise(cross(f, view.up));
  const up = cross(right, f);
  const h = distance * Math.tan((view.fov_deg * Math.PI) / 360);
  const w = h * view.aspect;
  const corner = (sx, sy) => eye.map((e, a) => e + distance * f[a] + sx * w * right[a] + sy * h * up[a]);
  const corners = [corner(-1, -1), corner(1, -1), corner(1, 1), corner(-1, 1)];
  const lines = [];
  corners.forEach((c, k) => lines.push([eye, c], [c, corners[(k + 1) % 4]]));
  return lines.flat();
}

function cross(u, v) {
  return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
}

// `points` (an array of [x, y, z], or a Float32Array of x, y, z) in one colour, as line segments
// or as points
function drawLines(points, tint, matrix, kind = gl.LINES) {
  const flat = points instanceof Float32Array ? points : new Float32Array(points.flat());
  if (flat.length === 0) return;
  gl.useProgram(lineProgram);
  gl.bindVertexArray(lineVao);
  gl.bindBuffer(gl.ARRAY_BUFFER, lineBuffer);
  gl.bufferData(gl.ARRAY_BUFFER, flat, gl.DYNAMIC_DRAW);
  gl.uniformMatrix4fv(gl.getUniformLocation(lineProgram, 'viewProjection'), false, matrix);
  gl.uniform3fv(gl.getUniformLocation(lineProgram, 'tint'), tint);
  gl.drawArrays(kind, 0, flat.length / 3);
}

function drawBodies(frame, matrix) {
  const bodies = preview.state && preview.state.bodies;
  if (!bodies) return;
  if (bodies.floor_height_m !== null) drawLines(floorLines(bodies.floor_height_m, camera.distance), [0.4, 0.42, 0.45], matrix);
  // the projectiles and indenters start with the simulation
  drawLines(sphereLines(bodies.spheres, Math.max(0, frame.time)), [0.95, 0.6, 0.2], matrix);
  if (bodies.camera) drawLines(frustumLines(bodies.camera), [0.3, 0.75, 0.85], matrix);
}

// the orbit camera: yaw and pitch about a target, at a distance
const camera = { target: [0, 0, 0], distance: 1, yaw: 0.6, pitch: 0.35, framed: false };

function frameCamera(frame) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < frame.count; i++) {
    for (let a = 0; a < 3; a++) {
      const v = frame.positions[3 * i + a];
      lo[a] = Math.min(lo[a], v);
      hi[a] = Math.max(hi[a], v);
    }
  }
  camera.target = lo.map((v, a) => (v + hi[a]) / 2);
  camera.distance = 1.8 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) + 1e-6;
  camera.framed = true;
}

function viewProjection() {
  const [cy, sy, cp, sp] = [Math.cos(camera.yaw), Math.sin(camera.yaw), Math.cos(camera.pitch), Math.sin(camera.pitch)];
  const back = [sy * cp, sp, cy * cp];
  const eye = camera.target.map((t, a) => t + camera.distance * back[a]);
  const f = back.map((v) => -v);
  const right = normalise([f[1] * 0 - f[2] * 1, f[2] * 0 - f[0] * 0, f[0] * 1 - f[1] * 0]);
  const up = [right[1] * f[2] - right[2] * f[1], right[2] * f[0] - right[0] * f[2], right[0] * f[1] - right[1] * f[0]];
  const dot = (u, v) => u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  const view = [
    right[0], up[0], -f[0], 0, right[1], up[1], -f[1], 0, right[2], up[2], -f[2], 0,
    -dot(right, eye), -dot(up, eye), dot(f, eye), 1,
  ];
  const near = camera.distance / 100;
  const far = camera.distance * 100;
  const s = 1 / Math.tan((40 * Math.PI) / 360);
  const aspect = canvas.width / canvas.height;
  const projection = [s / aspect, 0, 0, 0, 0, s, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0, (2 * far * near) / (near - far), 0];
  return multiply(projection, view);
}

function normalise(v) {
  const length = Math.hypot(v[0], v[1], v[2]) || 1;
  return v.map((c) => c / length);
}

function multiply(a, b) {
  const out = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) out[4 * c + r] += a[4 * k + r] * b[4 * c + k];
  return out;
}

function shownFrame() {
  const index = Number($('frame').value) - 1;
  return preview.frames[Math.min(index, preview.frames.length - 1)];
}

let uploaded = null; // the frame and values in the GPU's buffers

function draw() {
  gl.viewport(0, 0, canvas.width, canvas.height);
  gl.clearColor(0.17, 0.18, 0.19, 1);
  gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  const frame = shownFrame();
  if (frame) {
    // framed on the run's first frame (the rest state), whichever frame is shown first
    if (!camera.framed) frameCamera(preview.frames[0]);
    const mode = { damage: 0, speed: 1, fragment: 2 }[$('colour').value];
    const values = [frame.damage, frame.speed, frame.fragmentValues][mode];
    const maxSpeed = Math.max(1e-6, ...preview.frames.map((f) => f.maxSpeed));
    gl.enable(gl.DEPTH_TEST);
    // the particles go to the GPU when the frame or the colouring changes, not at every draw
    if (!uploaded || uploaded.frame !== frame || uploaded.values !== values) {
      gl.bindBuffer(gl.ARRAY_BUFFER, positionBuffer);
      gl.bufferData(gl.ARRAY_BUFFER, frame.positions, gl.DYNAMIC_DRAW);
      gl.bindBuffer(gl.ARRAY_BUFFER, valueBuffer);
      gl.bufferData(gl.ARRAY_BUFFER, values, gl.DYNAMIC_DRAW);
      uploaded = { frame, values };
    }
    const matrix = viewProjection();
    drawBodies(frame, matrix);
    gl.useProgram(program);
    gl.bindVertexArray(vao);
    gl.uniformMatrix4fv(uniform('viewProjection'), false, matrix);
    gl.uniform1f(uniform('pointScale'), (canvas.height * 1.2 * camera.distance) / Math.cbrt(frame.count) / 3);
    gl.uniform1f(uniform('valueScale'), [2.5, 1 / maxSpeed, 0][mode]);
    gl.uniform1i(uniform('mode'), mode);
    gl.drawArrays(gl.POINTS, 0, frame.count);
    // where particles lost bonds during the frame (post's debris points), over the particles
    if ($('debris').checked) drawLines(frame.debris, [1.0, 0.95, 0.6], matrix, gl.POINTS);
    $('frame-label').textContent = `${frame.frame}: ${SOURCES[frame.source]}, ${seconds(frame.time)}`;
    if (preview.shown !== frame.frame) showFragments(frame);
    preview.shown = frame.frame;
  }
  preview.framesDrawn += frame ? 1 : 0;
}

// ---- orbit, pan, zoom -----------------------------------------------------------------------

let drag = null;
canvas.addEventListener('pointerdown', (event) => {
  drag = { x: event.clientX, y: event.clientY, pan: event.shiftKey || event.button === 2, moved: 0 };
  canvas.setPointerCapture(event.pointerId);
});
canvas.addEventListener('pointerup', (event) => {
  // a click, not a drag, on the body aims the projectile there
  if (drag && !drag.pan && drag.moved < 4 && event.button === 0 && preview.mode === 'preview') aimAt(event);
  drag = null;
});
canvas.addEventListener('contextmenu', (event) => event.preventDefault());
canvas.addEventListener('pointermove', (event) => {
  if (!drag) return;
  const [dx, dy] = [event.clientX - drag.x, event.clientY - drag.y];
  drag.moved += Math.abs(dx) + Math.abs(dy);
  drag.x = event.clientX;
  drag.y = event.clientY;
  if (drag.pan) {
    const step = camera.distance / canvas.height;
    const right = [Math.cos(camera.yaw), 0, -Math.sin(camera.yaw)];
    camera.target = camera.target.map((t, a) => t - dx * step * right[a]);
    camera.target[1] += dy * step;
  } else {
    camera.yaw -= dx * 0.01;
    camera.pitch = Math.max(-1.5, Math.min(1.5, camera.pitch + dy * 0.01));
  }
});
canvas.addEventListener('wheel', (event) => {
  event.preventDefault();
  camera.distance *= Math.exp(event.deltaY * 0.001);
}, { passive: false });

// ---- the run: state and frames --------------------------------------------------------------

const SOURCES = ['lead-in', 'simulation', 'follow-through'];

// a frame message (src/preview/frame_message.rs)
function decode(buffer) {
  const view = new DataView(buffer);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== 'SHPV' || view.getUint32(4, true) !== 2) throw new Error('not a frame message');
  const count = view.getUint32(12, true);
  const bins = view.getUint32(32, true);
  const histogram = Array.from(new Uint32Array(buffer, 36, bins));
  const start = 36 + 4 * bins;
  const floats = new Float32Array(buffer, start, 5 * count);
  const fragment = new Uint32Array(buffer, start + 20 * count, count);
  const debrisCount = view.getUint32(start + 24 * count, true);
  const debris = new Float32Array(buffer, start + 24 * count + 4, 3 * debrisCount);
  const speed = floats.subarray(4 * count, 5 * count);
  return {
    frame: view.getUint32(8, true),
    time: view.getFloat32(16, true),
    source: view.getUint32(20, true),
    fragments: view.getUint32(24, true),
    largestShare: view.getFloat32(28, true),
    histogram,
    count,
    positions: floats.subarray(0, 3 * count),
    damage: floats.subarray(3 * count, 4 * count),
    speed,
    fragment,
    fragmentValues: Float32Array.from(fragment),
    debris,
    maxSpeed: speed.reduce((m, v) => Math.max(m, v), 0),
  };
}

function seconds(time) {
  const size = Math.abs(time);
  if (size === 0 || size >= 1) return `${time.toFixed(2)} s`;
  return size >= 1e-3 ? `${(time * 1e3).toFixed(2)} ms` : `${(time * 1e6).toFixed(1)} µs`;
}

// the shown frame's fragments: count, largest piece's share, and their sizes' histogram
function showFragments(frame) {
  $('fragments').textContent = frame.fragments.toLocaleString();
  $('largest').textContent = `${(frame.largestShare * 100).toFixed(1)}%`;
  const most = Math.max(1, ...frame.histogram);
  const rows = frame.histogram.map((count, bin) => {
    const low = 2 ** bin;
    const label = bin === 0 ? '1' : bin < 10 ? `${low}–${2 * low - 1}` : `${low / 1024}k–${low / 512}k`;
    const width = count ? Math.max(2, (100 * count) / most) : 0;
    return `<div class="bin"><span>${label}</span><i style="width:${width}%"></i><b>${count}</b></div>`;
  });
  $('histogram').innerHTML = rows.join('');
  $('histogram').dataset.counts = frame.histogram.join(',');
}

async function fetchFrames(run) {
  if (preview.fetching) return;
  preview.fetching = true;
  try {
    while (preview.generation === run.generation && preview.frames.length < run.frames) {
      const next = preview.frames.length + 1;
      const url = run.generation === 'review'
        ? `/api/review/frame?frame=${next}`
        : `/api/frame?generation=${run.generation}&frame=${next}`;
      const response = await fetch(url, { cache: 'no-store' });
      if (!response.ok) break;
      const frame = decode(await response.arrayBuffer());
      // a simulation frame asked for before the handoff was known, and now past it, is dropped
      const stale = frame.source === 1 && preview.handoff !== null && frame.frame > preview.leadIn + preview.handoff;
      if (preview.generation === run.generation && frame.frame === preview.frames.length + 1 && !stale) {
        preview.frames.push(frame);
        followFrames();
      }
    }
  } finally {
    preview.fetching = false;
  }
}

function figure(name, value) {
  return `<dt>${name}</dt><dd>${value}</dd>`;
}

function showState(state) {
  $('scene').textContent = state.scene;
  const run = state.run;
  const rows = preview.mode === 'review' ? reviewFigures() : [];
  if (run && preview.mode === 'preview') {
    const broken = run.broken_bonds.length ? run.broken_bonds[run.broken_bonds.length - 1] : 0;
    const frame = shownFrame();
    rows.push(figure('run', `${run.generation} (${run.status})`));
    rows.push(figure('particles', frame ? frame.count.toLocaleString() : '…'));
    rows.push(figure('spacing', `${(run.spacing_m * 1000).toFixed(2)} mm`));
    rows.push(figure('frames', run.frames));
    rows.push(figure('broken bonds', `<span id="broken">${broken}</span>`));
    rows.push(figure('seconds', run.seconds.toFixed(1)));
    if (run.first_break_s !== null) rows.push(figure('first broken bond', `${run.first_break_s.toFixed(2)} s`));
  }
  $('figures').innerHTML = rows.join('');
  $('error').textContent = preview.editError || state.error || (run && run.failure) || '';
  followFrames();
}

// the slider spans the frames held, and stays on the newest while "follow" is checked
function followFrames() {
  const slider = $('frame');
  slider.max = Math.max(1, preview.frames.length);
  if ($('follow').checked) slider.value = slider.max;
}

function buildFields(state) {
  const fields = $('fields');
  if (fields.dataset.built === '1') return;
  fields.innerHTML = '';
  for (const [key, value] of Object.entries(state.values)) {
    const label = document.createElement('label');
    label.textContent = key;
    const input = document.createElement('input');
    input.type = 'text';
    input.name = key;
    input.value = JSON.stringify(value);
    input.dataset.original = input.value;
    label.appendChild(input);
    fields.appendChild(label);
  }
  $('particles').value = state.target_particles;
  fields.dataset.built = '1';
}

async function poll() {
  try {
    const response = await fetch('/api/state', { cache: 'no-store' });
    const state = await response.json();
    preview.state = state;
    $('review').hidden = !state.review;
    // the scene's output folder's frames in review mode (review.js), else the live run's
    const run = preview.mode === 'review' ? await reviewRun() : state.run;
    if (run && (run.generation !== preview.generation || run.lead_in_frames !== preview.leadIn)) {
      preview.generation = run.generation;
      preview.leadIn = run.lead_in_frames;
      preview.handoff = null;
      preview.frames = [];
    }
    if (run && run.handoff !== preview.handoff) {
      // the follow-through has begun: the simulation's frames past the handoff leave the list
      preview.frames.length = Math.min(preview.frames.length, run.lead_in_frames + run.handoff);
      preview.handoff = run.handoff;
      uploaded = null;
    }
    buildFields(state);
    showState(state);
    if (run) fetchFrames(run);
  } catch (error) {
    // the server is away (restarting, or the connection dropped): the next poll resumes
  }
  setTimeout(poll, 250);
}

$('edits').addEventListener('submit', (event) => {
  event.preventDefault();
  applyEdits();
});

// sends the fields that differ from the run's, and `extra` edits; a refused edit shows the CLI's
// message
async function applyEdits(extra = {}) {
  const edits = { ...extra };
  try {
    for (const input of $('fields').querySelectorAll('input')) {
      if (input.value !== input.dataset.original) edits[input.name] = JSON.parse(input.value);
    }
  } catch (error) {
    preview.editError = `not a value: ${error.message}`;
    $('error').textContent = preview.editError;
    return;
  }
  const body = JSON.stringify({ edits, particles: Number($('particles').value) });
  const response = await fetch('/api/edit', { method: 'POST', body });
  const answer = await response.json();
  preview.editError = response.ok ? '' : answer.error;
  $('error').textContent = preview.editError;
  if (!response.ok) return;
  for (const input of $('fields').querySelectorAll('input')) input.dataset.original = input.value;
}

// "Save": the diff first, then the write
$('save').addEventListener('click', async () => {
  const answer = await (await fetch('/api/diff', { cache: 'no-store' })).json();
  $('diff').textContent = answer.error || answer.diff || '(no change)';
  $('saving').hidden = false;
  $('saved').textContent = '';
});
$('cancel').addEventListener('click', () => { $('saving').hidden = true; });
$('write').addEventListener('click', async () => {
  const answer = await (await fetch('/api/save', { method: 'POST' })).json();
  $('saving').hidden = true;
  $('saved').textContent = answer.error || `saved ${answer.saved}`;
});

// the colouring may be named in the address (`?colour=fragment`)
const colourAsked = new URLSearchParams(location.search).get('colour');
if ([...$('colour').options].some((option) => option.value === colourAsked)) $('colour').value = colourAsked;

function loop() {
  draw();
  requestAnimationFrame(loop);
}
poll();
loop();
