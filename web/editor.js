// Editing the map: virtual walls and tracks (the Slamware node's add_line / remove_line /
// clear_lines), no-go areas and erasing them (BLOCKED / NOT_MASKED masks through
// /map_manager/modify_map, which the planner honours) and which layers /map is made of
// (/map_manager/map_layers).
/* global ROSLIB */
import { confirmAction } from './dialogs.js';
import { log } from './log.js';
import { TOPICS } from './names.js';
import { plural } from './util.js';

const USAGE = { wall: 0, track: 1 }; // slamware_ros_sdk/ArtifactUsage
const MASK = { area: 100, erase: -1 }; // map_messages/ModifyMap: BLOCKED, NOT_MASKED
const MASKING_LAYER = 1;
const LAYER_NAMES = ["the robot's map", 'the masks', 'the depth camera obstacles', 'the lidar obstacles'];

export class MapEditor {
  constructor({ ros, view, walls, tracks }) {
    this.view = view;
    this.walls = walls;
    this.tracks = tracks;
    const topic = (name, messageType) => new ROSLIB.Topic({ ros, name, messageType });
    this.addLine = topic(TOPICS.addLine, 'slamware_ros_sdk/AddLineRequest');
    this.removeLine = topic(TOPICS.removeLine, 'slamware_ros_sdk/RemoveLineRequest');
    this.clearLines = topic(TOPICS.clearLines, 'slamware_ros_sdk/ClearLinesRequest');
    this.modifyMap = topic(TOPICS.modifyMap, 'map_messages/ModifyMap');
    this.mapLayers = topic(TOPICS.mapLayers, 'map_messages/MapLayers');
    this.counts = document.getElementById('line-counts');
    document.getElementById('clear-walls').addEventListener('click', () => this.clear('wall'));
    document.getElementById('clear-tracks').addEventListener('click', () => this.clear('track'));
    for (const box of document.querySelectorAll('[data-map-layer]')) {
      box.addEventListener('change', () => {
        const layer = Number(box.dataset.mapLayer);
        this.mapLayers.publish(new ROSLIB.Message({ layer, state: box.checked }));
        log('info', `${LAYER_NAMES[layer]} ${box.checked ? 'shown on' : 'taken off'} the map`);
      });
    }
  }

  showCounts() {
    this.counts.textContent = `${plural(this.walls.lines.length, 'wall')} · ${plural(this.tracks.lines.length, 'track')}`;
  }

  /** A pick from one of the editing tools (see MapTools). */
  pick(tool, { x, y, end }) {
    if (tool === 'wall' || tool === 'track') this.line(tool, { x, y }, end);
    else if (tool === 'area' || tool === 'erase') this.area(tool, { x, y }, end);
    else if (tool === 'unline') this.unline(x, y);
  }

  line(kind, a, b) {
    this.addLine.publish(new ROSLIB.Message({
      usage: { usage: USAGE[kind] },
      line: { id: 0, start: { x: a.x, y: a.y }, end: { x: b.x, y: b.y } },
    }));
    log('info', `virtual ${kind} added: ${a.x.toFixed(2)}, ${a.y.toFixed(2)} → ${b.x.toFixed(2)}, ${b.y.toFixed(2)} m`);
  }

  area(kind, a, b) {
    const [x0, x1] = [Math.min(a.x, b.x), Math.max(a.x, b.x)];
    const [y0, y1] = [Math.min(a.y, b.y), Math.max(a.y, b.y)];
    this.modifyMap.publish(new ROSLIB.Message({
      region: [[x0, y0], [x1, y0], [x1, y1], [x0, y1]].map(([px, py]) => ({ x: px, y: py, z: 0 })),
      maskAction: MASK[kind],
      mapLayer: MASKING_LAYER,
    }));
    const size = `${(x1 - x0).toFixed(2)} × ${(y1 - y0).toFixed(2)} m`;
    log('info', kind === 'area' ? `no-go area added (${size})` : `masks erased (${size})`);
  }

  unline(x, y) {
    const tolerance = 8 * this.view.metresPerPixel;
    const hits = [['wall', this.walls.nearest(x, y, tolerance)], ['track', this.tracks.nearest(x, y, tolerance)]]
      .filter(([, hit]) => hit).sort((p, q) => p[1].d - q[1].d);
    if (!hits.length) {
      log('warning', 'no wall or track there');
      return;
    }
    const [kind, { line }] = hits[0];
    this.removeLine.publish(new ROSLIB.Message({ usage: { usage: USAGE[kind] }, id: line.id }));
    log('info', `virtual ${kind} ${line.id} removed`);
  }

  async clear(kind) {
    const n = (kind === 'wall' ? this.walls : this.tracks).lines.length;
    const question = n === 1 ? `Remove the virtual ${kind}?` : `Remove all ${n} virtual ${kind}s?`;
    if (!(await confirmAction(question, 'Remove'))) return;
    this.clearLines.publish(new ROSLIB.Message({ usage: { usage: USAGE[kind] } }));
    log('info', `virtual ${kind}s cleared`);
  }
}
