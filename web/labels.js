// Names on the map that do not pile up: a layer marks each name it draws (a POI's, a zone's, a
// robot's) with label(), and what no name may cover (a robot's body) with avoid(). Before each
// frame placeLabels() puts every name back where its layer drew it, then moves each, in the
// order drawn, by the smallest vertical step that clears the bodies and the names placed
// before it. The boxes it settled on are kept for the page's tests (MapView.labelBoxes).
/* global createjs */

const STEP = 16; // CSS px between two tried places
const TRIES = 9; // where it was drawn, then 4 steps up and 4 down, nearest first

/** `node` (a createjs Text, or a container given bounds) is a name called `name`. */
export function label(node, name) {
  node.labelName = name;
  node.baseY = node.y;
  return node;
}

/** `node` is a body of `radius` px (its own units) around its origin: no name covers it. */
export function avoid(node, radius) {
  node.avoidRadius = radius;
  return node;
}

function collect(node, labels, bodies) {
  if (!node.visible) return;
  if (node.labelName !== undefined) labels.push(node);
  if (node.avoidRadius !== undefined) bodies.push(node);
  if (node instanceof createjs.Container) for (const child of node.children) collect(child, labels, bodies);
}

const overlaps = (a, b) => a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom;

/** Place the names under `root`; their boxes in canvas px ({name, left, top, right, bottom}). */
export function placeLabels(root, dpr) {
  const labels = [];
  const bodies = [];
  collect(root, labels, bodies);
  const taken = bodies.map((body) => {
    const c = body.localToGlobal(0, 0);
    const r = Math.abs(body.localToGlobal(body.avoidRadius, 0).x - c.x) || body.avoidRadius;
    return { left: c.x - r, top: c.y - r, right: c.x + r, bottom: c.y + r };
  });
  const boxes = [];
  for (const node of labels) {
    node.y = node.baseY;
    const b = node.getBounds();
    if (!b) continue;
    const p0 = node.localToGlobal(b.x, b.y);
    const p1 = node.localToGlobal(b.x + b.width, b.y + b.height);
    const box = { left: Math.min(p0.x, p1.x), top: Math.min(p0.y, p1.y), right: Math.max(p0.x, p1.x), bottom: Math.max(p0.y, p1.y) };
    const perUnit = b.height ? (p1.y - p0.y) / b.height : 1; // canvas px per unit of node.y's parent
    const parentScale = node.scaleY ? perUnit / node.scaleY : perUnit;
    let shift = 0;
    for (let k = 0; k < TRIES; k++) {
      const dy = (k % 2 ? -1 : 1) * Math.ceil(k / 2) * STEP * dpr;
      const moved = { ...box, top: box.top + dy, bottom: box.bottom + dy };
      if (!taken.some((t) => overlaps(moved, t))) {
        shift = dy;
        break;
      }
    }
    if (shift) node.y = node.baseY + shift / (parentScale || 1);
    const placed = { ...box, top: box.top + shift, bottom: box.bottom + shift };
    taken.push(placed);
    boxes.push({ name: node.labelName, ...placed });
  }
  return boxes;
}
