// Saved maps: the list from the `list_map_files` service, Load (the `load_laser_map` service,
// which answers with the outcome) after a confirmation, and Save as… a name the operator types
// (/map_manager/save_map), replacing an existing map only when confirmed.
/* global ROSLIB */
import { confirmAction, nameForm } from './dialogs.js';
import { log } from './log.js';
import { SERVICES, TOPICS } from './names.js';
import { el } from './util.js';

const NAME = /^[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}$/;

export class SavedMaps {
  constructor({ ros, stores }) {
    this.stores = stores;
    this.names = [];
    this.current = '';
    this.list = document.getElementById('map-list');
    this.saveTopic = new ROSLIB.Topic({ ros, name: TOPICS.saveMap, messageType: 'map_messages/SaveMap' });
    // which map is loaded, as the server keeps it (latched, so after a reload or a restart too)
    stores.topic(TOPICS.loadedMap).subscribe((msg) => {
      this.current = msg.data;
      this.show(this.names);
    });
    document.getElementById('maps-refresh').addEventListener('click', () => this.refresh());
    document.getElementById('map-save-as').addEventListener('click', () => this.saveAs());
  }

  /** Ask the server for the list; resolves the names. */
  async refresh() {
    const { reply, error } = await this.stores.call(SERVICES.listMapFiles, { directory: '' });
    if (error) log('error', `listing the saved maps failed: ${error}`);
    else this.show(reply.files || []);
    return this.names;
  }

  show(names) {
    this.names = [...names].sort();
    this.list.replaceChildren(...(this.names.length ? this.names.map((name) => el('li', { dataset: { name } },
      el('span', { class: 'map-name' }, name, name === this.current ? el('small', {}, ' · loaded') : null),
      el('button', { type: 'button', class: 'load', title: `Load “${name}” into the robot`, onclick: () => this.load(name) }, 'Load')))
      : [el('li', { class: 'empty' }, 'no saved maps yet')]));
  }

  async load(name) {
    if (!(await confirmAction(`Load the map “${name}”? The robot's current map, masks, POIs and walls are replaced.`, 'Load'))) return;
    log('info', `loading the map “${name}”…`);
    const { reply, error } = await this.stores.call(SERVICES.loadLaserMap, { name });
    if (reply && reply.success) {
      this.current = name;
      this.show(this.names);
      log('info', `map “${name}”: ${reply.message}`);
    } else {
      log('error', `loading the map “${name}” failed: ${error || reply.message}`);
    }
  }

  async saveAs() {
    await this.refresh();
    const name = await nameForm({
      title: 'Save the map as',
      name: this.current || '',
      where: 'The map, its masks, POIs, virtual walls and tracks and the dock, in a folder of this name.',
      validate: (value) => (NAME.test(value) ? '' : 'letters, digits, _ . - only (no spaces or slashes), at most 64'),
    });
    if (!name) return;
    // the name dialog was the question; only replacing a saved map asks again
    if (this.names.includes(name) && !(await confirmAction(
      `A map named “${name}” exists. Replace it with the current map?`, 'Replace'))) return;
    this.saveTopic.publish(new ROSLIB.Message({ filename: name }));
    log('info', `saving the map as “${name}”…`);
    // the save answers with a status only; the list shows when it is there
    for (let i = 0; i < 20 && !(await this.refresh()).includes(name); i++) {
      await new Promise((r) => setTimeout(r, 500));
    }
    if (this.names.includes(name)) log('info', `map saved as “${name}”`);
  }
}
