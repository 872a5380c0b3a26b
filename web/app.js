// The hitrobot operator console: wires the connection, the map view and its layers, the tools,
// navigation, POIs, map editing and saved maps, patrols, the robot's actions and state,
// diagnostics and sensors, system commands, driving and the topic inspector together.
/* global ROSLIB, ROS2D, createjs */
import { connect, showBroken, showFoxgloveUrl } from './connection.js';
import { CurrentRobot } from './currentrobot.js';
import { Diagnostics } from './diagnostics.js';
import { dialogOpen } from './dialogs.js';
import { DockLayer } from './docklayer.js';
import { MapEditor } from './editor.js';
import { Fleet } from './fleet.js';
import { Zones } from './zones.js';
import { FleetOps } from './fleetops.js';
import { VdaLinks } from './vda5050.js';
import { Inspector } from './inspector.js';
import { log } from './log.js';
import { SavedMaps } from './maps.js';
import { MapView } from './mapview.js';
import { TOPICS } from './names.js';
import { Navigator } from './navigator.js';
import {
  COLORS, CostmapLayer, GraphLayer, GridLayer, LinesLayer, PathLayer, PoiLayer, RobotMarker,
  ScanLayer, SensorLayer, WaypointLayer, niceStep,
} from './overlays.js';
import { Patrol } from './patrol.js';
import { placementProblem } from './placement.js';
import { Pois } from './pois.js';
import { Recordings, ReplayTimeline } from './recordings.js';
import { RobotActions } from './robotpanel.js';
import { RobotPresence } from './robotpresence.js';
import { RobotState } from './robotstate.js';
import { Shell } from './shell.js';
import { mount } from './slots.js';
import { Stores } from './stores.js';
import { followRole, signedIn } from './signin.js';
import { showStateOnce } from './statenotice.js';
import { Teleop } from './teleop.js';
import { MapTools } from './tools.js';
import { formatPose, yawOf } from './util.js';

function librariesMissing() {
  const missing = [['ROSLIB', 'roslib'], ['ROS2D', 'ros2d'], ['createjs', 'easeljs'],
    ['EventEmitter2', 'eventemitter2']].filter(([global]) => !(global in window));
  if (!missing.length) return false;
  const text = `The console's libraries are missing (${missing.map((m) => m[1]).join(', ')}): ` +
    'run `npm ci --prefix web` in the hitrobot-server checkout.';
  document.getElementById('hint').textContent = text;
  document.body.classList.add('broken');
  showBroken('console libraries missing (npm ci --prefix web)');
  console.error(text);
  return true;
}

/** The map's layers, bottom to top. */
function buildLayers(view) {
  return {
    grid: new GridLayer(view),
    costmap: new CostmapLayer(view),
    graph: new GraphLayer(view),
    tracks: new LinesLayer(view, { color: COLORS.track, width: 3, dash: [8, 5] }),
    walls: new LinesLayer(view, { color: COLORS.wall, width: 3 }),
    path: new PathLayer(view),
    scan: new ScanLayer(view),
    waypoints: new WaypointLayer(view),
    pois: new PoiLayer(view),
    dock: new DockLayer(view),
    sensors: new SensorLayer(view),
  };
}

/** The layers drawn from the robot's topics: walls and tracks, the graph, the dock, the
 * costmap and the planned path (which the navigator measures too; the chosen robot's). */
function subscribeLayers({ ros, stores, layers, editor, navigator, currentRobot }) {
  stores.topic(TOPICS.virtualWalls).subscribe((m) => { layers.walls.set(m); editor.showCounts(); });
  stores.topic(TOPICS.virtualTracks).subscribe((m) => { layers.tracks.set(m); editor.showCounts(); });
  stores.topic(TOPICS.graph).subscribe((g) => layers.graph.set(g));
  stores.topic(TOPICS.home).subscribe((h) => layers.dock.set(h));
  // the costmap overlay is computed from the very /map messages ros2d receives (no second
  // subscription): roslib emits each topic's messages on the Ros object under the topic name
  ros.on(TOPICS.map, (grid) => layers.costmap.set(grid));
  const noPlan = { poses: [] };
  stores.follow(currentRobot, TOPICS.globalPlan,
    (m) => { layers.path.set(m); navigator.plan = m; }, () => layers.path.set(noPlan));
}

/** The chosen robot's pose (into `state.pose`): its marker, the distance to go, where its
 * sensors are drawn, the pose readout, and the view when it follows the robot. */
function followPose({ stores, view, layers, navigator, robot, state, currentRobot }) {
  const poseText = document.getElementById('robot-pose');
  stores.follow(currentRobot, TOPICS.robotPose,
    (pose) => {
      const yaw = yawOf(pose.orientation);
      state.pose = { x: pose.position.x, y: pose.position.y, yaw };
      robot.setPose(state.pose.x, state.pose.y, yaw);
      navigator.robot = state.pose;
      layers.sensors.setPose(state.pose);
      poseText.textContent = `${currentRobot.name || 'robot'} at ${formatPose(state.pose.x, state.pose.y, yaw)}`;
      if (state.follow) view.keepInView(state.pose.x, state.pose.y);
    }, () => { poseText.textContent = `${currentRobot.name} at –`; });
}

/** The chosen robot's laser points, placed with the map→laser transform of the scan's frame
 * published with each scan (same stamp); the robot's pose stands in if no such transform comes. */
function followScan({ stores, layers, state, currentRobot }) {
  const laserPoses = [];
  let pendingScan = null;
  const sameStamp = (a, b) => a && b && a.secs === b.secs && a.nsecs === b.nsecs;
  const frameOf = (id) => (id || '').replace(/^\//, '');
  const drawScan = (scan) => {
    const frame = frameOf(scan.header.frame_id);
    const tf = laserPoses.find((t) => sameStamp(t.stamp, scan.header.stamp) && (!frame || t.frame === frame));
    if (tf) {
      layers.scan.set(scan, tf);
      pendingScan = null;
      return true;
    }
    return false;
  };
  stores.topic(TOPICS.tf).subscribe((msg) => {
    for (const t of msg.transforms || []) {
      if (!/laser/.test(t.child_frame_id || '')) continue;
      const tr = t.transform;
      laserPoses.unshift({ stamp: t.header.stamp, frame: frameOf(t.child_frame_id), x: tr.translation.x,
        y: tr.translation.y, yaw: yawOf(tr.rotation) });
      laserPoses.length = Math.min(laserPoses.length, 16);
      if (pendingScan) drawScan(pendingScan.scan);
    }
  });
  stores.follow(currentRobot, TOPICS.scan,
    (scan) => {
      if (drawScan(scan)) return;
      pendingScan = { scan, at: Date.now() };
      setTimeout(() => {
        if (pendingScan && pendingScan.scan === scan && state.pose) {
          layers.scan.set(scan, state.pose);
          pendingScan = null;
        }
      }, 500);
    }, () => { pendingScan = null; layers.scan.set(null); });
}

/** The side panels. The drive pad, the navigator and the fleet view share the current robot. */
function buildPanels({ ros, stores, view, layers, navigator, currentRobot, marker }) {
  const pois = new Pois({ ros, stores, layer: layers.pois, warning: (x, y) => placementProblem(layers.costmap.grid, x, y) });
  const shell = new Shell({ ros, stores, robot: currentRobot });
  const teleop = new Teleop({ ros, stores, robot: currentRobot });
  const robotState = new RobotState({ stores, robot: currentRobot });
  const robotActions = new RobotActions({ ros, stores, navigator, robot: currentRobot });
  const patrol = new Patrol({ stores, layer: layers.waypoints });
  const maps = new SavedMaps({ ros, stores });
  const diagnostics = new Diagnostics({ stores, sensorLayer: layers.sensors });
  showStateOnce(stores);
  const inspector = new Inspector({ ros });
  const zones = new Zones({ stores, view }); // under the robots; shown with named robots only
  const fleet = new Fleet({ stores, view, robot: currentRobot, marker }); // shown with named robots only
  // the fleet's panels scroll with the others above the Drive pad
  mount('operate', fleet.panel, { first: true });
  mount('operate', zones.panel);
  patrol.onState = (s) => navigator.patrolState(s, () => patrol.call('stop', {}));
  pois.onGo = (poi) => {
    navigator.goToPoi(poi);
    return false; // the navigator publishes it and follows it
  };
  return { pois, shell, teleop, robotState, robotActions, patrol, maps, diagnostics, inspector, fleet, zones };
}

/** Where a robot is sent: a goal, a waypoint or a POI must stand where it fits (placement.js). */
const PLACED = new Set(['goal', 'waypoint', 'poi']);

/** The map tools: what a pick on the map does with each. A goal or a waypoint where the robot
 * cannot stand is refused at once, before anything is sent (it would drive and then abort). */
function buildTools({ view, state, navigator, panels, editor }) {
  const refused = (what, x, y) => {
    const problem = panels.pois.warning(x, y);
    if (!problem) return false;
    if (what === 'goal') navigator.show('rejected', `REFUSED → ${formatPose(x, y, 0)} — ${problem}`);
    log('error', `${what} refused: ${problem}`);
    return true;
  };
  return new MapTools(view, (tool, pick) => {
    const facing = () => (state.pose
      ? Math.atan2(pick.y - state.pose.y, pick.x - state.pose.x) : 0);
    if (tool === 'goal') {
      if (!refused('goal', pick.x, pick.y)) navigator.sendGoal(pick.x, pick.y, pick.yaw ?? facing());
    } else if (tool === 'pose') navigator.setInitialPose(pick.x, pick.y, pick.yaw ?? (state.pose ? state.pose.yaw : 0));
    else if (tool === 'poi') panels.pois.addAt(pick.x, pick.y, pick.yaw ?? 0);
    else if (tool === 'waypoint') {
      if (!refused('waypoint', pick.x, pick.y)) panels.patrol.add(pick.x, pick.y);
    } else editor.pick(tool, pick);
  }, (tool, x, y) => (PLACED.has(tool) ? panels.pois.warning(x, y) : ''));
}

/** On and off line: nothing that sends works while the bridge is down. */
function followBridge({ ros, tools, navigator }) {
  const sending = () => [...document.querySelectorAll('.side button:not([data-tab]):not([data-tool]), .side input, .side select')];
  const setOnline = (on) => {
    tools.setEnabled(on);
    navigator.setOnline(on);
    for (const control of sending()) {
      if (!on) {
        control.dataset.offlineDisabled = String(!control.disabled);
        control.disabled = true;
      } else if (control.dataset.offlineDisabled === 'true') {
        control.disabled = false;
      }
    }
  };
  window.addEventListener('bridge', (e) => setOnline(e.detail.online));
  if (!ros.isConnected) setOnline(false);
}

/** What would drive or change a robot (the view, layers, inspector and whatever is marked
 * data-robotless, such as the recordings panel, keep working). */
const robotControls = () => [...document.querySelectorAll(
  '.side button:not([data-tab]):not([data-tool]), .side input:not([data-layer]), .side select')]
  .filter((c) => !c.closest('[data-tab-panel=inspect], [data-robotless]') && c.id !== 'maps-refresh');

/** No robot behind the bridge (--robot none, or its server gone): say so, and disable
 * everything that would drive or change it. */
function followPresence({ ros, stores, tools, navigator, robotState }) {
  return new RobotPresence({
    ros, stores,
    onChange: (present, seen) => {
      if (present) return;
      tools.setEnabled(false);
      for (const control of robotControls()) control.disabled = true;
      if (document.body.classList.contains('replaying')) return; // followReplay says what this is
      navigator.robotAbsent(seen);
      robotState.setRobot('none', seen ? 'offline' : 'no robot');
      document.getElementById('hint').textContent = seen
        ? 'Robot offline: its server left the bus. The map and pose shown are its last known.'
        : 'No robot: this server runs the bridge alone (--robot none).';
      log(seen ? 'error' : 'info', seen ? 'the robot went offline' : 'no robot behind this bridge');
    },
  });
}

/** A replaying server (`hitrobot-server replay`, recordings.js's timeline): the page says one
 * thing, "Replaying NAME — playing t / T", in the hint, the robot pill and the goal status,
 * where it would say "No robot" (and the recorded "robot connected" is not shown as live). */
function followReplay({ navigator, robotState, tools }) {
  let shown = '';
  window.addEventListener('replay', (e) => {
    const { summary } = e.detail;
    if (summary === shown) return;
    const name = summary.split(' — ')[0];
    if (!shown) {
      log('info', `${name}: a recording, not a live robot`);
      // nothing that would drive a robot works in a replay (Cancel goal included)
      navigator.setReplaying();
      tools.setEnabled(false);
      for (const control of robotControls()) control.disabled = true;
    }
    // the goal box follows the recorded goals; it names the replay where it would say "No robot"
    if (!shown || navigator.statusBox.dataset.status === 'offline') navigator.show('replay', name);
    shown = summary;
    robotState.setRobot('replay', name.replace('Replaying', 'replaying'));
    document.getElementById('hint').textContent = `${summary}. A recording, not a live robot: ` +
      'what would drive a robot is off; the timeline over the map plays, pauses and seeks.';
  });
}

/** The side panel's tabs; the saved maps and the topics are listed when first shown. */
function wireTabs({ maps, inspector }) {
  const tabs = [...document.querySelectorAll('.tabs [data-tab]')];
  const showTab = (name) => {
    for (const t of tabs) t.classList.toggle('active', t.dataset.tab === name);
    for (const panel of document.querySelectorAll('[data-tab-panel]')) panel.hidden = panel.dataset.tabPanel !== name;
    if (name === 'map' && !maps.listed) { maps.listed = true; maps.refresh(); }
    if (name === 'inspect' && !inspector.topics.length) inspector.refresh();
  };
  for (const t of tabs) t.addEventListener('click', () => showTab(t.dataset.tab));
  return showTab;
}

/** The scale bar, kept to a round length as the view zooms. */
function wireScaleBar(view) {
  const scalebar = document.getElementById('scalebar');
  const showScale = () => {
    const mpp = view.metresPerPixel;
    const metres = niceStep(mpp * 90);
    scalebar.querySelector('.bar').style.width = `${metres / mpp}px`;
    scalebar.querySelector('.label').textContent = metres >= 1 ? `${metres} m` : `${Math.round(metres * 100)} cm`;
    scalebar.dataset.metres = String(metres);
  };
  view.addEventListener('view', showScale);
  view.addEventListener('map', showScale);
}

/** The toolbar over the map: follow the robot, zoom, fit, and the layers shown. */
function wireToolbar({ view, layers, tools, state }) {
  const followButton = document.getElementById('follow');
  const setFollow = (on) => {
    state.follow = on;
    followButton.setAttribute('aria-pressed', String(on));
    followButton.classList.toggle('active', on);
    if (on && state.pose) view.centerOn(state.pose.x, state.pose.y);
  };
  followButton.addEventListener('click', () => setFollow(!state.follow));
  document.getElementById('zoom-in').addEventListener('click', () => view.zoomCentre(1.25));
  document.getElementById('zoom-out').addEventListener('click', () => view.zoomCentre(0.8));
  document.getElementById('fit').addEventListener('click', () => view.fit());
  for (const box of document.querySelectorAll('[data-layer]')) {
    const show = () => {
      const names = box.dataset.layer === 'lines' ? ['walls', 'tracks'] : [box.dataset.layer];
      for (const name of names) layers[name].visible = box.checked;
    };
    box.addEventListener('change', show);
    show();
  }
  view.addEventListener('map', (e) => {
    if (e.detail.first) {
      tools.setTool(tools.tool);
      log('info', 'map received');
    }
  });
  // dragging the map by hand stops following
  view.canvas.addEventListener('pointerdown', (e) => {
    if (state.follow && (tools.tool === 'move' || e.button !== 0)) setFollow(false);
  });
}

/** The keyboard shortcuts of the map tools and the view. */
function wireShortcuts({ view, tools }) {
  window.addEventListener('keydown', (e) => {
    const t = e.target;
    if (e.ctrlKey || e.metaKey || e.altKey || dialogOpen() ||
        (t && /^(INPUT|TEXTAREA|SELECT)$/.test(t.tagName))) return;
    const shortcuts = { m: 'move', g: 'goal', p: 'pose', i: 'poi' };
    if (!tools.enabled && shortcuts[e.key]) return;
    if (shortcuts[e.key]) tools.setTool(shortcuts[e.key]);
    else if (e.key === 'f') view.fit();
    else if (e.key === '+' || e.key === '=') view.zoomCentre(1.25);
    else if (e.key === '-') view.zoomCentre(0.8);
    else if (e.key === 'Escape') tools.escape();
  });
}

function main() {
  const ros = connect();
  const stores = new Stores(ros); // every topic the panels share, subscribed once (stores.js)
  const role = followRole(stores); // the badge, and the controls this role lacks disabled
  showFoxgloveUrl();
  const view = new MapView(document.getElementById('map'), ros);
  // record and replay (recordings.js): a timeline over the map, first: the page knows it is a
  // replay's before the recorded topics reach the panels
  const timeline = new ReplayTimeline({ stores, view });
  mount('map', timeline.bar);
  const layers = buildLayers(view);
  const currentRobot = new CurrentRobot(); // on a fleet server, the one the tools act on
  const navigator = new Navigator({ ros, view, robot: currentRobot });
  const robot = new RobotMarker(view);
  const editor = new MapEditor({ ros, view, walls: layers.walls, tracks: layers.tracks });
  subscribeLayers({ ros, stores, layers, editor, navigator, currentRobot });
  const state = { pose: null, follow: false };
  followPose({ stores, view, layers, navigator, robot, state, currentRobot });
  followScan({ stores, layers, state, currentRobot });

  const panels = buildPanels({ ros, stores, view, layers, navigator, currentRobot, marker: robot });
  const tools = buildTools({ view, state, navigator, panels, editor });
  followBridge({ ros, tools, navigator });
  const presence = followPresence({ ros, stores, tools, navigator, robotState: panels.robotState });
  followReplay({ navigator, robotState: panels.robotState, tools });
  const showTab = wireTabs(panels);
  wireScaleBar(view);
  wireToolbar({ view, layers, tools, state });
  wireShortcuts({ view, tools });

  // record and replay (recordings.js): a panel in the Status tab
  const recordings = new Recordings({ stores });
  mount('status', recordings.panel);
  // fleet operations (fleetops.js): the Fleet tab, shown on a server with named robots; the
  // robots' VDA 5050 links (vda5050.js) under them
  const fleetTab = document.getElementById('fleet-tab');
  const fleetops = new FleetOps({ stores, tab: fleetTab });
  const vda5050 = new VdaLinks({ stores, tab: fleetTab });
  mount('fleet', [...fleetops.panels, vda5050.panel]);

  // The page's test interface (and the browser console's), declared once: its connection and
  // stores, the view and its layers, every panel, the tools and the page's state.
  window.hitrobot = { ros, stores, role, view, navigator, ...panels, tools, layers, editor, presence, showTab,
    robot, currentRobot, state, recordings, timeline, fleetops, vda5050,
    libraries: { roslib: ROSLIB.REVISION, ros2d: ROS2D.REVISION, easeljs: createjs.EaselJS && createjs.EaselJS.version } };
}

async function start() {
  if (librariesMissing()) return;
  if (await signedIn()) main(); // else the sign-in box is shown (--authenticate)
}

start();
