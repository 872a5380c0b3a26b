// The topic inspector (what Foxglove users expect): every topic on the bridge (rosapi), its
// type, its rate and its last message; a form built from the type's definition
// (rosapi/message_details) to publish one; and a small live plot of a numeric field.
/* global ROSLIB */
import { log } from './log.js';
import { niceStep } from './overlays.js';
import { el, plural } from './util.js';

const RATE_WINDOW_MS = 5000;
const PLOT_POINTS = 200;
const WAITING = 'waiting for a message…';
const NUMERIC = new Set(['float32', 'float64', 'int8', 'uint8', 'int16', 'uint16', 'int32', 'uint32',
  'int64', 'uint64', 'byte', 'char']);

/** A message shortened for display: long arrays and strings cut. */
function preview(value, depth = 0) {
  if (Array.isArray(value)) {
    const head = value.slice(0, 12).map((v) => preview(v, depth + 1));
    return value.length > 12 ? [...head, `… ${value.length} items`] : head;
  }
  if (value && typeof value === 'object') {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, preview(v, depth + 1)]));
  }
  if (typeof value === 'string' && value.length > 200) return `${value.slice(0, 200)}… (${value.length} chars)`;
  return value;
}

/** The paths of the numeric leaves of a message (array elements only for short arrays). */
export function numericPaths(value, prefix = '', out = []) {
  if (out.length >= 200) return out;
  if (typeof value === 'number') out.push(prefix);
  else if (Array.isArray(value)) value.slice(0, 8).forEach((v, i) => numericPaths(v, `${prefix}[${i}]`, out));
  else if (value && typeof value === 'object') {
    for (const [k, v] of Object.entries(value)) numericPaths(v, prefix ? `${prefix}.${k}` : k, out);
  }
  return out;
}

export function valueAt(message, path) {
  let v = message;
  for (const part of path.match(/[^.[\]]+/g) || []) {
    if (v === null || v === undefined) return undefined;
    v = v[part];
  }
  return v;
}

export class Inspector {
  constructor({ ros }) {
    this.ros = ros;
    this.topics = [];
    this.selected = null;
    this.listEl = document.getElementById('topic-list');
    this.filter = document.getElementById('topic-filter');
    this.detail = document.getElementById('topic-detail');
    this.rateEl = document.getElementById('topic-rate');
    this.lastEl = document.getElementById('topic-last');
    this.form = document.getElementById('publish-form');
    this.plotPanel = document.getElementById('plot-panel');
    this.plotCanvas = document.getElementById('plot');
    this.plotRange = document.getElementById('plot-range');
    this.plotField = document.getElementById('plot-field');
    this.filter.addEventListener('input', () => this.showList());
    document.getElementById('topics-refresh').addEventListener('click', () => this.refresh());
    document.getElementById('publish-send').addEventListener('click', () => this.publish());
    this.form.addEventListener('submit', (e) => { e.preventDefault(); this.publish(); });
    setInterval(() => this.showRate(), 1000);
  }

  refresh() {
    return new Promise((resolve) => {
      this.ros.getTopics((result) => {
        this.topics = result.topics.map((name, i) => ({ name, type: result.types[i] }))
          .sort((a, b) => a.name.localeCompare(b.name));
        this.showList();
        resolve(this.topics);
      }, (error) => {
        log('error', `listing the topics failed: ${error}`);
        resolve(this.topics);
      });
    });
  }

  showList() {
    const f = this.filter.value.trim().toLowerCase();
    const shown = this.topics.filter((t) => !f || t.name.toLowerCase().includes(f) || t.type.toLowerCase().includes(f));
    this.listEl.replaceChildren(...shown.map((t) => el('li', {
      dataset: { topic: t.name }, class: this.selected && this.selected.name === t.name ? 'active' : '',
      onclick: () => this.select(t),
    }, el('span', { class: 'topic' }, t.name), el('span', { class: 'type' }, t.type))));
  }

  select(t) {
    if (this.selected) this.selected.sub.unsubscribe();
    const sub = new ROSLIB.Topic({ ros: this.ros, name: t.name, messageType: t.type, throttle_rate: 0, queue_length: 1 });
    this.selected = { ...t, sub, stamps: [], last: null, plotPath: null, series: [], times: [] };
    const mine = this.selected;
    sub.subscribe((msg) => this.onMessage(mine, msg));
    this.detail.hidden = false;
    this.detail.querySelector('.topic-name').textContent = t.name;
    this.detail.querySelector('.topic-type').textContent = t.type;
    this.detail.dataset.topic = t.name;
    this.rateEl.textContent = '–';
    this.forget();
    this.buildForm(t.type);
    this.showList();
  }

  /** Nothing of the last topic left on show: no message, no fields to plot, no plot, until
   * the first message of the one just selected. */
  forget() {
    this.lastEl.textContent = WAITING;
    const select = this.detail.querySelector('select.plot-pick');
    if (select) {
      select.replaceChildren(el('option', { value: '' }, WAITING));
      select.disabled = true;
    }
    this.plotPanel.hidden = true;
    this.plotField.textContent = '';
    this.plotRange.textContent = '';
    delete this.plotRange.dataset.samples;
    this.clearPlot();
    delete this.plotCanvas.dataset.yTicks;
    delete this.plotCanvas.dataset.tTicks;
  }

  onMessage(sel, msg) {
    if (sel !== this.selected) return;
    const now = performance.now();
    sel.stamps.push(now);
    while (sel.stamps.length && now - sel.stamps[0] > RATE_WINDOW_MS) sel.stamps.shift();
    const first = !sel.last;
    sel.last = msg;
    sel.count = (sel.count || 0) + 1;
    if (!sel.drawPending) {
      sel.drawPending = true;
      requestAnimationFrame(() => {
        sel.drawPending = false;
        if (sel === this.selected && sel.last) this.lastEl.textContent = JSON.stringify(preview(sel.last), null, 1);
      });
    }
    if (first) this.showFields(msg);
    if (sel.plotPath) {
      const v = valueAt(msg, sel.plotPath);
      if (typeof v === 'number' && Number.isFinite(v)) {
        sel.series.push(v);
        sel.times.push(performance.now());
        if (sel.series.length > PLOT_POINTS) { sel.series.shift(); sel.times.shift(); }
        this.drawPlot();
      }
    }
  }

  showRate() {
    const sel = this.selected;
    if (!sel) return;
    const now = performance.now();
    while (sel.stamps.length && now - sel.stamps[0] > RATE_WINDOW_MS) sel.stamps.shift();
    const n = sel.stamps.length;
    const span = n > 1 ? (sel.stamps[n - 1] - sel.stamps[0]) / 1000 : 0;
    const rate = span > 0 ? (n - 1) / span : 0;
    this.rateEl.textContent = `${rate.toFixed(1)} Hz · ${plural(sel.count || 0, 'message')}`;
    this.rateEl.dataset.count = String(sel.count || 0);
  }

  /** The numeric fields of the first message: pick one to plot. */
  showFields(msg) {
    const paths = numericPaths(msg);
    let select = this.detail.querySelector('select.plot-pick');
    if (!select) {
      select = el('select', { class: 'plot-pick', title: 'Plot a numeric field' });
      select.addEventListener('change', () => this.plot(select.value));
      this.rateEl.after(select);
    }
    select.disabled = false;
    select.replaceChildren(el('option', { value: '' }, paths.length ? 'plot a field…' : 'no numeric fields'),
      ...paths.map((p) => el('option', { value: p }, p)));
  }

  plot(path) {
    const sel = this.selected;
    if (!sel) return;
    sel.plotPath = path || null;
    sel.series = [];
    sel.times = [];
    this.plotPanel.hidden = !path;
    this.plotField.textContent = path ? `${sel.name} ${path}` : '';
    this.drawPlot();
  }

  drawPlot() {
    const sel = this.selected;
    const { ctx, w, h } = this.clearPlot();
    const s = sel ? sel.series : [];
    if (!s.length) return;
    let lo = Math.min(...s);
    let hi = Math.max(...s);
    if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
    // axes: the value on the left, seconds before the last sample along the bottom
    const left = 44;
    const bottom = 16;
    const pw = w - left - 4;
    const ph = h - bottom - 6;
    const times = sel.times;
    const last = times[times.length - 1];
    const span = Math.max(1, (last - times[0]) / 1000);
    const X = (t) => left + pw + (t / span) * pw; // t ≤ 0: seconds before the last sample
    const Y = (v) => 6 + ph - ((v - lo) / (hi - lo)) * ph;
    this.drawAxes({ ctx, left, pw, ph, lo, hi, span, X, Y });

    ctx.strokeStyle = '#2196f3';
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    s.forEach((v, i) => {
      const x = X((times[i] - last) / 1000);
      if (i) ctx.lineTo(x, Y(v)); else ctx.moveTo(x, Y(v));
    });
    ctx.stroke();
    this.plotRange.textContent = `last ${s[s.length - 1].toPrecision(4)} · min ${Math.min(...s).toPrecision(4)} · max ${Math.max(...s).toPrecision(4)} · ${plural(s.length, 'sample')}`;
    this.plotRange.dataset.samples = String(s.length);
  }

  /** The plot's canvas sized to its box (in device pixels) and cleared: its 2D context, drawing
   * in CSS pixels, and its size. */
  clearPlot() {
    const c = this.plotCanvas;
    const dpr = window.devicePixelRatio || 1;
    const w = c.clientWidth || 320;
    const h = c.clientHeight || 120;
    if (c.width !== Math.round(w * dpr)) { c.width = Math.round(w * dpr); c.height = Math.round(h * dpr); }
    const ctx = c.getContext('2d');
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    ctx.fillStyle = '#12151a';
    ctx.fillRect(0, 0, w, h);
    return { ctx, w, h };
  }

  /** The plot's grid lines, value and time ticks and axes; the ticks also go into the canvas's
   * data-y-ticks and data-t-ticks. */
  drawAxes({ ctx, left, pw, ph, lo, hi, span, X, Y }) {
    const c = this.plotCanvas;
    ctx.font = '10px system-ui, sans-serif';
    ctx.fillStyle = '#8a96a3';
    ctx.strokeStyle = '#2a3039';
    ctx.lineWidth = 1;
    const yStep = niceStep((hi - lo) / 4);
    const yTicks = [];
    for (let v = Math.ceil(lo / yStep) * yStep; v <= hi + 1e-9; v += yStep) yTicks.push(v);
    ctx.textAlign = 'right';
    ctx.textBaseline = 'middle';
    for (const v of yTicks) {
      ctx.beginPath(); ctx.moveTo(left, Y(v)); ctx.lineTo(left + pw, Y(v)); ctx.stroke();
      ctx.fillText(Number(v.toPrecision(6)).toString(), left - 4, Y(v));
    }
    const tStep = niceStep(span / 4);
    const tTicks = [];
    for (let t = 0; t >= -span - 1e-9; t -= tStep) tTicks.push(t);
    ctx.textBaseline = 'top';
    for (const t of tTicks) {
      ctx.textAlign = t === 0 ? 'right' : 'center';
      ctx.fillText(t === 0 ? 'now' : `${Number(t.toPrecision(6))} s`, X(t), 6 + ph + 3);
    }
    ctx.strokeStyle = '#8a96a3';
    ctx.beginPath(); ctx.moveTo(left, 6); ctx.lineTo(left, 6 + ph); ctx.lineTo(left + pw, 6 + ph); ctx.stroke();
    c.dataset.yTicks = yTicks.map((v) => Number(v.toPrecision(6))).join(',');
    c.dataset.tTicks = tTicks.map((t) => Number(t.toPrecision(6))).join(',');
  }

  // ---- publishing ----------------------------------------------------------------------------

  buildForm(type) {
    this.form.replaceChildren(el('div', { class: 'muted' }, 'loading the type…'));
    this.ros.getMessageDetails(type, (typedefs) => {
      const defs = new Map(typedefs.map((d) => [d.type, d]));
      this.form.replaceChildren(this.fields(defs, type, ''));
    }, (error) => {
      this.form.replaceChildren(el('div', { class: 'muted' }, `no definition: ${error}`));
    });
  }

  fields(defs, type, prefix) {
    const def = defs.get(type);
    const box = el('div', { class: 'fields' });
    if (!def) return box;
    def.fieldnames.forEach((name, i) => {
      const ftype = def.fieldtypes[i];
      const arrayLen = def.fieldarraylen[i];
      const path = prefix ? `${prefix}.${name}` : name;
      const label = el('span', { class: 'field-name' }, name, el('small', {}, ` ${ftype}${arrayLen >= 0 ? '[]' : ''}`));
      if (arrayLen >= 0) {
        box.append(el('label', {}, label, el('input', { name: path, dataset: { kind: 'json' }, placeholder: '[] (JSON)', value: '[]' })));
      } else if (defs.has(ftype)) {
        const set = el('fieldset', {}, el('legend', {}, name), this.fields(defs, ftype, path));
        box.append(set);
      } else if (ftype === 'bool') {
        box.append(el('label', { class: 'check' }, el('input', { type: 'checkbox', name: path, dataset: { kind: 'bool' } }), label));
      } else if (NUMERIC.has(ftype)) {
        box.append(el('label', {}, label, el('input', { type: 'number', step: 'any', name: path, value: '0', dataset: { kind: 'number' } })));
      } else if (ftype === 'time' || ftype === 'duration') {
        box.append(el('label', {}, label, el('input', { type: 'number', step: 'any', name: path, value: '0', dataset: { kind: 'seconds' } })));
      } else {
        box.append(el('label', {}, label, el('input', { name: path, dataset: { kind: 'string' }, autocomplete: 'off' })));
      }
    });
    return box;
  }

  /** The form as a message; throws naming the field when one does not parse. */
  message() {
    const msg = {};
    for (const input of this.form.querySelectorAll('input[name]')) {
      const parts = input.name.split('.');
      let target = msg;
      for (const p of parts.slice(0, -1)) target = target[p] || (target[p] = {});
      const key = parts[parts.length - 1];
      const kind = input.dataset.kind;
      if (kind === 'bool') target[key] = input.checked;
      else if (kind === 'number') {
        const v = Number(input.value);
        if (input.value.trim() === '' || !Number.isFinite(v)) throw new Error(`${input.name} is not a number`);
        target[key] = v;
      } else if (kind === 'seconds') {
        const v = Number(input.value);
        if (!Number.isFinite(v)) throw new Error(`${input.name} is not a number of seconds`);
        target[key] = { secs: Math.floor(v), nsecs: Math.round((v - Math.floor(v)) * 1e9) };
      } else if (kind === 'json') {
        try {
          target[key] = JSON.parse(input.value || '[]');
        } catch (err) {
          throw new Error(`${input.name} is not JSON: ${err.message}`);
        }
      } else target[key] = input.value;
    }
    return msg;
  }

  publish() {
    const sel = this.selected;
    if (!sel) return;
    let msg;
    try {
      msg = this.message();
    } catch (err) {
      log('error', `not published: ${err.message}`);
      return;
    }
    if (!sel.pub) sel.pub = new ROSLIB.Topic({ ros: this.ros, name: sel.name, messageType: sel.type });
    sel.pub.publish(new ROSLIB.Message(msg));
    log('info', `published on ${sel.name}`);
  }
}
