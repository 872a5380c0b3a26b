// Every ROS name the console uses, in one place: the topics it subscribes to and publishes on,
// the services it calls and the action it sends goals to. The other modules import these and
// spell no name themselves, so a name the server changes is changed here only.
// A fleet server (`--robot NAME=SPEC`) has each robot's own names under /NAME/ (robotName);
// the fleet's names, and what the bridge itself serves, stay where they are.

/** The Slamware SDK node: most of the robot's own topics are under its name. */
export const SLAMWARE_NODE = '/slamware_ros_sdk_server_node';
const slamware = (name) => `${SLAMWARE_NODE}/${name}`;

export const TOPICS = Object.freeze({
  // the map and what is drawn on it
  map: '/map',
  tf: '/tf',
  robotPose: '/robot_pose',
  scan: slamware('scan'),
  globalPlan: slamware('global_plan_path'),
  graph: '/graph/current',
  home: '/map_manager/home',
  virtualWalls: slamware('virtual_walls'),
  virtualTracks: slamware('virtual_tracks'),
  // driving, navigation and the robot's actions
  cmdVel: '/cmd_vel',
  driveLease: '/drive_lease', // latched: who drives the robot (one driver at a time)
  initialPose: '/initialpose',
  navigateToPoi: '/navigation/navigate_to_poi',
  cancelAction: slamware('cancel_action'),
  goHome: slamware('go_home'),
  recoverLocalization: slamware('recover_localization'),
  odom: slamware('odom'),
  // editing the map
  addLine: slamware('add_line'),
  removeLine: slamware('remove_line'),
  clearLines: slamware('clear_lines'),
  modifyMap: '/map_manager/modify_map',
  mapLayers: '/map_manager/map_layers',
  // points of interest and saved maps
  pois: '/map_manager/pois',
  addPoi: '/map_manager/add_poi',
  modifyPoi: '/map_manager/modify_poi',
  deletePoi: '/map_manager/delete_poi',
  saveMap: '/map_manager/save_map',
  loadedMap: '/map_manager/loaded_map',  // latched: the saved map last loaded, across restarts
  // the robot's state, diagnostics and sensors
  robotBasicState: slamware('robot_basic_state'),
  diagnostics: '/diagnostics_agg',
  sensorsInfo: slamware('basic_sensors_info'),
  sensorsValues: slamware('basic_sensors_values'),
  // the system shell
  shellCommand: '/system_shell/cmd_string',
  systemMode: '/system_shell/system_mode',
  version: '/system_shell/version',
  // patrols, the fleet, record and replay
  patrolState: '/planning/patrol_state',
  fleetRobots: '/fleet/robots',
  fleetTasks: '/fleet/tasks',
  fleetZones: '/fleet/zones',
  recordState: '/record/state',
  recordIncident: '/record/incident',
  replayState: '/replay/state',
  vda5050Link: '/vda5050/link',  // latched: each robot's VDA 5050 link (vda5050.js)
});

/** The message type of each topic, by the same keys as TOPICS (the stores, stores.js, open
 * their subscriptions from these two tables). */
export const TOPIC_TYPES = Object.freeze({
  map: 'nav_msgs/OccupancyGrid',
  tf: 'tf2_msgs/TFMessage',
  robotPose: 'geometry_msgs/Pose',
  scan: 'sensor_msgs/LaserScan',
  globalPlan: 'nav_msgs/Path',
  graph: 'hitrobot_msgs/Graph',
  home: 'geometry_msgs/PoseStamped',
  virtualWalls: 'slamware_ros_sdk/Line2DFlt32Array',
  virtualTracks: 'slamware_ros_sdk/Line2DFlt32Array',
  cmdVel: 'geometry_msgs/Twist',
  driveLease: 'hitrobot_msgs/DriveLease',
  initialPose: 'geometry_msgs/PoseWithCovarianceStamped',
  navigateToPoi: 'map_messages/NavigateToPOI',
  cancelAction: 'slamware_ros_sdk/CancelActionRequest',
  goHome: 'slamware_ros_sdk/GoHomeRequest',
  recoverLocalization: 'slamware_ros_sdk/RecoverLocalizationRequest',
  odom: 'nav_msgs/Odometry',
  addLine: 'slamware_ros_sdk/AddLineRequest',
  removeLine: 'slamware_ros_sdk/RemoveLineRequest',
  clearLines: 'slamware_ros_sdk/ClearLinesRequest',
  modifyMap: 'map_messages/ModifyMap',
  mapLayers: 'map_messages/MapLayers',
  pois: 'map_messages/PointsOfInterest',
  addPoi: 'map_messages/PointOfInterest',
  modifyPoi: 'map_messages/ModifyPOI',
  deletePoi: 'map_messages/DeletePointOfInterest',
  saveMap: 'map_messages/SaveMap',
  loadedMap: 'std_msgs/String',
  robotBasicState: 'slamware_ros_sdk/RobotBasicState',
  diagnostics: 'diagnostic_msgs/DiagnosticArray',
  sensorsInfo: 'slamware_ros_sdk/BasicSensorInfoArray',
  sensorsValues: 'slamware_ros_sdk/BasicSensorValueDataArray',
  shellCommand: 'std_msgs/String',
  systemMode: 'std_msgs/String',
  version: 'std_msgs/String',
  patrolState: 'hitrobot_msgs/PatrolState',
  fleetRobots: 'hitrobot_msgs/FleetRobots',
  fleetTasks: 'hitrobot_msgs/FleetTasks',
  fleetZones: 'hitrobot_msgs/FleetZones',
  recordState: 'hitrobot_msgs/RecordState',
  recordIncident: 'hitrobot_msgs/RecordIncident',
  replayState: 'hitrobot_msgs/ReplayState',
  vda5050Link: 'hitrobot_msgs/VdaLinks',
});

export const SERVICES = Object.freeze({
  rosapiNodes: '/rosapi/nodes',
  whoami: '/hitrobot/whoami', // who this page is signed in as (signin.js)
  listMapFiles: '/list_map_files',
  loadLaserMap: '/load_laser_map',
  setWaypoints: '/planning/set_waypoints',
  clearWaypoints: '/planning/clear_waypoints',
  startPatrol: '/planning/start_patrol',
  stopPatrol: '/planning/stop_patrol',
  resumePatrol: '/planning/resume_patrol',
  fleetDispatch: '/fleet/dispatch',
  fleetCancel: '/fleet/cancel',
  fleetZoneAdd: '/fleet/zone_add',
  fleetZoneRemove: '/fleet/zone_remove',
  // the fleet-operations console (fleetops.js)
  fleetPause: '/fleet/pause',
  fleetResume: '/fleet/resume',
  fleetHistory: '/fleet/history',
  fleetScheduleAdd: '/fleet/schedule_add',
  fleetScheduleList: '/fleet/schedule_list',
  fleetScheduleRemove: '/fleet/schedule_remove',
  fleetSetInService: '/fleet/set_in_service',
  fleetPolicy: '/fleet/policy',
  recordStart: '/record/start',
  recordStop: '/record/stop',
  recordList: '/record/list',
  recordIncidents: '/record/incidents',
  recordSnapshot: '/record/snapshot',
  recordReplay: '/record/replay',
  replayPause: '/replay/pause',
  replayResume: '/replay/resume',
  replaySeek: '/replay/seek',
  replaySetSpeed: '/replay/set_speed',
});

/** The service type of each service, by the same keys as SERVICES (stores.js's call()). */
export const SERVICE_TYPES = Object.freeze({
  rosapiNodes: 'rosapi/Nodes',
  whoami: 'std_srvs/Trigger',
  listMapFiles: 'hitrobot_msgs/ListMapFiles',
  loadLaserMap: 'hitrobot_msgs/LoadLaserMap',
  setWaypoints: 'hitrobot_msgs/SetWaypoints',
  clearWaypoints: 'std_srvs/Trigger',
  startPatrol: 'std_srvs/Trigger',
  stopPatrol: 'std_srvs/Trigger',
  resumePatrol: 'hitrobot_msgs/ResumePatrol',
  fleetDispatch: 'hitrobot_msgs/Dispatch',
  fleetCancel: 'hitrobot_msgs/CancelTask',
  fleetZoneAdd: 'hitrobot_msgs/FleetZoneAdd',
  fleetZoneRemove: 'hitrobot_msgs/FleetZoneRemove',
  fleetPause: 'hitrobot_msgs/CancelTask',
  fleetResume: 'hitrobot_msgs/CancelTask',
  fleetHistory: 'hitrobot_msgs/FleetHistory',
  fleetScheduleAdd: 'hitrobot_msgs/FleetScheduleAdd',
  fleetScheduleList: 'hitrobot_msgs/FleetScheduleList',
  fleetScheduleRemove: 'hitrobot_msgs/CancelTask',
  fleetSetInService: 'hitrobot_msgs/SetInService',
  fleetPolicy: 'hitrobot_msgs/FleetPolicy',
  recordStart: 'hitrobot_msgs/RecordStart',
  recordStop: 'std_srvs/Trigger',
  recordList: 'hitrobot_msgs/ListRecordings',
  recordIncidents: 'hitrobot_msgs/ListIncidents',
  recordSnapshot: 'hitrobot_msgs/RecordSnapshot',
  recordReplay: 'hitrobot_msgs/ReplayRecording',
  replayPause: 'std_srvs/Trigger',
  replayResume: 'std_srvs/Trigger',
  replaySeek: 'hitrobot_msgs/ReplaySeek',
  replaySetSpeed: 'hitrobot_msgs/ReplaySetSpeed',
});

export const ACTIONS = Object.freeze({
  moveBase: '/move_base',
});

/** The action type of each action, by the same keys as ACTIONS. */
export const ACTION_TYPES = Object.freeze({
  moveBase: 'move_base_msgs/MoveBase',
});

/** An action's result topic (actionlib: ACTION/result), where every goal's end is told. */
export const resultTopic = (action) => `${action}/result`;

/** The entries of /diagnostics_agg the console looks for by name. */
export const DIAGNOSTICS = Object.freeze({
  bridgeState: '/Bridge/State', // where the robot's state came from (restored or fresh)
});

/** `name` as robot `robot` of a fleet server has it (/robot/name); `name` itself when no robot
 * is chosen (a single-robot server). */
export function robotName(robot, name) {
  return robot ? `/${robot}${name}` : name;
}
