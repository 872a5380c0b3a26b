// The task side of the fleet-operations console (fleetops.js): the new-task form (dispatch now
// or as a schedule), the task list (live from /fleet/tasks, with pause / resume / cancel) and
// its history (/fleet/history), and the schedules (/fleet/schedule_list, _add, _remove).
import { log } from './log.js';
import { SERVICES } from './names.js';
import { BEST_ROBOT, KIND_WORDS, STATE_WORDS, robotWords, targetWords } from './fleetwords.js';
import { el, plural, quatOfYaw } from './util.js';

const OPEN = ['running', 'paused', 'queued'];
const input = (attrs) => el('input', { autocomplete: 'off', ...attrs });
const option = (value, text) => el('option', { value }, text);

/** Fill `select` with `options` ([value, text]), keeping its choice when still offered; left
 * alone when they are the ones it has (the lists come twice a second: an open choice stays open). */
function refill(select, options) {
  const have = [...select.options].map((o) => [o.value, o.textContent]);
  if (JSON.stringify(have) === JSON.stringify(options)) return;
  const kept = select.value;
  select.replaceChildren(...options.map(([value, text]) => option(value, text)));
  if (options.some(([value]) => value === kept)) select.value = kept;
}

/** A reply in `box`: its headline, and the bids ("why this robot") as a list. */
export function showReply(box, { ok, message, robot = '', id = 0 }) {
  const [head, bids] = message.split(' — bids: ');
  box.dataset.accepted = String(ok);
  box.dataset.robot = robot;
  box.dataset.id = String(id); // the task's or the schedule's (0: refused)
  box.replaceChildren(el('div', { class: 'headline' }, ok ? head : `Refused: ${head}`));
  if (!bids) return;
  const winner = robot || (head.match(/queued for (\S+)/) || [])[1] || 'this robot';
  const why = /\(asked for\)/.test(head) || (robot && bids.split('; ').length === 1)
    ? `Why ${winner}: asked for by name; its estimated finish time`
    : `Why ${winner}: each robot's estimated finish time, and the robots skipped`;
  box.append(el('div', { class: 'why' }, why),
    el('ul', { class: 'bids' }, ...bids.split('; ').map((b) => el('li', {}, b))));
}

/** What to do: a POI or a point (go to), POIs with dwell times (sequence), a route for N laps
 * (patrol); a priority; the best robot or a chosen one. Dispatched now, or as a schedule. */
export class TaskForm {
  constructor({ stores, schedules }) {
    this.dispatchService = (request) => stores.call(SERVICES.fleetDispatch, request);
    this.schedules = schedules;
    this.pois = [];
    this.kind = el('select', { id: 'fleetops-kind', onchange: () => this.showKind() },
      option('goto', 'go to a POI or a point'), option('sequence', 'a sequence of POIs'), option('patrol', 'patrol a route'));
    this.poi = el('select', { id: 'fleetops-poi', onchange: () => this.showKind() });
    this.pose = ['x', 'y', 'yaw'].map((k) => input({ id: `fleetops-${k}`, type: 'number', step: k === 'yaw' ? '15' : '0.1', value: '0', 'aria-label': k === 'yaw' ? 'heading (°)' : `${k} (m)`,
      oninput: () => { this.placed = true; } }));
    this.poseRow = el('div', { class: 'fleetops-pose' }, 'x ', this.pose[0], ' y ', this.pose[1], ' heading ', this.pose[2], ' °');
    this.stops = el('ol', { class: 'fleetops-stops', id: 'fleetops-stops' });
    this.laps = input({ id: 'fleetops-laps', type: 'number', min: '1', max: '100', value: '1' });
    this.lapsRow = el('label', {}, 'laps ', this.laps);
    this.route = el('div', { class: 'fleetops-route' }, this.stops,
      el('button', { type: 'button', class: 'small', id: 'fleetops-add-stop', onclick: () => this.addStop() }, 'Add stop'), this.lapsRow);
    this.priority = input({ id: 'fleetops-priority', type: 'number', min: '-100', max: '100', value: '0' });
    this.robot = el('select', { id: 'fleetops-robot' }, option('', BEST_ROBOT));
    this.placed = false; // the operator typed a point: it is theirs, not the default's
    this.when = input({ id: 'fleetops-when', placeholder: 'every 2 h, or daily 09:00', maxlength: '40' });
    this.reply = el('div', { class: 'fleetops-reply', id: 'fleetops-reply', role: 'status' });
    this.panel = el('section', { class: 'panel', id: 'fleetops-new' }, el('h2', {}, 'New task'),
      el('label', {}, 'what ', this.kind), el('label', { class: 'fleetops-target' }, 'where ', this.poi), this.poseRow,
      this.route, el('label', {}, 'priority ', this.priority, el('small', {}, ' −100 to 100, higher first')),
      el('label', {}, 'robot ', this.robot),
      el('div', { class: 'row' }, el('button', { type: 'button', id: 'fleetops-dispatch', onclick: () => this.dispatch() }, 'Dispatch now')),
      el('div', { class: 'row fleetops-repeat' }, this.when,
        el('button', { type: 'button', id: 'fleetops-schedule', onclick: () => this.schedule() }, 'Add as schedule')),
      this.reply);
    this.addStop();
    this.addStop();
    this.showKind();
  }

  setPois(names) {
    this.pois = names;
    refill(this.poi, [...names.map((n) => [n, n]), ['', 'a point on the map…']]);
    for (const select of this.stops.querySelectorAll('select')) refill(select, names.map((n) => [n, n]));
    this.showKind();
  }

  /** The robots (/fleet/robots): the choice of one, and the point's default where the first
   * one stands (a free spot of the map: (0, 0) is inside the office's outer wall). */
  setRobots(robots) {
    refill(this.robot, [['', BEST_ROBOT], ...robots.map((r) => [r.name, r.name])]);
    const here = robots.find((r) => r.state !== 'offline');
    if (this.placed || !here) return;
    const p = here.pose.position;
    this.pose[0].value = p.x.toFixed(1);
    this.pose[1].value = p.y.toFixed(1);
  }

  addStop() {
    const select = el('select', { class: 'stop-poi', 'aria-label': 'POI' }, ...this.pois.map((n) => option(n, n)));
    const dwell = input({ class: 'stop-dwell', type: 'number', min: '0', max: '3600', step: '1', value: '0', 'aria-label': 'wait (s)' });
    const li = el('li', {}, select, el('span', { class: 'dwell' }, ' wait ', dwell, ' s'),
      el('button', { type: 'button', class: 'small', title: 'Remove this stop', onclick: () => li.remove() }, '✕'));
    if (this.stops.children.length < this.pois.length) select.selectedIndex = this.stops.children.length;
    this.stops.append(li);
  }

  showKind() {
    const kind = this.kind.value;
    this.panel.dataset.kind = kind;
    this.poi.closest('label').hidden = kind !== 'goto';
    this.poseRow.hidden = kind !== 'goto' || this.poi.value !== '';
    this.route.hidden = kind === 'goto';
    this.lapsRow.hidden = kind !== 'patrol';
  }

  /** The Dispatch (and FleetScheduleAdd) fields of what the form says. */
  request() {
    const kind = this.kind.value;
    const [x, y, yaw] = this.pose.map((i) => Number(i.value) || 0);
    const stops = [...this.stops.children];
    return {
      kind, poi: kind === 'goto' ? this.poi.value : '',
      pose: { position: { x, y, z: 0 }, orientation: quatOfYaw((yaw * Math.PI) / 180) },
      pois: kind === 'goto' ? [] : stops.map((li) => li.querySelector('select').value),
      dwell: kind === 'sequence' ? stops.map((li) => Number(li.querySelector('.stop-dwell').value) || 0) : [],
      laps: kind === 'patrol' ? Math.round(Number(this.laps.value) || 1) : 1,
      priority: Math.round(Number(this.priority.value) || 0), robot: this.robot.value,
    };
  }

  /** The reply box while a request is on its way (the last reply is not taken for this one's). */
  asking() {
    for (const key of ['accepted', 'robot', 'id', 'ended', 'schedule']) delete this.reply.dataset[key];
    this.reply.replaceChildren(el('div', { class: 'headline' }, 'asking the fleet…'));
  }

  async dispatch() {
    this.asking();
    const { reply, error } = await this.dispatchService(this.request());
    if (error) return this.refused(`the server did not answer: ${error}`);
    showReply(this.reply, { ok: reply.accepted, message: reply.message, robot: reply.robot, id: reply.task });
    log(reply.accepted ? 'info' : 'error', `dispatch: ${reply.message.split(' — ')[0]}`);
    return reply;
  }

  /** The tasks changed: a dispatch's reply ("task 6: b is on its way") is replaced once its
   * task has failed or was cancelled, by what happened (it used to stay). */
  setTasks(tasks) {
    const shown = this.reply.dataset.id;
    const t = shown && this.reply.dataset.accepted === 'true' && !this.reply.dataset.schedule
      ? tasks.find((task) => String(task.id) === shown) : null;
    if (!t || !['failed', 'cancelled'].includes(t.state) || this.reply.dataset.ended === t.state) return;
    this.reply.dataset.ended = t.state;
    const why = t.message && t.message !== t.state ? `: ${t.message}` : '';
    this.reply.querySelector('.headline').textContent = `task ${t.id} ${STATE_WORDS[t.state]}${why}`;
  }

  async schedule() {
    this.asking();
    const { reply, error } = await this.schedules.add({ when: this.when.value, ...this.request() });
    if (error) return this.refused(`the server did not answer: ${error}`);
    showReply(this.reply, { ok: reply.success, message: reply.message, id: reply.id });
    this.reply.dataset.schedule = 'true'; // its id is a schedule's, not a task's
    log(reply.success ? 'info' : 'error', `schedule: ${reply.message}`);
    return reply;
  }

  refused(text) {
    showReply(this.reply, { ok: false, message: text });
    log('error', text);
  }
}

/** One task as a list row: what, where, who, its state and times, why it waits or failed. */
function taskRow(t, clock, act) {
  const li = el('li', { dataset: { task: String(t.id), state: t.state, robot: t.assigned || t.robot } },
    el('div', { class: 'head' }, el('span', { class: 'id' }, `#${t.id}`), ' ',
      el('span', { class: 'kind' }, KIND_WORDS[t.kind] || t.kind), ' ',
      el('span', { class: 'target' }, targetWords(t)), ' ',
      el('span', { class: 'state' }, STATE_WORDS[t.state] || t.state)),
    el('div', { class: 'who' }, robotWords(t), t.priority ? ` · priority ${t.priority}` : '',
      t.tried && t.tried.length ? ` · failed on ${t.tried.join(', ')}` : ''),
    el('div', { class: 'times' }, `created ${clock.format(t.created)} · started ${clock.format(t.started)} · ` +
      `finished ${clock.format(t.finished)}`),
    el('div', { class: 'message' }, t.message));
  if (act && OPEN.includes(t.state)) {
    const button = (action, text, cls = '') => el('button', { type: 'button', class: `small ${cls}`, dataset: { action },
      onclick: (e) => act(action, t, e.target) }, text);
    li.append(el('div', { class: 'actions' },
      t.state === 'paused' ? button('resume', 'Resume') : button('pause', 'Pause'),
      button('cancel', 'Cancel', 'danger')));
  }
  return li;
}

/** The tasks: live (open first, then the last finished) and the history, by robot. */
export class TaskBoard {
  constructor({ stores, clock }) {
    this.clock = clock;
    const call = (name) => (request) => stores.call(name, request);
    this.services = { pause: call(SERVICES.fleetPause), resume: call(SERVICES.fleetResume), cancel: call(SERVICES.fleetCancel) };
    this.history = call(SERVICES.fleetHistory);
    this.tasks = [];
    this.finished = new Set();
    this.live = el('ul', { class: 'fleetops-tasks', id: 'fleetops-tasks' }, el('li', { class: 'empty' }, 'no tasks yet'));
    this.historyRobot = el('select', { id: 'fleetops-history-robot', 'aria-label': 'robot', onchange: () => this.refreshHistory() }, option('', 'every robot'));
    this.limit = input({ id: 'fleetops-history-limit', type: 'number', min: '1', max: '1000', value: '50', 'aria-label': 'at most', onchange: () => this.refreshHistory() });
    this.historyList = el('ul', { class: 'fleetops-tasks', id: 'fleetops-history' }, el('li', { class: 'empty' }, '–'));
    this.historyView = el('div', { hidden: true }, el('div', { class: 'row' }, this.historyRobot, el('label', {}, 'newest ', this.limit),
      el('button', { type: 'button', class: 'small', id: 'fleetops-history-refresh', title: 'Read the history again', onclick: () => this.refreshHistory() }, '↻')),
    this.historyList);
    this.views = el('div', { class: 'fleetops-views', role: 'tablist' },
      ...[['live', 'Current'], ['history', 'History']].map(([view, text]) => el('button', { type: 'button', role: 'tab',
        class: view === 'live' ? 'active' : '', dataset: { view }, onclick: () => this.show(view) }, text)));
    this.panel = el('section', { class: 'panel', id: 'fleetops-tasks-panel', dataset: { view: 'live' } },
      el('h2', {}, 'Tasks ', el('span', { class: 'count', id: 'fleetops-task-count' })), this.views, this.live, this.historyView);
  }

  show(view) {
    this.panel.dataset.view = view;
    for (const b of this.views.children) b.classList.toggle('active', b.dataset.view === view);
    this.live.hidden = view !== 'live';
    this.historyView.hidden = view !== 'history';
    if (view === 'history') this.refreshHistory();
  }

  setRobots(names) {
    refill(this.historyRobot, [['', 'every robot'], ...names.map((n) => [n, n])]);
  }

  /** /fleet/tasks: open ones first (running, paused, waiting; by priority), then the finished,
   * newest first. The history is read again when a task has finished. */
  setTasks(tasks) {
    this.tasks = tasks;
    const open = tasks.filter((t) => OPEN.includes(t.state))
      .sort((a, b) => OPEN.indexOf(a.state) - OPEN.indexOf(b.state) || b.priority - a.priority || a.id - b.id);
    const done = tasks.filter((t) => !OPEN.includes(t.state)).sort((a, b) => b.finished - a.finished || b.id - a.id);
    document.getElementById('fleetops-task-count').textContent = open.length ? `${open.length} open` : '';
    const rows = [...open, ...done].map((t) => taskRow(t, this.clock, (a, task, b) => this.act(a, task, b)));
    this.live.replaceChildren(...(rows.length ? rows : [el('li', { class: 'empty' }, 'no tasks yet')]));
    const ended = done.filter((t) => !this.finished.has(t.id));
    for (const t of ended) this.finished.add(t.id);
    if (ended.length && this.panel.dataset.view === 'history') this.refreshHistory();
  }

  async act(action, task, button) {
    for (const b of button.parentElement.querySelectorAll('button')) b.disabled = true;
    const { reply, error } = await this.services[action]({ task: task.id });
    const text = error ? `the server did not answer: ${error}` : reply.message;
    log(reply && reply.success ? 'info' : 'error', text);
    if (!reply || !reply.success) {
      for (const b of button.parentElement.querySelectorAll('button')) b.disabled = false;
      const row = button.closest('li');
      if (row) row.append(el('div', { class: 'refused' }, `Refused: ${text}`));
    }
  }

  async refreshHistory() {
    const limit = Math.max(1, Math.min(1000, Math.round(Number(this.limit.value) || 50)));
    const { reply, error } = await this.history({ robot: this.historyRobot.value, limit });
    if (error) {
      this.historyList.replaceChildren(el('li', { class: 'empty' }, `the history cannot be read: ${error}`));
      return;
    }
    const rows = reply.tasks.map((t) => taskRow(t, this.clock, null));
    this.historyList.replaceChildren(...(rows.length ? rows : [el('li', { class: 'empty' }, 'nothing finished yet')]));
    this.historyList.dataset.count = String(rows.length);
  }
}

/** The recurring tasks: listed with their next and last slots and what the last one did (or the
 * slots missed while the server was down), each removable; added from the task form. */
export class Schedules {
  constructor({ stores, clock }) {
    this.clock = clock;
    this.addService = (request) => stores.call(SERVICES.fleetScheduleAdd, request);
    this.listService = () => stores.call(SERVICES.fleetScheduleList);
    this.removeService = (request) => stores.call(SERVICES.fleetScheduleRemove, request);
    this.list = el('ul', { class: 'fleetops-schedules', id: 'fleetops-schedules' }, el('li', { class: 'empty' }, '–'));
    this.panel = el('section', { class: 'panel', id: 'fleetops-schedules-panel' },
      el('h2', {}, 'Schedules ', el('span', { class: 'count', id: 'fleetops-schedule-count' }),
        el('button', { type: 'button', class: 'small', id: 'fleetops-schedules-refresh', title: 'List again', onclick: () => this.refresh() }, '↻')),
      this.list, el('div', { class: 'hint-text' }, 'Add one from New task: what to do, then when, then “Add as schedule”.'));
  }

  async add(request) {
    const answer = await this.addService(request);
    if (answer.reply && answer.reply.success) await this.refresh();
    return answer;
  }

  async remove(id, button) {
    button.disabled = true;
    const { reply, error } = await this.removeService({ task: id });
    log(reply && reply.success ? 'info' : 'error', error ? `the server did not answer: ${error}` : reply.message);
    await this.refresh();
  }

  async refresh() {
    const { reply, error } = await this.listService();
    if (error) {
      this.list.replaceChildren(el('li', { class: 'empty' }, `the schedules cannot be read: ${error}`));
      return;
    }
    const schedules = reply.schedules;
    document.getElementById('fleetops-schedule-count').textContent = schedules.length ? plural(schedules.length, 'schedule') : '';
    this.list.replaceChildren(...(schedules.length ? schedules.map((s) => this.row(s))
      : [el('li', { class: 'empty' }, 'no schedules')]));
  }

  row(s) {
    const kind = s.kind || 'goto';
    const target = (s.pois || []).length && kind !== 'goto' ? s.pois.join(' → ') : s.poi || 'a point on the map';
    return el('li', { dataset: { schedule: String(s.id), missed: String(/missed/.test(s.message)) } },
      el('div', { class: 'head' }, el('span', { class: 'id' }, `#${s.id}`), ' ', el('span', { class: 'when' }, s.when), ' · ',
        `${KIND_WORDS[kind] || kind} ${target} · ${s.robot || BEST_ROBOT}`,
        el('button', { type: 'button', class: 'small danger', dataset: { action: 'remove' }, onclick: (e) => this.remove(s.id, e.target) }, 'Remove')),
      el('div', { class: 'times' }, `next ${this.clock.format(s.next)} · last ${this.clock.format(s.last)}`),
      s.message ? el('div', { class: 'message' }, s.message) : null);
  }
}
