// Drives the real roslibjs 2.x (Node, `ws` transport) against a running hitrobot-server.
// Usage: node roslibjs_client.mjs ws://127.0.0.1:PORT
// Prints one line per check: "ok <name>" or "fail <name>: <reason>"; exits 1 if any failed.
// Every wait is bounded; the script ends by itself.
import * as ROSLIB from 'roslib';
import { assert, check, connect, finish, within } from './harness.mjs';

const url = process.argv[2];

const a = await connect(ROSLIB, url);
const b = await connect(ROSLIB, url);

await check('pubsub', async () => {
  const sub = new ROSLIB.Topic({ ros: b, name: '/js/chatter', messageType: 'std_msgs/String' });
  const pub = new ROSLIB.Topic({ ros: a, name: '/js/chatter', messageType: 'std_msgs/String' });
  const got = within(5000, 'message', (ok) => sub.subscribe((m) => ok(m)));
  await new Promise((r) => setTimeout(r, 200));
  pub.publish({ data: 'héllo from roslibjs' });
  const m = await got;
  assert(m.data === 'héllo from roslibjs', `got ${JSON.stringify(m)}`);
  sub.unsubscribe();
});

await check('png_compression', async () => {
  const sub = new ROSLIB.Topic({ ros: b, name: '/js/png', messageType: 'std_msgs/String',
                                 compression: 'png' });
  const pub = new ROSLIB.Topic({ ros: a, name: '/js/png', messageType: 'std_msgs/String' });
  const got = within(5000, 'png message', (ok) => sub.subscribe((m) => ok(m)));
  await new Promise((r) => setTimeout(r, 200));
  pub.publish({ data: 'compressed ✓ ' + 'x'.repeat(5000) });
  const m = await got;
  assert(m.data === 'compressed ✓ ' + 'x'.repeat(5000), 'png payload differs');
});

await check('cbor_compression', async () => {
  const sub = new ROSLIB.Topic({ ros: b, name: '/js/scan', messageType: 'sensor_msgs/LaserScan',
                                 compression: 'cbor' });
  const pub = new ROSLIB.Topic({ ros: a, name: '/js/scan', messageType: 'sensor_msgs/LaserScan' });
  const got = within(5000, 'cbor message', (ok) => sub.subscribe((m) => ok(m)));
  await new Promise((r) => setTimeout(r, 200));
  pub.publish({ ranges: [1.5, 2.5, 3.5], angle_max: 1.0 });
  const m = await got;
  assert(m.ranges instanceof Float32Array, `ranges is ${Object.prototype.toString.call(m.ranges)}`);
  assert(m.ranges.length === 3 && m.ranges[1] === 2.5, `ranges ${Array.from(m.ranges)}`);
});

await check('fragmented_large_message', async () => {
  // the server runs with --max-message-size, so this arrives as fragments roslibjs 2.x joins
  const sub = new ROSLIB.Topic({ ros: b, name: '/js/big', messageType: 'std_msgs/String' });
  const pub = new ROSLIB.Topic({ ros: a, name: '/js/big', messageType: 'std_msgs/String' });
  const got = within(10000, 'big message', (ok) => sub.subscribe((m) => ok(m)));
  await new Promise((r) => setTimeout(r, 200));
  const big = 'abcdefghij'.repeat(100000);
  pub.publish({ data: big });
  const m = await got;
  assert(m.data === big, `length ${m.data.length}`);
});

await check('service_between_clients', async () => {
  const server = new ROSLIB.Service({ ros: a, name: '/js/toggle', serviceType: 'std_srvs/SetBool' });
  await server.advertise((req, res) => { res.success = !req.data; res.message = 'negated'; return true; });
  await new Promise((r) => setTimeout(r, 200));
  const client = new ROSLIB.Service({ ros: b, name: '/js/toggle', serviceType: 'std_srvs/SetBool' });
  const res = await within(5000, 'service response', (ok, bad) =>
    client.callService({ data: true }, ok, (e) => bad(new Error(e))));
  assert(res.success === false && res.message === 'negated', JSON.stringify(res));
});

await check('service_failure', async () => {
  const client = new ROSLIB.Service({ ros: b, name: '/js/missing', serviceType: 'std_srvs/Empty' });
  const err = await within(5000, 'failure', (ok, bad) =>
    client.callService({}, () => bad(new Error('unexpected success')), ok));
  assert(String(err).includes('does not exist'), String(err));
});

await check('rosapi_and_params', async () => {
  const topics = await within(5000, 'topics', (ok, bad) => a.getTopics(ok, bad));
  assert(topics.topics.includes('/js/chatter'), JSON.stringify(topics.topics));
  const p = new ROSLIB.Param({ ros: a, name: '/js/gain' });
  await within(5000, 'set', (ok, bad) => p.set(1.25, ok, bad));
  const v = await within(5000, 'get', (ok, bad) => p.get(ok, bad));
  assert(v === 1.25, `param ${v}`);
  const names = await within(5000, 'names', (ok, bad) => a.getParams(ok, bad));
  assert(names.includes('/js/gain'), JSON.stringify(names));
  const type = await within(5000, 'type', (ok, bad) => a.getTopicType('/js/chatter', ok, bad));
  assert(type === 'std_msgs/String', type);
});

await check('ros2_action_goal', async () => {
  // /js/count is served in-process by the test (counts feedback, then succeeds)
  const action = new ROSLIB.Action({ ros: b, name: '/js/count', actionType: 'nav2_msgs/action/FollowPath' });
  const feedback = [];
  const result = await within(5000, 'action result', (ok, bad) =>
    action.sendGoal({ controller_id: 'js' }, ok, (f) => feedback.push(f), (e) => bad(new Error(e))));
  assert(feedback.length >= 2, `feedback ${JSON.stringify(feedback)}`);
  assert(feedback[feedback.length - 1].distance_to_goal === 0, JSON.stringify(feedback));
  assert(result !== undefined, 'no result');
});

await check('status_errors_reach_client', async () => {
  // roslibjs emits a status that carries an id as the event `status:<id>`
  const status = within(5000, 'status', (ok) => b.on('status:js-bad', (s) => ok(s)));
  b.callOnConnection({ op: 'subscribe', id: 'js-bad', topic: '/js/never', type: 'nope_msgs/Nothing' });
  const s = await status;
  assert(s.level === 'error' && s.msg.includes('nope_msgs/Nothing'), JSON.stringify(s));
});

finish([a, b]);
