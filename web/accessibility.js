// The viewer's panels for assistive technology and the keyboard. egui draws its panels into the canvas, which a
// screen reader cannot read; the viewer sends its AccessKit tree (web/src/page/a11y.rs: only what changed each
// frame) and this mirrors it in the element's shadow DOM as invisible elements with ARIA roles, names, states and
// values, each placed over the widget it stands for — the approach Flutter's web engine takes for its canvas.
// Buttons, toggles and options are <button>s, sliders are <input type="range">, text fields <input>s: the browser
// gives them Tab order, Enter/Space, arrows, Home/End and Page Up/Down, and what they do comes back to egui as
// AccessKit action requests (click, focus, set value). The focused one shows a visible focus ring.

export const ACCESSIBILITY_STYLE = `
.kloub-a11y { position: absolute; inset: 0; overflow: clip; pointer-events: none; }
.kloub-a11y .k-group { position: absolute; left: 0; top: 0; width: 100%; height: 100%; }
.kloub-a11y .k-node { position: absolute; margin: 0; padding: 0; border: 0; box-sizing: border-box;
  background: transparent; color: transparent; font: 12px system-ui, sans-serif; line-height: 1;
  white-space: nowrap; overflow: hidden; appearance: none; -webkit-appearance: none; opacity: 1; }
.kloub-a11y input[type="range"].k-node::-webkit-slider-thumb { -webkit-appearance: none; width: 0; height: 0; }
.kloub-a11y .k-node:focus { outline: none; }
.kloub-a11y .k-node:focus-visible { outline: 2px solid #4da3ff; outline-offset: 1px; border-radius: 3px;
  box-shadow: 0 0 0 4px rgba(0, 0, 0, 0.55); }
`;

/** ARIA roles shown as a <button> (with the role when it is not "button"). */
const BUTTONS = new Set(['button', 'checkbox', 'switch', 'radio', 'link', 'menuitem', 'menuitemcheckbox',
  'menuitemradio', 'option', 'tab']);
/** Roles whose state is aria-checked (the others that toggle say aria-pressed). */
const CHECKED = new Set(['checkbox', 'switch', 'radio', 'menuitemcheckbox', 'menuitemradio']);

/** The text a slider reads out: its value text when the viewer gives one, else its number. */
function valueText(node) {
  if (typeof node.value === 'string' && node.value !== '') return node.value;
  return node.now === undefined || node.now === null ? '' : String(node.now);
}

export class AccessibilityMirror {
  /** `host`: where the mirror goes (the shadow root); `act(id, action, number, text)` sends an action to the viewer;
   *  `key(name)` presses and releases a key in it (Enter, Escape: what egui's popups and text fields listen for). */
  constructor(host, act, key) {
    this.act = act;
    this.key = key;
    this.root = document.createElement('div');
    this.root.className = 'kloub-a11y';
    this.root.setAttribute('part', 'accessibility');
    host.append(this.root);
    /** id → { el, node } */
    this.nodes = new Map();
    this.rootId = null;
    /** A popup that opened from the focused control: focus moves into it once its first item exists. */
    this.opener = null;
  }

  /** Removes every mirrored node (the panels went away). */
  clear() {
    this.root.replaceChildren();
    this.nodes.clear();
    this.rootId = null;
  }

  /** Removes the mirror from the page. */
  remove() {
    this.clear();
    this.root.remove();
  }

  /** The element that has the keyboard focus inside the mirror, if any. */
  focused() {
    const active = this.root.getRootNode().activeElement;
    return active && this.root.contains(active) ? active : null;
  }

  /** Applies one update of the viewer (the JSON of takeAccessibility). */
  apply(text) {
    let update;
    try {
      update = JSON.parse(text);
    } catch {
      return;
    }
    const hadFocus = this.focused();
    if (update.full) {
      const keep = new Set(update.nodes.map((n) => n.id));
      for (const [id, { el }] of this.nodes) {
        if (!keep.has(id)) { el.remove(); this.nodes.delete(id); }
      }
    }
    for (const id of update.removed ?? []) {
      const entry = this.nodes.get(id);
      if (!entry) continue;
      entry.el.remove();
      this.nodes.delete(id);
    }
    this.rootId = update.root;
    let popup = null;
    for (const node of update.nodes) {
      const fresh = !this.nodes.has(node.id);
      this.#put(node);
      if (fresh && node.popup) popup = node.id;
    }
    // A popup is named after the control that opened it (the one whose list is open).
    for (const el of this.root.querySelectorAll('[data-popup]:not([aria-label])')) {
      const opener = this.root.querySelector('[aria-haspopup][aria-expanded="true"]');
      const name = opener?.getAttribute('aria-label')?.split(':')[0];
      el.setAttribute('aria-label', name || (el.getAttribute('role') === 'menu' ? 'Menu' : 'Options'));
    }
    // Children in the order the viewer lists them (its reading and Tab order).
    for (const node of update.nodes) this.#order(node);
    // A popup opened from the focused control (a combo box, a menu button): the keyboard goes into it.
    if (popup && hadFocus) this.opener = { popup, from: hadFocus };
    if (this.opener) {
      const first = this.#firstControl(this.nodes.get(this.opener.popup)?.el);
      if (first) {
        first.focus();
        this.opener = { ...this.opener, popup: null };
      } else if (this.opener.popup === null && !this.opener.from.isConnected) {
        this.opener = null;
      }
    }
    // The focused element went away (a popup closed, a section folded): back to where the popup came from.
    if (hadFocus && !hadFocus.isConnected) {
      const back = this.opener?.from;
      this.opener = null;
      if (back?.isConnected) back.focus();
    }
  }

  /** The first control under `el` in Tab order. */
  #firstControl(el) {
    if (!el) return null;
    return el.querySelector('button, input');
  }

  #tag(node) {
    if (node.kind === 'group' || node.kind === 'skip') return 'div';
    if (node.kind === 'text') return node.role === 'heading' ? 'div' : 'span';
    if (node.role === 'slider') return 'input:range';
    if (node.role === 'spinbutton') return 'input:number';
    if (node.role === 'textbox') return 'input:text';
    return 'button';
  }

  #create(node, tag) {
    let el;
    if (tag.startsWith('input:')) {
      el = document.createElement('input');
      el.type = tag.slice(6);
    } else {
      el = document.createElement(tag);
    }
    el.dataset.tag = tag;
    el.dataset.id = node.id;
    el.className = node.kind === 'group' || node.kind === 'skip' ? 'k-group' : 'k-node';
    if (tag === 'button') el.type = 'button';
    const id = node.id;
    if (node.kind === 'control') {
      el.addEventListener('focus', () => {
        this.act(id, 'focus');
        this.act(id, 'scrollIntoView');
      });
    }
    if (tag === 'button') {
      // Enter and Space on a <button> click it; so does a screen reader's default action.
      el.addEventListener('click', (event) => {
        event.preventDefault();
        this.act(id, 'click');
        // egui closes a popup on a pointer click, which this is not: a choice in a list or menu closes it here.
        if (el.closest('[data-popup]')) this.key('Escape');
      });
      el.addEventListener('keydown', (event) => {
        if (event.key === 'Escape' && el.closest('[data-popup]')) {
          event.preventDefault();
          this.key('Escape');
        } else {
          this.#listKeys(event, el);
        }
      });
    } else if (tag === 'input:range' || tag === 'input:number') {
      el.addEventListener('input', () => {
        const v = Number(el.value);
        if (!Number.isFinite(v)) return;
        // Until the viewer reports this value (a frame or two later), its older value does not overwrite it.
        el.kloubSent = { value: v, at: performance.now() };
        this.act(id, 'setValue', v);
      });
    } else if (tag === 'input:text') {
      el.addEventListener('input', () => this.act(id, 'setValue', undefined, el.value));
      // Enter submits the field (e.g. Open → URL), Escape leaves it: egui reads both as keys.
      el.addEventListener('keydown', (event) => {
        if (event.key === 'Enter' || event.key === 'Escape') this.key(event.key);
      });
    }
    return el;
  }

  /** Arrow keys move between the options of a list box (Tab leaves it). */
  #listKeys(event, el) {
    if (el.getAttribute('role') !== 'option' && el.getAttribute('role') !== 'menuitem') return;
    const step = { ArrowDown: 1, ArrowUp: -1 }[event.key];
    if (!step) return;
    const list = el.closest('[role="listbox"], [role="menu"]');
    if (!list) return;
    const items = [...list.querySelectorAll('[role="option"], [role="menuitem"]')];
    const next = items[items.indexOf(el) + step];
    if (next) {
      event.preventDefault();
      next.focus();
    }
  }

  #put(node) {
    const tag = this.#tag(node);
    let entry = this.nodes.get(node.id);
    if (entry && entry.el.dataset.tag !== tag) {
      // The node changed what it is (e.g. a label became a button): a new element in its place.
      const el = this.#create(node, tag);
      entry.el.replaceWith(el);
      entry.el = el;
    }
    if (!entry) {
      entry = { el: this.#create(node, tag) };
      this.nodes.set(node.id, entry);
    }
    entry.node = node;
    const el = entry.el;
    const set = (name, value) => {
      if (value === undefined || value === null || value === '') el.removeAttribute(name);
      else if (el.getAttribute(name) !== String(value)) el.setAttribute(name, String(value));
    };
    const isRoot = node.id === this.rootId;
    if (isRoot) {
      set('role', null);
    } else if (tag === 'button') {
      set('role', node.role === 'button' ? null : node.role);
    } else if (tag.startsWith('input:')) {
      set('role', null);
    } else {
      set('role', node.role || null);
    }
    if (node.role === 'heading') set('aria-level', '3');
    // Names: controls and named groups by aria-label; text by its content.
    if (node.kind === 'text') {
      const text = node.text || node.name || '';
      if (el.textContent !== text) el.textContent = text;
      if (node.role === 'progressbar') {
        set('aria-label', node.name || text);
        set('aria-valuemin', 0);
        set('aria-valuemax', 1);
        set('aria-valuenow', node.now);
        set('aria-valuetext', node.text || null);
      }
    } else if (node.kind === 'control') {
      let name = node.name || node.value || '';
      if (node.haspopup && node.value && node.name && node.value !== node.name) name = `${node.name}: ${node.value}`;
      set('aria-label', name);
      if (tag === 'button' && el.textContent !== name) el.textContent = name;
    } else {
      if (node.name || !node.popup) set('aria-label', isRoot ? null : node.name);
      set('data-popup', node.popup ? 'true' : null);
    }
    if (node.kind === 'control') {
      if (CHECKED.has(node.role)) set('aria-checked', node.checked ?? 'false');
      else if (node.role === 'button' && node.checked !== undefined) set('aria-pressed', node.checked);
      else { set('aria-checked', null); set('aria-pressed', null); }
      set('aria-selected', node.role === 'option' || node.role === 'tab' ? String(node.selected === true) : null);
      set('aria-expanded', node.expanded === undefined ? (node.haspopup ? 'false' : null) : String(node.expanded));
      set('aria-haspopup', node.haspopup ?? null);
      set('aria-disabled', node.disabled ? 'true' : null);
      set('aria-description', node.description ?? null);
      if (tag === 'input:range' || tag === 'input:number') {
        const min = Number.isFinite(node.min) ? node.min : 0;
        const max = Number.isFinite(node.max) ? node.max : min + 1;
        set('min', min);
        set('max', max);
        set('step', Number.isFinite(node.step) && node.step > 0 ? node.step : (max - min) / 100 || 'any');
        // The viewer's value wins, except while a change made here has not reached it yet (some controls report
        // the value a frame after they apply it; keys pressed meanwhile would step from the old one).
        const now = Number.isFinite(node.now) ? String(node.now) : '';
        const sent = el.kloubSent;
        const caughtUp = !sent || Math.abs(Number(now) - sent.value) < 1e-6 || performance.now() - sent.at > 500;
        if (caughtUp) {
          el.kloubSent = undefined;
          if (el.value !== now) el.value = now;
        }
        set('aria-valuetext', valueText(node));
      } else if (tag === 'input:text') {
        if (el.value !== (node.value ?? '') && this.focused() !== el) el.value = node.value ?? '';
        set('placeholder', node.placeholder ?? null);
      }
      el.tabIndex = node.focusable ? 0 : -1;
    }
    // Where the widget is (controls and text; groups span the view).
    if (node.kind === 'control' || node.kind === 'text') {
      const px = (v) => `${Math.round(v * 10) / 10}px`;
      const style = el.style;
      if (Number.isFinite(node.x)) {
        style.left = px(node.x); style.top = px(node.y); style.width = px(Math.max(1, node.w)); style.height = px(Math.max(1, node.h));
      }
    }
  }

  #order(node) {
    const entry = this.nodes.get(node.id);
    if (!entry) return;
    const el = entry.el;
    // A new node goes under its parent; its place among its siblings is set when the parent is ordered (the parent's
    // list changed with it, so the parent is in the same update).
    if (!el.parentNode) ((node.parent !== null && this.nodes.get(node.parent)?.el) || this.root).append(el);
    // Controls and text hold no other nodes (their children are listed after them, under the parent).
    if (node.kind === 'control' || node.kind === 'text') return;
    let at = null;
    for (let i = node.children.length - 1; i >= 0; i--) {
      const child = this.nodes.get(node.children[i])?.el;
      if (!child) continue;
      if (child.parentNode !== el || child.nextSibling !== at) el.insertBefore(child, at);
      at = child;
    }
  }
}
