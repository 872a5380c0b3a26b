// The robots' VDA 5050 links (`--vda5050 mqtt://HOST:PORT`), on the Fleet tab: for each robot
// the broker and its topic tree, whether it is connected, the master control's current order
// and the last error, from the latched /vda5050/link. Shown (with the tab) once a link exists.
import { TOPICS } from './names.js';
import { el } from './util.js';

/** One robot's line: what an operator reads of its link. */
export function linkWords(link) {
  const who = link.robot || link.serial;
  const state = link.connected ? 'connected' : 'not connected';
  let order = 'no order';
  if (link.order_id) {
    const doing = link.active ? (link.paused ? 'paused on' : 'running') : 'last';
    order = `${doing} order ${link.order_id} (update ${link.order_update_id})`;
  }
  return { who, state, text: `${state} to ${link.broker} as ${link.topic}; ${order}`,
    error: link.last_error };
}

export class VdaLinks {
  /** `tab`: the Fleet tab's button (the panel is mounted by app.js, in the Fleet tab). */
  constructor({ stores, tab }) {
    this.tab = tab;
    this.links = [];
    this.list = el('ul', { class: 'vda5050-links', id: 'vda5050-links' });
    this.panel = el('section', { class: 'panel', id: 'vda5050-panel', hidden: true },
      el('h2', {}, 'VDA 5050 master control'), this.list);
    stores.topic(TOPICS.vda5050Link).subscribe((m) => this.show(m.links));
  }

  show(links) {
    this.links = links;
    this.panel.hidden = links.length === 0;
    if (links.length) this.tab.hidden = false;  // a single robot has a Fleet tab for it too
    this.list.replaceChildren(...links.map((link) => {
      const words = linkWords(link);
      return el('li', { dataset: { robot: link.robot, serial: link.serial,
        connected: String(link.connected), order: link.order_id } },
      el('strong', {}, words.who), ` ${words.text}`,
      words.error ? el('div', { class: 'vda5050-error' }, `last error: ${words.error}`) : null);
    }));
  }
}
