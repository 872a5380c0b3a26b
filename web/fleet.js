// The fleet view (a server with named robots, `--robot NAME=SPEC`): every robot of
// /fleet/robots on the map in its own colour with its state, a choice of the robot that the
// drive pad, the goal and set-pose tools and "Go" act on (the current robot, currentrobot.js:
// those panels follow it and move their names under /NAME/), the POIs with a Dispatch button
// each (/fleet/dispatch picks the best robot by cost: the soonest to finish, its charge counted),
// and the task list of /fleet/tasks with Cancel; a dispatch's reply says so when its task ends. It stays hidden on a single-robot server (no /fleet/robots).
/* global createjs */
import { CurrentRobot } from './currentrobot.js';
import { BEST_ROBOT, STATE_WORDS } from './fleetwords.js';
import { avoid, label as named } from './labels.js';
import { log } from './log.js';
import { SERVICES, TOPICS } from './names.js';
import { el, yawOf } from './util.js';

const FAINT = 0.45; // the robots not chosen, on the map

/** A robot's state in the operator's words. */
export function stateWords(r) {
  if (r.in_service === false) return 'out of service';
  if (r.state === 'waiting') return r.message || 'waiting for a zone'; // before a mutex zone
  return { idle: 'idle', moving: 'moving', charging: 'charging', error: 'in error', offline: 'offline' }[r.state] || r.state;
}


export const FLEET_COLORS = ['#e53935', '#43a047', '#fb8c00', '#8e24aa', '#00897b', '#3949ab',
  '#6d4c41', '#c0ca33'];

/** A map layer with a coloured marker and the name of every robot. */
class FleetLayer {
  /** `marker`: the chosen robot's live marker (app.js's RobotMarker), which draws that one. */
  constructor(view, marker = null) {
    this.view = view;
    this.marker = marker;
    this.node = new createjs.Container();
    this.node.mouseEnabled = false;
    this.robots = [];
    this.dirty = true;
    view.addLayer(this);
  }

  set(robots, colorOf, selected) {
    this.robots = robots.map((r) => ({ ...r, color: colorOf(r.name), selected: r.name === selected }));
    this.dirty = true;
    this.view.requestRender();
  }

  render(view) {
    const u = view.metresPerPixel;
    this.node.removeAllChildren();
    if (this.marker) this.marker.setLabel(null);
    for (const r of this.robots) {
      if (r.selected && this.marker) { // drawn once, where it is now: by its live marker
        this.marker.setLabel(`${r.name} · ${stateWords(r)}`, r.color);
        continue;
      }
      const at = new createjs.Container();
      at.alpha = r.selected ? 1 : FAINT;
      at.x = r.pose.position.x;
      at.y = -r.pose.position.y;
      at.scaleX = at.scaleY = u;
      const body = new createjs.Shape();
      body.rotation = (-yawOf(r.pose.orientation) * 180) / Math.PI;
      const radius = Math.max(0.2 / u, 9);
      const g = body.graphics;
      if (r.selected) g.setStrokeStyle(3).beginStroke('#ffeb3b').drawCircle(0, 0, radius + 4).endStroke();
      g.setStrokeStyle(2).beginStroke('#222').beginFill(r.state === 'offline' || r.in_service === false ? '#9e9e9e' : r.color)
        .drawCircle(0, 0, radius).endStroke().endFill();
      g.beginFill('#fff').moveTo(radius * 0.75, 0).lineTo(-radius * 0.35, radius * 0.45)
        .lineTo(-radius * 0.1, 0).lineTo(-radius * 0.35, -radius * 0.45).closePath().endFill();
      const label = new createjs.Text(`${r.name} · ${stateWords(r)}`, 'bold 12px sans-serif', r.color);
      label.x = radius + 4;
      label.y = -radius - 10;
      at.addChild(avoid(body, radius), named(label, r.name));
      this.node.addChild(at);
    }
  }
}

export class Fleet {
  /** `robot`: the current robot (a CurrentRobot), which this panel chooses and shows. */
  constructor({ stores, view, robot = new CurrentRobot(), marker = null }) {
    this.robot = robot;
    this.robots = [];
    this.tasks = [];
    this.pois = [];
    this.colors = new Map();
    this.layer = new FleetLayer(view, marker);
    this.panel = this.buildPanel();
    robot.follow((name) => this.showSelected(name));
    this.stores = stores;
    stores.topic(TOPICS.fleetRobots).subscribe((m) => this.onRobots(m.robots));
    stores.topic(TOPICS.fleetTasks).subscribe((m) => { this.tasks = m.tasks; this.showTasks(); });
    stores.topic(TOPICS.pois).subscribe((m) => { this.pois = m.pois; this.showPois(); });
  }

  /** The robot the tools act on (null until one is chosen). */
  get selected() {
    return this.robot.name;
  }

  buildPanel() {
    return el('section', { class: 'panel', id: 'fleet-panel', hidden: true },
      el('h2', {}, 'Fleet ', el('span', { class: 'count', id: 'fleet-count' })),
      el('ul', { class: 'fleet-robots', id: 'fleet-robots' }),
      el('h2', {}, 'Dispatch to a POI'),
      el('label', { class: 'fleet-send' }, 'send ', el('select', { id: 'fleet-send' }, el('option', { value: '' }, BEST_ROBOT))),
      el('ul', { class: 'fleet-pois', id: 'fleet-pois' }, el('li', { class: 'empty' }, 'no POIs')),
      el('div', { class: 'fleet-reply', id: 'fleet-reply' }),
      el('h2', {}, 'Tasks'),
      el('ul', { class: 'fleet-tasks', id: 'fleet-tasks' }, el('li', { class: 'empty' }, 'none')));
  }

  colorOf(name) {
    if (!this.colors.has(name)) this.colors.set(name, FLEET_COLORS[this.colors.size % FLEET_COLORS.length]);
    return this.colors.get(name);
  }

  onRobots(robots) {
    this.robots = robots;
    this.panel.hidden = robots.length === 0;
    if (!this.selected && robots.length) this.select(robots[0].name);
    this.layer.set(robots, (n) => this.colorOf(n), this.selected);
    document.getElementById('fleet-count').textContent = String(robots.length);
    this.showSendChoice(robots);
    const list = document.getElementById('fleet-robots');
    list.replaceChildren(...robots.map((r) => {
      const swatch = el('span', { class: 'swatch' });
      // set through the CSSOM: the page's CSP refuses style attributes
      swatch.style.cssText = `display:inline-block;width:0.8em;height:0.8em;border-radius:50%;background:${this.colorOf(r.name)}`;
      return el('li', { dataset: { robot: r.name, state: r.state, service: r.in_service === false ? 'out' : 'in' } },
        el('label', {},
          el('input', { type: 'radio', name: 'fleet-robot', value: r.name, checked: r.name === this.selected, onchange: () => this.select(r.name) }),
          swatch,
          el('span', { class: 'fleet-state' }, ` ${r.name} — ${stateWords(r)}, ${Math.round(r.battery)} %${r.task ? `, task ${r.task}` : ''}`)));
    }));
  }

  /** The "send" choice: the best robot, or one by name (kept across updates). */
  showSendChoice(robots) {
    const select = document.getElementById('fleet-send');
    const names = robots.map((r) => r.name);
    const have = [...select.options].slice(1).map((o) => o.value);
    if (names.join('\n') === have.join('\n')) return;
    const kept = select.value;
    select.replaceChildren(select.options[0], ...names.map((n) => el('option', { value: n }, n)));
    select.value = names.includes(kept) ? kept : '';
  }

  /** The drive pad, the goal/set-pose tools and "Go" now act on robot `name` (under /name/):
   * the panels that act on one robot follow the current robot. */
  select(name) {
    this.robot.set(name);
  }

  /** Robot `name` was chosen: marked in the list and on the map. */
  showSelected(name) {
    this.panel.dataset.selected = name;
    this.layer.set(this.robots, (n) => this.colorOf(n), name);
    for (const input of this.panel.querySelectorAll('input[name="fleet-robot"]')) input.checked = input.value === name;
    log('info', `the tools now drive ${name}`);
  }

  showPois() {
    const list = document.getElementById('fleet-pois');
    if (!this.pois.length) {
      list.replaceChildren(el('li', { class: 'empty' }, 'no POIs'));
      return;
    }
    list.replaceChildren(...this.pois.map((p) => el('li', {}, `${p.name} `,
      el('button', { type: 'button', class: 'small', dataset: { dispatch: p.name }, title: 'Send the robot chosen above, or the best one',
        onclick: () => this.dispatch(p.name) }, 'Dispatch'))));
  }

  async dispatch(poi) {
    const reply = document.getElementById('fleet-reply');
    const zero = { position: { x: 0, y: 0, z: 0 }, orientation: { x: 0, y: 0, z: 0, w: 1 } };
    const robot = document.getElementById('fleet-send').value; // '' = the best robot
    const { reply: r, error } = await this.stores.call(SERVICES.fleetDispatch, { poi, pose: zero, robot });
    if (error) {
      reply.textContent = error;
      reply.dataset.accepted = 'false';
      log('error', `dispatch to ${poi}: ${error}`);
      return;
    }
    reply.textContent = r.message;
    reply.dataset.accepted = String(r.accepted);
    reply.dataset.robot = r.robot;
    reply.dataset.task = String(r.task || 0);
    this.showTasks();
    log(r.accepted ? 'info' : 'error', `dispatch to ${poi}: ${r.message}`);
  }

  showTasks() {
    this.showOutcome();
    const list = document.getElementById('fleet-tasks');
    if (!this.tasks.length) {
      list.replaceChildren(el('li', { class: 'empty' }, 'none'));
      return;
    }
    list.replaceChildren(...[...this.tasks].reverse().map((t) => el('li', { dataset: { task: String(t.id), state: t.state } },
      `#${t.id} ${t.poi || 'pose'} — ${STATE_WORDS[t.state] || t.state}${t.assigned ? ` (${t.assigned})` : ''}: ${t.message} `,
      t.state === 'queued' || t.state === 'running'
        ? el('button', { type: 'button', class: 'small danger', onclick: () => this.cancel(t.id) }, 'Cancel') : null)));
  }

  async cancel(task) {
    const { reply, error } = await this.stores.call(SERVICES.fleetCancel, { task });
    if (reply) log(reply.success ? 'info' : 'error', reply.message);
    else log('error', `cancel task ${task}: ${error}`);
  }

  /** The last dispatch's reply ("task 6: b is on its way") once its task has ended: what
   * happened instead (it used to stay, after the task failed). */
  showOutcome() {
    const reply = document.getElementById('fleet-reply');
    const t = this.tasks.find((task) => String(task.id) === reply.dataset.task);
    if (!t || !['succeeded', 'failed', 'cancelled'].includes(t.state)) return;
    reply.dataset.state = t.state;
    reply.textContent = `task ${t.id} ${STATE_WORDS[t.state]}${t.message && t.message !== t.state ? `: ${t.message}` : ''}`;
  }
}
