// The Foxglove column of issue 47's matrix: the real @foxglove/ws-protocol client of each role,
// its token as ?token= in the URL (the protocol has no auth op), against every op kind.
// Usage: node foxglove_access.mjs ws://127.0.0.1:PORT '{"viewer": "TOKEN", ...}'
// Prints one line per role and cell: "refused ROLE/CELL: reason" or "done ROLE/CELL", then
// "ok finished". Every wait is bounded; the script ends by itself.
import wsProtocol from '@foxglove/ws-protocol';
import rosmsg from '@foxglove/rosmsg';
import serialization from '@foxglove/rosmsg2-serialization';
import WebSocket from 'ws';
import { until, within } from './harness.mjs';

const { FoxgloveClient } = wsProtocol;
const { parse } = rosmsg;
const { MessageWriter } = serialization;
const url = process.argv[2];
const tokens = JSON.parse(process.argv[3]);
const REFUSALS = ['lacks the permission', 'may drive at most', 'may send goals only'];
const TWIST = 'geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n' +
  '================================================================================\n' +
  'MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n';
const twist = new MessageWriter(parse(TWIST, { ros2: true }));

async function open(token) {
  const ws = new WebSocket(`${url}/?token=${encodeURIComponent(token)}`,
    [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const client = new FoxgloveClient({ ws });
  const s = { ws, client, channels: new Map(), services: new Map(), statuses: [], calls: new Set() };
  client.on('status', (m) => s.statuses.push(m));
  client.on('advertise', (cs) => cs.forEach((c) => s.channels.set(c.id, c)));
  client.on('advertiseServices', (ss) => ss.forEach((v) => s.services.set(v.name, v)));
  client.on('serviceCallResponse', (r) => s.calls.add(r.callId));
  client.on('serviceCallFailure', (r) => s.calls.add(r.callId));
  client.on('error', () => {});
  await within(5000, 'serverInfo', (ok) => client.on('serverInfo', ok));
  await until(5000, 'channels and services', () =>
    [...s.channels.values()].some((c) => c.topic === '/scan') && s.services.has('/hitrobot/whoami'));
  return s;
}

let callId = 1;
function callService(s, name) {
  const svc = s.services.get(name);
  const id = callId++;
  const data = svc.request && svc.request.schema
    ? new MessageWriter(parse(svc.request.schema, { ros2: true })).writeMessage({})
    : new Uint8Array([0, 1, 0, 0]);
  s.client.sendServiceCallRequest({ serviceId: svc.id, callId: id, encoding: 'cdr', data });
  return id;
}

// Run one cell; the refusals it got, once a later call (whoami: every role) is answered.
async function refusals(s, act) {
  s.statuses.length = 0;
  act();
  const sync = callService(s, '/hitrobot/whoami');
  await until(5000, 'the round trip', () => s.calls.has(sync));
  return s.statuses.filter((m) => REFUSALS.some((w) => m.message.includes(w))).map((m) => m.message);
}

const CELLS = {
  subscribe: (s) => s.client.subscribe([...s.channels.values()].find((c) => c.topic === '/scan').id),
  advertise: (s) => s.client.advertise({ topic: '/matrix/fox', encoding: 'cdr',
    schemaName: 'std_msgs/msg/String', schema: 'string data\n', schemaEncoding: 'ros2msg' }),
  publish_drive: (s) => s.client.sendMessage(s.cmdVel,
    twist.writeMessage({ linear: { x: 0.1, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } })),
  publish_drive_over_the_agents_cap: (s) => s.client.sendMessage(s.cmdVel,
    twist.writeMessage({ linear: { x: 1.0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } })),
  call_read_only: (s) => callService(s, '/rosapi/get_time'),
  call_param_set: (s) => callService(s, '/rosapi/set_param'),
  get_parameters: (s) => s.client.getParameters(['/rosdistro'], 'get'),
  set_parameters: (s) => s.client.setParameters([{ name: '/matrix/fox', value: 1 }], 'set'),
  playback_control: (s) => s.ws.send(new Uint8Array([3, 0, 0, 0, 0x80, 0x3f, 0, 0, 0, 0, 0, 0, 0, 0])),
};

for (const [role, token] of Object.entries(tokens)) {
  const s = await open(token);
  // the drive cells publish on a channel of /cmd_vel advertised first (refused for some roles:
  // then the message names an unknown channel, which is no role refusal; that cell is skipped)
  const before = await refusals(s, () => {
    s.cmdVel = s.client.advertise({ topic: '/cmd_vel', encoding: 'cdr',
      schemaName: 'geometry_msgs/msg/Twist', schema: TWIST, schemaEncoding: 'ros2msg' });
  });
  for (const [cell, act] of Object.entries(CELLS)) {
    if (cell.startsWith('publish_drive') && before.length) {
      console.log(`refused ${role}/${cell}: ${before[0]}`);
      continue;
    }
    const got = await refusals(s, () => act(s));
    console.log(got.length ? `refused ${role}/${cell}: ${got[0]}` : `done ${role}/${cell}`);
  }
  s.client.close();
}
console.log('ok finished');
process.exit(0);
