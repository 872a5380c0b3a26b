// Overlay layers drawn over the map, in metres (ROS y flipped, as ros2d draws). Sizes given in
// CSS pixels stay the same on screen at any zoom: each layer is redrawn when the scale changes.
/* global createjs */
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
};

class Layer {
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

  render(view) {
    const u = view.metresPerPixel;
    const g = this.shape.graphics.clear();
    if (!this.lines.length) return;
    g.setStrokeStyle(this.style.width * u, 'round', 'round');
    if (this.style.dash) g.setStrokeDash(this.style.dash.map((d) => d * u), 0);
    g.beginStroke(this.style.color);
    for (const line of this.lines) {
      g.moveTo(line.start.x, -line.start.y).lineTo(line.end.x, -line.end.y);
    }
    g.endStroke();
    // end points, so a zero-length-looking wall is still visible
    g.setStrokeDash(null).beginFill(this.style.color);
    for (const line of this.lines) {
      g.drawCircle(line.start.x, -line.start.y, this.style.width * 0.9 * u);
      g.drawCircle(line.end.x, -line.end.y, this.style.width * 0.9 * u);
    }
    g.endFill();
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

/** The robot: its footprint (at least 9 px) and an arrow for its heading. */
export class RobotMarker extends PoseMarker {
  constructor(view, radius = 0.2) {
    super(view);
    this.radius = radius;
  }

  draw(g, u) {
    const r = Math.max(this.radius / u, 9);
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
      tag.graphics.beginFill('rgba(33, 26, 10, 0.85)')
        .drawRoundRect(label.x - 5, label.y - 9, label.getMeasuredWidth() + 10, 18, 4);
      marker.addChild(shape, tag, label);
      this.node.addChild(marker);
    }
  }
}
