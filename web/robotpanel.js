// The Robot panel's actions and the speed/odometry readout: Relocalize (recover_localization
// over the whole map), Go home (go_home: to the dock, where it charges), Stop (cancel_action),
// and from odom the speed and the distance driven since the page opened (only continuous
// motion: a set pose, a relocalization or a replay's seek moves the pose, not the robot); all
// of the robot chosen in the fleet panel on a fleet server (currentrobot.js).
/* global ROSLIB */
import { CurrentRobot } from './currentrobot.js';
import { log } from './log.js';
import { TOPICS } from './names.js';

export class RobotActions {
  constructor({ ros, stores, navigator, robot = new CurrentRobot() }) {
    const publisher = (name, messageType) => () => robot.publisher(ros, name, messageType);
    this.recover = publisher(TOPICS.recoverLocalization, 'slamware_ros_sdk/RecoverLocalizationRequest');
    this.home = publisher(TOPICS.goHome, 'slamware_ros_sdk/GoHomeRequest');
    this.cancel = publisher(TOPICS.cancelAction, 'slamware_ros_sdk/CancelActionRequest');
    this.buttons = ['relocalize', 'go-home', 'stop-motion'].map((id) => document.getElementById(id));
    document.getElementById('relocalize').addEventListener('click', () => {
      // a complete message: no time limit, the robot's own choice of movement (not given)
      this.recover().publish(new ROSLIB.Message({
        area: { x: 0, y: 0, w: 0, h: 0 },
        options: { max_time_ms: { is_valid: false, value: 0 },
          mvmt_type: { is_valid: false, value: { type: 0 } } },
      }));
      log('info', 'relocalization requested (whole map)');
    });
    // followed in the Navigation panel, like a goal
    document.getElementById('go-home').addEventListener('click', () => navigator.goHome(this.home()));
    document.getElementById('stop-motion').addEventListener('click', () => {
      this.cancel().publish(new ROSLIB.Message({}));
      log('info', 'stop: the current action cancelled');
    });

    this.readout = document.getElementById('odometry');
    this.last = null;
    this.distance = 0;
    stores.follow(robot, TOPICS.odom, (odom) => this.odometry(odom), () => this.restart());
    // a replay's seek (or loop) is no drive: the odometer counts again from there
    window.addEventListener('replayseek', () => this.restart());
  }

  restart() {
    this.last = null;
    this.distance = 0;
    this.readout.textContent = 'speed –';
    this.readout.dataset.odometer = '0';
  }

  odometry(odom) {
    const p = odom.pose.pose.position;
    const t = odom.twist.twist;
    const speed = Math.hypot(t.linear.x, t.linear.y);
    const stamp = odom.header && odom.header.stamp;
    const now = { x: p.x, y: p.y, speed, time: stamp ? stamp.secs + stamp.nsecs / 1e9 : performance.now() / 1000 };
    if (this.last) this.distance += driven(this.last, now);
    this.last = now;
    this.readout.textContent = `speed ${speed.toFixed(2)} m/s · turn ${t.angular.z.toFixed(2)} rad/s · ` +
      `odometer ${this.distance.toFixed(1)} m`;
    this.readout.dataset.speed = speed.toFixed(3);
    this.readout.dataset.odometer = this.distance.toFixed(3);
  }
}

const SLACK = 1.5; // a step may be this much longer than its speed says (the speed varies)
const FASTEST = 3; // m/s: faster than any robot here drives (a simulator sped up 4× included)
const GAP = 2; // s between two readings: longer is a pause or a seek, not a drive

/** The metres driven from reading `a` to `b`: 0 when it is a jump the robot could not have
 * driven in the time between (a set pose, a relocalization, a replay's seek). */
export function driven(a, b) {
  const step = Math.hypot(b.x - a.x, b.y - a.y);
  const dt = b.time - a.time;
  if (!(dt > 0) || dt > GAP) return 0;
  const reach = Math.max(a.speed * SLACK, b.speed * SLACK, FASTEST) * dt + 0.05;
  return step <= reach ? step : 0;
}
