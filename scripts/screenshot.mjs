// Refreshes web/screenshot.png (the README's picture): serves the built bundle, opens the app, waits for the
// default model, poses it, and screenshots the whole page. Run after scripts/build-web.sh: node scripts/screenshot.mjs
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { ROOT, openBrowser, pageUrl, startServer, waitForDataset } from '../tests/browser/lib.mjs';

const server = await startServer();
const ctx = await openBrowser();
try {
  await ctx.page.setViewportSize({ width: 1280, height: 720 });
  await ctx.page.goto(pageUrl(server.url, 'webgpu'));
  await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.status === 'ready', 'the default model');
  // Fox paused mid-walk, Survey layered on the neck, the skeleton shown and the neck selected (its channel plot),
  // shaded by glTF's BRDF in the studio environment, its shadow on the ground.
  await ctx.page.evaluate(async () => {
    const v = document.querySelector('kloub-viewer');
    v.crossfadeTo('Walk', 0);
    v.setLayer('Survey', 'b_Neck_04', 1);
    v.pause();
    v.currentTime = 0.3;
    v.setOverlays({ skeleton: true });
    v.selectJoint('b_Neck_04');
    // The grey theme: the studio environment's light and the ground shadow show on it.
    v.setBackground('grey');
  });
  await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.joint === 'b_Neck_04', 'the joint selection');
  await ctx.page.waitForTimeout(1200);
  writeFileSync(join(ROOT, 'web/screenshot.png'), await ctx.page.screenshot());
  console.log('wrote web/screenshot.png');
} finally {
  await ctx.close();
  server.stop();
}
