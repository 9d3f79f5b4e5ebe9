// The page of `squish serve`: the scene from /api/scene, frames from the WebSocket, every
// control a message to the server (which computes the latest edits only).
import './style.css';
import { Connection } from './connection.js';
import { View3D } from './view3d.js';
import { ParamPanel, levelOf } from './params.js';
import { ProfileEditor } from './profile.js';
import { readouts } from './readouts.js';

const $ = (id) => document.getElementById(id);
const state = { scene: null, frame: null, target: { object: 0 }, key: 'stiffness', frames: 0, playing: null, exported: null };
// For tests and the console: the scene, the latest frame, the profile editor and the view.
window.squish = state;

function showError(message) {
  const banner = $('error');
  banner.hidden = !message;
  banner.textContent = message ? `error: ${message}` : '';
}

const connection = new Connection(receive, (status) => { $('status').textContent = status; });
const send = (message) => connection.send(message);
const view = new View3D($('view'));
const panel = new ParamPanel($('params'), send);
const profile = new ProfileEditor($('profile'), (edits) => {
  if (!('object' in state.target)) return;
  for (const [key, value] of Object.entries(edits)) send({ type: 'set', target: state.target, key, value });
});
state.view = view;
state.send = send;
state.profile = profile;

function receive(message) {
  if (message.type === 'error') {
    showError(message.message);
    return;
  }
  if (message.type === 'exported') {
    state.exported = message.exported;
    const e = message.exported;
    $('exported').textContent = `wrote ${[e.scene, ...e.maps, ...e.meshes].join(', ')}\nrender it: ${e.command}`;
    return;
  }
  if (message.type !== 'frame') return;
  // A frame that arrives before the scene is kept for when the meshes are built.
  if (!state.scene) {
    state.pending = message;
    return;
  }
  showError(null);
  const first = state.frame === null;
  state.frame = message.frame;
  state.frames += 1;
  view.update(message.frame);
  if (first) view.frameContact();
  refresh();
}

// Everything shown from the latest frame.
function refresh() {
  const frame = state.frame;
  if (!frame) return;
  $('scrub').value = String(frame.frame);
  $('frame-label').textContent = `frame ${frame.frame}${frame.edit ? ' (edit)' : ''}`;
  const values = valuesOf(frame, state.target);
  panel.update(values, frame.frame);
  if ('object' in state.target) profile.set(frame.objects[state.target.object]?.profile ?? null);
  $('readouts').innerHTML = readouts(frame);
  drawKeys(values?.[state.key]?.keys ?? []);
}

// The keys of the selected parameter on the timeline.
function drawKeys(keys) {
  const { start, end } = state.scene.frames;
  const holder = $('keys');
  holder.textContent = '';
  for (const k of keys) {
    const mark = document.createElement('span');
    mark.style.left = `${(100 * (k - start)) / Math.max(1, end - start)}%`;
    mark.title = `${state.key}: key at frame ${k}`;
    holder.append(mark);
  }
}

// The values the frame holds for a target's parameters.
function valuesOf(frame, target) {
  if ('object' in target) return frame.values.objects[target.object];
  if ('pair' in target) return frame.values.pairs[target.pair];
  const [i, k] = target.articulation;
  return frame.values.articulations?.[i]?.[k];
}

function selectTarget(target) {
  state.target = target;
  for (const li of $('targets').children) li.classList.toggle('selected', li.dataset.target === JSON.stringify(target));
  const inert = 'object' in target ? state.scene.objects[target.object].inert ?? {} : {};
  panel.build(state.scene.schema, target, inert);
  $('target-name').textContent = li_name(target);
  $('profile-section').hidden = !('object' in target);
  refresh();
}

function li_name(target) {
  if ('object' in target) return state.scene.objects[target.object].name;
  if ('articulation' in target) {
    const [i, k] = target.articulation;
    return `${state.scene.objects[i].name}: ${state.scene.objects[i].articulations[k].name}`;
  }
  const pair = state.scene.pairs[target.pair];
  return `${pair.names[0]} × ${pair.names[1]}`;
}

// The list of objects, their articulations (self-contact) and parts, and the pairs.
function listTargets(scene) {
  const list = $('targets');
  const add = (target, text, className) => {
    const li = document.createElement('li');
    li.dataset.target = JSON.stringify(target);
    li.textContent = text;
    if (className) li.className = className;
    li.onclick = () => selectTarget(target);
    list.append(li);
  };
  scene.objects.forEach((object, i) => {
    add({ object: i }, `object: ${object.name}`);
    object.articulations.forEach((a, k) => {
      add({ articulation: [i, k] }, `${a.automatic ? 'auto' : 'articulation'}: ${a.name}`, 'sub');
    });
    if (object.parts.length) {
      const li = document.createElement('li');
      li.className = 'sub parts';
      li.textContent = `parts: ${object.parts.join(', ')}`;
      li.dataset.testid = 'parts';
      list.append(li);
    }
  });
  scene.pairs.forEach((pair, i) => add({ pair: i }, `pair: ${pair.names.join(' × ')}`));
}

async function start() {
  const response = await fetch('api/scene');
  const scene = await response.json();
  if (scene.type === 'error') {
    showError(scene.message);
    return;
  }
  state.scene = scene;
  $('scene-name').textContent = scene.name;
  view.build(scene);
  listTargets(scene);
  panel.onSelectKey = (key) => { state.key = key; refresh(); };
  const scrub = $('scrub');
  scrub.min = String(scene.frames.start);
  scrub.max = String(scene.frames.end);
  scrub.oninput = () => send({ type: 'frame', frame: Number(scrub.value) });
  selectTarget({ object: 0 });
  if (state.pending) receive(state.pending);
  send({ type: 'refresh' });
}

$('show').onchange = (e) => view.setShow(e.target.value);
$('overlay').onchange = (e) => view.setOverlay(e.target.value);
$('section-on').onchange = () => view.setSection($('section-on').checked, Number($('section').value));
$('section').oninput = () => view.setSection($('section-on').checked, Number($('section').value));
$('frame-contact').onclick = () => view.frameContact();
$('clear-paint').onclick = () => 'object' in state.target && send({ type: 'clear_paint', object: state.target.object });
$('export').onclick = () => send({ type: 'export', name: $('export-name').value });

// Play: the next frame is asked for once the previous one arrived (never a queue of frames).
$('play').onclick = () => {
  if (state.playing) {
    clearInterval(state.playing);
    state.playing = null;
    $('play').textContent = '▶';
    return;
  }
  $('play').textContent = '⏸';
  let asked = null;
  state.playing = setInterval(() => {
    const { start, end } = state.scene.frames;
    if (asked !== null && state.frame?.frame !== asked) return;
    asked = state.frame.frame >= end ? start : state.frame.frame + 1;
    send({ type: 'frame', frame: asked });
  }, 1000 / (state.scene.frames.fps || 24));
};

// Painting: strokes on the selected object's input surface while the brush is on (the local
// brush paints a disc, the radial one along the profiles of u through the picked point).
let painting = false;
let lastStroke = 0;
function stroke(event) {
  if (!('object' in state.target)) return;
  const point = view.pick(event, state.target.object);
  if (!point) return;
  send({
    type: 'paint',
    object: state.target.object,
    stroke: {
      kind: $('brush-kind').value,
      center: [point.x, point.y, point.z],
      radius: Number($('brush-radius').value),
      operation: $('brush-op').value,
      strength: Number($('brush-strength').value),
    },
  });
}
const canvas = view.renderer.domElement;
canvas.addEventListener('pointerdown', (e) => {
  if (!$('paint-on').checked) return;
  painting = true;
  view.controls.enabled = false;
  stroke(e);
});
canvas.addEventListener('pointermove', (e) => {
  if (!painting || performance.now() - lastStroke < 60) return;
  lastStroke = performance.now();
  stroke(e);
});
window.addEventListener('pointerup', () => {
  painting = false;
  view.controls.enabled = true;
});

start().catch((e) => showError(`cannot load the scene: ${e}`));
