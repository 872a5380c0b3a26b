// Overlay layers drawn over the map, in metres (ROS y flipped, as ros2d draws). Sizes given in
// CSS pixels stay the same on screen at any zoom: each layer is redrawn when the scale changes.
/* global createjs */
import { avoid, label as named } from './labels.js';
import { ROBOT_RADIUS, SAFETY_MARGIN } from './placement.js';
import { degrees, yawOf } from './util.js';

export const COLORS = {
  robot: '#2196f3',
  robotEdge: '#0d47a1',
  path: '#00c853',
  scan: '#ff6d00',
  wall: '#ff1744',
  track: '#00b8d4',
  goal: '#d500f9',
  preview: '#ffab00',
  poi: '#ffc400',
  waypoint: '#76ff03',
  graph: '#b388ff',
  grid: 'rgba(120, 144, 156, 0.35)',
  sensorOk: 'rgba(0, 230, 118, 0.55)',
  sensorHit: '#ff1744',
  area: 'rgba(255, 23, 68, 0.25)',
};

export class Layer {
  constructor(view) {
    this.view = view;
    this.node = new createjs.Container();
    this.node.mouseEnabled = false;
    this.dirty = true;
    view.addLayer(this);
  }

  changed() {
    this.dirty = true;
    this.view.requestRender();
  }

  set visible(on) {
    this.node.visible = on;
    this.view.requestRender();
  }

  get visible() {
    return this.node.visible;
  }

  render() {}
}

/** slamware_ros_sdk/Line2DFlt32Array: virtual walls (solid) or virtual tracks (dashed). */
export class LinesLayer extends Layer {
  constructor(view, { color, width = 3, dash = null }) {
    super(view);
    this.style = { color, width, dash };
    this.lines = [];
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
  }

  set(message) {
    this.lines = (message && message.lines) || [];
    this.changed();
  }

  /** The line within `tolerance` metres of (x, y), nearest first, or null. */
  nearest(x, y, tolerance) {
    let best = null;
    for (const line of this.lines) {
      const d = segmentDistance(x, y, line.start, line.end);
      if (d <= tolerance && (!best || d < best.d)) best = { line, d };
    }
    return best;
  }

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    if (!this.lines.length) return;
    // Each segment and each end cap is a path of its own: one path holding several circles
    // joins them (an arc starts from where the last one ended) and fills the shape between.
    g.setStrokeStyle(this.style.width * u, 'round', 'round');
    if (this.style.dash) g.setStrokeDash(this.style.dash.map((d) => d * u), 0);
    for (const line of this.lines) {
      g.beginStroke(this.style.color).moveTo(line.start.x, -line.start.y)
        .lineTo(line.end.x, -line.end.y).endStroke();
    }
    // end points, so a zero-length-looking wall is still visible
    g.setStrokeDash(null);
    const r = this.style.width * 0.9 * u;
    for (const line of this.lines) {
      g.beginFill(this.style.color).drawCircle(line.start.x, -line.start.y, r).endFill();
      g.beginFill(this.style.color).drawCircle(line.end.x, -line.end.y, r).endFill();
    }
  }
}

/** nav_msgs/Path: the remaining planned path. */
export class PathLayer extends Layer {
  constructor(view) {
    super(view);
    this.points = [];
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
  }

  set(message) {
    this.points = ((message && message.poses) || []).map((p) => p.pose.position);
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    if (this.points.length < 2) return;
    g.setStrokeStyle(3 * u, 'round', 'round').beginStroke(COLORS.path);
    g.moveTo(this.points[0].x, -this.points[0].y);
    for (const p of this.points.slice(1)) g.lineTo(p.x, -p.y);
    g.endStroke();
    const end = this.points[this.points.length - 1];
    g.beginFill(COLORS.path).drawCircle(end.x, -end.y, 4 * u).endFill();
  }
}

/** sensor_msgs/LaserScan drawn from the laser's pose in the map. */
export class ScanLayer extends Layer {
  constructor(view) {
    super(view);
    this.points = [];
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
  }

  set(scan, laserPose) {
    const pts = [];
    if (scan && laserPose) {
      const { x, y, yaw } = laserPose;
      const ranges = scan.ranges || [];
      for (let i = 0; i < ranges.length; i++) {
        const r = ranges[i];
        if (r === null || !Number.isFinite(r) || r < scan.range_min || r > scan.range_max) continue;
        const a = yaw + scan.angle_min + i * scan.angle_increment;
        pts.push(x + r * Math.cos(a), y + r * Math.sin(a));
      }
    }
    this.points = pts;
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    const half = 1.5 * u;
    g.beginFill(COLORS.scan);
    for (let i = 0; i < this.points.length; i += 2) {
      g.rect(this.points[i] - half, -this.points[i + 1] - half, 2 * half, 2 * half);
    }
    g.endFill();
  }
}

/** A marker at a pose, drawn in screen pixels (the container is scaled by metres/pixel). */
class PoseMarker extends Layer {
  constructor(view) {
    super(view);
    this.node.visible = false;
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
    this.pose = null;
  }

  setPose(x, y, yaw) {
    this.pose = { x, y, yaw };
    this.node.x = x;
    this.node.y = -y;
    this.node.rotation = -degrees(yaw);
    this.node.visible = true;
    this.view.requestRender();
  }

  hide() {
    this.pose = null;
    this.node.visible = false;
    this.view.requestRender();
  }

  render(view) {
    const u = view.metresPerPixel;
    this.node.scaleX = this.node.scaleY = u;
    this.draw(this.shape.graphics.clear(), u);
  }
}

/** The robot: its footprint (at least 9 px) and an arrow for its heading; on a fleet server
 * the chosen robot's ring and name (setLabel), drawn here once, where the robot is now. */
export class RobotMarker extends PoseMarker {
  constructor(view, radius = 0.2) {
    super(view);
    this.radius = radius;
    this.label = null;
    avoid(this.shape, 9);
  }

  /** Name the robot beside it (`text` in `color`), or no name (null). */
  setLabel(text, color) {
    if (this.label && this.label.text === text && this.label.color === color) return;
    if (this.label) this.node.removeChild(this.label);
    this.label = text ? named(new createjs.Text(text, 'bold 12px sans-serif', color), text) : null;
    if (this.label) this.node.addChild(this.label);
    this.view.requestRender();
  }

  setPose(x, y, yaw) {
    super.setPose(x, y, yaw);
    this.node.rotation = 0; // the name stays upright: only the body turns
    this.shape.rotation = -degrees(yaw);
  }

  draw(g, u) {
    const r = Math.max(this.radius / u, 9);
    this.shape.avoidRadius = r;
    if (this.label) {
      this.label.x = r + 4;
      this.label.y = this.label.baseY = -r - 10;
      g.setStrokeStyle(3).beginStroke('#ffeb3b').drawCircle(0, 0, r + 4).endStroke();
    }
    g.setStrokeStyle(2).beginStroke(COLORS.robotEdge).beginFill(COLORS.robot).drawCircle(0, 0, r);
    g.endStroke().endFill();
    g.beginFill('#ffffff').moveTo(r * 0.75, 0).lineTo(-r * 0.35, r * 0.45).lineTo(-r * 0.1, 0)
      .lineTo(-r * 0.35, -r * 0.45).closePath().endFill();
  }
}

/** An arrow at a pose: the current goal, or the one being dragged. */
export class ArrowMarker extends PoseMarker {
  constructor(view, color, { dashed = false } = {}) {
    super(view);
    this.color = color;
    this.dashed = dashed;
  }

  draw(g) {
    g.setStrokeStyle(2);
    if (this.dashed) g.setStrokeDash([4, 3]);
    g.beginStroke(this.color).drawCircle(0, 0, 7).endStroke();
    g.setStrokeDash(null).setStrokeStyle(3, 'round').beginStroke(this.color).moveTo(0, 0)
      .lineTo(24, 0).endStroke();
    g.beginFill(this.color).moveTo(32, 0).lineTo(20, 7).lineTo(20, -7).closePath().endFill();
  }
}

/** map_messages/PointsOfInterest: a pin and its name for each. */
export class PoiLayer extends Layer {
  constructor(view) {
    super(view);
    this.pois = [];
  }

  set(pois) {
    this.pois = pois || [];
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    this.node.removeAllChildren();
    for (const poi of this.pois) {
      const p = poi.pose.position;
      const marker = new createjs.Container();
      marker.x = p.x;
      marker.y = -p.y;
      marker.scaleX = marker.scaleY = u;
      const yaw = yawOf(poi.pose.orientation);
      const shape = new createjs.Shape();
      const g = shape.graphics;
      g.setStrokeStyle(2).beginStroke('#3e2723').beginFill(COLORS.poi)
        .drawPolyStar(0, 0, 7, 4, 0, 0).endStroke().endFill();
      g.setStrokeStyle(2, 'round').beginStroke(COLORS.poi).moveTo(0, 0)
        .lineTo(14 * Math.cos(yaw), -14 * Math.sin(yaw)).endStroke();
      const label = new createjs.Text(poi.name, 'bold 12px system-ui, sans-serif', '#fff8e1');
      label.textBaseline = 'middle';
      label.x = 15;
      label.y = -15;
      const tag = new createjs.Shape();
      const width = label.getMeasuredWidth() + 10;
      tag.graphics.beginFill('rgba(33, 26, 10, 0.85)').drawRoundRect(label.x - 5, label.y - 9, width, 18, 4);
      const tagged = new createjs.Container(); // the name and its tag move together (labels.js)
      tagged.addChild(tag, label);
      tagged.setBounds(label.x - 5, label.y - 9, width, 18);
      marker.addChild(shape, named(tagged, poi.name));
      this.node.addChild(marker);
    }
  }
}

export const SONAR_NEAR = 0.5; // m: a sonar echo nearer than this is shown as triggered

/** Whether a sensor reading (basic_sensors_values' `value`) of a sensor of `type` (0 bumper,
 * 1 cliff, 2 sonar) is triggered. A Slamware analog sonar always reports `is_in_impact`
 * (slamware_ros_sdk's rule): its range against SONAR_NEAR says it instead. */
export function sensorTriggered(type, value) {
  if (!value) return false;
  if (type === 2) return Number.isFinite(value.value) && value.value > 0 && value.value < SONAR_NEAR;
  return Boolean(value.is_in_impact);
}

/** Distance from (x, y) to the segment a–b. */
export function segmentDistance(x, y, a, b) {
  const dx = b.x - a.x;
  const dy = b.y - a.y;
  const len2 = dx * dx + dy * dy;
  const t = len2 ? Math.max(0, Math.min(1, ((x - a.x) * dx + (y - a.y) * dy) / len2)) : 0;
  return Math.hypot(x - (a.x + t * dx), y - (a.y + t * dy));
}

/** The line or rectangle being dragged with an editing tool. */
export class ShapePreview extends Layer {
  constructor(view) {
    super(view);
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
    this.what = null;
  }

  set(kind, a, b) {
    this.what = kind ? { kind, a, b } : null;
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    if (!this.what) return;
    const { kind, a, b } = this.what;
    g.setStrokeStyle(2 * u).setStrokeDash([6 * u, 4 * u], 0).beginStroke(COLORS.preview);
    if (kind === 'line') {
      g.moveTo(a.x, -a.y).lineTo(b.x, -b.y);
    } else {
      g.beginFill(kind === 'erase' ? 'rgba(255, 171, 0, 0.15)' : COLORS.area);
      g.drawRect(Math.min(a.x, b.x), -Math.max(a.y, b.y), Math.abs(b.x - a.x), Math.abs(b.y - a.y));
    }
    g.endStroke().endFill();
  }
}

/** A metric grid over the map, spaced so lines are at least ~48 CSS px apart. */
export class GridLayer extends Layer {
  constructor(view) {
    super(view);
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
    view.addEventListener('map', () => this.changed());
  }

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    const b = view.mapBounds;
    if (!b) return;
    const step = niceStep(48 * u);
    const x0 = Math.ceil(b.x / step) * step;
    const y0 = Math.ceil(b.y / step) * step;
    g.setStrokeStyle(u).beginStroke(COLORS.grid);
    for (let x = x0; x <= b.x + b.w; x += step) g.moveTo(x, -b.y).lineTo(x, -(b.y + b.h));
    for (let y = y0; y <= b.y + b.h; y += step) g.moveTo(b.x, -y).lineTo(b.x + b.w, -y);
    g.endStroke();
  }
}

/** The smallest 1-2-5 × 10ⁿ length at least `min` metres. */
export function niceStep(min) {
  const p = 10 ** Math.floor(Math.log10(min));
  for (const m of [1, 2, 5, 10]) if (m * p >= min) return m * p;
  return 10 * p;
}

/**
 * The planner's view of the map, computed in the page from /map with the simulator planner's
 * defaults: lethal cells (the robot's centre cannot go there: closer than radius + half a cell
 * + safety margin to an obstacle) and a fading inflation band out to `inflation`. A chamfer
 * distance transform, O(cells). Virtual walls are not in /map, so they are not inflated here.
 */
export class CostmapLayer extends Layer {
  constructor(view, { robotRadius = ROBOT_RADIUS, safetyMargin = SAFETY_MARGIN, inflation = 0.6 } = {}) {
    super(view);
    this.robotRadius = robotRadius;
    this.safetyMargin = safetyMargin;
    this.inflation = inflation;
    this.bitmap = null;
    this.pending = null;
    this.timer = null;
    this.node.alpha = 0.55;
    this.node.visible = false;
  }

  set(grid) {
    this.grid = grid; // the latest /map (where a POI may stand is judged on it too)
    this.pending = grid;
    if (this.node.visible && !this.timer) {
      this.timer = setTimeout(() => { this.timer = null; this.compute(); }, 300);
    }
  }

  set visible(on) {
    this.node.visible = on;
    if (on && this.pending) this.compute();
    this.view.requestRender();
  }

  get visible() {
    return this.node.visible;
  }

  compute() {
    const msg = this.pending;
    if (!msg) return;
    const { width: w, height: h, resolution: res } = msg.info;
    const dist = chamferDistance(msg.data, w, h);
    const canvas = document.createElement('canvas');
    canvas.width = w;
    canvas.height = h;
    const ctx = canvas.getContext('2d');
    const img = ctx.createImageData(w, h);
    const lethal = (this.robotRadius + 0.5 * res + this.safetyMargin) / res;
    const band = this.inflation / res;
    for (let row = 0; row < h; row++) {
      for (let col = 0; col < w; col++) {
        const d = dist[row * w + col];
        if (d === 0 || d >= band) continue;
        const o = ((h - 1 - row) * w + col) * 4; // image rows go down, map rows go up
        if (d < lethal) {
          img.data[o] = 255; img.data[o + 1] = 0; img.data[o + 2] = 200; img.data[o + 3] = 200;
        } else {
          img.data[o] = 0; img.data[o + 1] = 150; img.data[o + 2] = 255;
          img.data[o + 3] = Math.round(170 * (1 - (d - lethal) / (band - lethal)));
        }
      }
    }
    ctx.putImageData(img, 0, 0);
    this.node.removeAllChildren();
    this.bitmap = new createjs.Bitmap(canvas);
    this.bitmap.scaleX = this.bitmap.scaleY = res;
    this.bitmap.x = msg.info.origin.position.x;
    this.bitmap.y = -(msg.info.origin.position.y + h * res);
    this.node.addChild(this.bitmap);
    this.cells = { dist, w, h, res, lethal, band };
    this.view.requestRender();
  }
}

/** Distance (in cells) of every cell to the nearest occupied one (> 50); 0 on obstacles. */
export function chamferDistance(data, w, h) {
  const INF = 1e9;
  const d = new Float32Array(w * h);
  for (let i = 0; i < w * h; i++) d[i] = data[i] > 50 ? 0 : INF;
  const D = Math.SQRT2;
  for (let r = 0; r < h; r++) {
    for (let c = 0; c < w; c++) {
      const i = r * w + c;
      if (d[i] === 0) continue;
      let v = d[i];
      if (c > 0) v = Math.min(v, d[i - 1] + 1);
      if (r > 0) {
        v = Math.min(v, d[i - w] + 1);
        if (c > 0) v = Math.min(v, d[i - w - 1] + D);
        if (c < w - 1) v = Math.min(v, d[i - w + 1] + D);
      }
      d[i] = v;
    }
  }
  for (let r = h - 1; r >= 0; r--) {
    for (let c = w - 1; c >= 0; c--) {
      const i = r * w + c;
      let v = d[i];
      if (c < w - 1) v = Math.min(v, d[i + 1] + 1);
      if (r < h - 1) {
        v = Math.min(v, d[i + w] + 1);
        if (c < w - 1) v = Math.min(v, d[i + w + 1] + D);
        if (c > 0) v = Math.min(v, d[i + w - 1] + D);
      }
      d[i] = v;
    }
  }
  return d;
}

/** Patrol waypoints: numbered dots joined in visiting order, the current target ringed. */
export class WaypointLayer extends Layer {
  constructor(view) {
    super(view);
    this.points = [];
    this.target = -1;
  }

  set(points, target = -1) {
    this.points = points;
    this.target = target;
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    this.node.removeAllChildren();
    if (!this.points.length) return;
    const lines = new createjs.Shape();
    const g = lines.graphics.setStrokeStyle(2 * u).setStrokeDash([6 * u, 4 * u], 0)
      .beginStroke(COLORS.waypoint);
    this.points.forEach((p, i) => (i ? g.lineTo(p.x, -p.y) : g.moveTo(p.x, -p.y)));
    if (this.points.length > 2) g.lineTo(this.points[0].x, -this.points[0].y);
    g.endStroke();
    this.node.addChild(lines);
    this.points.forEach((p, i) => {
      const m = new createjs.Container();
      m.x = p.x;
      m.y = -p.y;
      m.scaleX = m.scaleY = u;
      const dot = new createjs.Shape();
      dot.graphics.setStrokeStyle(2).beginStroke('#1b5e20').beginFill(COLORS.waypoint).drawCircle(0, 0, 9);
      if (i === this.target) dot.graphics.endFill().setStrokeStyle(3).beginStroke('#ffffff').drawCircle(0, 0, 14);
      const label = new createjs.Text(String(i + 1), 'bold 11px system-ui, sans-serif', '#102010');
      label.textAlign = 'center';
      label.textBaseline = 'middle';
      m.addChild(dot, label);
      this.node.addChild(m);
    });
  }
}

/** hitrobot_msgs/Graph (graph/current): edges and numbered nodes. */
export class GraphLayer extends Layer {
  constructor(view) {
    super(view);
    this.graph = null;
  }

  set(graph) {
    this.graph = graph;
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    this.node.removeAllChildren();
    const graph = this.graph;
    if (!graph || !graph.nodes || !graph.nodes.length) return;
    const byId = new Map(graph.nodes.map((n) => [n.id, n]));
    const edges = new createjs.Shape();
    const g = edges.graphics.setStrokeStyle(2 * u).beginStroke(COLORS.graph);
    for (const e of graph.edges || []) {
      const a = byId.get(e.from_node);
      const b = byId.get(e.to_node);
      if (a && b) g.moveTo(a.x, -a.y).lineTo(b.x, -b.y);
    }
    g.endStroke();
    this.node.addChild(edges);
    for (const n of graph.nodes) {
      const m = new createjs.Container();
      m.x = n.x;
      m.y = -n.y;
      m.scaleX = m.scaleY = u;
      const dot = new createjs.Shape();
      dot.graphics.beginFill(COLORS.graph).drawRect(-5, -5, 10, 10);
      const label = new createjs.Text(String(n.id), '11px system-ui, sans-serif', '#ede7f6');
      label.x = 8;
      label.y = 4;
      m.addChild(dot, label);
      this.node.addChild(m);
    }
  }
}

/**
 * Bumpers, cliff sensors and sonars (basic_sensors_info + basic_sensors_values), drawn where
 * they sit on the robot: green when quiet, red when triggered; sonars as a cone to their range
 * (red when nearer than SONAR_NEAR).
 */
export class SensorLayer extends Layer {
  constructor(view) {
    super(view);
    this.info = new Map();
    this.values = new Map();
    this.pose = null;
    this.shape = new createjs.Shape();
    this.node.addChild(this.shape);
  }

  setInfo(infos) {
    this.info = new Map((infos || []).map((s) => [s.id, s]));
    this.changed();
  }

  setValues(values) {
    this.values = new Map((values || []).map((v) => [v.info.id, v]));
    for (const v of values || []) if (!this.info.has(v.info.id)) this.info.set(v.info.id, v.info);
    this.changed();
  }

  setPose(pose) {
    this.pose = pose;
    this.changed();
  }

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    if (!this.pose) return;
    const { x: rx, y: ry, yaw } = this.pose;
    const cos = Math.cos(yaw);
    const sin = Math.sin(yaw);
    for (const [id, s] of this.info) {
      const v = this.values.get(id);
      const hit = sensorTriggered(s.sensor_type.type, v && v.value);
      const p = s.install_pose.position;
      const a = yaw + yawOf(s.install_pose.orientation);
      const x = rx + p.x * cos - p.y * sin;
      const y = ry + p.x * sin + p.y * cos;
      const type = s.sensor_type.type;
      const colour = hit ? COLORS.sensorHit : COLORS.sensorOk;
      if (type === 2) { // sonar: a 15° cone to the measured range (capped at 1.5 m)
        const range = Math.min(1.5, v && Number.isFinite(v.value.value) && v.value.value > 0 ? v.value.value : 1.5);
        const half = (7.5 * Math.PI) / 180;
        g.beginFill(hit ? 'rgba(255, 23, 68, 0.35)' : 'rgba(0, 230, 118, 0.12)')
          .moveTo(x, -y)
          .lineTo(x + range * Math.cos(a - half), -(y + range * Math.sin(a - half)))
          .lineTo(x + range * Math.cos(a + half), -(y + range * Math.sin(a + half)))
          .closePath().endFill();
      } else if (type === 0) { // bumper: a thick arc segment on the rim
        g.setStrokeStyle(5 * u, 'round').beginStroke(colour)
          .moveTo(x - 0.06 * Math.sin(a), -(y + 0.06 * Math.cos(a)))
          .lineTo(x + 0.06 * Math.sin(a), -(y - 0.06 * Math.cos(a))).endStroke();
      } else { // cliff and the rest: a small square
        g.beginFill(colour).drawRect(x - 3 * u, -y - 3 * u, 6 * u, 6 * u).endFill();
      }
    }
  }
}
