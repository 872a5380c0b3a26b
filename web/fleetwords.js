// What the fleet-operations console (fleetops.js) says of tasks and times: the site's clock (/fleet/policy's time zone), a task's kind, target and
// robot in the operator's words.

/** Times as the site's clock reads them: its IANA zone when the server names one
 * (--site-timezone), else the server's UTC offset, else the browser's own zone. */
export class SiteClock {
  constructor() {
    this.zone = undefined; // an IANA name Intl accepts
    this.offset = null; // seconds east of UTC, when no zone is named
    this.label = 'this browser\'s time';
  }

  /** From a /fleet/policy reply. */
  set({ timezone, utc_offset: offset, zone_name: name }) {
    this.zone = undefined;
    this.offset = null;
    if (timezone) {
      try {
        new Intl.DateTimeFormat('en-GB', { timeZone: timezone }).format(0);
        this.zone = timezone;
      } catch (_) { /* a zone this browser does not know: the offset below */ }
    }
    if (!this.zone) this.offset = Number(offset) || 0;
    this.label = timezone ? `${timezone} (${name})` : `the server's time (${name})`;
  }

  /** "14:03:12" today (on the site's calendar), "25 Nov 14:03" before; "–" for 0. */
  format(seconds) {
    if (!seconds) return '–';
    const shift = this.offset === null ? 0 : this.offset;
    const timeZone = this.offset === null ? this.zone : 'UTC';
    const at = new Date((Number(seconds) + shift) * 1000);
    const now = new Date(Date.now() + shift * 1000);
    const day = (d) => new Intl.DateTimeFormat('en-GB', { timeZone, day: 'numeric', month: 'short' }).format(d);
    const time = new Intl.DateTimeFormat('en-GB', { timeZone, hour: '2-digit', minute: '2-digit', second: '2-digit', hour12: false });
    return day(at) === day(now) ? time.format(at) : `${day(at)} ${time.format(at).slice(0, 5)}`;
  }
}

/** One name for the dispatcher's choice, on the Operate and the Fleet tab alike: the robot
 * whose bid finishes first (its path, its work before, its charge counted). */
export const BEST_ROBOT = 'the best robot (by cost)';

export const KIND_WORDS = { goto: 'Go to', sequence: 'Sequence', patrol: 'Patrol', charge: 'Charge' };
export const STATE_WORDS = { queued: 'waiting', running: 'running', paused: 'paused', succeeded: 'done', failed: 'failed', cancelled: 'cancelled' };

/** Where a task goes: a POI, a pose, a route of POIs (with dwell times), a dock. */
export function targetWords(t) {
  if (t.kind === 'charge') return 'its dock';
  if (t.kind === 'sequence' || t.kind === 'patrol') {
    const stops = (t.pois || []).map((name, i) => {
      const dwell = Number((t.dwell || [])[i] || 0);
      return dwell ? `${name} (wait ${Math.round(dwell * 10) / 10} s)` : name;
    }).join(' → ');
    return t.kind === 'patrol' ? `${stops}, ${t.laps} ${Number(t.laps) === 1 ? 'lap' : 'laps'}` : stops;
  }
  if (t.poi) return t.poi;
  const p = t.pose.position;
  return `the point ${p.x.toFixed(2)}, ${p.y.toFixed(2)} m`;
}

/** Who runs it: the robot running it (or that last ran it), the one asked for, or any. */
export function robotWords(t) {
  if (t.assigned) return t.assigned;
  return t.robot ? `${t.robot} (asked for)` : BEST_ROBOT;
}
