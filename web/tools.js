// Pointer and keyboard interaction with the map: the tool buttons (Move, Goal, Set pose,
// Add POI, and the editing tools: walls and tracks dragged as lines, no-go and erase areas
// dragged as rectangles, Remove line, patrol waypoints), drag-to-orient like nav2d (press at
// the position, drag towards the heading, release), pan with the Move tool or the
// middle/right button, zoom with the wheel. While the bridge is down only Move works.
import { ArrowMarker, COLORS, ShapePreview } from './overlays.js';
import { formatPose } from './util.js';

const DRAG_PX = 6; // a press that moved less than this many CSS pixels is a click
const HINTS = {
  move: 'Drag to pan, wheel to zoom. Pick a tool to act on the map.',
  goal: 'Goal: click a destination, or press and drag towards the heading you want.',
  pose: 'Set pose: press where the robot is and drag towards where it faces.',
  poi: 'Add POI: click the spot, or press and drag to give it a heading.',
  wall: 'Virtual wall: press at one end and drag to the other.',
  track: 'Virtual track: press at one end and drag to the other.',
  area: 'No-go area: drag a rectangle the robot must stay out of.',
  erase: 'Erase masks: drag a rectangle to clear the masks in it.',
  unline: 'Remove line: click a wall or a track.',
  waypoint: 'Waypoints: click each in visiting order; Esc or Move when done.',
};
const LINE_TOOLS = new Set(['wall', 'track']);
const RECT_TOOLS = new Set(['area', 'erase']);
const STAYING_TOOLS = new Set(['goal', 'waypoint', 'wall', 'track', 'area', 'erase', 'unline']);

export class MapTools {
  /** `onPick(tool, {x, y, yaw})`: yaw is null for a plain click (no heading dragged).
   * `warning(tool, x, y)`: why the tool should not be used there ('' when it may), shown in
   * the hint while the pointer is over the spot (a POI beside an obstacle). */
  constructor(view, onPick, warning = () => '') {
    this.view = view;
    this.onPick = onPick;
    this.warning = warning;
    this.tool = 'move';
    this.drag = null;
    this.preview = new ArrowMarker(view, COLORS.preview, { dashed: true });
    this.shapePreview = new ShapePreview(view);
    this.enabled = true;
    this.buttons = [...document.querySelectorAll('[data-tool]')];
    this.hint = document.getElementById('hint');
    this.cursor = document.getElementById('cursor');
    for (const b of this.buttons) b.addEventListener('click', () => this.setTool(b.dataset.tool));

    const canvas = view.canvas;
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', (e) => this.up(e));
    canvas.addEventListener('pointercancel', () => this.abort());
    canvas.addEventListener('pointerleave', () => { this.cursor.textContent = ''; });
    canvas.addEventListener('contextmenu', (e) => e.preventDefault());
    canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      const p = view.clientToCanvas(e.clientX, e.clientY);
      view.zoomAt(p.x, p.y, Math.exp(-e.deltaY * 0.0015));
    }, { passive: false });
    this.setTool('move');
  }

  /** Offline: every tool but Move is disabled (nothing can be sent). */
  setEnabled(on) {
    this.enabled = on;
    for (const b of this.buttons) b.disabled = !on && b.dataset.tool !== 'move';
    if (!on) this.setTool('move');
  }

  setTool(tool) {
    this.abort();
    if (!this.enabled) tool = 'move';
    this.tool = tool;
    for (const b of this.buttons) b.classList.toggle('active', b.dataset.tool === tool);
    this.view.canvas.dataset.cursor = tool === 'move' ? 'move' : 'goal';
    this.setHint(HINTS[tool] || '');
  }

  setHint(text) {
    if (this.view.mapBounds || this.tool !== 'move') this.hint.textContent = text;
    delete this.hint.dataset.warning;
  }

  /** While placing: warn in the hint when the spot under the pointer is a bad one. */
  warnAt(spot) {
    const problem = this.warning(this.tool, spot.x, spot.y);
    if (problem === (this.hint.dataset.warning || '')) return;
    if (!problem) {
      this.setHint(HINTS[this.tool] || '');
      return;
    }
    this.hint.textContent = `⚠ Not a good spot: ${problem}.`;
    this.hint.dataset.warning = problem;
  }

  down(e) {
    const p = this.view.clientToCanvas(e.clientX, e.clientY);
    this.view.canvas.setPointerCapture(e.pointerId);
    if (this.tool === 'move' || e.button !== 0) {
      this.drag = { kind: 'pan' };
      this.view.startPan(p.x, p.y);
      this.view.canvas.classList.add('panning');
      return;
    }
    if (!this.enabled) return;
    const at = this.view.clientToRos(e.clientX, e.clientY);
    this.drag = { kind: 'pick', at, end: at, cx: e.clientX, cy: e.clientY, yaw: null };
    if (LINE_TOOLS.has(this.tool)) this.shapePreview.set('line', at, at);
    else if (RECT_TOOLS.has(this.tool)) this.shapePreview.set(this.tool, at, at);
    else if (this.tool !== 'unline' && this.tool !== 'waypoint') this.preview.setPose(at.x, at.y, 0);
  }

  move(e) {
    const r = this.view.clientToRos(e.clientX, e.clientY);
    this.cursor.textContent = `${r.x.toFixed(2)}, ${r.y.toFixed(2)} m`;
    if (this.enabled && (!this.drag || this.drag.kind === 'pick')) this.warnAt(this.drag ? this.drag.at : r);
    if (!this.drag) return;
    if (this.drag.kind === 'pan') {
      const p = this.view.clientToCanvas(e.clientX, e.clientY);
      this.view.pan(p.x, p.y);
      return;
    }
    const d = this.drag;
    d.end = r;
    if (LINE_TOOLS.has(this.tool) || RECT_TOOLS.has(this.tool)) {
      this.shapePreview.set(LINE_TOOLS.has(this.tool) ? 'line' : this.tool, d.at, r);
      const size = LINE_TOOLS.has(this.tool) ? `${Math.hypot(r.x - d.at.x, r.y - d.at.y).toFixed(2)} m`
        : `${Math.abs(r.x - d.at.x).toFixed(2)} × ${Math.abs(r.y - d.at.y).toFixed(2)} m`;
      this.setHint(`${this.tool}: ${size}`);
      return;
    }
    if (Math.hypot(e.clientX - d.cx, e.clientY - d.cy) >= DRAG_PX) {
      d.yaw = Math.atan2(r.y - d.at.y, r.x - d.at.x);
      this.preview.setPose(d.at.x, d.at.y, d.yaw);
      if (!this.hint.dataset.warning) this.setHint(`${this.tool}: ${formatPose(d.at.x, d.at.y, d.yaw)}`);
    }
  }

  up(e) {
    const d = this.drag;
    this.drag = null;
    this.view.canvas.classList.remove('panning');
    if (this.view.canvas.hasPointerCapture(e.pointerId)) this.view.canvas.releasePointerCapture(e.pointerId);
    if (!d || d.kind !== 'pick') return;
    this.preview.hide();
    this.shapePreview.set(null);
    const tool = this.tool;
    if (!STAYING_TOOLS.has(tool)) this.setTool('move'); // setting a pose or a POI is a one-off
    else this.setHint(HINTS[tool]);
    const dragged = Math.hypot(e.clientX - d.cx, e.clientY - d.cy) >= DRAG_PX;
    if ((LINE_TOOLS.has(tool) || RECT_TOOLS.has(tool)) && !dragged) return; // a click draws nothing
    this.onPick(tool, { x: d.at.x, y: d.at.y, yaw: d.yaw, end: d.end });
  }

  /** Esc: drop a drag in progress; otherwise leave the tool (back to Move), as the hints say. */
  escape() {
    if (this.drag && this.drag.kind === 'pick') this.abort();
    else if (this.tool !== 'move') this.setTool('move');
  }

  abort() {
    if (this.drag && this.drag.kind === 'pick') {
      this.preview.hide();
      this.shapePreview.set(null);
      this.setHint(HINTS[this.tool] || '');
    }
    this.drag = null;
    this.view.canvas.classList.remove('panning');
  }
}
