// The Messages panel and the toasts over the map: every status the bridge reports, every
// command sent, goal outcomes. Errors and warnings also pop up as toasts.
import { el } from './util.js';

const MAX_ENTRIES = 200;
const list = () => document.getElementById('log');

/** What the server's requests are called in its replies ("add_poi: …"), in the operator's words. */
const REQUEST_WORDS = {
  add_poi: 'POI', modify_poi: 'POI change', delete_poi: 'POI deletion', modify_map: 'map edit',
  save_map: 'saving the map', load_map: 'loading the map', map_layers: 'map layers',
  do_mapping: 'mapping', navigate_to_poi: 'going to the POI', set_waypoints: 'patrol waypoints',
  recover_localization: 'relocalization', go_home: 'going home', cancel_action: 'stop',
};
/** actionlib's status names as an operator says them. */
const STATUS_WORDS = { PREEMPTED: 'cancelled', RECALLED: 'cancelled', ABORTED: 'failed',
  REJECTED: 'refused', SUCCEEDED: 'done', PREEMPTING: 'cancelling', RECALLING: 'cancelling', LOST: 'lost' };

/** A line for the Messages panel without developer-speak: a request's raw name leading a reply
 * ("add_poi: …"), actionlib's upper-case status names, an exception's class name and the stack
 * lines after it, "-0°". */
export function operatorWords(text) {
  let line = String(text).split('\n')[0].replace(/\s+at \S+ \(\S+:\d+:\d+\)/g, '');
  line = line.replace(/^(?:[A-Z][A-Za-z]*(?:Error|Exception)): /, '');
  line = line.replace(/^([a-z]+(?:_[a-z]+)+): /, (whole, name) =>
    (REQUEST_WORDS[name] ? `${REQUEST_WORDS[name]}: ` : `${name.replace(/_/g, ' ')}: `));
  line = line.replace(/\b(PREEMPTED|RECALLED|ABORTED|REJECTED|SUCCEEDED|PREEMPTING|RECALLING|LOST)\b/g,
    (word) => STATUS_WORDS[word]);
  return line.replace(/-0°/g, '0°');
}

export function log(level, raw) {
  const text = operatorWords(raw);
  const time = new Date().toLocaleTimeString([], { hour12: false });
  const entry = el('li', { class: level, dataset: { level } },
    el('time', {}, time), el('span', { class: 'level' }, level), el('span', { class: 'text' }, text));
  const ol = list();
  if (ol) {
    ol.prepend(entry);
    while (ol.children.length > MAX_ENTRIES) ol.lastChild.remove();
  }
  if (level === 'error' || level === 'warning') toast(level, text);
  const method = level === 'error' ? 'warn' : 'info';  // an error *reported to* the page
  console[method](`[${level}] ${text}`);
}

// Reports of one failure arrive together (a status error, then the outcome it caused): they
// share one toast, each new line added to the toast shown within the last MERGE_MS.
const MERGE_MS = 1500;
let lastToast = null;

export function toast(level, text, ms = 6000) {
  const box = document.getElementById('toasts');
  if (!box) return;
  const now = Date.now();
  if (lastToast && lastToast.node.isConnected && now - lastToast.at < MERGE_MS) {
    if (!lastToast.node.textContent.includes(text)) lastToast.node.append(el('div', {}, text));
    if (level === 'error') lastToast.node.className = 'toast error';
    return;
  }
  const node = el('div', { class: `toast ${level}`, role: 'status' }, text);
  lastToast = { node, at: now };
  node.addEventListener('click', () => node.remove());
  box.append(node);
  while (box.children.length > 4) box.firstChild.remove();
  setTimeout(() => node.remove(), ms);
}
