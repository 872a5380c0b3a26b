// The robot the console's tools act on. On a fleet server (`--robot NAME=SPEC`) the fleet
// panel chooses it, and the panels that act on one robot (the drive pad, the goal and set-pose
// tools, "Go" to a POI) follow it: each re-makes its own topics under /NAME/. On a
// single-robot server none is chosen and the names stay as they are. What the page shows of
// "the robot" (its pose, laser, planned path, state in the top bar, the Navigation panel) is
// read through stores.js's follow(), so it follows the chosen robot too.
/* global ROSLIB */
import { robotName } from './names.js';

export class CurrentRobot {
  constructor() {
    this.name = null; // no robot chosen: a single-robot server
    this.followers = [];
    this.publishers = new Map(); // full topic name → ROSLIB.Topic
  }

  /** Choose robot `name`: every follower hears of it, in the order they started following
   * (nothing happens when it is the robot already chosen). */
  set(name) {
    if (name === this.name) return;
    this.name = name;
    for (const follower of this.followers) follower(name);
  }

  /** Call `follower(name)` whenever another robot is chosen. */
  follow(follower) {
    this.followers.push(follower);
  }

  /** The chosen robot's topic `name` to publish on (made once per robot). */
  publisher(ros, name, messageType) {
    const full = this.nameOf(name);
    if (!this.publishers.has(full)) this.publishers.set(full, new ROSLIB.Topic({ ros, name: full, messageType }));
    return this.publishers.get(full);
  }

  /** `name` as the chosen robot has it. */
  nameOf(name) {
    return robotName(this.name, name);
  }
}
