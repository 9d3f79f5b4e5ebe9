// Browser tests of `squish serve` in a real Chromium (Debian's package, driven by Playwright):
// the page on a copy of the press example, its controls driving the server, results read back
// through the API and compared with `squish run` on the exported scene.
//
// Environment: SQUISH (the binary, default ../target/debug/squish), CHROMIUM (default
// /usr/bin/chromium), SQUISH_SCREENSHOTS (a folder: the README's screenshots are written there).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { cpSync, mkdtempSync, readFileSync, readdirSync, rmSync, mkdirSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { openPage, startServer, waitForFrame } from './serve.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '../..');
const squish = process.env.SQUISH ?? join(repo, 'target/debug/squish');
const screenshots = process.env.SQUISH_SCREENSHOTS;
const FRAME = 24;

let folder;
let server;
let url;
let browser;
let page;

const frame = () => page.evaluate(() => window.squish.frame);
const api = async (path, body) => {
  const response = await fetch(new URL(path, url), body ? { method: 'POST', body: JSON.stringify(body) } : {});
  return response.json();
};

// Waits until the page shows a frame for which `check` holds.
const waitFor = (check, what) => waitForFrame(page, check, what);

// Fraction of pixels that differ between two PNG screenshots (decoded by the browser).
async function pixelDifference(a, b) {
  return page.evaluate(async ([a, b]) => {
    const load = async (data) => {
      const image = new Image();
      image.src = `data:image/png;base64,${data}`;
      await image.decode();
      const canvas = document.createElement('canvas');
      canvas.width = image.width;
      canvas.height = image.height;
      const ctx = canvas.getContext('2d');
      ctx.drawImage(image, 0, 0);
      return ctx.getImageData(0, 0, image.width, image.height).data;
    };
    const [x, y] = [await load(a), await load(b)];
    let differ = 0;
    for (let i = 0; i < x.length; i += 4) {
      if (Math.abs(x[i] - y[i]) + Math.abs(x[i + 1] - y[i + 1]) + Math.abs(x[i + 2] - y[i + 2]) > 24) differ++;
    }
    return differ / (x.length / 4);
  }, [a.toString('base64'), b.toString('base64')]);
}

const shot = () => page.locator('#view canvas').screenshot();
const maxDistance = (a, b) => a.reduce((m, x, i) => Math.max(m, Math.abs(x - b[i])), 0);

async function saveScreenshot(name) {
  if (!screenshots) return;
  mkdirSync(screenshots, { recursive: true });
  await page.screenshot({ path: join(screenshots, name) });
}

before(async () => {
  folder = mkdtempSync(join(tmpdir(), 'squish-serve-'));
  cpSync(join(repo, 'examples/press'), folder, { recursive: true });
  ({ server, url } = await startServer(squish, join(folder, 'press.toml')));
  ({ browser, page } = await openPage(url));
});

after(async () => {
  await browser?.close();
  server?.kill('SIGINT');
  if (folder) rmSync(folder, { recursive: true, force: true });
});

test('the page loads the press scene and shows its first frame', async () => {
  const f = await waitFor((f) => f.objects.length === 2, 'the first frame');
  assert.deepEqual(f.objects.map((o) => o.name), ['ball', 'ground']);
  assert.equal(await page.locator('#status').textContent(), 'connected');
  assert.equal(await page.locator('.param[data-key="stiffness"]').count(), 1, 'a control per parameter from the schema');
  assert.ok(await page.locator('#error').isHidden(), await page.locator('#error').textContent());
});

test('the timeline scrubs to the deepest press', async () => {
  await page.locator('#scrub').fill(String(FRAME));
  const f = await waitFor((f) => f.frame === FRAME, `frame ${FRAME}`);
  assert.ok(f.pairs[0].in_contact, 'the ball touches the ground at the deepest press');
  assert.match(await page.locator('#frame-label').textContent(), new RegExp(`frame ${FRAME}`));
  await page.locator('#frame-contact').click();
  await page.locator('#overlay').selectOption('deformable');
  await saveScreenshot('serve-page.png');
  await page.locator('#overlay').selectOption('none');
});

test('the intersecting faces overlay marks the input where the meshes overlap', async () => {
  const f = await waitFor((f) => f.frame === FRAME, `frame ${FRAME}`);
  const count = (flags) => flags.reduce((n, x) => n + x, 0);
  for (const object of f.objects) {
    assert.equal(object.intersecting.input.length, object.input.length / 3, 'a flag per vertex');
    assert.ok(count(object.intersecting.input) > 0, `${object.name}: the input overlaps the other object`);
  }
  // The outputs do not interleave (pair.contact_gap): what overlapped is resolved.
  for (const object of f.objects) {
    assert.ok(
      count(object.intersecting.output) < count(object.intersecting.input),
      `${object.name}: ${count(object.intersecting.output)} intersecting vertices left of ${count(object.intersecting.input)}`,
    );
  }
  // The input ("before") shows its overlaps in red.
  await page.locator('#show').selectOption('before');
  await page.waitForTimeout(300);
  const plain = await shot();
  await page.locator('#overlay').selectOption('intersecting');
  await page.waitForTimeout(300);
  const marked = await shot();
  await page.locator('#overlay').selectOption('none');
  await page.locator('#show').selectOption('after');
  assert.ok((await pixelDifference(plain, marked)) > 0.001, 'the overlay is drawn on the input');
});

test('the stiffness slider changes the mesh', async () => {
  await page.waitForTimeout(300);
  const before = await shot();
  const positions = (await api('api/frame')).frame.objects[0].output;
  await page.locator('.param[data-key="stiffness"] input[type=range]').fill('0.2');
  const f = await waitFor((f) => f.values.objects[0].stiffness.value === 0.2, 'stiffness 0.2');
  assert.equal(f.edit, false, 'stiffness is upstream of §5.4: a full frame');
  const moved = (await api('api/frame')).frame.objects[0].output;
  assert.ok(maxDistance(positions, moved) > 1e-3, 'the ball deforms more when softer');
  await page.waitForTimeout(300);
  const difference = await pixelDifference(before, await shot());
  assert.ok(difference > 0.001, `the picture changes (${difference} of the pixels)`);
});

test('dragging the profile control point v2 changes the bulge (a fast edit)', async () => {
  const f0 = await frame();
  const box = await page.locator('#profile').boundingBox();
  const [x, y] = await page.evaluate(() => window.squish.profile.point(2));
  await page.mouse.move(box.x + x, box.y + y);
  await page.mouse.down();
  await page.mouse.move(box.x + x + 40, box.y + y - 30, { steps: 6 });
  await page.mouse.up();
  const f = await waitFor(
    (f) => f.values.objects[0].profile_v2.value !== f0.values.objects[0].profile_v2.value && f.values.objects[0].bulge.value !== f0.values.objects[0].bulge.value,
    'the dragged profile',
  );
  assert.equal(f.edit, true, 'profile and bulge are downstream: the frame is a fast edit');
  assert.ok(maxDistance(f0.objects[0].output, f.objects[0].output) > 1e-4, 'the bulge moves');
  assert.notDeepEqual(f0.objects[0].profile.curve, f.objects[0].profile.curve, 'the curve is redrawn by the core');
  await saveScreenshot('serve-profile.png');
});

test('a painted stroke changes the bulge map', async () => {
  const f0 = await frame();
  // A deformable vertex of the ball that the brush's ray reaches first.
  const target = await page.evaluate(() => {
    const { view, frame } = window.squish;
    const object = frame.objects[0];
    const entry = view.objects[0];
    const canvas = view.renderer.domElement.getBoundingClientRect();
    const p = entry.before.position.clone();
    for (let v = 0; v < object.overlays.deformable.length; v++) {
      if (!object.overlays.deformable[v]) continue;
      p.set(object.input[3 * v], object.input[3 * v + 1], object.input[3 * v + 2]).project(view.camera);
      const event = { clientX: canvas.left + ((p.x + 1) / 2) * canvas.width, clientY: canvas.top + ((1 - p.y) / 2) * canvas.height };
      const hit = view.pick(event, 0);
      if (hit && hit.distanceTo(p.set(object.input[3 * v], object.input[3 * v + 1], object.input[3 * v + 2])) < 0.05) return [event.clientX, event.clientY];
    }
    return null;
  });
  assert.ok(target, 'a deformable vertex of the ball is in view');
  await page.locator('#paint-on').check();
  await page.locator('#brush-strength').fill('3');
  await page.mouse.move(target[0], target[1]);
  await page.mouse.down();
  await page.mouse.move(target[0] + 15, target[1] + 5, { steps: 4 });
  await page.mouse.up();
  await page.locator('#paint-on').uncheck();
  const f = await waitFor((f) => f.objects[0].painted !== null, 'a painted map');
  assert.ok(f.objects[0].painted.some((eta) => eta > 1.5), 'the stroke raised η');
  assert.ok(maxDistance(f0.objects[0].overlays.bulge_map, f.objects[0].overlays.bulge_map) > 0.5, 'the bulge map changed');
  assert.equal(f.edit, true, 'the bulge map is downstream: a fast edit');
  await page.locator('#overlay').selectOption('bulge');
  await saveScreenshot('serve-paint.png');
  await page.locator('#overlay').selectOption('none');
});

test('a radial stroke changes the bulge map along the profiles', async () => {
  await page.evaluate(() => window.squish.send({ type: 'clear_paint', object: 0 }));
  await waitFor((f) => f.objects[0].painted === null, 'the cleared map');
  // A vertex of the ball halfway along the profiles (u near ½) that the brush's ray reaches first.
  const target = await page.evaluate(() => {
    const { view, frame } = window.squish;
    const object = frame.objects[0];
    const canvas = view.renderer.domElement.getBoundingClientRect();
    const p = view.objects[0].before.position.clone();
    for (let v = 0; v < object.overlays.u.length; v++) {
      if (!object.overlays.deformable[v] || Math.abs(object.overlays.u[v] - 0.5) > 0.15) continue;
      p.set(object.input[3 * v], object.input[3 * v + 1], object.input[3 * v + 2]).project(view.camera);
      const event = { clientX: canvas.left + ((p.x + 1) / 2) * canvas.width, clientY: canvas.top + ((1 - p.y) / 2) * canvas.height };
      const hit = view.pick(event, 0);
      if (hit && hit.distanceTo(p.set(object.input[3 * v], object.input[3 * v + 1], object.input[3 * v + 2])) < 0.05) return [event.clientX, event.clientY];
    }
    return null;
  });
  assert.ok(target, 'a vertex of the ball with u near ½ is in view');
  await page.locator('#paint-on').check();
  await page.locator('#brush-kind').selectOption('radial');
  await page.locator('#brush-op').selectOption('add');
  await page.locator('#brush-strength').fill('3');
  await page.mouse.click(target[0], target[1]);
  await page.locator('#paint-on').uncheck();
  await page.locator('#brush-kind').selectOption('local');
  const f = await waitFor((f) => f.objects[0].painted !== null, 'a radially painted map');
  const { u } = f.objects[0].overlays;
  const raised = f.objects[0].painted.flatMap((eta, v) => (eta > 1 ? [u[v]] : []));
  assert.ok(raised.length > 10, `${raised.length} vertices painted`);
  assert.ok(Math.min(...raised) < 0.2 && Math.max(...raised) > 0.8, `the stroke runs from ∂𝒞 to ∂𝒟 (u ${Math.min(...raised)} … ${Math.max(...raised)})`);
  assert.equal(await page.locator('#error').isHidden(), true, 'no error shown');
  assert.equal(f.edit, true, 'the bulge map is downstream: a fast edit');
});

test('a key set on the timeline and removed again', async () => {
  const row = page.locator('.param[data-key="bulge_height"]');
  await row.locator('.name').click();
  await row.locator('button.key').click();
  await waitFor((f) => f.values.objects[0].bulge_height.keys.includes(FRAME), 'a key at the current frame');
  assert.equal(await page.locator('#keys span').count(), 1, 'the key is marked on the timeline');
  await row.locator('button.key').click();
  await waitFor((f) => f.values.objects[0].bulge_height.keys.length === 0, 'the key removed');
  assert.equal(await page.locator('#keys span').count(), 0);
});

test('a malformed message is rejected with an error shown on the page', async () => {
  await page.evaluate(() => window.squish.send({ type: 'set', target: { object: 0 }, key: 'stiffness', value: 'soft' }));
  await page.locator('#error').waitFor({ state: 'visible' });
  assert.match(await page.locator('#error').textContent(), /stiffness/);
  // The next frame clears it.
  await page.evaluate(() => window.squish.send({ type: 'refresh' }));
});

test('the exported scene reproduces the page with squish run', async () => {
  await page.locator('#export-name').fill('edited');
  await page.locator('#export').click();
  await page.waitForFunction(() => window.squish.exported !== null);
  const exported = await page.evaluate(() => window.squish.exported);
  assert.equal(exported.maps.length, 1, 'the painted map is written beside the scene');
  const shown = (await api('api/frame')).frame;
  const out = join(folder, 'run-out');
  execFileSync(squish, ['run', join(folder, exported.scene), '--frames', String(FRAME), '-o', out], { stdio: 'ignore' });
  for (const object of shown.objects) {
    const dir = join(out, object.name);
    const file = readdirSync(dir).find((f) => f.endsWith('.obj'));
    const written = readFileSync(join(dir, file), 'utf8')
      .split('\n')
      .filter((l) => l.startsWith('v '))
      .flatMap((l) => l.slice(2).trim().split(/\s+/).map(Number));
    assert.equal(written.length, object.output.length, `${object.name}: vertex count`);
    assert.equal(maxDistance(written, object.output), 0, `${object.name}: squish run gives the page's positions bit for bit`);
  }
});
