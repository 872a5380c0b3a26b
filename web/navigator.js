// Navigation, doing what nav2d's OccupancyGridClientNav does (nav2d is not on npm): a roslib
// ActionClient on /move_base (move_base_msgs/MoveBaseAction) sends goals with an orientation,
// the goal is drawn on the map and its status shown; /initialpose sets the robot's pose.
/* global ROSLIB */
import { ArrowMarker, COLORS } from './overlays.js';
import { log } from './log.js';
import { formatPose, quatOfYaw } from './util.js';

// actionlib_msgs/GoalStatus
export const GOAL_STATUS = ['PENDING', 'ACTIVE', 'PREEMPTED', 'SUCCEEDED', 'ABORTED', 'REJECTED',
  'PREEMPTING', 'RECALLING', 'RECALLED', 'LOST'];
const TERMINAL = new Set([2, 3, 4, 5, 8, 9]);

export class Navigator {
  constructor({ ros, view, serverName = '/move_base', actionName = 'move_base_msgs/MoveBaseAction',
    frameId = 'map' }) {
    this.view = view;
    this.frameId = frameId;
    this.client = new ROSLIB.ActionClient({ ros, serverName, actionName });
    this.initialPoseTopic = new ROSLIB.Topic({
      ros, name: '/initialpose', messageType: 'geometry_msgs/PoseWithCovarianceStamped',
    });
    this.goal = null;
    this.target = null;
    this.marker = new ArrowMarker(view, COLORS.goal);
    this.statusBox = document.getElementById('goal-status');
    this.cancelButton = document.getElementById('cancel-goal');
    this.cancelButton.addEventListener('click', () => this.cancel());
    this.robot = null;
  }

  pose(x, y, yaw) {
    return new ROSLIB.Pose({ position: new ROSLIB.Vector3({ x, y, z: 0 }),
      orientation: new ROSLIB.Quaternion(quatOfYaw(yaw)) });
  }

  /** Send the robot to (x, y) facing `yaw` (rad); a new goal replaces the previous one. */
  sendGoal(x, y, yaw) {
    const goal = new ROSLIB.Goal({
      actionClient: this.client,
      goalMessage: {
        target_pose: { header: { frame_id: this.frameId }, pose: this.pose(x, y, yaw) },
      },
    });
    this.goal = goal;
    this.target = { x, y, yaw };
    this.marker.setPose(x, y, yaw);
    this.show('pending', `PENDING → ${formatPose(x, y, yaw)}`);
    this.cancelButton.disabled = false;
    goal.on('status', (status) => this.onStatus(goal, status));
    goal.on('feedback', (feedback) => this.onFeedback(goal, feedback));
    goal.send();
    log('info', `goal sent: ${formatPose(x, y, yaw)}`);
    return goal;
  }

  onStatus(goal, status) {
    const code = status.status;
    const name = GOAL_STATUS[code] || `status ${code}`;
    if (goal !== this.goal) return; // a replaced goal: its end is not news
    if (goal.lastStatus === code) return;
    goal.lastStatus = code;
    const t = this.target;
    const text = status.text ? ` — ${status.text}` : '';
    this.show(name.toLowerCase(), `${name} → ${formatPose(t.x, t.y, t.yaw)}${text}`);
    if (TERMINAL.has(code)) {
      this.cancelButton.disabled = true;
      this.marker.hide();
      const level = code === 3 ? 'info' : code === 2 || code === 8 ? 'warning' : 'error';
      log(level, `goal ${name.toLowerCase()}${text}`);
    }
  }

  onFeedback(goal, feedback) {
    if (goal !== this.goal || !this.target || !feedback || !feedback.base_position) return;
    const p = feedback.base_position.pose.position;
    const left = Math.hypot(this.target.x - p.x, this.target.y - p.y);
    const t = this.target;
    this.show('active', `ACTIVE → ${formatPose(t.x, t.y, t.yaw)} · ${left.toFixed(1)} m to go`);
  }

  show(state, text) {
    this.statusBox.dataset.status = state;
    this.statusBox.textContent = text;
  }

  cancel() {
    if (this.goal) {
      this.goal.cancel();
      log('info', 'goal cancel requested');
    } else {
      this.client.cancel();
    }
  }

  /** Publish /initialpose (the covariance rviz's "2D Pose Estimate" uses). */
  setInitialPose(x, y, yaw) {
    const covariance = new Array(36).fill(0);
    covariance[0] = covariance[7] = 0.25;
    covariance[35] = 0.06853891945200942;
    this.initialPoseTopic.publish(new ROSLIB.Message({
      header: { frame_id: this.frameId },
      pose: { pose: this.pose(x, y, yaw), covariance },
    }));
    log('info', `initial pose set: ${formatPose(x, y, yaw)}`);
  }
}
