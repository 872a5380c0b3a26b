// The connection to hitrobot-server: a roslib 1.x `ROSLIB.Ros` on ws://<this host>:<this port>
// (or ?url=ws://… for another bridge), its state in the top bar, and every `status` message
// the server sends shown to the operator.
/* global ROSLIB */
import { log } from './log.js';

export function bridgeUrl() {
  const param = new URLSearchParams(location.search).get('url');
  if (param) return param;
  const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
  return `${scheme}://${location.host}`;
}

function setPill(state, text) {
  document.body.classList.toggle('offline', state === 'down');
  const pill = document.getElementById('bridge-state');
  pill.dataset.state = state;
  pill.querySelector('.value').textContent = text;
}

/**
 * Open the connection. roslib 1.x does not re-subscribe after a reconnect, so when the bridge
 * goes away the page probes the URL every two seconds and reloads itself once it answers.
 */
export function connect(url = bridgeUrl()) {
  const ros = new ROSLIB.Ros({ url });
  let everConnected = false;
  let probing = false;

  ros.on('connection', () => {
    everConnected = true;
    setPill('up', 'connected');
    log('info', `connected to ${url}`);
  });
  ros.on('error', () => {
    if (!everConnected) setPill('down', 'unreachable');
  });
  ros.on('close', () => {
    setPill('down', everConnected ? 'disconnected — retrying' : 'unreachable — retrying');
    if (everConnected) log('error', `lost the connection to ${url}`);
    if (!probing) {
      probing = true;
      probe(url);
    }
  });

  // roslib 1.4 emits a status without an id as 'status' and one with an id (our publishes,
  // subscribes, goals…) as 'status:<id>': listen to both. Ask for warnings too.
  ros.onAny((event, message) => {
    if (typeof event !== 'string' || !(event === 'status' || event.startsWith('status:'))) return;
    const level = message && message.level ? message.level : 'error';
    const where = message && message.id ? ` (${message.id})` : '';
    log(level === 'info' ? 'info' : level, `${message && message.msg ? message.msg : 'status'}${where}`);
  });
  ros.setStatusLevel('warning');
  return ros;
}

function probe(url) {
  const retry = () => setTimeout(() => probe(url), 2000);
  let socket;
  try {
    socket = new WebSocket(url);
  } catch (err) {
    retry();
    return;
  }
  socket.onopen = () => {
    socket.close();
    location.reload();
  };
  socket.onerror = () => {};
  socket.onclose = (ev) => {
    if (!ev.wasClean || ev.code !== 1000) retry();
  };
}
