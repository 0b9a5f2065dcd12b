// Loads the wasm bundle and starts the viewer on #kloub-canvas.
// Kept out of index.html so the page works under a CSP without 'unsafe-inline'.
import init, { start } from './kloub_web.js';

function fail(message) {
  document.body.dataset.status = 'error';
  document.body.dataset.error = message;
  const loading = document.getElementById('kloub-loading');
  if (loading) {
    loading.textContent = message;
  }
  console.error(message);
}

try {
  await init();
  const canvas = document.getElementById('kloub-canvas');
  // The control handle (playClip, crossfadeTo, setLayer, ...) on the canvas it drives.
  canvas.kloub = await start('kloub-canvas');
} catch (error) {
  // start() has already shown its overlay for errors it caught; this covers init().
  if (document.body.dataset.status !== 'error') {
    fail(`Kloub could not start: ${error && error.message ? error.message : error}`);
  }
}
