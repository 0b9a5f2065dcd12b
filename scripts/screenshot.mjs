// Refreshes web/screenshot.png (the README's picture): serves the built bundle, opens the app, waits for the
// default model, and screenshots the whole page. Run after scripts/build-web.sh: node scripts/screenshot.mjs
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { ROOT, openBrowser, pageUrl, startServer, waitForDataset } from '../tests/browser/lib.mjs';

const server = await startServer();
const ctx = await openBrowser();
try {
  await ctx.page.setViewportSize({ width: 1280, height: 720 });
  await ctx.page.goto(pageUrl(server.url, 'webgpu'));
  await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.status === 'ready', 'the default model');
  await ctx.page.waitForTimeout(1200);
  writeFileSync(join(ROOT, 'web/screenshot.png'), await ctx.page.screenshot());
  console.log('wrote web/screenshot.png');
} finally {
  await ctx.close();
  server.stop();
}
