// shatter preview, aiming: a click on the body (not a drag) moves the impact point, the first
// projectile's start or, in a drop without one, the body's turn at its release. Uses
// preview.js's drawing state (its camera and frames).
'use strict';

// particle `i` of the shown frame in the canvas's CSS pixels, and its depth (tests click there),
// through the view's matrix `m`
function project(i, m = viewProjection()) {
  const frame = shownFrame();
  const p = [0, 1, 2].map((a) => frame.positions[3 * i + a]);
  const clip = [0, 1, 2, 3].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
  const rect = canvas.getBoundingClientRect();
  return {
    x: rect.left + ((clip[0] / clip[3] + 1) / 2) * rect.width,
    y: rect.top + ((1 - clip[1] / clip[3]) / 2) * rect.height,
    depth: clip[2] / clip[3],
    visible: clip[3] > 0,
  };
}
preview.project = project;

// the particle under the pointer: the nearest to the eye of those within a few pixels
function pickParticle(event) {
  const frame = shownFrame();
  if (!frame) return -1;
  let best = -1;
  let bestDepth = Infinity;
  const matrix = viewProjection();
  for (let i = 0; i < frame.count; i++) {
    const at = project(i, matrix);
    if (at.visible && Math.hypot(at.x - event.clientX, at.y - event.clientY) <= 6 && at.depth < bestDepth) {
      best = i;
      bestDepth = at.depth;
    }
  }
  return best;
}

// a click on the body: the projectile meets it there, or, in a drop without one, it lands there
function aimAt(event) {
  const particle = pickParticle(event);
  const values = preview.state && preview.state.values;
  if (particle < 0 || !values) return;
  if (values['sim.projectile[0].center_m']) aimProjectile(particle);
  else if (preview.leadIn > 0) aimDrop(particle);
  else $('aim').textContent = 'the scene has no projectile to aim and no drop';
}

// turns the dropped body at its release so that the picked particle faces the floor straight
// down from the particles' centroid: the lead-in's start rotation becomes that turn after the one
// it had (the body still spins as the scene says, so it lands near there, not exactly there)
function aimDrop(particle) {
  const release = preview.frames[0];
  const values = preview.state.values;
  const at = (i) => [0, 1, 2].map((a) => release.positions[3 * i + a]);
  const centre = [0, 1, 2].map((a) => {
    let sum = 0;
    for (let i = 0; i < release.count; i++) sum += release.positions[3 * i + a];
    return sum / release.count;
  });
  const d = normalise(at(particle).map((v, a) => v - centre[a]));
  const turn = quaternionBetween(d, [0, -1, 0]);
  const axis = values['lead_in.rotate_axis'] || [0, 1, 0];
  const before = quaternionAbout(normalise(axis), ((values['lead_in.rotate_deg'] || 0) * Math.PI) / 180);
  const [newAxis, angle] = axisAngle(multiplyQuaternions(turn, before));
  const round = (v) => Number(v.toPrecision(6));
  $('aim').textContent = `the drop lands on particle ${particle}`;
  applyEdits({ 'lead_in.rotate_axis': newAxis.map(round), 'lead_in.rotate_deg': round((angle * 180) / Math.PI) });
}

// quaternions as [x, y, z, w]
function quaternionAbout(axis, angle) {
  const s = Math.sin(angle / 2);
  return [axis[0] * s, axis[1] * s, axis[2] * s, Math.cos(angle / 2)];
}
function quaternionBetween(from, to) {
  const c = cross(from, to);
  const dot = from[0] * to[0] + from[1] * to[1] + from[2] * to[2];
  if (dot < -0.999999) return quaternionAbout(normalise(Math.abs(from[0]) < 0.9 ? cross(from, [1, 0, 0]) : cross(from, [0, 0, 1])), Math.PI);
  const q = [c[0], c[1], c[2], 1 + dot];
  const length = Math.hypot(...q);
  return q.map((v) => v / length);
}
function multiplyQuaternions(a, b) {
  return [
    a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
    a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
    a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
    a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
  ];
}
function axisAngle(q) {
  const w = Math.max(-1, Math.min(1, q[3]));
  const s = Math.sqrt(1 - w * w);
  return s < 1e-9 ? [[0, 1, 0], 0] : [[q[0] / s, q[1] / s, q[2] / s], 2 * Math.acos(w)];
}

// moves the first projectile so that it meets the body at the picked particle: along its own
// direction, as far from that point as it was from the point it met before
function aimProjectile(particle) {
  const rest = preview.frames[preview.leadIn];
  const values = preview.state.values;
  const key = 'sim.projectile[0].center_m';
  if (!rest) return;
  const input = $('fields').querySelector(`input[name="${key}"]`);
  const centre = JSON.parse(input.value);
  const direction = normalise(JSON.parse($('fields').querySelector('input[name="sim.projectile[0].velocity_m_s"]').value));
  const at = (i) => [0, 1, 2].map((a) => rest.positions[3 * i + a]);
  // the point it met: of the particles nearest its line ahead of it (within half a spacing),
  // the first along it
  const line = [];
  for (let i = 0; i < rest.count; i++) {
    const d = at(i).map((v, a) => v - centre[a]);
    const along = d[0] * direction[0] + d[1] * direction[1] + d[2] * direction[2];
    if (along > 0) line.push([Math.hypot(...d.map((v, a) => v - along * direction[a])), along]);
  }
  const nearest = line.reduce((m, [off]) => Math.min(m, off), Infinity);
  const limit = nearest + preview.state.run.spacing_m / 2;
  const distance = line.reduce((m, [off, along]) => (off <= limit ? Math.min(m, along) : m), Infinity);
  if (!Number.isFinite(distance)) return;
  const target = at(particle);
  input.value = JSON.stringify(target.map((v, a) => Number((v - distance * direction[a]).toPrecision(6))));
  $('aim').textContent = `aimed at particle ${particle}`;
  applyEdits();
}
