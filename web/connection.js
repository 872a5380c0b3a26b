// The connection to hitrobot-server: a roslib 1.x `ROSLIB.Ros` on ws://<this host>:<this port>
// (or ?url=ws://… for another bridge), its state in the top bar, and every `status` message
// the server sends shown to the operator.
/* global ROSLIB */
import { log } from './log.js';
import { withToken } from './signin.js';

/** The WebSocket URL this page connects to, without the tab's token (safe to show). */
function plainBridgeUrl() {
  const param = new URLSearchParams(location.search).get('url');
  if (param) return param;
  const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
  return `${scheme}://${location.host}/`;
}

export function bridgeUrl() {
  return withToken(plainBridgeUrl());
}

/** The top bar's "Open in Foxglove": beside the layout's link (with the tab's token, which
 * --authenticate asks of it), the URL to connect to (never showing the token on screen). */
export function showFoxgloveUrl() {
  const link = document.getElementById('foxglove-layout');
  link.href = withToken(link.getAttribute('href'));
  document.getElementById('foxglove-url').textContent = plainBridgeUrl().replace(/\/$/, '');
}

// Statuses that a caller of publishTracked() reports itself (so they are not shown twice).
const tracked = new Map();
// Tests of statuses that are no news to the operator (quietWhen): a replay's missing services.
const quiet = [];

/** Statuses for which `test(text)` is true are not shown (e.g. a service a replay has not). */
export function quietWhen(test) {
  quiet.push(test);
}

/**
 * Publish and hear what the server answers to this very publish (its `status` ops, e.g. the
 * map manager's and navigation's replies): `onStatus(message)` until `done()` is called.
 */
export function publishTracked(topic, message, onStatus) {
  topic.publish(message);
  const id = `publish:${topic.name}:${topic.ros.idCounter}`; // the id roslib 1.x gave it
  const listener = (status) => onStatus(status);
  tracked.set(id, listener);
  topic.ros.on(`status:${id}`, listener);
  return () => {
    topic.ros.off(`status:${id}`, listener);
    tracked.delete(id);
  };
}

/** A status as the operator reads it: the server's reply without the op it answers
 * ("publish to '/topic': …") and without roslib's op id ("publish:/topic:26"); the topic or
 * service the id names is said when the text does not say it. */
export function operatorText(text, id = '') {
  const plain = text.replace(/^publish to '[^']*': /, '');
  const name = (id.match(/^[a-z_]+:(.+):\d+$/) || [])[1];
  return name && !plain.includes(name) ? `${plain} (${name})` : plain;
}

let online = null;

/** Set the bridge pill; going on or off line fires a `bridge` event ({online}) on window. */
function setPill(state, text) {
  document.body.classList.toggle('offline', state === 'down' || state === 'broken');
  if (online !== (state === 'up')) {
    online = state === 'up';
    window.dispatchEvent(new CustomEvent('bridge', { detail: { online } }));
  }
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
  // subscribes, goals…) as 'status:<id>': listen to both. Ask for info too, for the replies to
  // publishes (map saved, arrived…); the info about subscribing and advertising is noise.
  ros.onAny((event, message) => {
    if (typeof event !== 'string' || !(event === 'status' || event.startsWith('status:'))) return;
    const level = message && message.level ? message.level : 'error';
    const id = (message && message.id) || '';
    if (tracked.has(id)) return;
    if (level === 'info' && !id.startsWith('publish:')) return;
    const text = message && message.msg ? message.msg : 'status';
    if (quiet.some((test) => test(text))) return;
    log(level, operatorText(text, id));
  });
  ros.setStatusLevel('info');
  return ros;
}

/** The page cannot work (its libraries are missing): say why in the bridge pill. */
export function showBroken(text) {
  setPill('broken', text);
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
