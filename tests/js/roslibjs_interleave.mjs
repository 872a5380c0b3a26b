// roslibjs 2.x reassembles a fragmented big message whose fragments the server interleaves
// with another topic's messages (the fair scheduler of issue 22).
// Usage: node roslibjs_interleave.mjs ws://127.0.0.1:PORT (the server fragments at 20 kB and
// sends through its outbox, so fragments and small messages are picked in turn).
import * as ROSLIB from 'roslib';
import { assert, check, connect, finish, until } from './harness.mjs';

const url = process.argv[2];
const a = await connect(ROSLIB, url);
const b = await connect(ROSLIB, url);

await check('fragments_interleaved_with_another_topic', async () => {
  const type = 'std_msgs/String';
  const bigSub = new ROSLIB.Topic({ ros: b, name: '/js/interleave/big', messageType: type });
  const smallSub = new ROSLIB.Topic({ ros: b, name: '/js/interleave/pose', messageType: type });
  const bigPub = new ROSLIB.Topic({ ros: a, name: '/js/interleave/big', messageType: type });
  const smallPub = new ROSLIB.Topic({ ros: a, name: '/js/interleave/pose', messageType: type });
  const order = [];
  const bigs = [];
  const smalls = [];
  bigSub.subscribe((m) => { bigs.push(m.data); order.push(`B${m.data.split(':')[0]}`); });
  smallSub.subscribe((m) => { if (m.data !== 'ready') { smalls.push(m.data); order.push(`s${m.data}`); } });
  let ready = false;
  const probe = new ROSLIB.Topic({ ros: b, name: '/js/interleave/pose', messageType: type });
  probe.subscribe((m) => { if (m.data === 'ready') ready = true; });
  await until(5000, 'subscriptions', () => { smallPub.publish({ data: 'ready' }); return ready; });
  const body = 'abcdefghij'.repeat(20000); // 200 kB: 10 fragments
  const rounds = 3;
  for (let r = 0; r < rounds; r++) {
    bigPub.publish({ data: `${r}:${body}` });
    for (let i = 0; i < 10; i++) smallPub.publish({ data: `${r}.${i}` });
  }
  await until(20000, 'all messages', () => bigs.length === rounds && smalls.length === rounds * 10);
  for (let r = 0; r < rounds; r++) assert(bigs[r] === `${r}:${body}`, `big ${r} differs`);
  const want = [];
  for (let r = 0; r < rounds; r++) for (let i = 0; i < 10; i++) want.push(`${r}.${i}`);
  assert(JSON.stringify(smalls) === JSON.stringify(want), `small order ${smalls}`);
  // a small message published after big 0 arrived before big 0 was complete: interleaved
  assert(order.indexOf('s0.0') < order.indexOf('B0'), `not interleaved: ${order.join(' ')}`);
});

finish([a, b]);
