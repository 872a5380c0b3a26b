// The console's shared data: one store per topic it reads (the robots, the tasks, the POIs, the
// zones, the loaded map, the diagnostics, a robot's drive lease, the VDA 5050 links, …), each
// holding ONE roslib subscription, opened when its first panel subscribes and closed when its
// last one leaves, however many panels show it. A panel subscribes to a store, never to the
// socket: `stores.topic(TOPICS.fleetRobots).subscribe(fn)` calls fn with the latest message at
// once (a panel made late misses nothing) and with every one after. A fleet robot's own form of
// a topic (/NAME/…) is a store of its own; follow() keeps a panel on the chosen robot's.
// And one way to call a service: call(name, request) resolves { reply } or { error }.
/* global ROSLIB */
import {
  ACTION_TYPES, ACTIONS, SERVICE_TYPES, SERVICES, TOPIC_TYPES, TOPICS, resultTopic, robotName,
} from './names.js';

/** How each topic is subscribed, beyond its name and type: the rate its panels need (the
 * fastest of them), a queue of one where only the latest matters. */
const OPTIONS = {
  [TOPICS.fleetRobots]: { throttle_rate: 250 },
  [TOPICS.diagnostics]: { throttle_rate: 500 },
  [TOPICS.robotBasicState]: { throttle_rate: 500 },
  [TOPICS.virtualWalls]: { throttle_rate: 500 },
  [TOPICS.virtualTracks]: { throttle_rate: 500 },
  [TOPICS.robotPose]: { throttle_rate: 100, queue_length: 1 },
  [TOPICS.scan]: { throttle_rate: 200, queue_length: 1 },
  [TOPICS.globalPlan]: { throttle_rate: 200, queue_length: 1 },
  [TOPICS.odom]: { throttle_rate: 200, queue_length: 1 },
  [TOPICS.sensorsValues]: { throttle_rate: 200, queue_length: 1 },
};

/** Every topic's type by its name (names.js's tables), an action's result topic's too. */
const TYPES = new Map([
  ...Object.entries(TOPICS).map(([key, name]) => [name, TOPIC_TYPES[key]]),
  ...Object.entries(ACTIONS).map(([key, name]) => [resultTopic(name), `${ACTION_TYPES[key]}ActionResult`]),
]);
const SERVICE_TYPE = new Map(Object.entries(SERVICES).map(([key, name]) => [name, SERVICE_TYPES[key]]));

/** One topic's messages: one subscription, any number of panels. */
export class Store {
  constructor(ros, name, messageType, options = {}) {
    this.ros = ros;
    this.name = name;
    this.messageType = messageType;
    this.options = options;
    this.listeners = new Set();
    this.topic = null; // the roslib subscription, while a panel listens
    this.value = undefined; // the latest message
  }

  /** Call `fn(message)` with the latest message now (if one came) and each one after; returns
   * a function that stops it (the last panel to leave closes the subscription). */
  subscribe(fn) {
    this.listeners.add(fn);
    if (!this.topic) this.open();
    else if (this.value !== undefined) fn(this.value);
    return () => this.leave(fn);
  }

  /** The latest message (undefined until one came). */
  get() {
    return this.value;
  }

  open() {
    this.topic = new ROSLIB.Topic({ ros: this.ros, name: this.name, messageType: this.messageType, ...this.options });
    this.topic.subscribe((message) => {
      this.value = message;
      for (const fn of [...this.listeners]) fn(message);
    });
  }

  leave(fn) {
    this.listeners.delete(fn);
    if (this.listeners.size || !this.topic) return;
    this.topic.unsubscribe();
    this.topic = null;
    this.value = undefined;
  }
}

/** The page's stores, made on first use, and its service calls. */
export class Stores {
  constructor(ros) {
    this.ros = ros;
    this.stores = new Map(); // full topic name → Store
    this.services = new Map(); // full service name → ROSLIB.Service
  }

  /** The store of topic `name` (one of names.js's), robot `robot`'s own form (/robot/name) when
   * one is given. */
  topic(name, robot = null) {
    const full = robotName(robot, name);
    if (!this.stores.has(full)) {
      const type = TYPES.get(name);
      if (!type) throw new Error(`stores.js: no type for ${name} in names.js`);
      this.stores.set(full, new Store(this.ros, full, type, OPTIONS[name]));
    }
    return this.stores.get(full);
  }

  /** Call `fn` with the messages of the chosen robot's form of topic `name` (`robot`, a
   * CurrentRobot), moving to the next robot's store whenever another is chosen; `onSwitch()`
   * runs at each move, to forget what the last robot sent. The last robot's are dropped. */
  follow(robot, name, fn, onSwitch = () => {}) {
    let leave = null;
    const open = () => {
      if (leave) leave();
      const chosen = robot.name;
      leave = this.topic(name, chosen).subscribe((message) => { if (robot.name === chosen) fn(message); });
    };
    open();
    robot.follow(() => { onSwitch(); open(); });
  }

  /** Call service `name` (one of names.js's; `robot`'s own form when given) with `request`:
   * resolves { reply } or { error } (the server's words, without the prefix roslib gives
   * them). The caller shows an error where its panel shows answers. */
  call(name, request = {}, robot = null) {
    const full = robotName(robot, name);
    if (!this.services.has(full)) {
      const serviceType = SERVICE_TYPE.get(name);
      if (!serviceType) throw new Error(`stores.js: no type for ${name} in names.js`);
      this.services.set(full, new ROSLIB.Service({ ros: this.ros, name: full, serviceType }));
    }
    const service = this.services.get(full);
    return new Promise((resolve) => {
      service.callService(new ROSLIB.ServiceRequest(request), (reply) => resolve({ reply }),
        (error) => resolve({ error: String(error).replace(/^Error: /, '') || 'no answer' }));
    });
  }
}
