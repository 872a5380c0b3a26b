// Drives the real @foxglove/ws-protocol FoxgloveClient (Node, `ws` transport) against a running
// hitrobot-server with the simulated robot, decoding CDR with @foxglove/rosmsg +
// @foxglove/rosmsg2-serialization as Foxglove and Lichtblick do.
// Usage: node foxglove_client.mjs ws://127.0.0.1:PORT
// Prints one line per check: "ok <name>" or "fail <name>: <reason>"; exits 1 if any failed.
// Every wait is bounded; the script ends by itself.
import wsProtocol from '@foxglove/ws-protocol';
import rosmsg from '@foxglove/rosmsg';
import serialization from '@foxglove/rosmsg2-serialization';
import * as ROSLIB from 'roslib';
import WebSocket from 'ws';
import { assert, check, connect, finish, until, within } from './harness.mjs';

const { FoxgloveClient } = wsProtocol; // CommonJS packages: named exports via the default
const { parse } = rosmsg;
const { MessageReader, MessageWriter } = serialization;
const url = process.argv[2];

function open(subprotocol = FoxgloveClient.SUPPORTED_SUBPROTOCOL) {
  const ws = new WebSocket(url, [subprotocol]);
  const client = new FoxgloveClient({ ws });
  const state = { ws, client, info: null, channels: new Map(), services: new Map(), statuses: [],
    handlers: new Map(), params: [], graph: [], calls: new Map(), failures: [] };
  client.on('serverInfo', (i) => { state.info = i; });
  client.on('status', (s) => state.statuses.push(s));
  client.on('advertise', (cs) => cs.forEach((c) => state.channels.set(c.id, c)));
  client.on('unadvertise', (ids) => ids.forEach((id) => state.channels.delete(id)));
  client.on('advertiseServices', (ss) => ss.forEach((s) => state.services.set(s.id, s)));
  client.on('parameterValues', (p) => state.params.push(p));
  client.on('connectionGraphUpdate', (g) => state.graph.push(g));
  client.on('serviceCallFailure', (f) => state.failures.push(f));
  client.on('serviceCallResponse', (r) => state.calls.set(r.callId, r));
  client.on('message', (m) => state.handlers.get(m.subscriptionId)?.(m));
  client.on('error', () => {});
  return state;
}

function channelOf(fox, topic) {
  return [...fox.channels.values()].find((c) => c.topic === topic);
}

function reader(schemaName, schema) {
  return new MessageReader(parse(schema, { ros2: true }));
}

// Subscribe to a topic; decoded messages are pushed to the returned array.
function subscribe(fox, topic) {
  const chan = channelOf(fox, topic);
  assert(chan, `no channel for ${topic}`);
  assert(chan.encoding === 'cdr' && chan.schemaEncoding === 'ros2msg', JSON.stringify(chan));
  const r = reader(chan.schemaName, chan.schema);
  const got = [];
  const id = fox.client.subscribe(chan.id);
  fox.handlers.set(id, (m) => got.push({ msg: r.readMessage(m.data), ts: m.timestamp }));
  return { id, got };
}

const fox = open();
await within(5000, 'serverInfo', (ok) => fox.client.on('serverInfo', ok));
const ros = await connect(ROSLIB, url);

await check('server_info', async () => {
  for (const cap of ['clientPublish', 'services', 'parameters', 'parametersSubscribe',
    'connectionGraph', 'time']) {
    assert(fox.info.capabilities.includes(cap), `no ${cap}: ${JSON.stringify(fox.info)}`);
  }
  assert(fox.ws.protocol === 'foxglove.websocket.v1', fox.ws.protocol);
});

await check('channels_for_every_topic', async () => {
  const listed = await within(5000, 'rosapi topics', (ok, bad) => ros.getTopics(ok, bad));
  const want = listed.topics;
  assert(want.includes('/odom') && want.includes('/scan'), JSON.stringify(want));
  await until(5000, 'a channel per topic', () => {
    const have = new Set([...fox.channels.values()].map((c) => c.topic));
    return want.every((t) => have.has(t));
  });
  // a topic that appears later is advertised too
  const late = new ROSLIB.Topic({ ros, name: '/fg/late', messageType: 'std_msgs/String' });
  late.advertise();
  await until(5000, 'channel for /fg/late', () => channelOf(fox, '/fg/late'));
  assert(channelOf(fox, '/fg/late').schemaName === 'std_msgs/msg/String',
    JSON.stringify(channelOf(fox, '/fg/late')));
});

await check('every_channel_decodes', async () => {
  // every schema parses, and whatever arrives on any channel within 2 s decodes with it
  const readers = new Map([...fox.channels.values()].map((c) => [c.id, reader(c.schemaName, c.schema)]));
  const decoded = new Map();
  const failures = [];
  const ids = [...fox.channels.values()].map((c) => {
    const id = fox.client.subscribe(c.id);
    fox.handlers.set(id, (m) => {
      try {
        readers.get(c.id).readMessage(m.data);
        decoded.set(c.topic, (decoded.get(c.topic) || 0) + 1);
      } catch (err) {
        failures.push(`${c.topic} (${c.schemaName}): ${err.message}`);
      }
    });
    return id;
  });
  await new Promise((r) => setTimeout(r, 2000)); // a sampling window, not a synchronisation
  ids.forEach((id) => { fox.client.unsubscribe(id); fox.handlers.delete(id); });
  assert(failures.length === 0, failures.slice(0, 5).join('; '));
  for (const t of ['/odom', '/scan', '/tf', '/map', '/robot_pose', '/diagnostics_agg',
    '/slamware_ros_sdk_server_node/robot_basic_state', '/cloud_registered']) {
    assert(decoded.get(t) > 0, `nothing decoded on ${t}: ${JSON.stringify([...decoded.keys()])}`);
  }
});

await check('odom_scan_map_tf_at_their_rates', async () => {
  // /map (the map manager's, latched) comes on change; the Slamware node's map every 0.2 s
  const topics = ['/odom', '/scan', '/map', '/slamware_ros_sdk_server_node/map', '/tf'];
  const subs = Object.fromEntries(topics.map((t) => [t, subscribe(fox, t)]));
  await until(5000, 'the latched /map', () => subs['/map'].got.length > 0);
  const start = Object.fromEntries(Object.entries(subs).map(([t, s]) => [t, s.got.length]));
  const t0 = Date.now();
  await new Promise((r) => setTimeout(r, 3000)); // a measuring window, not a synchronisation
  const secs = (Date.now() - t0) / 1000;
  const rate = (t) => (subs[t].got.length - start[t]) / secs;
  // nominal: odom 20 Hz, scan 10 Hz, map 5 Hz, tf > 20 Hz; half is enough on a loaded machine
  assert(rate('/odom') >= 10, `odom ${rate('/odom')} Hz`);
  assert(rate('/scan') >= 5, `scan ${rate('/scan')} Hz`);
  const slamMap = '/slamware_ros_sdk_server_node/map';
  assert(rate(slamMap) >= 2, `map ${rate(slamMap)} Hz`);
  assert(rate('/tf') >= 10, `tf ${rate('/tf')} Hz`);
  const odom = subs['/odom'].got.at(-1).msg;
  assert(typeof odom.pose.pose.position.x === 'number' && odom.child_frame_id, JSON.stringify(odom));
  const scan = subs['/scan'].got.at(-1).msg;
  assert(scan.ranges.length === 360 && scan.header.stamp.sec > 1e9, `scan ${scan.ranges.length}`);
  for (const t of ['/map', slamMap]) {
    const map = subs[t].got.at(-1).msg;
    assert(map.info.width * map.info.height === map.data.length && map.data.length > 0,
      `${t} ${map.info.width}x${map.info.height} ${map.data.length}`);
  }
  const tf = subs['/tf'].got.at(-1).msg;
  assert(tf.transforms.length > 0 && tf.transforms[0].child_frame_id, JSON.stringify(tf));
  const ts = subs['/scan'].got.at(-1).ts;
  assert(Math.abs(Number(ts / 1000000n) - Date.now()) < 5000, `log time ${ts}`);
  for (const s of Object.values(subs)) fox.client.unsubscribe(s.id);
});

await check('cmd_vel_from_foxglove_turns_the_robot', async () => {
  const odom = subscribe(fox, '/odom');
  const twist = 'geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n' +
    '================================================================================\n' +
    'MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n';
  const writer = new MessageWriter(parse(twist, { ros2: true }));
  const chan = fox.client.advertise({ topic: '/cmd_vel', encoding: 'cdr',
    schemaName: 'geometry_msgs/msg/Twist', schema: twist, schemaEncoding: 'ros2msg' });
  const cmd = writer.writeMessage({ linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.8 } });
  const timer = setInterval(() => fox.client.sendMessage(chan, cmd), 100);
  try {
    await until(8000, 'the robot turning', () =>
      odom.got.length > 0 && odom.got.at(-1).msg.twist.twist.angular.z > 0.3);
  } finally {
    clearInterval(timer);
    fox.client.sendMessage(chan, writer.writeMessage({ linear: { x: 0, y: 0, z: 0 },
      angular: { x: 0, y: 0, z: 0 } }));
    fox.client.unsubscribe(odom.id);
    fox.client.unadvertise(chan);
  }
});

await check('cmd_vel_one_driver_at_a_time', async () => {
  // roslibjs drives; Foxglove's command meanwhile is refused naming it; once roslibjs stops,
  // the lease lapses and Foxglove's next command takes it
  const lease = subscribe(fox, '/drive_lease');
  const holder = () => (lease.got.length ? lease.got.at(-1).msg : null);
  await until(5000, 'nobody driving', () => holder() && holder().holder === '');
  const twist = 'geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n' +
    '================================================================================\n' +
    'MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n';
  const writer = new MessageWriter(parse(twist, { ros2: true }));
  const chan = fox.client.advertise({ topic: '/cmd_vel', encoding: 'cdr',
    schemaName: 'geometry_msgs/msg/Twist', schema: twist, schemaEncoding: 'ros2msg' });
  const turn = { linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.4 } };
  const rcmd = new ROSLIB.Topic({ ros, name: '/cmd_vel', messageType: 'geometry_msgs/Twist' });
  rcmd.publish(turn);
  const timer = setInterval(() => rcmd.publish(turn), 100);
  let driver;
  try {
    await until(5000, 'roslibjs holding the lease', () => holder().holder !== '');
    driver = holder().holder;
    const before = fox.statuses.length;
    fox.client.sendMessage(chan, writer.writeMessage(turn));
    await until(5000, 'the refusal', () => fox.statuses.slice(before).some((st) =>
      st.level === 2 && st.message.includes(`driven by ${driver}`)));
  } finally {
    clearInterval(timer);
  }
  await until(5000, 'the lease lapsing', () => holder().reason === 'lapsed' && holder().stopped);
  fox.client.sendMessage(chan, writer.writeMessage(turn));
  await until(5000, 'Foxglove holding the lease', () => holder().holder !== '' &&
    holder().holder !== driver);
  fox.client.sendMessage(chan, writer.writeMessage({ linear: { x: 0, y: 0, z: 0 },
    angular: { x: 0, y: 0, z: 0 } }));
  fox.client.unadvertise(chan);
  fox.client.unsubscribe(lease.id);
});

function service(name) {
  return [...fox.services.values()].find((s) => s.name === name);
}

let callId = 1;
async function call(name, request) {
  const svc = service(name);
  assert(svc, `no service ${name}`);
  const id = callId++;
  const req = svc.request.schema ? new MessageWriter(parse(svc.request.schema, { ros2: true }))
    .writeMessage(request) : new Uint8Array([0, 1, 0, 0, 0]);
  fox.client.sendServiceCallRequest({ serviceId: svc.id, callId: id, encoding: 'cdr', data: req });
  await until(5000, `reply to ${name}`, () => fox.calls.has(id) ||
    fox.failures.some((f) => f.callId === id));
  const failure = fox.failures.find((f) => f.callId === id);
  if (failure) return { failure };
  const resp = fox.calls.get(id);
  return { value: reader(svc.response.schemaName, svc.response.schema).readMessage(resp.data) };
}

await check('service_call', async () => {
  await until(5000, 'services advertised', () => service('/fg/add') && service('/rosapi/topics'));
  const sum = await call('/fg/add', { a: 40n, b: 2n });
  assert(sum.value && sum.value.sum === 42n, JSON.stringify(sum, (k, v) => `${v}`));
  const topics = await call('/rosapi/topics', {});
  assert(topics.value.topics.includes('/odom'), JSON.stringify(topics.value));
  const failed = await call('/fg/fail', { a: 1n, b: 1n });
  assert(failed.failure && failed.failure.message.includes('refused on purpose'),
    JSON.stringify(failed));
});

await check('parameters_get_set_subscribe', async () => {
  fox.client.setParameters([{ name: '/fg/gain', value: 1.5, type: 'float64' }], 'set1');
  await until(5000, 'set reply', () => fox.params.some((p) => p.id === 'set1'));
  fox.client.getParameters(['/fg/gain'], 'get1');
  await until(5000, 'get reply', () => fox.params.some((p) => p.id === 'get1'));
  const got = fox.params.find((p) => p.id === 'get1').parameters;
  assert(got.length === 1 && got[0].value === 1.5, JSON.stringify(got));
  // a value set by a rosbridge client reaches a Foxglove subscriber of that parameter
  fox.client.subscribeParameterUpdates(['/fg/gain']);
  fox.client.getParameters([], 'sync');  // ops run in order: subscribed once this is answered
  await until(5000, 'sync', () => fox.params.some((p) => p.id === 'sync'));
  const p = new ROSLIB.Param({ ros, name: '/fg/gain' });
  await within(5000, 'roslibjs set', (ok, bad) => p.set(2.5, ok, bad));
  await until(5000, 'update', () => fox.params.some((u) => u.id === undefined &&
    u.parameters.some((q) => q.name === '/fg/gain' && q.value === 2.5)));
});

await check('connection_graph', async () => {
  fox.client.subscribeConnectionGraph();
  await until(5000, 'graph', () => fox.graph.length > 0);
  const g = fox.graph[0];
  const odom = g.publishedTopics.find((t) => t.name === '/odom');
  assert(odom && odom.publisherIds.includes('/slamware_ros_sdk_server_node'), JSON.stringify(odom));
  assert(g.advertisedServices.some((s) => s.name === '/rosapi/topics'), 'no /rosapi/topics');
  // a new subscriber shows up in an update
  const t = new ROSLIB.Topic({ ros, name: '/fg/graph_probe', messageType: 'std_msgs/String' });
  t.subscribe(() => {});
  await until(5000, 'graph update', () => fox.graph.some((u) =>
    u.subscribedTopics.some((s) => s.name === '/fg/graph_probe')));
  t.unsubscribe();
  fox.client.unsubscribeConnectionGraph();
});

await check('foxglove_and_roslibjs_on_one_topic', async () => {
  const fsub = subscribe(fox, '/scan');
  const rgot = [];
  const rsub = new ROSLIB.Topic({ ros, name: '/scan', messageType: 'sensor_msgs/LaserScan' });
  rsub.subscribe((m) => rgot.push(m));
  await until(8000, 'both get scans with a common stamp', () => {
    const fs = new Set(fsub.got.map((g) => `${g.msg.header.stamp.sec}.${g.msg.header.stamp.nanosec}`));
    return rgot.some((m) => fs.has(`${m.header.stamp.secs}.${m.header.stamp.nsecs}`));
  });
  const f = fsub.got.at(-1).msg;
  const r = rgot.find((m) => m.header.stamp.secs === f.header.stamp.sec &&
    m.header.stamp.nsecs === f.header.stamp.nanosec) || rgot.at(-1);
  assert(r.ranges.length === f.ranges.length, `${r.ranges.length} vs ${f.ranges.length}`);
  rsub.unsubscribe();
  fox.client.unsubscribe(fsub.id);
});

await check('bad_input_gets_error_status', async () => {
  const before = fox.statuses.length;
  fox.ws.send('not json');
  fox.ws.send(new Uint8Array([9, 1, 2, 3]));
  fox.ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: 99, channelId: 424242 }] }));
  fox.ws.send(JSON.stringify({ op: 'unsubscribe', subscriptionIds: [777] }));
  fox.client.sendMessage(31337, new Uint8Array([0, 1, 0, 0]));
  fox.client.getParameters([], 'after-bad');
  await until(5000, 'answer after bad input', () => fox.params.some((p) => p.id === 'after-bad'));
  const errors = fox.statuses.slice(before).filter((s) => s.level === 2).map((s) => s.message);
  assert(errors.length === 5, JSON.stringify(errors));
  assert(errors.some((e) => e.includes('invalid JSON')) && errors.some((e) => e.includes('opcode 9'))
    && errors.some((e) => e.includes('424242')) && errors.some((e) => e.includes('777'))
    && errors.some((e) => e.includes('31337')), JSON.stringify(errors));
});

await check('sdk_subprotocol', async () => {
  const sdk = open('foxglove.sdk.v1');
  await within(5000, 'serverInfo', (ok) => sdk.client.on('serverInfo', ok));
  assert(sdk.ws.protocol === 'foxglove.sdk.v1', sdk.ws.protocol);
  await until(5000, 'channels', () => channelOf(sdk, '/odom'));
  const replies = [];
  sdk.ws.on('message', (d, binary) => { if (!binary) replies.push(JSON.parse(d.toString())); });
  sdk.ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ channelId: channelOf(sdk, '/odom').id }] }));
  await until(5000, 'subscriptionResponse', () => replies.some((r) => r.op === 'subscriptionResponse'));
  const r = replies.find((x) => x.op === 'subscriptionResponse');
  const got = [];
  sdk.handlers.set(r.subscriptions[0].id, (m) => got.push(m));
  await until(5000, 'odom on the sdk subprotocol', () => got.length > 0);
  sdk.client.close();
});

fox.client.close();
finish([ros]);
