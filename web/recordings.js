// Record and replay in the console.
// Recordings (Status tab): start/stop a recording on the server (/record/start, /record/stop),
// its size growing (/record/state), the recordings folder (/record/list) with download links
// (/recordings/NAME on this server's port).
// Incidents (in the same panel, when the server keeps a black box, --black-box): the files an
// incident left, with their cause (/record/incidents, refreshed on /record/incident), the
// black box saved on demand (/record/snapshot), and a replay in two clicks: Replay starts
// `hitrobot-server replay` on a port of its own (/record/replay), Open replay opens it.
// ReplayTimeline (over the map): shown when the server replays a file (`hitrobot-server
// replay`): play/pause, a seek bar, position/duration and the speed, from /replay/state; a
// black-box file's incident shown and marked on it (replayincident.js). A replay's server has
// none of the live server's record services: in a replay they are not called, and their
// absence is no error.
import { quietWhen } from './connection.js';
import { log } from './log.js';
import { SERVICES, TOPICS } from './names.js';
import { withToken } from './signin.js';
import { CAUSES, ReplayIncident, replayLink } from './replayincident.js';
import { el, plural } from './util.js';

/** Whether this page is a replay's: set by the first /replay/state. */
export const replay = { on: false };
/** A service the replaying server has not (the black box's): no news in a replay. */
const missingInReplay = (text) => replay.on && /does not exist/.test(String(text));
quietWhen(missingInReplay);

const SPEEDS = [0.25, 0.5, 1, 2, 4, 8];

function formatBytes(n) {
  if (n >= 1e9) return `${(n / 1e9).toFixed(2)} GB`;
  if (n >= 1e6) return `${(n / 1e6).toFixed(1)} MB`;
  if (n >= 1e3) return `${(n / 1e3).toFixed(0)} kB`;
  return `${n} B`;
}

function formatTime(s) {
  const m = Math.floor(s / 60);
  return `${m}:${(s - m * 60).toFixed(1).padStart(4, '0')}`;
}

/** Service `name` as a function of its request: resolves the reply, or null when the call
 * failed; a failure or a refusal is said in Messages (a service a replay has not, quietly). */
function caller(stores, name) {
  return async (args = {}) => {
    const { reply, error } = await stores.call(name, args);
    if (error) {
      if (!missingInReplay(error)) log('error', `${name} failed: ${error}`);
      return null;
    }
    if (reply.success === false) log('error', `${name}: ${reply.message}`);
    return reply;
  };
}

export class Recordings {
  constructor({ stores }) {
    this.start = caller(stores, SERVICES.recordStart);
    this.stop = caller(stores, SERVICES.recordStop);
    this.listService = caller(stores, SERVICES.recordList);
    this.state = el('div', { class: 'record-state', id: 'record-state', dataset: { recording: 'unknown' } }, 'recorder –');
    this.startButton = el('button', { type: 'button', id: 'record-start', title: 'Record every topic into a new file in the recordings folder (/record/start)', onclick: () => this.onStart() }, 'Start recording');
    this.stopButton = el('button', { type: 'button', id: 'record-stop', class: 'danger', disabled: true, onclick: () => this.onStop() }, 'Stop');
    this.list = el('ul', { class: 'recordings', id: 'recording-list' }, el('li', { class: 'empty' }, '–'));
    // recording needs no robot (a bridge alone records its clients' topics): never disabled
    // by the console's robot-presence check
    this.panel = el('section', { class: 'panel', id: 'recordings-panel', dataset: { robotless: '' } },
      el('h2', {}, 'Recordings ', el('button', { type: 'button', class: 'small', id: 'recordings-refresh', title: 'List again', onclick: () => this.refresh() }, '↻')),
      this.state, el('div', { class: 'buttons' }, this.startButton, this.stopButton), this.list);
    stores.topic(TOPICS.recordState).subscribe((s) => this.show(s));
    this.incidents = new Incidents({ stores, parent: this.panel, onWritten: () => this.refresh() });
  }

  show(s) {
    const first = this.state.dataset.recording === 'unknown';
    this.state.dataset.recording = String(s.recording);
    this.state.textContent = s.recording
      ? `recording ${s.file}: ${formatBytes(Number(s.bytes))}, ${plural(s.messages, 'message')}` +
        (Number(s.dropped) ? `, ${s.dropped} dropped` : '')
      : 'not recording';
    this.startButton.disabled = s.recording;
    this.stopButton.disabled = !s.recording;
    if (first) this.refresh();
  }

  async onStart() {
    const reply = await this.start({ name: '' });
    if (reply && reply.success) log('info', reply.message);
  }

  async onStop() {
    const reply = await this.stop();
    if (reply && reply.success) log('info', reply.message);
    await this.refresh();
  }

  async refresh() {
    const reply = await this.listService();
    if (!reply) return;
    const files = reply.files || [];
    this.list.replaceChildren(...(files.length ? files.map((name, i) => el('li', { dataset: { name } },
      el('a', { href: withToken(`recordings/${encodeURIComponent(name)}`), download: name, title: `Download ${name}` }, name),
      el('small', {}, ` ${formatBytes(Number(reply.sizes[i]))}`)))
      : [el('li', { class: 'empty' }, 'no recordings yet')]));
  }
}

function clock(seconds) {
  return new Date(seconds * 1000).toLocaleString([], { dateStyle: 'short', timeStyle: 'medium', hour12: false });
}

class Incidents {
  constructor({ stores, parent, onWritten }) {
    this.listService = caller(stores, SERVICES.recordIncidents);
    this.snapshot = caller(stores, SERVICES.recordSnapshot);
    this.replay = caller(stores, SERVICES.recordReplay);
    this.onWritten = onWritten;
    this.list = el('ul', { class: 'incidents', id: 'incident-list' }, el('li', { class: 'empty' }, '–'));
    this.saveButton = el('button', { type: 'button', class: 'small', id: 'black-box-save', title: 'Write the black box (the last seconds of every topic) to the recordings folder now (/record/snapshot)', onclick: () => this.onSave() }, 'Save black box');
    this.section = el('div', { class: 'incident-section', id: 'incidents', hidden: true },
      el('h3', {}, 'Incidents ', this.saveButton), this.list);
    parent.append(this.section);
    stores.topic(TOPICS.recordIncident).subscribe((m) => this.show(m));
  }

  show(m) {
    // a replay's incidents are the recorded server's: the timeline shows the file's own
    if (replay.on) return;
    const first = this.section.hidden;
    this.section.hidden = false; // the server keeps a black box
    if (!first && m.cause && m.cause !== 'snapshot') { // the first is latched: told before
      const what = CAUSES[m.cause] || m.cause;
      log('warning', m.file ? `${what}: ${m.detail} (black box saved: ${m.file})` : `${what}: ${m.detail} (the black box could not be saved)`);
    }
    this.refresh();
    if (m.cause) this.onWritten();
  }

  async onSave() {
    const reply = await this.snapshot({ reason: 'saved from the console' });
    if (reply && reply.success) log('info', reply.message);
  }

  async refresh() {
    const reply = await this.listService();
    if (!reply) return;
    const files = reply.files || [];
    this.list.replaceChildren(...(files.length ? files.map((name, i) => this.row(name, reply, i))
      : [el('li', { class: 'empty' }, 'no incidents')]));
  }

  row(name, reply, i) {
    const cause = reply.causes[i];
    const button = el('button', { type: 'button', class: 'small replay', title: `Serve ${name} on a port of its own, to open beside this console` }, 'Replay');
    const li = el('li', { dataset: { name, cause } },
      el('span', { class: 'cause' }, CAUSES[cause] || cause), ' ',
      el('small', { class: 'when' }, clock(Number(reply.times[i]))), ' ', button,
      el('div', { class: 'detail', title: name }, reply.details[i]));
    button.addEventListener('click', () => this.onReplay(name, button, reply.times[i], reply.details[i]));
    return li;
  }

  async onReplay(name, button, time, detail) {
    button.disabled = true;
    button.textContent = 'Starting…';
    const reply = await this.replay({ name });
    if (!reply || !reply.success) {
      button.disabled = false;
      button.textContent = 'Replay';
      return;
    }
    log('info', reply.message);
    const href = replayLink(reply.port, Number(time), detail); // the replay shows its incident
    button.replaceWith(el('a', { class: 'open-replay', href, target: '_blank', rel: 'noopener', title: `The replay of ${name}` }, 'Open replay ↗'));
  }
}

/** Whether the replay went from `a` to `b` other than by playing for `elapsed` seconds. */
function jumped(a, elapsed, b) {
  const expected = a.paused ? a.position : a.position + elapsed * a.speed;
  return b.position < a.position - 0.05 || b.position > expected + 1;
}

export class ReplayTimeline {
  /** `view`: the map view, fitted above the bar while it is shown. */
  constructor({ stores, view }) {
    this.view = view;
    this.pause = caller(stores, SERVICES.replayPause);
    this.resume = caller(stores, SERVICES.replayResume);
    this.seek = caller(stores, SERVICES.replaySeek);
    this.setSpeed = caller(stores, SERVICES.replaySetSpeed);
    this.dragging = false;
    this.play = el('button', { type: 'button', class: 'play', title: 'Play / pause the replay', onclick: () => this.toggle() }, '❚❚');
    this.slider = el('input', { type: 'range', class: 'seek', min: '0', max: '0', step: '0.1', value: '0', 'aria-label': 'Replay position' });
    this.slider.addEventListener('input', () => { this.dragging = true; this.showTime(Number(this.slider.value)); });
    this.slider.addEventListener('change', async () => {
      await this.seek({ position: Number(this.slider.value) });
      this.dragging = false;
    });
    this.time = el('span', { class: 'time' }, '–');
    this.speed = el('select', { class: 'speed', title: 'Replay speed', 'aria-label': 'Replay speed' },
      ...SPEEDS.map((v) => el('option', { value: String(v) }, `${v}×`)));
    this.speed.value = '1';
    this.speed.addEventListener('change', () => this.setSpeed({ speed: Number(this.speed.value) }));
    this.file = el('span', { class: 'file' });
    const track = el('span', { class: 'track' }, this.slider);
    this.incident = new ReplayIncident({ track, seek: (position) => this.seek({ position }) });
    this.bar = el('div', { class: 'replay-bar', id: 'replay-bar', hidden: true, dataset: { paused: 'unknown' } },
      el('div', { class: 'controls' }, this.play, track, this.time, this.speed, this.file), this.incident.line);
    stores.topic(TOPICS.replayState).subscribe((s) => this.show(s));
  }

  show(s) {
    const now = performance.now();
    if (this.state && jumped(this.state, (now - this.shownAt) / 1000, s)) {
      window.dispatchEvent(new Event('replayseek')); // a seek or a loop: the odometer restarts
    }
    this.state = s;
    this.shownAt = now;
    replay.on = true;
    // the page is a replay's: app.js's followReplay says so everywhere (no "No robot" beside it)
    document.body.classList.add('replaying');
    window.dispatchEvent(new CustomEvent('replay', { detail: { state: s, summary: this.summary(s) } }));
    this.bar.dataset.paused = String(s.paused);
    this.bar.dataset.position = s.position.toFixed(3);
    this.bar.dataset.speed = String(s.speed);
    this.play.textContent = s.paused ? '▶' : '❚❚';
    this.slider.max = String(s.duration);
    this.file.textContent = s.file + (s.loop ? ' ⟳' : '');
    if (SPEEDS.includes(s.speed)) this.speed.value = String(s.speed);
    if (!this.dragging) {
      this.slider.value = String(s.position);
      this.showTime(s.position);
    }
    this.incident.show(s);
    this.place();
  }

  /** The bar sits above the hint, and the map is fitted above both (nothing hidden under it). */
  place() {
    const first = this.bar.hidden;
    this.bar.hidden = false;
    const height = this.bar.offsetHeight;
    if (height === this.height) return;
    this.height = height;
    this.bar.parentElement.style.setProperty('--replay-bar', `${height}px`);
    const hint = document.getElementById('hint');
    if (this.view) {
      this.view.bottomInset = height + (hint ? hint.offsetHeight : 0) + 24;
      if (first || this.view.autoFit) this.view.fit();
    }
  }

  /** One line for the whole page: "Replaying NAME — playing 0:03.2 / 0:10.0". */
  summary(s) {
    const ended = s.paused && s.position >= s.duration;
    const what = s.waiting ? 'paused until a client subscribes' : ended ? 'ended' : s.paused ? 'paused' : 'playing';
    const speed = s.speed !== 1 ? ` at ${s.speed}×` : '';
    return `Replaying ${s.file} — ${what}${speed} ${formatTime(s.position)} / ${formatTime(s.duration)}`;
  }

  showTime(position) {
    this.time.textContent = `${formatTime(position)} / ${formatTime(this.state ? this.state.duration : 0)}`;
  }

  toggle() {
    if (!this.state) return;
    if (this.state.paused) this.resume();
    else this.pause();
  }
}
