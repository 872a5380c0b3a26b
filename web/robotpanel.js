// The Robot panel's actions and the speed/odometry readout: Relocalize (recover_localization
// over the whole map), Go home (go_home: to the dock, where it charges), Stop (cancel_action),
// and from odom the speed and the distance driven since the page opened; all of the robot
// chosen in the fleet panel on a fleet server (currentrobot.js).
/* global ROSLIB */
import { CurrentRobot } from './currentrobot.js';
import { log } from './log.js';
import { TOPICS } from './names.js';

export class RobotActions {
  constructor({ ros, navigator, robot = new CurrentRobot() }) {
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
    robot.subscribe(ros, TOPICS.odom, 'nav_msgs/Odometry', { throttle_rate: 200, queue_length: 1 },
      (odom) => this.odometry(odom), () => {
        this.last = null;
        this.distance = 0;
        this.readout.textContent = 'speed –';
      });
  }

  odometry(odom) {
    const p = odom.pose.pose.position;
    if (this.last) this.distance += Math.hypot(p.x - this.last.x, p.y - this.last.y);
    this.last = { x: p.x, y: p.y };
    const t = odom.twist.twist;
    const speed = Math.hypot(t.linear.x, t.linear.y);
    this.readout.textContent = `speed ${speed.toFixed(2)} m/s · turn ${t.angular.z.toFixed(2)} rad/s · ` +
      `odometer ${this.distance.toFixed(1)} m`;
    this.readout.dataset.speed = speed.toFixed(3);
  }
}
