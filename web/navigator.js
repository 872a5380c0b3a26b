// Navigation, doing what nav2d's OccupancyGridClientNav does (nav2d is not on npm): a roslib
// ActionClient on /move_base (move_base_msgs/MoveBaseAction) sends goals with an orientation,
// the goal is drawn on the map and its status shown; /initialpose sets the robot's pose. A
// "Go" to a POI and Go home are followed the same way (distance to go, Cancel), from the
// server's replies, and so is a running patrol: the panel always shows what the robot does.
// While the bridge is down nothing is sent and the panel says the state is unknown. On a fleet
// server goals, POIs, Cancel and the initial pose go to the robot chosen in the fleet panel
// (currentrobot.js), under its /NAME/.
/* global ROSLIB */
import { operatorText, publishTracked } from './connection.js';
import { CurrentRobot } from './currentrobot.js';
import { ArrowMarker, COLORS } from './overlays.js';
import { log } from './log.js';
import { ACTIONS, TOPICS, resultTopic } from './names.js';
import { fromOne } from './patrol.js';
import { formatPose, quatOfYaw, yawOf } from './util.js';

// actionlib_msgs/GoalStatus
export const GOAL_STATUS = ['PENDING', 'ACTIVE', 'PREEMPTED', 'SUCCEEDED', 'ABORTED', 'REJECTED',
  'PREEMPTING', 'RECALLING', 'RECALLED', 'LOST'];
const TERMINAL = new Set([2, 3, 4, 5, 8, 9]);
/** How the console words a status: a preempted goal is one the operator cancelled. */
const shown = (name) => (name === 'PREEMPTED' ? 'CANCELLED' : name);
const PLAN_MIN = 0.2; // m: a planned path this long means the robot is on its way somewhere
const STALE_PLAN_MS = 1500; // a plan seen this soon after an end may be one already on its way

export class Navigator {
  constructor({ ros, view, robot = new CurrentRobot(), serverName = ACTIONS.moveBase,
    actionName = 'move_base_msgs/MoveBaseAction', frameId = 'map' }) {
    this.view = view;
    this.frameId = frameId;
    this.ros = ros;
    this.online = true;
    this.serverName = serverName;
    this.actionName = actionName;
    // how a goal sent elsewhere ends: its abort and the reason (the recorded one in a replay),
    // heard on the action client's own result subscription (roslib emits each topic's messages
    // on the Ros object too), not on a second one
    this.onResult = (result) => this.resultElsewhere(result);
    this.useRobot(robot);
    robot.follow((name) => {
      this.client.dispose?.();
      this.useRobot(robot);
      this.switched(name);
    });
    // what the robot does that is not a /move_base goal, followed in the panel: a POI
    // navigation, going home, a patrol — {label, target?, cancel(), done()?, patrol?}
    this.activity = null;
    this.planLength = null;
    this.patrolRunning = false;
    this.endedAt = -Infinity; // when the panel last showed something ending
    this.goal = null;
    this.target = null;
    this.marker = new ArrowMarker(view, COLORS.goal);
    this.statusBox = document.getElementById('goal-status');
    this.cancelButton = document.getElementById('cancel-goal');
    this.cancelButton.addEventListener('click', () => this.cancel());
    this.robotPose = null;
    this.replaying = false; // a replay's page: nothing is sent, Cancel stays off
    this.elsewhereEnded = -Infinity; // when a motion sent elsewhere was last seen to stop
  }

  /** The page shows a replay: Cancel and the rest that would send stay off. */
  setReplaying() {
    this.replaying = true;
    this.cancelButton.disabled = true;
  }

  /** Cancel is on while something this page can cancel runs (never in a replay). */
  allowCancel() {
    this.cancelButton.disabled = this.replaying || !this.online;
  }

  /** The action client and topics of the chosen robot (`robot`, a CurrentRobot). */
  useRobot(robot) {
    const ros = this.ros;
    this.client = new ROSLIB.ActionClient({ ros, serverName: robot.nameOf(this.serverName), actionName: this.actionName });
    if (this.resultName) ros.off(this.resultName, this.onResult);
    this.resultName = robot.nameOf(resultTopic(this.serverName));
    ros.on(this.resultName, this.onResult);
    this.poiTopic = new ROSLIB.Topic({ ros, name: robot.nameOf(TOPICS.navigateToPoi), messageType: 'map_messages/NavigateToPOI' });
    this.cancelTopic = new ROSLIB.Topic({ ros, name: robot.nameOf(TOPICS.cancelAction),
      messageType: 'slamware_ros_sdk/CancelActionRequest' });
    this.initialPoseTopic = new ROSLIB.Topic({
      ros, name: robot.nameOf(TOPICS.initialPose), messageType: 'geometry_msgs/PoseWithCovarianceStamped',
    });
  }

  /** Another robot was chosen: what the panel showed was the last one's. */
  switched(name) {
    this.endActivity();
    this.goal = null;
    this.target = null;
    this.planLength = null;
    this.robotPose = null;
    this.cancelButton.disabled = true;
    this.show('idle', `No goal sent to ${name}`);
  }

  pose(x, y, yaw) {
    return new ROSLIB.Pose({ position: new ROSLIB.Vector3({ x, y, z: 0 }),
      orientation: new ROSLIB.Quaternion(quatOfYaw(yaw)) });
  }

  /** Going off line: nothing can be sent, and what the robot does is unknown from here. */
  setOnline(on) {
    this.online = on;
    if (on && this.statusBox.dataset.status === 'offline') this.show('idle', 'No goal');
    if (!on) {
      const last = this.statusBox.dataset.status;
      if (last === 'active' || last === 'pending') this.show('offline', `OFFLINE — the goal's state is unknown (was ${last.toUpperCase()})`);
      else this.show('offline', 'OFFLINE — no goals can be sent');
      this.cancelButton.disabled = true;
      this.marker.hide();
      this.endActivity();
    }
  }

  /** No robot behind the bridge (never was, or its server left): nothing to follow or send. */
  robotAbsent(seen) {
    this.endActivity();
    this.goal = null;
    this.cancelButton.disabled = true;
    this.show('offline', seen ? 'ROBOT OFFLINE — its state is unknown' : 'No robot');
  }

  refuse(what) {
    if (this.online) return false;
    log('error', `${what} not sent: the bridge is offline`);
    return true;
  }

  /** Send the robot to (x, y) facing `yaw` (rad); a new goal replaces the previous one. */
  sendGoal(x, y, yaw) {
    if (this.refuse('goal')) return null;
    this.endActivity();
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
    this.allowCancel();
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
    this.show(name.toLowerCase(), `${shown(name)} → ${formatPose(t.x, t.y, t.yaw)}${text}`);
    if (TERMINAL.has(code)) {
      this.cancelButton.disabled = true;
      this.marker.hide();
      // a cancel this page asked for is news, not a warning; one it did not (another client
      // took the robot over, the server names who) is
      const asked = goal.cancelAsked && (code === 2 || code === 8);
      const level = code === 3 || asked ? 'info' : code === 2 || code === 8 ? 'warning' : 'error';
      log(level, `goal ${shown(name).toLowerCase()}${text}`);
    }
  }

  /** Navigate to a POI through /navigation/navigate_to_poi and follow it in the panel. */
  goToPoi(poi) {
    if (this.refuse('POI navigation')) return;
    const p = poi.pose.position;
    this.followRequest(this.poiTopic, new ROSLIB.Message({
      poi_name: poi.name, distance_to_target: 0.0, skip_final_turn: false,
    }), `POI “${poi.name}”`, { x: p.x, y: p.y }, /arrived/);
    this.marker.setPose(p.x, p.y, yawOf(poi.pose.orientation));
    this.target = { x: p.x, y: p.y, yaw: 0 };
    log('info', `navigating to POI “${poi.name}”`);
  }

  /** Go home (go_home: to the dock), followed in the panel like a goal until the robot's
   * reply; the distance to go is what is left of the robot's planned path. */
  goHome(topic) {
    if (this.refuse('go home')) return;
    this.marker.hide();
    this.followRequest(topic, new ROSLIB.Message({}), 'home (the dock)', null, /: done$/);
    log('info', 'going home to the dock');
  }

  /**
   * Publish a request the robot carries out as one motion and follow it in the panel from the
   * server's replies to that publish: `arrived` (a regex) on success, another info or warning
   * when cancelled or replaced, an error when it failed. Cancel sends cancel_action.
   */
  followRequest(topic, message, label, target, arrived) {
    this.endActivity();
    this.goal = null;
    const mine = { label, target, cancel: () => this.cancelTopic.publish(new ROSLIB.Message({})) };
    this.activity = mine;
    this.show('active', `ACTIVE → ${label}`);
    this.allowCancel();
    mine.done = publishTracked(topic, message, (status) => {
      if (this.activity !== mine) return;
      const text = status.msg || '';
      if (status.level === 'info' && arrived.test(text)) {
        this.show('succeeded', `SUCCEEDED → ${label}`);
        log('info', `arrived at ${label}`);
      } else if (status.level === 'info' || status.level === 'warning') {
        // cancelled or replaced by another motion: the server says so at info level
        this.show('preempted', `CANCELLED → ${label} — ${operatorText(text)}`);
        log(status.level, operatorText(text));
      } else if (status.level === 'error') {
        this.show('aborted', `ABORTED → ${label} — ${operatorText(text)}`);
        log('error', operatorText(text));
      } else {
        return;
      }
      this.endActivity();
    });
  }

  /**
   * The patrol (planning/patrol_state): while it runs the panel follows it — the waypoint it
   * heads to, the lap, the distance to go — and Cancel stops it (`stop`). A patrol that ends
   * says so; a goal or POI sent meanwhile takes the panel over.
   */
  patrolState(state, stop) {
    const waypoints = state.waypoints || [];
    const i = state.target_index;
    const running = state.active && i >= 0 && i < waypoints.length;
    const started = running && !this.patrolRunning;
    this.patrolRunning = running;
    if (running) {
      const w = waypoints[i];
      const label = `waypoint ${i + 1} of ${waypoints.length} (patrol, lap ${state.laps + 1})`;
      if (!this.activity || !this.activity.patrol) {
        if (!started) return; // a goal sent since replaces the patrol: its last states are old news
        this.endActivity();
        this.goal = null;
        this.activity = { patrol: true, label, target: { x: w.x, y: w.y }, cancel: stop };
        this.allowCancel();
      }
      Object.assign(this.activity, { label, target: { x: w.x, y: w.y } });
      this.marker.hide();
      this.progress();
    } else if (this.activity && this.activity.patrol) {
      this.activity = null;
      this.cancelButton.disabled = true;
      this.show('idle', `Patrol stopped${state.message ? ` — ${fromOne(state.message)}` : ''}`);
      // another client took the robot over (the server names who): a warning, not news
      if (/taken over by/.test(state.message || '')) log('warning', `patrol ${state.message}`);
    }
  }

  endActivity() {
    if (!this.activity) return;
    if (this.activity.done) this.activity.done();
    this.activity = null;
    this.cancelButton.disabled = true;
    this.marker.hide();
  }

  /** The robot's remaining planned path (nav_msgs/Path): the distance to go when there is no
   * single target to measure to. */
  set plan(path) {
    const poses = (path && path.poses) || [];
    let length = 0;
    for (let k = 1; k < poses.length; k++) {
      const a = poses[k - 1].pose.position;
      const b = poses[k].pose.position;
      length += Math.hypot(b.x - a.x, b.y - a.y);
    }
    this.planLength = poses.length > 1 ? length : null;
    const status = this.statusBox.dataset.status;
    // (not within a moment of an end shown here: a plan message already on its way is stale)
    if (this.planLength > PLAN_MIN && !this.activity && this.online && status !== 'active' &&
        status !== 'pending' && performance.now() - this.endedAt > STALE_PLAN_MS) {
      // the robot set off on a motion this page did not send (another client, the shell):
      // the panel follows it rather than keep showing the last goal
      this.goal = null;
      this.activity = { label: 'a motion sent elsewhere', target: null, elsewhere: true,
        cancel: () => this.cancelTopic.publish(new ROSLIB.Message({})) };
      this.marker.hide();
      this.allowCancel();
      this.show('active', 'ACTIVE → a motion sent elsewhere');
    } else if (this.planLength == null && this.activity && this.activity.elsewhere) {
      this.activity = null;
      this.cancelButton.disabled = true;
      this.elsewhereEnded = performance.now();
      this.show('idle', 'No goal — the robot stopped');
    }
    this.progress();
  }

  /**
   * A /move_base result. One that fails a goal sent elsewhere (followed by the panel, or
   * refused or aborted before the robot set off) is shown with its reason, unless this page's
   * own goal runs: an abort is news wherever the goal came from. Other ends show as "the robot
   * stopped".
   */
  resultElsewhere(result) {
    const status = result && result.status;
    if (!status || (this.goal && status.goal_id && this.goal.goalID === status.goal_id.id)) return;
    // this page's own goal or motion running: its own end is what the panel shows
    if ((this.activity && !this.activity.elsewhere) || (status.status !== 4 && status.status !== 5)) return;
    this.activity = null;
    this.cancelButton.disabled = true;
    this.elsewhereEnded = -Infinity;
    const reason = status.text || 'no reason given';
    this.show('aborted', `No goal — the robot stopped: a motion sent elsewhere failed — ${reason}`);
    log('error', `a motion sent elsewhere failed: ${reason}`);
  }

  /** The robot moved: the distance left to what it is doing. */
  set robot(pose) {
    this.robotPose = pose;
    this.progress();
  }

  progress() {
    const a = this.activity;
    const pose = this.robotPose;
    if (!a || (this.statusBox.dataset.status !== 'active' && !a.patrol)) return;
    let left = null;
    if (a.target && pose) left = Math.hypot(a.target.x - pose.x, a.target.y - pose.y);
    else if (this.planLength != null) left = this.planLength;
    this.show('active', `ACTIVE → ${a.label}${left == null ? '' : ` · ${left.toFixed(1)} m to go`}`);
  }

  get robot() {
    return this.robotPose;
  }

  onFeedback(goal, feedback) {
    if (goal !== this.goal || !this.target || !feedback || !feedback.base_position) return;
    const p = feedback.base_position.pose.position;
    const left = Math.hypot(this.target.x - p.x, this.target.y - p.y);
    const t = this.target;
    this.show('active', `ACTIVE → ${formatPose(t.x, t.y, t.yaw)} · ${left.toFixed(1)} m to go`);
  }

  show(state, text) {
    if (state !== 'active' && state !== 'pending' && this.statusBox.dataset.status !== state) {
      this.endedAt = performance.now();
    }
    this.statusBox.dataset.status = state;
    this.statusBox.textContent = text;
  }

  cancel() {
    if (this.refuse('cancel')) return;
    if (this.activity) {
      this.activity.cancel();
      log('info', `${this.activity.label}: cancel requested`);
    } else if (this.goal) {
      this.goal.cancelAsked = true;
      this.goal.cancel();
      log('info', 'goal cancel requested');
    } else {
      this.client.cancel();
    }
  }

  /** Publish /initialpose (the covariance rviz's "2D Pose Estimate" uses). */
  setInitialPose(x, y, yaw) {
    if (this.refuse('initial pose')) return;
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
