// Pointer and keyboard interaction with the map: the tool buttons (Move, Goal, Set pose,
// Add POI), drag-to-orient like nav2d (press at the position, drag towards the heading,
// release), pan with the Move tool or the middle/right button, zoom with the wheel.
import { ArrowMarker, COLORS } from './overlays.js';
import { formatPose } from './util.js';

const DRAG_PX = 6; // a press that moved less than this many CSS pixels is a click
const HINTS = {
  move: 'Drag to pan, wheel to zoom. Pick a tool to act on the map.',
  goal: 'Goal: click a destination, or press and drag towards the heading you want.',
  pose: 'Set pose: press where the robot is and drag towards where it faces.',
  poi: 'Add POI: click the spot, or press and drag to give it a heading.',
};

export class MapTools {
  /** `onPick(tool, {x, y, yaw})`: yaw is null for a plain click (no heading dragged). */
  constructor(view, onPick) {
    this.view = view;
    this.onPick = onPick;
    this.tool = 'move';
    this.drag = null;
    this.preview = new ArrowMarker(view, COLORS.preview, { dashed: true });
    this.buttons = [...document.querySelectorAll('#tools [data-tool]')];
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

  setTool(tool) {
    this.abort();
    this.tool = tool;
    for (const b of this.buttons) b.classList.toggle('active', b.dataset.tool === tool);
    this.view.canvas.dataset.cursor = tool;
    this.setHint(HINTS[tool] || '');
  }

  setHint(text) {
    if (this.view.mapBounds || this.tool !== 'move') this.hint.textContent = text;
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
    const at = this.view.clientToRos(e.clientX, e.clientY);
    this.drag = { kind: 'pick', at, cx: e.clientX, cy: e.clientY, yaw: null };
    this.preview.setPose(at.x, at.y, 0);
  }

  move(e) {
    const r = this.view.clientToRos(e.clientX, e.clientY);
    this.cursor.textContent = `${r.x.toFixed(2)}, ${r.y.toFixed(2)} m`;
    if (!this.drag) return;
    if (this.drag.kind === 'pan') {
      const p = this.view.clientToCanvas(e.clientX, e.clientY);
      this.view.pan(p.x, p.y);
      return;
    }
    const d = this.drag;
    if (Math.hypot(e.clientX - d.cx, e.clientY - d.cy) >= DRAG_PX) {
      d.yaw = Math.atan2(r.y - d.at.y, r.x - d.at.x);
      this.preview.setPose(d.at.x, d.at.y, d.yaw);
      this.setHint(`${this.tool}: ${formatPose(d.at.x, d.at.y, d.yaw)}`);
    }
  }

  up(e) {
    const d = this.drag;
    this.drag = null;
    this.view.canvas.classList.remove('panning');
    if (this.view.canvas.hasPointerCapture(e.pointerId)) this.view.canvas.releasePointerCapture(e.pointerId);
    if (!d || d.kind !== 'pick') return;
    this.preview.hide();
    const tool = this.tool;
    if (tool !== 'goal') this.setTool('move'); // setting a pose or a POI is a one-off
    else this.setHint(HINTS.goal);
    this.onPick(tool, { x: d.at.x, y: d.at.y, yaw: d.yaw });
  }

  abort() {
    if (this.drag && this.drag.kind === 'pick') {
      this.preview.hide();
      this.setHint(HINTS[this.tool] || '');
    }
    this.drag = null;
    this.view.canvas.classList.remove('panning');
  }
}
