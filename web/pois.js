// Points of interest: the list from /map_manager/pois (map_messages/PointsOfInterest), drawn on
// the map; add at a picked pose, rename, delete, and "go" through /navigation/navigate_to_poi.
/* global ROSLIB */
import { operatorText, publishTracked } from './connection.js';
import { confirmAction, poiForm } from './dialogs.js';
import { log } from './log.js';
import { TOPICS } from './names.js';
import { el, formatPose, quatOfYaw, yawOf } from './util.js';

export const POI_DEFAULT = 100; // map_messages/PointOfInterest.DEFAULT

export class Pois {
  /** `warning(x, y)`: why a POI should not stand at (x, y) ('' when it may). */
  constructor({ ros, stores, layer, warning = () => '' }) {
    this.layer = layer;
    this.warning = warning;
    this.pois = [];
    const topic = (name, messageType) => new ROSLIB.Topic({ ros, name, messageType });
    this.addTopic = topic(TOPICS.addPoi, 'map_messages/PointOfInterest');
    this.modifyTopic = topic(TOPICS.modifyPoi, 'map_messages/ModifyPOI');
    this.deleteTopic = topic(TOPICS.deletePoi, 'map_messages/DeletePointOfInterest');
    this.goTopic = topic(TOPICS.navigateToPoi, 'map_messages/NavigateToPOI');
    this.list = document.getElementById('poi-list');
    this.count = document.getElementById('poi-count');
    stores.topic(TOPICS.pois).subscribe((msg) => this.set((msg && msg.pois) || []));
  }

  set(pois) {
    this.pois = pois;
    this.layer.set(pois);
    this.count.textContent = pois.length ? `(${pois.length})` : '';
    this.list.replaceChildren(...(pois.length ? pois.map((p) => this.item(p))
      : [el('li', { class: 'empty' }, 'none yet — use “Add POI” on the map')]));
  }

  item(poi) {
    const p = poi.pose.position;
    const where = formatPose(p.x, p.y, yawOf(poi.pose.orientation));
    return el('li', { dataset: { name: poi.name } },
      el('div', { class: 'poi-text' },
        el('span', { class: 'poi-name' }, poi.name),
        el('span', { class: 'poi-where' }, poi.remarks ? `${where} · ${poi.remarks}` : where)),
      el('div', { class: 'poi-actions' },
        el('button', { type: 'button', class: 'go', title: `Go to ${poi.name}`, onclick: () => this.go(poi) }, 'Go'),
        el('button', { type: 'button', class: 'rename', title: 'Rename', onclick: () => this.rename(poi) }, 'Rename'),
        el('button', { type: 'button', class: 'delete danger', title: 'Delete', onclick: () => this.remove(poi) }, '✕')));
  }

  /** Why `name` cannot be a new POI's name ('' when it can). */
  taken(name) {
    return this.pois.some((p) => p.name === name) ? `a POI named “${name}” exists already` : '';
  }

  /** Ask for a name and add a POI at (x, y, yaw). */
  async addAt(x, y, yaw) {
    const n = this.pois.length + 1;
    const problem = this.warning(x, y);
    // the dialog stays open until the map manager answers: a refusal is shown in it, with
    // the name as typed, to change the name or cancel
    await poiForm({ title: 'Add point of interest', name: `poi ${n}`,
      where: `at ${formatPose(x, y, yaw)}`, warning: problem && `⚠ ${problem}: the map manager will refuse it.`,
      validate: (name) => this.taken(name),
      submit: (answer) => this.request(this.addTopic, {
        type: POI_DEFAULT,
        name: answer.name,
        remarks: answer.remarks,
        pose: { position: { x, y, z: 0 }, orientation: quatOfYaw(yaw) },
      }, `POI “${answer.name}” added at ${formatPose(x, y, yaw)}`) });
  }

  async rename(poi) {
    const answer = await poiForm({ title: `Rename “${poi.name}”`, name: poi.name,
      remarks: poi.remarks || '', validate: (name) => (name === poi.name ? '' : this.taken(name)) });
    if (!answer || (answer.name === poi.name && answer.remarks === (poi.remarks || ''))) return;
    this.request(this.modifyTopic, {
      poi: { ...poi, name: answer.name, remarks: answer.remarks },
      old_name: poi.name,
    }, `POI “${poi.name}” renamed to “${answer.name}”`);
  }

  async remove(poi) {
    if (!(await confirmAction(`Delete the POI “${poi.name}”?`, 'Delete'))) return;
    this.request(this.deleteTopic, { name: poi.name }, `POI “${poi.name}” deleted`);
  }

  /** Publish a POI request; its line in Messages comes with the map manager's answer (one
   * line, the operator's words, only once it is done). Resolves '' once done, or the refusal. */
  request(topic, message, doneText) {
    return new Promise((resolve) => {
      const done = publishTracked(topic, new ROSLIB.Message(message), (status) => {
        const refused = status.level === 'error' ? operatorText(status.msg || 'refused') : '';
        if (refused) log('error', refused);
        else if (status.level === 'info') log('info', doneText);
        else return;
        done();
        resolve(refused);
      });
    });
  }

  go(poi) {
    if (this.onGo && this.onGo(poi) === false) return;
    this.goTopic.publish(new ROSLIB.Message({
      poi_name: poi.name, distance_to_target: 0.0, skip_final_turn: false,
    }));
    log('info', `navigating to POI “${poi.name}”`);
  }
}
