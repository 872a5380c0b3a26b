// Where the panels go: index.html marks each place a panel may stand with data-slot="NAME"
// (the map pane, the Operate tab's scrolling column, the Status tab, the Fleet tab), and app.js
// puts every panel a module builds into one with mount(). A panel builds its element and
// leaves it to its maker where it stands.

/** Put `panels` (elements) into slot `name` of index.html, after what it holds (before, with
 * `first`); returns the slot. */
export function mount(name, panels, { first = false } = {}) {
  const slot = document.querySelector(`[data-slot="${name}"]`);
  if (!slot) throw new Error(`index.html has no slot "${name}"`);
  const list = Array.isArray(panels) ? panels : [panels];
  if (first) slot.prepend(...list);
  else slot.append(...list);
  return slot;
}
