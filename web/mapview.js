// The map view: a ros2d Viewer with an OccupancyGridClient on /map (png-compressed, continuous),
// pan and zoom, and the overlay layers drawn in map metres on top of it.
//
// Coordinates: the easeljs stage is in canvas pixels; the scene is in metres with y flipped
// (ros2d's convention: a child at ROS (x, y) sits at (x, -y)). So a ROS point is drawn at
//   canvas = (stage.x + x * scale, stage.y - y * scale)
// and the canvas is devicePixelRatio times the CSS size, for crisp lines on HiDPI screens.
/* global createjs, ROS2D */
import { placeLabels } from './labels.js';
import { TOPICS } from './names.js';

const MIN_SCALE = 2; // canvas px per metre
const MAX_SCALE = 800;
const FIT_TOP_INSET = 52; // CSS px under the floating toolbar

export class MapView extends EventTarget {
  constructor(container, ros) {
    super();
    this.container = container;
    this.dpr = window.devicePixelRatio || 1;
    const { width, height } = this.cssSize();
    // ros2d 0.10.0's Viewer calls Ticker.setFPS, which EaselJS 1.0 kept but deprecated (it
    // logs a warning on each call); point it at the very setter it wraps.
    if (createjs.Ticker._setFPS) createjs.Ticker.setFPS = createjs.Ticker._setFPS;
    this.viewer = new ROS2D.Viewer({
      divID: container.id,
      width: Math.round(width * this.dpr),
      height: Math.round(height * this.dpr),
      background: '#1d2127',
    });
    this.stage = this.viewer.scene;
    this.canvas = this.stage.canvas;
    // Render only when something changed (the Viewer would redraw 30 times a second).
    createjs.Ticker.removeEventListener('tick', this.stage);
    this.needsRender = true;
    this.lastScale = NaN;
    this.layers = [];

    this.mapLayer = new createjs.Container();
    this.overlay = new createjs.Container();
    this.stage.addChild(this.mapLayer, this.overlay);

    this.grid = new ROS2D.OccupancyGridClient({
      ros,
      rootObject: this.mapLayer,
      topic: TOPICS.map,
      continuous: true,
    });
    // ros2d adds a 1 m debugging grid at the origin as an easeljs work-around: keep it hidden.
    for (const child of this.mapLayer.children) {
      if (child instanceof ROS2D.Grid) child.visible = false;
    }
    this.mapBounds = null;
    this.fitted = false;
    this.autoFit = true;
    this.grid.on('change', () => this.onMap());

    this.panView = new ROS2D.PanView({ rootObject: this.stage });
    this.zoomView = new ROS2D.ZoomView({ rootObject: this.stage, minScale: MIN_SCALE });

    createjs.Ticker.addEventListener('tick', () => this.tick());
    new ResizeObserver(() => this.resize()).observe(container);
  }

  cssSize() {
    return {
      width: Math.max(1, this.container.clientWidth),
      height: Math.max(1, this.container.clientHeight),
    };
  }

  get scale() {
    return this.stage.scaleX;
  }

  /** Metres per CSS pixel at the current zoom. */
  get metresPerPixel() {
    return this.dpr / this.stage.scaleX;
  }

  requestRender() {
    this.needsRender = true;
  }

  addLayer(layer) {
    this.layers.push(layer);
    this.overlay.addChild(layer.node);
    this.requestRender();
  }

  tick() {
    const scaleChanged = this.stage.scaleX !== this.lastScale;
    if (scaleChanged) this.lastScale = this.stage.scaleX;
    for (const layer of this.layers) {
      if (scaleChanged || layer.dirty) {
        layer.dirty = false;
        layer.render(this);
        this.needsRender = true;
      }
    }
    if (!this.needsRender) return;
    this.needsRender = false;
    this.placeLabels();
    const ctx = this.canvas.getContext('2d');
    ctx.imageSmoothingEnabled = false; // map cells stay sharp squares when zoomed in
    this.stage.update();
  }

  /** The names on the map kept apart (labels.js); their boxes, in client px, for the tests. */
  placeLabels() {
    const r = this.canvas.getBoundingClientRect();
    const kx = r.width / this.canvas.width;
    const ky = r.height / this.canvas.height;
    this.labelBoxes = placeLabels(this.overlay, this.dpr).map((b) => ({ name: b.name,
      left: r.left + b.left * kx, right: r.left + b.right * kx, top: r.top + b.top * ky, bottom: r.top + b.bottom * ky }));
  }

  onMap() {
    const g = this.grid.currentGrid;
    const first = this.mapBounds === null;
    const old = this.mapBounds;
    this.mapBounds = { x: g.pose.position.x, y: g.pose.position.y, w: g.width, h: g.height };
    const grew = old && (old.x !== this.mapBounds.x || old.y !== this.mapBounds.y ||
      old.w !== this.mapBounds.w || old.h !== this.mapBounds.h);
    // refit the first map, and a map that grows (mapping) until the operator pans or zooms
    if (!this.fitted || (grew && this.autoFit)) {
      this.fit();
      this.fitted = true;
    }
    this.requestRender();
    this.dispatchEvent(new CustomEvent('map', { detail: { first } }));
  }

  // ---- transforms -------------------------------------------------------------------------

  rosToCanvas(x, y) {
    return { x: this.stage.x + x * this.stage.scaleX, y: this.stage.y - y * this.stage.scaleY };
  }

  canvasToRos(px, py) {
    return { x: (px - this.stage.x) / this.stage.scaleX, y: (this.stage.y - py) / this.stage.scaleY };
  }

  clientToCanvas(cx, cy) {
    const r = this.canvas.getBoundingClientRect();
    return {
      x: ((cx - r.left) * this.canvas.width) / r.width,
      y: ((cy - r.top) * this.canvas.height) / r.height,
    };
  }

  canvasToClient(px, py) {
    const r = this.canvas.getBoundingClientRect();
    return { x: r.left + (px * r.width) / this.canvas.width, y: r.top + (py * r.height) / this.canvas.height };
  }

  /** Where a ROS map point is on the page, in CSS pixels (what a mouse event reports). */
  rosToClient(x, y) {
    const p = this.rosToCanvas(x, y);
    return this.canvasToClient(p.x, p.y);
  }

  clientToRos(cx, cy) {
    const p = this.clientToCanvas(cx, cy);
    return this.canvasToRos(p.x, p.y);
  }

  // ---- view changes -----------------------------------------------------------------------

  changed() {
    this.requestRender();
    this.dispatchEvent(new Event('view'));
  }

  /** Show the whole map, centred in the part of the canvas below the toolbar (and above
   * `bottomInset` CSS px: the replay's timeline). */
  fit() {
    const b = this.mapBounds;
    if (!b || b.w <= 0 || b.h <= 0) return;
    const top = FIT_TOP_INSET * this.dpr;
    const { width } = this.canvas;
    const height = Math.max(1, this.canvas.height - top - (this.bottomInset || 0) * this.dpr);
    const fitting = Math.min(width / b.w, height / b.h) * 0.96;
    const s = Math.min(MAX_SCALE, Math.max(MIN_SCALE, fitting));
    this.stage.scaleX = this.stage.scaleY = s;
    this.stage.x = width / 2 - (b.x + b.w / 2) * s;
    this.stage.y = top + height / 2 + (b.y + b.h / 2) * s;
    this.autoFit = true;
    this.changed();
  }

  centerOn(x, y) {
    const s = this.stage.scaleX;
    this.stage.x = this.canvas.width / 2 - x * s;
    this.stage.y = this.canvas.height / 2 + y * s;
    this.changed();
  }

  /** Zoom by `factor` keeping the canvas point (px, py) still. */
  zoomAt(px, py, factor) {
    const s = this.stage.scaleX;
    const clamped = Math.min(MAX_SCALE, Math.max(MIN_SCALE, s * factor)) / s;
    this.autoFit = false;
    this.zoomView.startZoom(px, py);
    this.zoomView.zoom(clamped);
    this.changed();
  }

  zoomCentre(factor) {
    this.zoomAt(this.canvas.width / 2, this.canvas.height / 2, factor);
  }

  startPan(px, py) {
    this.autoFit = false;
    this.panView.startPan(px, py);
  }

  pan(px, py) {
    this.panView.pan(px, py);
    this.changed();
  }

  /** Keep `(x, y)` inside the middle of the view (for "follow the robot"). */
  keepInView(x, y, margin = 0.25) {
    const p = this.rosToCanvas(x, y);
    const { width, height } = this.canvas;
    if (p.x < width * margin || p.x > width * (1 - margin) ||
        p.y < height * margin || p.y > height * (1 - margin)) {
      this.centerOn(x, y);
    }
  }

  resize() {
    this.dpr = window.devicePixelRatio || 1;
    const { width, height } = this.cssSize();
    const w = Math.round(width * this.dpr);
    const h = Math.round(height * this.dpr);
    if (w === this.canvas.width && h === this.canvas.height) return;
    const centre = this.canvasToRos(this.canvas.width / 2, this.canvas.height / 2);
    this.canvas.width = this.viewer.width = w;
    this.canvas.height = this.viewer.height = h;
    // a fitted map is fitted again to the new size; one the operator panned or zoomed keeps
    // its centre
    if (this.fitted && this.autoFit) this.fit();
    else if (this.fitted) this.centerOn(centre.x, centre.y);
    this.lastScale = NaN; // redraw every layer (pixel sizes depend on dpr)
    this.changed();
  }
}
