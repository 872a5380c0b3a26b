// The fleet's mutex zones (a door, a narrow corridor: one robot inside at a time) on the map,
// from the latched /fleet/zones (hitrobot_msgs/FleetZones): each polygon's outline and name,
// filled while a robot holds it, with who holds it and who waits. A panel lists them with a
// Remove button each, and draws a new one: "Draw a zone", click its corners on the map, name
// it, Save (/fleet/zone_add). Shown on a fleet server only (one with /fleet/robots).
/* global createjs */
import { label as named } from './labels.js';
import { SERVICES, TOPICS } from './names.js';
import { Layer } from './overlays.js';
import { el } from './util.js';

export const ZONE_COLOR = '#7b1fa2'; // a free zone's outline
export const HELD_COLOR = '#d50000'; // a held zone's outline and fill
const DRAFT_COLOR = '#ff6f00';

/** A zone in the operator's words: "corridor_a (corridor) — held by a; waiting: b". */
export function zoneWords(z) {
  let text = `${z.name} (${z.kind})`;
  text += z.holders.length ? ` — held by ${z.holders.join(', ')}` : ' — free';
  if (z.waiting.length) text += `; waiting: ${z.waiting.join(', ')}`;
  return text;
}

class ZonesLayer extends Layer {
  constructor(view) {
    super(view);
    this.zones = [];
    this.draft = [];
  }

  set(zones) {
    this.zones = zones;
    this.changed();
  }

  setDraft(points) {
    this.draft = points;
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    this.node.removeAllChildren();
    for (const z of this.zones) {
      const pts = z.polygon.points;
      if (pts.length < 3) continue;
      const held = z.holders.length > 0;
      const shape = new createjs.Shape();
      const g = shape.graphics.setStrokeStyle(3 * u).beginStroke(held ? HELD_COLOR : ZONE_COLOR);
      if (held) g.beginFill('rgba(213, 0, 0, 0.18)');
      g.moveTo(pts[0].x, -pts[0].y);
      for (const p of pts.slice(1)) g.lineTo(p.x, -p.y);
      g.closePath().endStroke();
      if (held) g.endFill();
      const label = new createjs.Text(held ? `${z.name} · ${z.holders.join(', ')}` : z.name,
        'bold 12px sans-serif', held ? HELD_COLOR : ZONE_COLOR);
      label.x = Math.min(...pts.map((p) => p.x));
      label.y = -Math.max(...pts.map((p) => p.y));
      label.scaleX = label.scaleY = u;
      label.textBaseline = 'bottom';
      this.node.addChild(shape, named(label, z.name)); // kept off robots and other names
    }
    if (this.draft.length) {
      const shape = new createjs.Shape();
      const g = shape.graphics.setStrokeStyle(2 * u).setStrokeDash([6 * u, 4 * u]).beginStroke(DRAFT_COLOR);
      g.moveTo(this.draft[0].x, -this.draft[0].y);
      for (const p of this.draft.slice(1)) g.lineTo(p.x, -p.y);
      if (this.draft.length > 2) g.closePath();
      g.endStroke();
      for (const p of this.draft) g.beginFill(DRAFT_COLOR).drawCircle(p.x, -p.y, 4 * u).endFill();
      this.node.addChild(shape);
    }
  }
}

export class Zones {
  constructor({ stores, view }) {
    this.view = view;
    this.zones = [];
    this.draft = null; // the corners clicked so far while drawing
    this.layer = new ZonesLayer(view);
    this.panel = this.buildPanel();
    this.stores = stores;
    stores.topic(TOPICS.fleetZones).subscribe((m) => this.onZones(m.zones));
    stores.topic(TOPICS.fleetRobots).subscribe((m) => { this.panel.hidden = m.robots.length === 0; });
    // before the map tools (a click while drawing is a corner, not a pan)
    view.canvas.parentElement.addEventListener('pointerdown', (e) => this.corner(e), true);
  }

  buildPanel() {
    const input = (id, maxlength, placeholder) => el('input', { id, maxlength, placeholder });
    const button = (id, text, onclick) => el('button', { type: 'button', class: 'small', id, onclick }, text);
    return el('section', { class: 'panel', id: 'zones-panel', hidden: true },
      el('h2', {}, 'Mutex zones ', el('span', { class: 'count', id: 'zones-count' })),
      el('ul', { class: 'zones-list', id: 'zones-list' }, el('li', { class: 'empty' }, 'none')),
      button('zone-draw', 'Draw a zone', () => this.startDraft()),
      el('div', { id: 'zone-form', hidden: true },
        el('p', { class: 'hint' }, "Click the zone's corners on the map, then name it."),
        el('label', {}, 'name ', input('zone-name', '64', 'corridor_a')), ' ',
        el('label', {}, 'kind ', input('zone-kind', '32', 'corridor, door')), ' ',
        button('zone-save', 'Save', () => this.save()), ' ',
        button('zone-cancel', 'Cancel', () => this.endDraft())),
      el('div', { class: 'zones-reply', id: 'zones-reply' }));
  }

  onZones(zones) {
    this.zones = zones;
    this.layer.set(zones);
    document.getElementById('zones-count').textContent = String(zones.length);
    const list = document.getElementById('zones-list');
    if (!zones.length) {
      list.replaceChildren(el('li', { class: 'empty' }, 'none'));
      return;
    }
    list.replaceChildren(...zones.map((z) => el('li', { dataset: { zone: z.name, held: z.holders.length ? 'yes' : 'no' } },
      el('span', {}, `${zoneWords(z)} `),
      el('button', { type: 'button', class: 'small', dataset: { removeZone: z.name }, onclick: () => this.remove(z.name) }, 'Remove'))));
  }

  reply(text) {
    document.getElementById('zones-reply').textContent = text;
  }

  startDraft() {
    this.draft = [];
    this.panel.querySelector('#zone-form').hidden = false;
    this.layer.setDraft([]);
    this.reply('');
  }

  endDraft() {
    this.draft = null;
    this.panel.querySelector('#zone-form').hidden = true;
    this.layer.setDraft([]);
  }

  corner(e) {
    if (this.draft === null || e.target !== this.view.canvas || e.button !== 0) return;
    e.stopPropagation();
    e.preventDefault();
    this.draft.push(this.view.clientToRos(e.clientX, e.clientY));
    this.layer.setDraft([...this.draft]);
  }

  async save() {
    const name = document.getElementById('zone-name').value.trim();
    const kind = document.getElementById('zone-kind').value.trim();
    const points = (this.draft || []).map((p) => ({ x: p.x, y: p.y, z: 0 }));
    const { reply, error } = await this.stores.call(SERVICES.fleetZoneAdd, { name, kind, polygon: { points } });
    if (error) {
      this.reply(`not added: ${error}`);
      return;
    }
    this.reply(reply.message);
    if (reply.success) this.endDraft();
  }

  async remove(name) {
    const { reply, error } = await this.stores.call(SERVICES.fleetZoneRemove, { name });
    this.reply(error ? `not removed: ${error}` : reply.message);
  }
}
