// The Messages panel and the toasts over the map: every status the bridge reports, every
// command sent, goal outcomes. Errors and warnings also pop up as toasts.
import { el } from './util.js';

const MAX_ENTRIES = 200;
const list = () => document.getElementById('log');

export function log(level, text) {
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
