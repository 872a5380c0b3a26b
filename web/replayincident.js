// A black-box file's incident in its replay (recordings.js's timeline). The file's name says
// the incident's cause and second (blackbox-YYYYMMDD-HHMMSS-CAUSE.mcap, in UTC: how the black
// box names it); the live console's "Open replay" link adds its detail and exact time
// (?incident_at=…&incident_detail=…). The timeline shows the cause, the time and the detail,
// marks the incident on the seek bar, and the replay opens LEAD seconds before it, so what led
// to it plays first.
import { log } from './log.js';
import { el } from './util.js';

export const CAUSES = {
  link_lost: 'Robot link lost',
  goal_aborted: 'Goal aborted',
  localization_lost: 'Localization lost',
  emergency_stop: 'Emergency stop',
  shutdown: 'Server stopped',
  snapshot: 'Saved by hand',
};
const LEAD = 10; // s of the recording played before the incident
const NAME = /^blackbox-(\d{4})(\d{2})(\d{2})-(\d{2})(\d{2})(\d{2})-([a-z0-9_]+?)(?:-\d+)?\.mcap$/;

/** A time as the console says it elsewhere: "2026-11-28 20:54:16", local and 24-hour. */
export function clock24(seconds) {
  const d = new Date(seconds * 1000);
  const two = (n) => String(n).padStart(2, '0');
  return `${d.getFullYear()}-${two(d.getMonth() + 1)}-${two(d.getDate())} ` +
    `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
}

/** The incident of black-box file `file` ({cause, time, detail}), or null for a recording. */
export function incidentOf(file, search = window.location.search) {
  const m = NAME.exec(file || '');
  if (!m) return null;
  const [, y, mo, d, h, mi, s, cause] = m;
  const named = Date.UTC(Number(y), Number(mo) - 1, Number(d), Number(h), Number(mi), Number(s)) / 1000;
  const params = new URLSearchParams(search);
  const at = Number(params.get('incident_at'));
  // the link's time and detail, when they are this file's (the same second)
  const linked = Number.isFinite(at) && Math.floor(at) === named;
  return { cause, time: linked ? at : named, detail: linked ? params.get('incident_detail') || '' : '' };
}

/** A replay's link, opened from the live console's incident list: it carries the incident. */
export function replayLink(port, time, detail) {
  const query = new URLSearchParams({ incident_at: String(time), incident_detail: detail });
  return `http://${window.location.hostname}:${port}/?${query}`;
}

export class ReplayIncident {
  /** `track`: the element around the seek bar (the mark goes in it); `seek(position)`. */
  constructor({ track, seek }) {
    this.seek = seek;
    this.file = null;
    this.incident = null;
    this.at = null;
    this.mark = el('i', { class: 'incident-mark', id: 'replay-incident-mark', hidden: true, title: 'The incident' });
    track.append(this.mark);
    this.text = el('span', { class: 'what' });
    this.again = el('button', { type: 'button', class: 'small', title: `Play again from ${LEAD} s before the incident`,
      onclick: () => this.seek(Math.max(0, this.at - LEAD)) }, '⚑ replay the incident');
    this.line = el('div', { class: 'incident', id: 'replay-incident', hidden: true }, this.text, this.again);
  }

  /** A /replay/state: the first of a black-box file seeks to just before its incident. */
  show(s) {
    if (s.file !== this.file) {
      this.file = s.file;
      this.incident = incidentOf(s.file);
      this.at = null;
    }
    const incident = this.incident;
    this.line.hidden = this.mark.hidden = !incident;
    if (!incident || !(s.duration > 0)) return;
    const at = Math.min(Math.max(incident.time - s.start, 0), s.duration);
    const first = this.at === null;
    this.at = at;
    this.mark.style.left = `${(at / s.duration) * 100}%`;
    this.mark.dataset.position = at.toFixed(3);
    if (!first) return;
    const what = CAUSES[incident.cause] || incident.cause;
    const when = clock24(incident.time);
    this.line.dataset.cause = incident.cause;
    this.text.textContent = `${what} at ${when}${incident.detail ? ` — ${incident.detail}` : ''}`;
    this.text.title = this.text.textContent;
    log('info', `the recorded incident: ${what} at ${when}${incident.detail ? ` — ${incident.detail}` : ''}`);
    if (s.position < at - LEAD) this.seek(at - LEAD);
  }
}
