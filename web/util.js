// Small helpers shared by the console's modules.

/** Yaw (rad) of a quaternion. */
export function yawOf(q) {
  if (!q) return 0;
  return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z));
}

/** A quaternion turning by `yaw` (rad) about z. */
export function quatOfYaw(yaw) {
  return { x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) };
}

export const degrees = (rad) => (rad * 180) / Math.PI;

/** Format a pose as "x, y m · θ°". */
export function formatPose(x, y, yaw) {
  const angle = degrees(yaw).toFixed(0);
  return `${x.toFixed(2)}, ${y.toFixed(2)} m · ${angle === '-0' ? '0' : angle}°`;
}

/** `n word`, the word plural unless n is 1: plural(1, 'message') is "1 message". */
export const plural = (n, word) => `${n} ${word}${Number(n) === 1 ? '' : 's'}`;

/** Create an element: el('li', {class: 'x', dataset: {name}}, 'text', child, ...). */
export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (key === 'dataset') Object.assign(node.dataset, value);
    else if (key === 'class') node.className = value;
    else if (key.startsWith('on')) node.addEventListener(key.slice(2), value);
    else if (value !== undefined && value !== null && value !== false) node.setAttribute(key, value);
  }
  for (const child of children) {
    if (child !== null && child !== undefined) node.append(child);
  }
  return node;
}
