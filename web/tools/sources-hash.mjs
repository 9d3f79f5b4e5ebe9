// The hash of the page's sources that web/build.sh records in web-bundle/SOURCES and that the
// Rust test `the_committed_bundle_is_built_from_the_current_sources` recomputes: FNV-1a 64 over
// every source file in sorted path order, of `path NUL bytes NUL` (paths relative to web/).
import { readFileSync, readdirSync, statSync } from 'node:fs';
import { join, relative, sep } from 'node:path';

export function sourceFiles(web) {
  const files = ['index.html', 'vite.config.js', 'package.json', 'package-lock.json'];
  const walk = (dir) => {
    for (const name of readdirSync(dir)) {
      const path = join(dir, name);
      if (statSync(path).isDirectory()) walk(path);
      else files.push(relative(web, path).split(sep).join('/'));
    }
  };
  walk(join(web, 'src'));
  return files;
}

export function sourcesHash(web) {
  const enc = new TextEncoder();
  let hash = 0xcbf29ce484222325n;
  const feed = (bytes) => {
    for (const b of bytes) {
      hash ^= BigInt(b);
      hash = (hash * 0x100000001b3n) & 0xffffffffffffffffn;
    }
  };
  const files = sourceFiles(web).sort((a, b) => (Buffer.from(a) < Buffer.from(b) ? -1 : Buffer.from(a) > Buffer.from(b) ? 1 : 0));
  for (const file of files) {
    feed(enc.encode(file));
    feed([0]);
    feed(readFileSync(join(web, file)));
    feed([0]);
  }
  return hash.toString(16).padStart(16, '0');
}

if (import.meta.url === `file://${process.argv[1]}`) {
  console.log(sourcesHash(process.argv[2] ?? '.'));
}
