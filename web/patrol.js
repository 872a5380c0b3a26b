// Patrol routes (planning/*): waypoints clicked on the map with the "Add waypoints" tool are the
// route (planning/set_waypoints after each click), drawn numbered; Run (start_patrol), Stop
// (stop_patrol), Resume (resume_patrol, from the waypoint nearest the robot), Clear. The
// latched planning/patrol_state says what the patrol does: its target, laps and last event.
import { log } from './log.js';
import { SERVICES, TOPICS } from './names.js';
import { el } from './util.js';

/** The server counts waypoints from 0 (the SDK's texts); the panel and the map from 1. */
export const fromOne = (text) => text.replace(/\bwaypoint (\d+)/g, (_, n) => `waypoint ${Number(n) + 1}`);

export class Patrol {
  constructor({ stores, layer }) {
    this.layer = layer;
    this.onState = null; // (state) => …: the Navigation panel follows a running patrol
    this.waypoints = [];
    this.frame = 'map';
    this.stores = stores;
    this.services = { set: SERVICES.setWaypoints, clear: SERVICES.clearWaypoints, start: SERVICES.startPatrol,
      stop: SERVICES.stopPatrol, resume: SERVICES.resumePatrol };
    this.stateBox = document.getElementById('patrol-state');
    this.list = document.getElementById('waypoint-list');
    this.count = document.getElementById('patrol-count');
    document.getElementById('patrol-clear').addEventListener('click', () => this.call('clear', {}, 'route cleared'));
    document.getElementById('patrol-start').addEventListener('click', () => this.call('start', {}));
    document.getElementById('patrol-stop').addEventListener('click', () => this.call('stop', {}));
    document.getElementById('patrol-resume').addEventListener('click', () => this.call('resume', {}));
    stores.topic(TOPICS.patrolState).subscribe((state) => this.show(state));
  }

  async call(what, request, okText = '') {
    const { reply, error } = await this.stores.call(this.services[what], request);
    if (error) log('error', `patrol ${what} failed: ${error}`);
    else if (reply.success) log('info', okText || `patrol ${what}: ${fromOne(reply.message)}`);
    else log('error', `patrol ${what}: ${fromOne(reply.message)}`);
  }

  /** A click with the waypoint tool: the route gets one more waypoint. */
  add(x, y) {
    const next = [...this.waypoints, { frame: this.frame, x, y, z: 0, use_z: false }];
    this.call('set', { waypoints: next }, `waypoint ${next.length} at ${x.toFixed(2)}, ${y.toFixed(2)} m`);
  }

  show(state) {
    if (this.onState) this.onState(state);
    this.waypoints = state.waypoints || [];
    if (this.waypoints.length) this.frame = this.waypoints[0].frame || 'map';
    this.layer.set(this.waypoints, state.active ? state.target_index : -1);
    this.count.textContent = this.waypoints.length ? `(${this.waypoints.length})` : '';
    this.stateBox.dataset.active = String(state.active);
    this.stateBox.dataset.target = String(state.target_index);
    this.stateBox.dataset.laps = String(state.laps);
    const route = state.route ? `route “${state.route}” · ` : '';
    // its "heading to …" is said here already
    const event = state.message && !/^heading to/.test(state.message) ? ` · ${fromOne(state.message)}` : '';
    this.stateBox.textContent = state.active
      ? `${route}patrolling → waypoint ${state.target_index + 1} of ${this.waypoints.length} · lap ${state.laps + 1}${event}`
      : `${route}${this.waypoints.length ? 'stopped' : 'no route'}${event}`;
    this.list.replaceChildren(...this.waypoints.map((w, i) => el('li', {
      class: state.active && i === state.target_index ? 'target' : '',
    }, `${w.x.toFixed(2)}, ${w.y.toFixed(2)} m`)));
  }
}
