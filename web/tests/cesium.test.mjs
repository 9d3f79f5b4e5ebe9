// The page on a skinned glTF character with `self_contact = "auto"` (CesiumMan, from the shared
// test data; skipped when absent): standing upright (glTF is y-up), textured with its base-colour
// texture, its articulations and parts listed, an articulation's stiffness edited from its
// controls changing the character, and the self-contact's stage times shown.
//
// Environment: as browser.test.mjs (SQUISH, CHROMIUM, SQUISH_SCREENSHOTS: writes serve-cesium.png).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, mkdtempSync, rmSync, writeFileSync, mkdirSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { openPage, startServer, waitForFrame } from './serve.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '../..');
const squish = process.env.SQUISH ?? join(repo, 'target/debug/squish');
const glb = resolve(repo, '../shared/data/rigged/CesiumMan.glb');
const present = existsSync(glb);
const FRAME = 9;

let folder;
let server;
let browser;
let page;

const frame = () => page.evaluate(() => window.squish.frame);
const waitFor = (check, what) => waitForFrame(page, check, what, 120);

before(async () => {
  if (!present) return;
  folder = mkdtempSync(join(tmpdir(), 'squish-cesium-'));
  const scene = join(folder, 'cesium.toml');
  writeFileSync(
    scene,
    `frames = { start = 1, end = 48, fps = 24 }\n[[objects]]\nname = "cesium_man"\nmesh = { file = ${JSON.stringify(glb)}, repeat = true }\nself_contact = "auto"\n`,
  );
  let url;
  ({ server, url } = await startServer(squish, scene));
  ({ browser, page } = await openPage(url));
  await waitFor((f) => f.objects.length === 1, 'the first frame');
  await page.locator('#scrub').fill(String(FRAME));
  await waitFor((f) => f.frame === FRAME, `frame ${FRAME}`);
});

after(async () => {
  await browser?.close();
  server?.kill('SIGINT');
  if (folder) rmSync(folder, { recursive: true, force: true });
});

test('CesiumMan stands upright, textured', { skip: !present && `${glb} is absent` }, async () => {
  await page.locator('#frame-contact').click();
  const view = await page.evaluate(async () => {
    const v = window.squish.view;
    const entry = v.objects[0];
    const box = entry.after.geometry.boundingBox;
    const size = [box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z];
    const image = entry.after.material.map?.image;
    if (image && !image.complete) await new Promise((ok) => image.addEventListener('load', ok, { once: true }));
    // Where the head and the feet fall on the screen: the head above the feet.
    const project = (y) => {
      const p = box.getCenter(new entry.after.geometry.boundingBox.min.constructor());
      p.y = y;
      return p.project(v.camera).y;
    };
    return {
      up: v.camera.up.toArray(),
      size,
      head: project(box.max.y),
      feet: project(box.min.y),
      textured: !!image && image.width > 0,
      drawn: entry.after.geometry.getAttribute('position').count,
      uv: !!entry.after.geometry.getAttribute('uv'),
    };
  });
  assert.deepEqual(view.up, [0, 1, 0], 'the camera is y-up');
  assert.ok(view.size[1] > 2 * Math.max(view.size[0], view.size[2]), `the character is tall along y: ${view.size}`);
  assert.ok(view.head > view.feet + 0.5, `the head is above the feet on the screen (${view.head} vs ${view.feet})`);
  assert.ok(view.textured && view.uv, 'the base-colour texture is loaded and drawn with the UVs');
  assert.ok(view.drawn > 2338, `the mesh is split along its UV seams for drawing: ${view.drawn} vertices`);
  if (process.env.SQUISH_SCREENSHOTS) {
    mkdirSync(process.env.SQUISH_SCREENSHOTS, { recursive: true });
    await page.screenshot({ path: join(process.env.SQUISH_SCREENSHOTS, 'serve-cesium.png') });
  }
});

test('the articulations and parts are listed, and an articulation edit changes the character', { skip: !present && `${glb} is absent` }, async () => {
  const articulations = page.locator('#targets li.sub:not(.parts)');
  assert.ok((await articulations.count()) >= 8, 'every articulation of the skeleton is listed');
  assert.match(await page.locator('#targets li.parts').textContent(), /^parts: .*leg_joint_L_2/);
  const before = await frame();
  assert.match(await page.locator('[data-testid="times"]').textContent(), /self-contact: parts \d/);
  assert.ok((await page.locator('[data-testid="articulations"] tr').count()) > 8, 'their figures are shown');
  // The object's stiffness is marked as having no effect (the object is in no pair).
  await page.locator('#targets li', { hasText: 'object: cesium_man' }).click();
  assert.equal(await page.locator('.param.inert[data-key="stiffness"]').count(), 1);
  // The left knee's stiffness [parent side, child side]: the child side four times stiffer.
  await page.locator('#targets li.sub', { hasText: 'leg_joint_L_1 / leg_joint_L_2' }).click();
  const fields = page.locator('.param[data-key="stiffness"] input[type=number]');
  assert.equal(await fields.count(), 2, 'a pair of numbers');
  await fields.nth(1).fill('4');
  await fields.nth(1).dispatchEvent('change');
  const after = await waitFor((f) => f.version > before.version, 'the edited frame');
  const moved = after.objects[0].output.reduce((m, x, i) => Math.max(m, Math.abs(x - before.objects[0].output[i])), 0);
  assert.ok(moved > 1e-4, `the edit moved the skin by ${moved}`);
  assert.ok(await page.locator('#error').isHidden(), await page.locator('#error').textContent());
});
