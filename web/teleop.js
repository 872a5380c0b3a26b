// Driving by hand: arrow keys (or W/A/S/D) and the on-screen pad publish geometry_msgs/Twist on
// /cmd_vel ten times a second while held. Dead-man: releasing the keys, lifting or losing the
// pointer, leaving the window or hiding the page sends a stop at once (and the server stops
// the robot by itself half a second after the last command) -- but only from the page that is
// driving (it sent a non-zero command within the last second): a page that only watched sends
// nothing, since on the robot any /cmd_vel, a stop too, supersedes the goal, patrol or task
// someone else started. On a fleet server it drives the robot chosen in the fleet panel
// (currentrobot.js): /NAME/cmd_vel. One client drives a robot at a time (the server's drive
// lease, /drive_lease): the pad shows who does; another's commands are refused meanwhile.
/* global ROSLIB */
import { CurrentRobot } from './currentrobot.js';
import { dialogOpen } from './dialogs.js';
import { TOPICS } from './names.js';

const PERIOD_MS = 100;
const DRIVING_MS = 1000; // a page that sent a non-zero command this recently is the one driving
const KEYS = {
  ArrowUp: 'fwd', ArrowDown: 'back', ArrowLeft: 'left', ArrowRight: 'right',
  w: 'fwd', s: 'back', a: 'left', d: 'right',
};

export class Teleop {
  constructor({ ros, stores, robot = new CurrentRobot() }) {
    this.ros = ros;
    this.stores = stores;
    this.robot = robot;
    this.topic = this.cmdVel();
    this.keys = new Set();
    this.pad = null;
    this.timer = null;
    this.moving = false;
    this.droveAt = -Infinity; // when this page last sent a non-zero command
    this.state = document.getElementById('drive-state');
    this.lin = document.getElementById('lin-speed');
    this.ang = document.getElementById('ang-speed');
    const showSpeeds = () => {
      document.getElementById('lin-out').textContent = `${Number(this.lin.value).toFixed(2)} m/s`;
      document.getElementById('ang-out').textContent = `${Number(this.ang.value).toFixed(1)} rad/s`;
    };
    this.lin.addEventListener('input', showSpeeds);
    this.ang.addEventListener('input', showSpeeds);
    showSpeeds();

    window.addEventListener('keydown', (e) => this.key(e, true));
    window.addEventListener('keyup', (e) => this.key(e, false));
    window.addEventListener('blur', () => this.release());
    document.addEventListener('visibilitychange', () => { if (document.hidden) this.release(); });
    window.addEventListener('pagehide', () => this.release());
    this.bindPad();
    this.showLease();
    // another robot chosen: stop this one, then drive that one
    robot.follow(() => {
      this.release();
      this.topic = this.cmdVel();
    });
  }

  /** The on-screen pad: a direction held while pressed; ■ stops at once. */
  bindPad() {
    for (const b of document.querySelectorAll('#pad [data-drive]')) {
      const dir = b.dataset.drive;
      b.addEventListener('pointerdown', (e) => {
        e.preventDefault();
        if (dir === 'stop') {
          this.release();
          return;
        }
        b.setPointerCapture(e.pointerId);
        this.pad = dir;
        b.classList.add('held');
        this.update();
      });
      const up = () => {
        b.classList.remove('held');
        if (this.pad === dir) {
          this.pad = null;
          this.update();
        }
      };
      for (const ev of ['pointerup', 'pointercancel', 'lostpointercapture']) b.addEventListener(ev, up);
    }
  }

  /** Who holds the chosen robot's drive lease: "driven by NAME" under the pad. */
  showLease() {
    const shown = document.getElementById('drive-lease');
    const show = (lease) => {
      const holder = lease ? lease.holder : '';
      shown.hidden = !holder;
      shown.dataset.holder = holder;
      shown.textContent = holder ? `driven by ${holder}` : '';
    };
    this.stores.follow(this.robot, TOPICS.driveLease, show, () => show(null));
  }

  /** /cmd_vel of the chosen robot. */
  cmdVel() {
    return new ROSLIB.Topic({ ros: this.ros, name: this.robot.nameOf(TOPICS.cmdVel), messageType: 'geometry_msgs/Twist' });
  }

  key(e, down) {
    const dir = KEYS[e.key] || KEYS[e.key.toLowerCase()];
    if (!dir) return;
    const t = e.target;
    if (down && (dialogOpen() || document.body.classList.contains('no-robot') || (t && (t.isContentEditable || /^(INPUT|TEXTAREA|SELECT)$/.test(t.tagName))))) {
      return;
    }
    e.preventDefault();
    if (down) this.keys.add(dir);
    else this.keys.delete(dir);
    this.update();
  }

  /** Stop now: forget every held key and the pad; a stop goes out only if this page is the
   * one driving, so a watching page never cancels what another started. */
  release() {
    this.keys.clear();
    this.pad = null;
    for (const b of document.querySelectorAll('#pad .held')) b.classList.remove('held');
    this.update(this.driving());
  }

  /** Whether this page sent a non-zero command within the last second. */
  driving() {
    return performance.now() - this.droveAt < DRIVING_MS;
  }

  command() {
    const held = new Set(this.keys);
    if (this.pad) held.add(this.pad);
    const v = Number(this.lin.value);
    const w = Number(this.ang.value);
    const linear = (held.has('fwd') ? v : 0) - (held.has('back') ? v : 0);
    const angular = (held.has('left') ? w : 0) - (held.has('right') ? w : 0);
    return { linear, angular, active: held.size > 0 };
  }

  update(forceStop = false) {
    const c = this.command();
    if (c.active && document.body.classList.contains('offline')) {
      // the bridge is down: nothing would arrive (roslib would queue it for later)
      this.keys.clear();
      this.pad = null;
      this.state.textContent = 'offline — not driving';
      this.state.dataset.state = 'offline';
      return;
    }
    if (c.active) {
      this.publish(c.linear, c.angular);
      if (!this.timer) this.timer = setInterval(() => this.tick(), PERIOD_MS);
      this.moving = true;
      this.state.textContent = `driving ${c.linear.toFixed(2)} m/s, ${c.angular.toFixed(1)} rad/s`;
      this.state.dataset.state = 'driving';
      return;
    }
    if (this.timer) {
      clearInterval(this.timer);
      this.timer = null;
    }
    if (this.moving || forceStop) this.publish(0, 0);
    this.moving = false;
    this.state.textContent = 'stopped';
    this.state.dataset.state = 'stopped';
  }

  tick() {
    const c = this.command();
    if (c.active) this.publish(c.linear, c.angular);
    else this.update();
  }

  publish(linear, angular) {
    if (document.body.classList.contains('offline')) return;
    if (linear !== 0 || angular !== 0) this.droveAt = performance.now();
    this.topic.publish(new ROSLIB.Message({
      linear: { x: linear, y: 0, z: 0 }, angular: { x: 0, y: 0, z: angular },
    }));
  }
}
