// shatter preview, review mode: the scene's own output folder (GET /api/review*, see
// src/preview/review.rs), finished or still being written: its shot's frames through the same
// drawing as the live run's, a plot of the bonds broken and the kinetic energy per simulation
// frame, the rendered frame's passes, and the Cryptomatte pick under the cursor.
'use strict';

preview.review = null; // the last GET /api/review
preview.picked = null; // the last pick: { pieces: [[name, coverage]], materials: [...] }

// the frames' source: the live run, or the scene's output folder
for (const radio of document.querySelectorAll('input[name="source"]')) {
  radio.addEventListener('change', () => {
    preview.mode = radio.value;
    preview.generation = null;
    preview.frames = [];
    preview.handoff = null;
    camera.framed = false;
    uploaded = null;
    $('review-view').hidden = preview.mode !== 'review';
  });
}

// the address may ask for the scene's own frames (`?source=review`)
if (new URLSearchParams(location.search).get('source') === 'review') {
  document.querySelector('input[name="source"][value="review"]').click();
}

// the output folder as a run for the frame fetcher, after fetching its summary
async function reviewRun() {
  const response = await fetch('/api/review', { cache: 'no-store' });
  if (!response.ok) return null;
  const review = await response.json();
  preview.review = review;
  drawPlot();
  showRendered();
  return { generation: 'review', frames: review.frames, lead_in_frames: review.lead_in_frames, handoff: review.handoff };
}

// the figures of the output folder, for the Run list
function reviewFigures() {
  const review = preview.review;
  if (!review) return [];
  const broken = review.broken_bonds.length ? review.broken_bonds[review.broken_bonds.length - 1] : 0;
  return [
    figure('output', review.output_dir),
    figure('frames', review.frames),
    figure('broken bonds', broken.toLocaleString()),
    figure('rendered', `${review.rendered.length} of ${review.frames}`),
  ];
}

// bonds broken per simulation frame (bars) and the kinetic energy (a line), each scaled to its
// largest; the shown frame marked
function drawPlot() {
  const review = preview.review;
  const plot = $('plot');
  const context = plot.getContext('2d');
  context.clearRect(0, 0, plot.width, plot.height);
  const energy = review.kinetic_energy_j;
  const cumulative = [0, ...review.broken_bonds];
  const perFrame = cumulative.map((total, k) => (k === 0 ? 0 : total - cumulative[k - 1]));
  const frames = Math.max(energy.length, perFrame.length);
  if (frames < 2) return;
  const x = (k) => 4 + ((plot.width - 8) * k) / (frames - 1);
  const mostBroken = Math.max(1, ...perFrame);
  context.fillStyle = '#d0584a';
  perFrame.forEach((count, k) => {
    const h = ((plot.height - 16) * count) / mostBroken;
    context.fillRect(x(k) - 1, plot.height - 4 - h, 2, h);
  });
  const mostEnergy = Math.max(Number.MIN_VALUE, ...energy);
  context.strokeStyle = '#6a9fd4';
  context.beginPath();
  energy.forEach((e, k) => {
    const y = plot.height - 4 - ((plot.height - 16) * e) / mostEnergy;
    if (k === 0) context.moveTo(x(k), y); else context.lineTo(x(k), y);
  });
  context.stroke();
  const shown = preview.shown - review.lead_in_frames - 1;
  if (shown >= 0 && shown < frames) {
    context.fillStyle = '#ddd';
    context.fillRect(x(shown), 0, 1, plot.height);
  }
  context.fillStyle = '#aaa';
  context.fillText(`bonds broken a frame (max ${mostBroken.toLocaleString()})`, 6, 10);
  context.fillText(`kinetic energy (max ${mostEnergy.toPrecision(3)} J)`, plot.width / 2 + 6, 10);
}

// the shown frame's pass, when it is rendered
let rendered = null; // the frame and pass the picture shows
function showRendered() {
  const review = preview.review;
  const frame = preview.shown;
  const pass = $('pass').value;
  const there = review && review.rendered.includes(frame);
  $('rendered').hidden = !there;
  $('not-rendered').hidden = there || !review;
  if (!there || (rendered && rendered.frame === frame && rendered.pass === pass)) return;
  rendered = { frame, pass };
  $('rendered').src = `/api/review/image?frame=${frame}&pass=${pass}`;
}
$('pass').addEventListener('change', showRendered);

// a click on the picture names what the Cryptomattes hold under it
$('rendered').addEventListener('click', async (event) => {
  const image = $('rendered');
  const x = Math.floor((event.offsetX * image.naturalWidth) / image.clientWidth);
  const y = Math.floor((event.offsetY * image.naturalHeight) / image.clientHeight);
  const response = await fetch(`/api/review/pick?frame=${rendered.frame}&x=${x}&y=${y}`, { cache: 'no-store' });
  if (!response.ok) return;
  const picked = await response.json();
  preview.picked = picked;
  const named = (list) => list.map(([name, coverage]) => `${name} (${(coverage * 100).toFixed(0)}%)`).join(', ');
  $('picked').textContent = picked.pieces.length || picked.materials.length
    ? `${named(picked.pieces) || 'no piece'} · ${named(picked.materials)}`
    : 'nothing there';
});
