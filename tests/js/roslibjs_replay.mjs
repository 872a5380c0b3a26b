// `hitrobot-server replay` seen by the real roslibjs 2.x (Node).
// Usage: node roslibjs_replay.mjs ws://127.0.0.1:PORT RECORDED.json
// RECORDED.json: {"poses": {"secs.nsecs": [x, y]}, "grid": [width, height]} read from the file.
// Prints one line per check: "ok <name>" or "fail <name>: <reason>"; exits 1 if any failed.
import { readFileSync } from 'node:fs';
import * as ROSLIB from 'roslib';
import { assert, check, connect, finish, until, within } from './harness.mjs';

const url = process.argv[2];
const recorded = JSON.parse(readFileSync(process.argv[3], 'utf8'));
const ros = await connect(ROSLIB, url);

await check('recorded_poses', async () => {
  const got = [];
  const odom = new ROSLIB.Topic({ ros, name: '/odom', messageType: 'nav_msgs/Odometry' });
  odom.subscribe((m) => got.push(m));
  await until(15000, '20 odometry messages', () => got.length >= 20);
  odom.unsubscribe();
  for (const m of got.slice(0, 20)) {
    const key = `${m.header.stamp.secs}.${m.header.stamp.nsecs}`;
    const pose = recorded.poses[key];
    assert(pose, `stamp ${key} was not recorded`);
    const p = m.pose.pose.position;
    assert(pose[0] === p.x && pose[1] === p.y, `pose at ${key}: ${p.x},${p.y} != ${pose}`);
  }
});

await check('latched_map_late_joiner', async () => {
  const map = new ROSLIB.Topic({ ros, name: '/map', messageType: 'nav_msgs/OccupancyGrid' });
  const grid = await within(15000, 'the latched map', (ok) => map.subscribe(ok));
  map.unsubscribe();
  assert(grid.info.width === recorded.grid[0] && grid.info.height === recorded.grid[1],
    `map ${grid.info.width}x${grid.info.height}`);
});

await check('seek_and_state', async () => {
  const seek = new ROSLIB.Service({ ros, name: '/replay/seek', serviceType: 'hitrobot_msgs/ReplaySeek' });
  const pause = new ROSLIB.Service({ ros, name: '/replay/pause', serviceType: 'std_srvs/Trigger' });
  const resume = new ROSLIB.Service({ ros, name: '/replay/resume', serviceType: 'std_srvs/Trigger' });
  const call = (service, args) => within(10000, service.name, (ok, bad) => service.callService(args, ok, bad));
  const states = [];
  const state = new ROSLIB.Topic({ ros, name: '/replay/state', messageType: 'hitrobot_msgs/ReplayState' });
  state.subscribe((s) => states.push(s));
  assert((await call(pause, {})).success, 'pause');
  const reply = await call(seek, { position: 1.5 });
  assert(reply.success, `seek: ${reply.message}`);
  await until(10000, 'paused at 1.5 s', () => states.some((s) => s.paused && s.position === 1.5));
  assert((await call(resume, {})).success, 'resume');
  await until(10000, 'playing again', () => states.some((s) => !s.paused && s.position > 1.5));
  state.unsubscribe();
});

finish([ros]);
