// Whether a robot stands behind the bridge at all: the Slamware node in rosapi's node list,
// on this server or on another one of a Zenoh bus (whose liveliness tokens leave the list
// when that server dies). No robot yet: "no robot" (--robot none); gone: "robot offline". Both
// disable what would drive or change the robot; when it comes (back) the page reloads, so the
// map, POIs and state are fresh.
import { SERVICES, SLAMWARE_NODE } from './names.js';

const PERIOD_MS = 2000;

export class RobotPresence {
  /** `onChange(present, seen)`: present is this poll's answer, seen whether it ever was. */
  constructor({ ros, stores, onChange }) {
    this.stores = stores;
    this.onChange = onChange;
    this.present = null; // unknown until rosapi answers
    this.seen = false;
    const poll = () => {
      if (ros.isConnected) this.poll();
    };
    ros.on('connection', poll);
    if (ros.isConnected) poll();
    setInterval(poll, PERIOD_MS);
  }

  async poll() {
    const { reply } = await this.stores.call(SERVICES.rosapiNodes);
    // the single robot's node, or a fleet robot's under its /NAME/ namespace
    if (reply) this.update((reply.nodes || []).some((n) => n === SLAMWARE_NODE || n.endsWith(SLAMWARE_NODE)));
  }

  update(present) {
    if (present === this.present) return;
    const before = this.present;
    this.present = present;
    if (present && before === false) {
      location.reload(); // the robot came (back): start over with its map, POIs and state
      return;
    }
    if (present) this.seen = true;
    document.body.classList.toggle('no-robot', !present);
    this.onChange(present, this.seen);
  }
}
