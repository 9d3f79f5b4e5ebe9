// What the browser tests share: `squish serve` started on a free port, Chromium with software
// WebGL, and waiting for the page to show a frame.
import { spawn } from 'node:child_process';
import { chromium } from 'playwright-core';

// Starts `squish serve SCENE` (the binary `squish`) on a free port: the process and its URL.
export function startServer(squish, scene) {
  return new Promise((ok, fail) => {
    const server = spawn(squish, ['serve', scene, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    server.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/http:\/\/[^\s]+/);
      if (m) ok({ server, url: m[0] });
    });
    server.stderr.on('data', (d) => process.stderr.write(d));
    server.on('exit', (code) => fail(new Error(`squish serve exited (${code}): ${out}`)));
  });
}

// Debian's Chromium (or $CHROMIUM) with WebGL2 through SwiftShader, and a page on `url`.
export async function openPage(url) {
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    args: ['--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-sandbox'],
  });
  const page = await browser.newPage({ viewport: { width: 1400, height: 860 } });
  page.on('pageerror', (e) => process.stderr.write(`page error: ${e}\n`));
  await page.goto(url);
  return { browser, page };
}

// Waits (up to `seconds`) until `page` shows a frame for which `check` holds.
export async function waitForFrame(page, check, what, seconds = 30) {
  const deadline = Date.now() + seconds * 1000;
  while (Date.now() < deadline) {
    const f = await page.evaluate(() => window.squish.frame);
    if (f && check(f)) return f;
    await page.waitForTimeout(50);
  }
  throw new Error(`timed out waiting for ${what}`);
}
