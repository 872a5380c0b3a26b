// The Status tab: /diagnostics_agg as a list (group summaries and their items, worst first in
// the header), and the robot's bumpers, cliff sensors and sonars (basic_sensors_info/values)
// listed and drawn on the map.
import { TOPICS } from './names.js';
import { sensorTriggered } from './overlays.js';
import { el } from './util.js';

const LEVELS = ['OK', 'WARN', 'ERROR', 'STALE'];
const SENSOR_TYPES = { 0: 'bumper', 1: 'cliff', 2: 'sonar', 3: 'depth camera', 4: 'wall sensor', 5: 'magnetic tape' };

export class Diagnostics {
  constructor({ stores, sensorLayer }) {
    this.list = document.getElementById('diagnostics');
    this.summary = document.getElementById('diag-summary');
    this.sensorList = document.getElementById('sensors');
    this.sensorLayer = sensorLayer;
    this.info = [];
    stores.topic(TOPICS.diagnostics).subscribe((array) => this.show(array.status || []));
    stores.topic(TOPICS.sensorsInfo).subscribe((msg) => {
      this.info = msg.sensors_info || [];
      sensorLayer.setInfo(this.info);
    });
    stores.topic(TOPICS.sensorsValues).subscribe((msg) => this.sensors(msg.values_data || []));
  }

  show(statuses) {
    const worst = Math.max(0, ...statuses.map((s) => s.level));
    this.summary.textContent = statuses.length ? LEVELS[worst] || '' : '';
    this.summary.dataset.level = LEVELS[worst] || '';
    this.list.replaceChildren(...statuses.map((s) => {
      const group = (s.name.match(/\//g) || []).length <= 1;
      const values = (s.values || []).map((kv) => `${kv.key}: ${kv.value}`).join(' · ');
      return el('li', { class: group ? 'group' : 'item', dataset: { name: s.name, level: LEVELS[s.level] || String(s.level) } },
        el('span', { class: 'diag-level' }, LEVELS[s.level] || String(s.level)),
        el('span', { class: 'diag-name' }, s.name),
        el('span', { class: 'diag-message' }, s.message || ''),
        values && !group ? el('span', { class: 'diag-values' }, values) : null);
    }));
  }

  sensors(values) {
    this.sensorLayer.setValues(values);
    if (!values.length) return;
    this.sensorList.replaceChildren(...values.map((v) => {
      const type = SENSOR_TYPES[v.info.sensor_type.type] || 'sensor';
      const hit = sensorTriggered(v.info.sensor_type.type, v.value);
      const range = Number.isFinite(v.value.value) ? `${v.value.value.toFixed(2)} m` : 'no echo';
      const reading = type === 'sonar' ? range : hit ? 'triggered' : 'clear';
      return el('li', { dataset: { id: String(v.info.id), impact: String(hit) } },
        el('span', {}, `${type} ${v.info.id}`), el('span', { class: hit ? 'hit' : '' }, reading));
    }));
  }
}
