// The home dock on the map, from the map manager's latched /map_manager/home
// (geometry_msgs/PoseStamped; an empty frame id: the map has no dock): a charging-station mark
// facing the way the robot docks, labelled "dock".
/* global createjs */
import { Layer } from './overlays.js';
import { yawOf } from './util.js';

const DOCK_COLOR = '#ffd600';

export class DockLayer extends Layer {
  constructor(view) {
    super(view);
    this.pose = null;
  }

  /** A PoseStamped of the dock; none when its frame id is empty. */
  set(stamped) {
    this.pose = stamped && stamped.header.frame_id ? stamped.pose : null;
    this.changed();
  }

  render(view) {
    this.node.removeAllChildren();
    if (!this.pose) return;
    const p = this.pose.position;
    const mark = new createjs.Container();
    mark.x = p.x;
    mark.y = -p.y;
    mark.scaleX = mark.scaleY = view.metresPerPixel;
    const yaw = yawOf(this.pose.orientation);
    const shape = new createjs.Shape();
    shape.graphics.setStrokeStyle(2).beginStroke('#3e2c00').beginFill(DOCK_COLOR)
      .drawRoundRect(-8, -8, 16, 16, 3).endStroke().endFill()
      .setStrokeStyle(2, 'round').beginStroke('#3e2c00')
      .moveTo(1, -6).lineTo(-3, 1).lineTo(2, 1).lineTo(-1, 6).endStroke()
      .setStrokeStyle(2, 'round').beginStroke(DOCK_COLOR).moveTo(0, 0)
      .lineTo(16 * Math.cos(yaw), -16 * Math.sin(yaw)).endStroke();
    const label = new createjs.Text('dock', 'bold 11px system-ui, sans-serif', DOCK_COLOR);
    label.textAlign = 'center';
    label.y = 11;
    mark.addChild(shape, label);
    this.node.addChild(mark);
  }
}
