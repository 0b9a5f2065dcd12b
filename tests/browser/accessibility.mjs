// Browser tests of the viewer for assistive technology and the keyboard: axe-core's audit, Chromium's own
// accessibility tree against the panels egui drew, keyboard-only use, what a screen reader's actions do, the
// announcements, and the embedded viewer's role. Registered by run.mjs.
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { ROOT, control, openApp, waitForDataset } from './lib.mjs';

const AXE = readFileSync(join(ROOT, 'node_modules/axe-core/axe.min.js'), 'utf8');

function assert(cond, msg) { if (!cond) throw new Error(msg); }

/** Opens the app for `backend` and waits until the panels' mirror lists the default model's clips. */
async function openMirroredApp(ctx, backend) {
  await openApp(ctx, backend);
  await mirrorReady(ctx.page);
}

/** Waits until the panels' mirror lists the model's clips. */
async function mirrorReady(page, selector = 'kloub-viewer') {
  await page.waitForFunction((s) => document.querySelector(s).shadowRoot.querySelectorAll('.kloub-a11y [role="option"]').length > 0,
    selector, { timeout: 30000, polling: 100 });
}

/** Runs axe-core on the page (the CSP of `kloub serve` forbids inline scripts: the audit goes in through the
 *  devtools protocol); returns its violations. */
async function audit(page) {
  await page.evaluate(AXE);
  return page.evaluate(async () => (await window.axe.run(document, { resultTypes: ['violations'] })).violations
    .map((v) => ({ id: v.id, impact: v.impact, help: v.help, targets: v.nodes.slice(0, 3).map((n) => JSON.stringify(n.target)) })));
}

/** Chromium's accessibility tree (the page as assistive technology gets it), flattened: role, name, value text,
 *  checked and expanded states of every node that is not ignored. */
async function axTree(page) {
  const cdp = await page.context().newCDPSession(page);
  await cdp.send('Accessibility.enable');
  const { nodes } = await cdp.send('Accessibility.getFullAXTree');
  await cdp.detach();
  const prop = (n, name) => n.properties?.find((p) => p.name === name)?.value?.value;
  return nodes.filter((n) => !n.ignored).map((n) => ({
    role: n.role?.value ?? '', name: n.name?.value ?? '', value: n.value?.value,
    valuetext: prop(n, 'valuetext'), checked: prop(n, 'checked'), expanded: prop(n, 'expanded'), selected: prop(n, 'selected'),
  }));
}

/** Evaluates `fn(mirror root, element)` in the page. */
function inMirror(page, fn, arg) {
  return page.evaluate(({ body, arg }) => {
    const el = document.querySelector('kloub-viewer');
    // eslint-disable-next-line no-new-func
    return new Function('root', 'element', 'arg', body)(el.shadowRoot.querySelector('.kloub-a11y'), el, arg);
  }, { body: `return (${fn})(root, element, arg);`, arg });
}

/** Turns IK on through the panel's checkbox (its section then shows the goal's controls). */
async function turnOnIk(page) {
  await inMirror(page, (root) => root.querySelector('button[role="checkbox"][aria-label="Inverse kinematics"]').click());
  await waitForDataset(page, () => (document.querySelector('kloub-viewer').dataset.ik ?? '') !== '', 'IK on');
  await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y [aria-label="iterations"]'),
    null, { timeout: 10000 });
}

/** Opens every collapsed section of the panel (as a screen reader would: the mirrored disclosure buttons' click). */
async function openEverySection(page) {
  for (let round = 0; round < 8; round++) {
    const opened = await inMirror(page, (root) => {
      const closed = [...root.querySelectorAll('button[aria-expanded="false"]:not([aria-haspopup])')];
      for (const b of closed) b.click();
      return closed.length;
    });
    if (opened === 0) return;
    // A paused viewer draws only when something changes (no frame counter to wait on): give it time.
    await page.waitForTimeout(300);
  }
}

/** The name (aria-label) and role of the element focused inside the viewer's shadow root. */
function focused(page) {
  return page.evaluate(() => {
    const a = document.querySelector('kloub-viewer').shadowRoot.activeElement;
    if (!a) return null;
    return { name: a.getAttribute('aria-label') ?? '', role: a.getAttribute('role') ?? (a.tagName === 'INPUT' ? `input:${a.type}` : a.tagName.toLowerCase()),
      outline: getComputedStyle(a).outlineStyle, outlineWidth: getComputedStyle(a).outlineWidth, rect: a.getBoundingClientRect().toJSON() };
  });
}

/** Presses Tab (Shift+Tab with `back`) until the focused mirrored control matches `want` ({ name, role }); at most
 *  `limit` presses. */
async function tabTo(page, want, { back = false, limit = 160 } = {}) {
  for (let i = 0; i < limit; i++) {
    await page.keyboard.press(back ? 'Shift+Tab' : 'Tab');
    const f = await focused(page);
    if (f && (want.name instanceof RegExp ? want.name.test(f.name) : f.name === want.name) && (!want.role || f.role === want.role)) return f;
  }
  throw new Error(`Tab never reached ${want.role ?? ''} "${want.name}"`);
}

export function registerAccessibilityTests(test, BACKENDS) {
  for (const backend of BACKENDS) {
    test(`${backend}: axe-core finds no critical or serious violation on the app (every section open, IK on) nor on embed.html`, async (ctx) => {
      const { page } = ctx;
      await openMirroredApp(ctx, backend);
      await turnOnIk(page);
      await openEverySection(page);
      const expanded = await inMirror(page, (root) => root.querySelectorAll('button[aria-expanded="true"]').length);
      assert(expanded >= 5, `the panel's sections are open (${expanded})`);
      const bad = (await audit(page)).filter((v) => v.impact === 'critical' || v.impact === 'serious');
      assert(bad.length === 0, `app: ${JSON.stringify(bad, null, 1)}`);
      // And with a popup open (the skinning method's list): named after its button, its options inside.
      await inMirror(page, (root) => root.querySelector('button[aria-label^="Skinning method"]').click());
      await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot
        .querySelector('[data-popup][aria-label="Skinning method"] [role="option"]'), null, { timeout: 10000 });
      const badPopup = (await audit(page)).filter((v) => v.impact === 'critical' || v.impact === 'serious');
      assert(badPopup.length === 0, `app with a popup open: ${JSON.stringify(badPopup, null, 1)}`);
      await page.goto(`${ctx.url}/embed.html?backend=${backend}`);
      await page.waitForFunction(() => [...document.querySelectorAll('kloub-viewer')].every((v) => v.dataset.status === 'ready'), null, { timeout: 60000 });
      const badEmbed = (await audit(page)).filter((v) => v.impact === 'critical' || v.impact === 'serious');
      assert(badEmbed.length === 0, `embed.html: ${JSON.stringify(badEmbed, null, 1)}`);
    });

    test(`${backend}: Chromium's accessibility tree lists every control egui drew in the panel, with names and values`, async (ctx) => {
      const { page } = ctx;
      await openMirroredApp(ctx, backend);
      await control(page, 'pause');
      await turnOnIk(page);
      await openEverySection(page);
      await page.evaluate(() => { document.querySelector('kloub-viewer').currentTime = 1.5; });
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.time === '1.500', 'the seek');
      await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot
        .querySelector('input[aria-label="time"]')?.getAttribute('aria-valuetext') === '1.50 of 3.42 seconds', null, { timeout: 10000 });
      const drawn = await page.evaluate(() => document.querySelector('kloub-viewer')._testAccessibilityControls());
      assert(drawn.length >= 40, `egui drew ${drawn.length} controls`);
      const tree = await axTree(page);
      // How Chromium names the roles of the mirror's elements.
      const ax = { button: ['button', 'PopUpButton', 'combobox'], option: ['option', 'ListBoxOption'], input: ['textbox'] };
      const missing = [];
      const pool = tree.map((n) => ({ ...n }));
      // Chromium collapses runs of white space in names.
      // Numbers that change every frame (an IK goal's error) are compared as numbers, not digits.
      const squash = (text) => text.replace(/\s+/g, ' ').replace(/[-+]?\d+(\.\d+)?/g, '#').trim();
      for (const n of pool) n.name = squash(n.name);
      for (const [role, raw] of drawn) {
        const name = squash(raw);
        const roles = ax[role] ?? [role === 'textbox' ? 'textbox' : role];
        const at = pool.findIndex((n) => roles.some((r) => r.toLowerCase() === n.role.toLowerCase()) && (n.name === name || n.name.startsWith(`${name}: `)));
        if (at < 0) missing.push(`${role} "${raw}"`);
        else pool.splice(at, 1);
      }
      assert(missing.length === 0, `not in the accessibility tree: ${missing.join(', ')}`);
      assert(drawn.every(([, name]) => name !== ''), `a control without a name: ${JSON.stringify(drawn.filter(([, n]) => n === ''))}`);
      // The sections as named groups, each with its controls.
      const groups = tree.filter((n) => n.role === 'group').map((n) => n.name);
      for (const section of ['Clips', 'Playback', 'Transition', 'Skinning', 'IK', 'Ragdoll', 'View']) {
        assert(groups.includes(section), `no "${section}" group in ${JSON.stringify(groups)}`);
      }
      const find = (role, name) => tree.find((n) => n.role.toLowerCase() === role.toLowerCase() && (name instanceof RegExp ? name.test(n.name) : n.name === name));
      const survey = find('option', /^Survey/);
      assert(survey?.selected === true, `the playing clip is the selected option: ${JSON.stringify(survey)}`);
      assert(find('listbox', 'Clips'), 'the clip list is a list box');
      // (The devtools protocol does not report aria-valuetext; the mirror's attribute was checked above.)
      const time = find('slider', 'time');
      assert(time && Number(time.value) === 1.5, `the timeline: ${JSON.stringify(time)}`);
      const speed = find('slider', 'speed');
      assert(speed && Number(speed.value) === 1, `speed ${JSON.stringify(speed)}`);
      for (const [role, name] of [['button', 'Play'], ['checkbox', 'Skeleton'], ['checkbox', 'Deviation heatmap'], ['radio', 'CPU'],
        ['slider', 'crossfade s'], ['slider', 'gravity'], ['slider', 'iterations'], ['checkbox', 'Inverse kinematics'], ['button', 'Frame model']]) {
        assert(find(role, name), `no ${role} "${name}"`);
      }
      const method = tree.find((n) => n.name === 'Skinning method: Linear blend (LBS)');
      assert(method && method.expanded === false, `the skinning method's button: ${JSON.stringify(method)}`);
      const grid = find('checkbox', 'Grid');
      assert(grid?.checked === 'true', `Grid is checked: ${JSON.stringify(grid)}`);
    });

    test(`${backend}: keyboard only: play a named clip, speed 2×, scrub to half the clip, DQS, the skeleton overlay`, async (ctx) => {
      const { page } = ctx;
      await openMirroredApp(ctx, backend);
      // From the top of the page: Tab enters the panel first.
      const run = await tabTo(page, { name: /^Run/, role: 'option' });
      assert(run.outline === 'solid' && parseFloat(run.outlineWidth) >= 2, `a visible focus ring: ${run.outline} ${run.outlineWidth}`);
      assert(run.rect.width > 20 && run.rect.height > 10, `the ring sits on the widget: ${JSON.stringify(run.rect)}`);
      await page.keyboard.press('Enter');
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.clip === 'Run', 'Enter on Run to play it');
      await tabTo(page, { name: 'speed', role: 'input:range' });
      for (let i = 0; i < 20; i++) await page.keyboard.press('ArrowRight');
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.speed === '2.000', '20 × → to reach speed 2');
      await tabTo(page, { name: 'Pause' }, { back: true });
      await page.keyboard.press('Space');
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.playing === 'false', 'Space on Pause');
      await tabTo(page, { name: 'time', role: 'input:range' });
      // Home, then Page Up by tenths of the clip, then → and ← frame by frame onto the middle.
      await page.keyboard.press('Home');
      for (let i = 0; i < 5; i++) await page.keyboard.press('PageUp');
      const timeOff = () => page.evaluate(() => {
        const d = document.querySelector('kloub-viewer').dataset;
        return Number(d.time) - Number(d.duration) / 2;
      });
      for (let i = 0; i < 12; i++) {
        await page.waitForTimeout(200);
        const off = await timeOff();
        if (Math.abs(off) <= 1 / 60 + 1e-3) break;
        await page.keyboard.press(off < 0 ? 'ArrowRight' : 'ArrowLeft');
      }
      const off = await timeOff();
      assert(Math.abs(off) <= 1 / 60 + 1e-3, `the keyboard scrubbed to ${off.toFixed(3)} s from half the clip`);
      await tabTo(page, { name: /^Skinning method/ });
      await page.keyboard.press('Enter');
      // The list opens with the keyboard in it; ↓ walks its options.
      await page.waitForFunction(() => {
        const a = document.querySelector('kloub-viewer').shadowRoot.activeElement;
        return a?.getAttribute('role') === 'option';
      }, null, { timeout: 10000 });
      for (let i = 0; i < 4; i++) {
        const f = await focused(page);
        if (f.name.includes('DQS')) break;
        await page.keyboard.press('ArrowDown');
      }
      assert((await focused(page)).name.includes('DQS'), `↓ reached DQS: ${JSON.stringify(await focused(page))}`);
      await page.keyboard.press('Enter');
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.skinning === 'dqs', 'Enter on DQS');
      await tabTo(page, { name: 'Skeleton', role: 'checkbox' });
      await page.keyboard.press('Space');
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.overlays === 'skeleton', 'Space on Skeleton');
      // The 3D view is a tab stop that says how to use it; Escape leaves it for the panel.
      const view = await tabTo(page, { name: /^3D view of .*Shift and the arrow keys/, role: 'application' });
      assert(view, 'the view is focusable');
      await page.keyboard.press('Shift+ArrowLeft');
      await page.keyboard.press('Escape');
      const after = await focused(page);
      assert(after && after.role !== 'application', `Escape left the view: ${JSON.stringify(after)}`);
      const log = ctx.logs.filter((l) => l.startsWith('[error]') || l.startsWith('[pageerror]'));
      assert(log.length === 0, log.join('\n'));
    });

    test(`${backend}: a screen reader's actions on the mirrored nodes change the viewer; announcements through a live region`, async (ctx) => {
      const { page } = ctx;
      await openMirroredApp(ctx, backend);
      const live = () => page.evaluate(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('[aria-live]').textContent);
      await page.waitForFunction(() => /loaded: 3 clips/.test(document.querySelector('kloub-viewer').shadowRoot.querySelector('[aria-live]').textContent), null, { timeout: 10000 });
      await inMirror(page, (root) => root.querySelector('button[aria-label="Pause"]').click());
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.playing === 'false', 'click() on the mirrored Pause');
      await inMirror(page, (root) => {
        const speed = root.querySelector('input[type="range"][aria-label="speed"]');
        speed.value = '0.5';
        speed.dispatchEvent(new Event('input', { bubbles: true }));
      });
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.speed === '0.500', 'setting the mirrored speed slider');
      await inMirror(page, (root) => {
        const time = root.querySelector('input[type="range"][aria-label="time"]');
        time.value = '2';
        time.dispatchEvent(new Event('input', { bubbles: true }));
      });
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.time === '2.000', 'setting the mirrored timeline');
      await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot
        .querySelector('input[aria-label="time"]').getAttribute('aria-valuetext') === '2.00 of 3.42 seconds', null, { timeout: 10000 });
      await inMirror(page, (root) => root.querySelector('button[role="checkbox"][aria-label="Skeleton"]').click());
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.overlays === 'skeleton', 'click() on Skeleton');
      await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot
        .querySelector('button[aria-label="Skeleton"]').getAttribute('aria-checked') === 'true', null, { timeout: 10000 });
      await inMirror(page, (root) => root.querySelector('[role="option"][aria-label^="Walk"]').click());
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.clip === 'Walk', 'click() on the Walk option');
      await page.waitForFunction(() => /Playing Walk/.test(document.querySelector('kloub-viewer').shadowRoot.querySelector('[aria-live]').textContent), null, { timeout: 10000 });
      await inMirror(page, (root) => root.querySelector('button[aria-label="Ragdoll"]:not([aria-expanded])').click());
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'simulating', 'click() on Ragdoll');
      await page.waitForFunction(() => /Ragdoll started/.test(document.querySelector('kloub-viewer').shadowRoot.querySelector('[aria-live]').textContent), null, { timeout: 10000 });
      await inMirror(page, (root) => root.querySelector('button[aria-label="To animation"]').click());
      await waitForDataset(page, () => (document.querySelector('kloub-viewer').dataset.ragdoll ?? '') === '', 'back to the animation', 30000);
      await inMirror(page, (root) => root.querySelector('button[aria-label="Transition"]').click());
      await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot
        .querySelector('button[aria-label="Transition"]').getAttribute('aria-expanded') === 'false', null, { timeout: 10000 });
      // A folded section's controls leave the tree (once its folding animation ends).
      await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot
        .querySelectorAll('.kloub-a11y input[aria-label="crossfade s"]').length === 0, null, { timeout: 10000 });
      await control(page, 'load', '/models/nothing-here.glb').catch(() => {});
      await page.waitForFunction(() => /^Error: .*nothing-here/.test(document.querySelector('kloub-viewer').shadowRoot.querySelector('[aria-live]').textContent), null, { timeout: 30000 });
      assert((await live()).includes('404'), `the error is announced: ${await live()}`);
    });
  }

  test('<kloub-viewer> without controls is one image named by alt with no tab stop; camera-controls makes the view a labelled tab stop; no mirror', async (ctx) => {
    const { page } = ctx;
    await page.goto(`${ctx.url}/embed.html`);
    await page.waitForFunction(() => [...document.querySelectorAll('kloub-viewer')].every((v) => v.dataset.status === 'ready'), null, { timeout: 60000 });
    await page.evaluate(() => {
      const plain = document.createElement('kloub-viewer');
      plain.id = 'plain';
      plain.setAttribute('src', '/models/default.glb');
      plain.setAttribute('alt', 'A fox');
      document.querySelector('main').append(plain);
      plain.scrollIntoView();
    });
    await page.waitForFunction(() => document.getElementById('plain').dataset.status === 'ready', null, { timeout: 60000 });
    const tree = await axTree(page);
    const images = tree.filter((n) => n.role === 'image');
    assert(images.some((n) => n.name === 'A fox'), `the plain viewer is an image named by alt: ${JSON.stringify(images)}`);
    const facts = await page.evaluate(() => {
      const plain = document.getElementById('plain');
      const left = document.getElementById('left');
      return {
        plainTab: plain.shadowRoot.querySelector('canvas').tabIndex,
        plainMirror: plain.shadowRoot.querySelectorAll('.kloub-a11y *').length,
        leftMirror: left.shadowRoot.querySelectorAll('.kloub-a11y *').length,
        leftRole: left.shadowRoot.querySelector('canvas').getAttribute('role'),
        leftLabel: left.shadowRoot.querySelector('canvas').getAttribute('aria-label'),
        leftTab: left.shadowRoot.querySelector('canvas').tabIndex,
      };
    });
    assert(facts.plainTab === -1 && facts.plainMirror === 0, `no tab stop, no mirror without controls: ${JSON.stringify(facts)}`);
    assert(facts.leftMirror === 0, 'no panels, no mirror');
    assert(facts.leftTab === 0 && facts.leftRole === 'application' && /^The default character walking\. Shift and the arrow keys turn/.test(facts.leftLabel),
      `camera-controls: a labelled tab stop: ${JSON.stringify(facts)}`);
    // Keyboard orbit on the focused view, as its label says.
    const before = await page.evaluate(() => document.getElementById('left').dataset.camera);
    await page.evaluate(() => document.getElementById('left').shadowRoot.querySelector('canvas').focus());
    await page.keyboard.press('Shift+ArrowLeft');
    await page.waitForFunction((b) => document.getElementById('left').dataset.camera !== b, before, { timeout: 10000 });
  });
}
