// TF and ROS 2 action checks with the real roslibjs 2.x and 1.4.1 (Node) against a
// hitrobot-server running the simulated robot.
// Usage: node roslibjs_tf.mjs ws://127.0.0.1:PORT
// Prints one line per check: "ok <name>" or "fail <name>: <reason>"; exits 1 if any failed.
// Every wait is bounded; the script ends by itself.
import * as ROSLIB from 'roslib';
import ROSLIB1 from 'roslib1';
import { assert, check, connect as open, finish, results, until, within } from './harness.mjs';

const url = process.argv[2];

const ros2x = await open(ROSLIB, url);
const ros1x = await open(ROSLIB1, url);
const ros1xService = await open(ROSLIB1, url, { groovyCompatibility: false });

// Four TF clients, one per form a client library uses, all following base_link in map.
const options = { fixedFrame: 'map', angularThres: 0.01, transThres: 0.01, rate: 10.0 };
const clients = {
  tfclient_2x_actionlib: new ROSLIB.TFClient({ ros: ros2x, ...options }),
  ros2tfclient_2x_action: new ROSLIB.ROS2TFClient({ ros: ros2x, ...options }),
  tfclient_1x_actionlib: new ROSLIB1.TFClient({ ros: ros1x, ...options }),
  tfclient_1x_republish_service: new ROSLIB1.TFClient({ ros: ros1xService, ...options }),
};
const seen = {};
for (const [name, client] of Object.entries(clients)) {
  seen[name] = [];
  client.subscribe('base_link', (tf) => seen[name].push({ x: tf.translation.x, y: tf.translation.y }));
}

const odom = [];
new ROSLIB.Topic({ ros: ros2x, name: '/odom', messageType: 'nav_msgs/Odometry' })
  .subscribe((m) => odom.push(m));
const cmd = new ROSLIB.Topic({ ros: ros2x, name: '/cmd_vel', messageType: 'geometry_msgs/Twist' });

let firstSeen = false;
try {
  await until(10000, 'a first transform on every client',
    () => Object.values(seen).every((s) => s.length > 0));
  firstSeen = true;
} catch (err) {
  for (const name of Object.keys(clients)) {
    if (!seen[name].length) results.push(`fail ${name}: no transform within 10 s`);
  }
}

if (firstSeen) {
  const start = Object.fromEntries(Object.entries(seen).map(([n, s]) => [n, s[s.length - 1]]));
  const moved = (n) => {
    const last = seen[n][seen[n].length - 1];
    return Math.hypot(last.x - start[n].x, last.y - start[n].y);
  };
  // drive forward (free floor ahead of the start pose) until every client saw 0.3 m
  const drive = setInterval(() => cmd.publish({ linear: { x: 0.3, y: 0, z: 0 },
                                                angular: { x: 0, y: 0, z: 0 } }), 100);
  try {
    await until(15000, 'every client to follow the robot',
      () => Object.keys(clients).every((n) => moved(n) >= 0.3));
  } catch (err) { /* reported per client below */ }
  clearInterval(drive);
  cmd.publish({});
  const stopped = () => odom.length > 0 && Math.abs(odom[odom.length - 1].twist.twist.linear.x) < 1e-3;
  try { await until(5000, 'the robot to stop', stopped); } catch (err) { /* reported below */ }
  for (const name of Object.keys(clients)) {
    await check(name, async () => {
      assert(moved(name) >= 0.3, `base_link moved only ${moved(name).toFixed(3)} m`);
      // once stopped, the last transform is where odometry says the robot is
      await until(5000, 'the transform to match odometry', () => {
        const p = odom[odom.length - 1].pose.pose.position;
        const t = seen[name][seen[name].length - 1];
        return stopped() && Math.hypot(p.x - t.x, p.y - t.y) < 0.02;
      });
    });
  }
}
for (const client of Object.values(clients)) client.dispose();

await check('rosout_type', async () => {
  const type = await within(5000, 'topic type', (ok, bad) => ros2x.getTopicType('/rosout', ok, bad));
  assert(type === 'rosgraph_msgs/Log', type);
});

await check('cancel_all_goals_stops_follow_path', async () => {
  await until(5000, 'odometry', () => odom.length > 0);
  const p = odom[odom.length - 1].pose.pose.position;
  const pose = (x) => ({ header: { frame_id: 'map' },
                         pose: { position: { x, y: p.y, z: 0 }, orientation: { x: 0, y: 0, z: 0, w: 1 } } });
  const action = new ROSLIB.Action({ ros: ros2x, name: '/follow_path',
                                     actionType: 'nav2_msgs/action/FollowPath' });
  const feedback = [];
  const outcome = within(20000, 'the goal to end', (ok) => action.sendGoal(
    { path: { header: { frame_id: 'map' }, poses: [pose(p.x), pose(p.x + 1.5), pose(p.x + 3)] } },
    (result) => ok({ result }), (f) => feedback.push(f), (error) => ok({ error })));
  await until(10000, 'the robot driving the path',
    () => feedback.length > 0 && odom[odom.length - 1].twist.twist.linear.x > 0.05);
  action.cancelAllGoals(); // a call_service to /follow_path/_action/cancel_goal
  const end = await outcome;
  assert(end.error !== undefined && String(end.error).includes('canceled'),
    `the goal ended with ${JSON.stringify(end)}, not cancelled (status 5)`);
  await until(5000, 'the robot to stop',
    () => Math.abs(odom[odom.length - 1].twist.twist.linear.x) < 1e-3);
  const q = odom[odom.length - 1].pose.pose.position;
  assert(q.x < p.x + 2.9, `the robot drove the whole path (x ${q.x.toFixed(2)})`);
});

finish([ros2x, ros1x, ros1xService]);
