// Builds the page of `squish serve` into crates/squish-cli/web-bundle with fixed file names
// (the server embeds them by name): index.html and assets/app.js, styles inlined in the script.
import { defineConfig } from 'vite';

export default defineConfig({
  root: '.',
  base: './',
  build: {
    // three.js is most of the 0.55 MB script; the page loads once, from this machine.
    outDir: '../crates/squish-cli/web-bundle',
    emptyOutDir: false,
    assetsInlineLimit: 100000000,
    cssCodeSplit: false,
    modulePreload: false,
    chunkSizeWarningLimit: 1000,
    rollupOptions: {
      output: {
        entryFileNames: 'assets/app.js',
        chunkFileNames: 'assets/app.js',
        assetFileNames: 'assets/[name][extname]',
        inlineDynamicImports: true,
      },
    },
  },
});
