// The fleet-operations console: the Fleet tab of a server with named robots (`--robot
// NAME=SPEC`; hidden on a single-robot server). Robots with their battery, what the charging
// policy does with them (charging, going to charge, waiting for a dock, below the threshold —
// the thresholds from /fleet/policy) and an in/out of service switch (/fleet/set_in_service);
// a new task (fleettasks.js: dispatched now to the best robot by cost or a chosen one, the
// reply's bids shown, or added as a schedule); the task list with pause / resume / cancel and
// its history; the schedules. Times are the site's (/fleet/policy's time zone).
import { stateWords } from './fleet.js';
import { Schedules, TaskBoard, TaskForm } from './fleettasks.js';
import { SiteClock } from './fleetwords.js';
import { log } from './log.js';
import { SERVICES, TOPICS } from './names.js';
import { el } from './util.js';

const OPEN = ['queued', 'running', 'paused'];

/** What the charging policy does with robot `r` now: [data-charge value, words]. */
export function chargeWords(r, tasks, policy) {
  const charge = tasks.find((t) => t.kind === 'charge' && t.robot === r.name && OPEN.includes(t.state));
  const until = policy ? ` to ${Math.round(policy.charge_until)} %` : '';
  if (r.state === 'charging') return ['charging', `charging${until}`];
  if (charge && charge.state === 'running') return ['going', 'going to charge'];
  if (charge) return ['waiting', `waits to charge: ${charge.message}`];
  if (policy && r.battery < policy.charge_below && r.state !== 'offline') {
    return ['low', `below ${Math.round(policy.charge_below)} %: charges once free`];
  }
  return ['', ''];
}

export class FleetOps {
  /** `tab`: the side panel's Fleet tab button; `panels`: what app.js mounts in the tab. */
  constructor({ stores, tab }) {
    this.tab = tab;
    this.clock = new SiteClock();
    this.robots = [];
    this.tasks = [];
    this.policy = null;
    this.lastTask = 0;
    this.buttons = new Map(); // robot → its service button
    this.policyService = () => stores.call(SERVICES.fleetPolicy);
    this.serviceSwitch = (request) => stores.call(SERVICES.fleetSetInService, request);
    this.policyText = el('div', { class: 'fleetops-policy', id: 'fleetops-policy' }, 'charging policy –');
    this.list = el('ul', { class: 'fleetops-robots', id: 'fleetops-robots' });
    this.zone = el('div', { class: 'fleetops-zone', id: 'fleetops-zone' });
    const robotsPanel = el('section', { class: 'panel', id: 'fleetops-robots-panel' },
      el('h2', {}, 'Robots'), this.policyText, this.list, this.zone);
    this.schedules = new Schedules({ stores, clock: this.clock });
    this.form = new TaskForm({ stores, schedules: this.schedules });
    this.board = new TaskBoard({ stores, clock: this.clock });
    this.panels = [robotsPanel, this.form.panel, this.board.panel, this.schedules.panel];
    tab.addEventListener('click', () => this.schedules.refresh());
    window.addEventListener('bridge', (e) => { if (e.detail.online && this.robots.length) this.readPolicy(); });
    stores.topic(TOPICS.fleetRobots).subscribe((m) => this.onRobots(m.robots));
    stores.topic(TOPICS.fleetTasks).subscribe((m) => this.onTasks(m.tasks));
    stores.topic(TOPICS.pois).subscribe((m) => this.form.setPois(m.pois.map((p) => p.name)));
  }

  async readPolicy() {
    const { reply, error } = await this.policyService();
    if (error) {
      this.policyText.textContent = `charging policy: not reported by this server (${error})`;
      return;
    }
    this.policy = reply;
    this.clock.set(reply);
    this.shown = null;
    this.policyText.textContent = `Charging: a free robot under ${Math.round(reply.charge_below)} % goes to its dock ` +
      `and takes no task until ${Math.round(reply.charge_until)} %; a task takes ${reply.drain} % per metre, ` +
      `keeping ${Math.round(reply.reserve)} %.`;
    this.zone.textContent = `Times are the site's: ${this.clock.label}.`;
    this.showRobots();
    this.board.setTasks(this.tasks);
  }

  onRobots(robots) {
    const first = !this.robots.length && robots.length;
    this.robots = robots;
    this.tab.hidden = robots.length === 0;
    const names = robots.map((r) => r.name);
    this.form.setRobots(robots);
    this.board.setRobots(names);
    if (first) this.readPolicy();
    this.showRobots();
  }

  onTasks(tasks) {
    this.tasks = tasks;
    this.board.setTasks(tasks);
    this.form.setTasks(tasks);
    this.showRobots();
    const newest = Math.max(0, ...tasks.map((t) => t.id));
    if (newest > this.lastTask && this.lastTask) this.schedules.refresh(); // a slot may have fired
    this.lastTask = newest;
  }

  /** The robots' rows, made again only when what they show changed; each robot keeps its one
   * service button (moved, never replaced, so a click under way is not lost). */
  showRobots() {
    const shown = JSON.stringify(this.robots.map((r) => [r.name, r.state, Math.round(r.battery), r.task,
      r.in_service, r.message, chargeWords(r, this.tasks, this.policy)]));
    if (shown === this.shown) return;
    this.shown = shown;
    this.list.replaceChildren(...this.robots.map((r) => this.robotRow(r)));
  }

  /** Robot `name`'s service button: its words follow the robot; a click asks the other way. */
  serviceButton(name, serving) {
    if (!this.buttons.has(name)) {
      this.buttons.set(name, el('button', { type: 'button', dataset: { action: 'service' },
        onclick: (e) => this.setInService(name, e.currentTarget.dataset.serving !== 'true', e.currentTarget) }));
    }
    const button = this.buttons.get(name);
    button.dataset.serving = String(serving);
    button.className = `small${serving ? ' danger' : ''}`;
    button.title = serving ? 'It takes no task; its waiting tasks go to the others' : 'It takes tasks again';
    button.textContent = serving ? 'Take out of service' : 'Put back in service';
    return button;
  }

  robotRow(r) {
    const [charge, words] = chargeWords(r, this.tasks, this.policy);
    const serving = r.in_service !== false;
    const fill = el('span', { class: 'fill' });
    fill.style.width = `${Math.max(0, Math.min(100, r.battery))}%`;
    const low = this.policy && r.battery < this.policy.charge_below;
    return el('li', { dataset: { robot: r.name, state: r.state, charge, service: serving ? 'in' : 'out' } },
      el('div', { class: 'head' }, el('span', { class: 'name' }, r.name), ' ', el('span', { class: 'state' }, stateWords(r)),
        r.task ? el('span', { class: 'task' }, ` · task #${r.task}`) : null, this.serviceButton(r.name, serving)),
      el('div', { class: 'battery' }, el('span', { class: `bar${low ? ' low' : ''}` }, fill),
        el('span', { class: 'percent' }, ` ${Math.round(r.battery)} %`), words ? el('span', { class: 'charge' }, ` · ${words}`) : null),
      r.message && !['idle', 'waiting'].includes(r.state) ? el('div', { class: 'message' }, r.message) : null);
  }

  async setInService(robot, serving, button) {
    button.disabled = true;
    const { reply, error } = await this.serviceSwitch({ robot, in_service: serving });
    button.disabled = false;
    log(reply && reply.success ? 'info' : 'error', error ? `the server did not answer: ${error}` : reply.message);
    // the row itself changes with the next /fleet/robots (twice a second)
  }
}
