// Several real @foxglove/ws-protocol clients against one address that may be served by more
// than one process (`--workers N`: the kernel spreads the connections; a Zenoh peer without
// the robot): each must be offered the robot's topics and receive /scan data.
// Usage: node foxglove_spread.mjs ws://127.0.0.1:PORT CLIENTS WORKERS TOPIC[,TOPIC...]
// With WORKERS > 1, connections are opened (at most 64) until CLIENTS of them are spread
// evenly over the workers, as the handshake's X-Hitrobot-Worker header names them.
// Prints one line per check ("ok <name>" or "fail <name>: <reason>"); exits 1 if any failed.
import wsProtocol from '@foxglove/ws-protocol';
import rosmsg from '@foxglove/rosmsg';
import serialization from '@foxglove/rosmsg2-serialization';
import WebSocket from 'ws';
import { assert, check, finish, until, within } from './harness.mjs';

const { FoxgloveClient } = wsProtocol;
const { parse } = rosmsg;
const { MessageReader } = serialization;
const [url, clientsArg, workersArg, topicsArg] = process.argv.slice(2);
const wanted = Number(clientsArg);
const workers = Number(workersArg);
const topics = topicsArg.split(',');
const MAX_TRIES = 64;

// A connection and the worker that accepted it ("" when the server names none).
async function open() {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  let worker = '';
  ws.on('upgrade', (res) => { worker = res.headers['x-hitrobot-worker'] ?? ''; });
  const client = new FoxgloveClient({ ws });
  const fox = { ws, client, channels: new Map(), got: [], worker: '' };
  client.on('advertise', (cs) => cs.forEach((c) => fox.channels.set(c.id, c)));
  client.on('unadvertise', (ids) => ids.forEach((id) => fox.channels.delete(id)));
  client.on('error', () => {});
  await within(10000, 'serverInfo', (ok) => client.on('serverInfo', ok));
  fox.worker = worker;
  return fox;
}

// CLIENTS connections, as many on each worker (extra ones closed), bounded in tries.
async function spread() {
  const kept = [];
  const per = Math.ceil(wanted / Math.max(workers, 1));
  const count = new Map();
  for (let i = 0; i < MAX_TRIES && kept.length < wanted; i++) {
    const fox = await open();
    const n = count.get(fox.worker) ?? 0;
    if (workers > 1 && n >= per) { fox.client.close(); continue; }
    count.set(fox.worker, n + 1);
    kept.push(fox);
  }
  return kept;
}

const clients = await spread();
await check('spread', async () => {
  assert(clients.length === wanted, `only ${clients.length} of ${wanted} clients`);
  const seen = new Set(clients.map((c) => c.worker));
  assert(seen.size === Math.max(workers, 1), `workers seen: ${[...seen]}`);
});

async function offeredAndReceives(fox) {
  await until(30000, `channels ${topics} (have ${fox.channels.size})`, () => {
    const have = new Set([...fox.channels.values()].map((c) => c.topic));
    return topics.every((t) => have.has(t));
  });
  const scan = [...fox.channels.values()].find((c) => c.topic === '/scan');
  assert(scan, 'no /scan channel');
  const reader = new MessageReader(parse(scan.schema, { ros2: true }));
  const id = fox.client.subscribe(scan.id);
  await within(30000, '/scan data', (ok) => fox.client.on('message', (m) => {
    if (m.subscriptionId !== id) return;
    const msg = reader.readMessage(m.data);
    if (msg.ranges && msg.ranges.length > 0) ok();
  }));
}

await Promise.all(clients.map((fox, i) => check(`client_${i}`, () => offeredAndReceives(fox))));
for (const fox of clients) console.log(`client on worker ${fox.worker || '-'}`);
for (const fox of clients) fox.client.close();
finish([]);
