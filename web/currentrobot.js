// The robot the console's tools act on. On a fleet server (`--robot NAME=SPEC`) the fleet
// panel chooses it, and the panels that act on one robot (the drive pad, the goal and set-pose
// tools, "Go" to a POI) follow it: each re-makes its own topics under /NAME/. On a
// single-robot server none is chosen and the names stay as they are.
import { robotName } from './names.js';

export class CurrentRobot {
  constructor() {
    this.name = null; // no robot chosen: a single-robot server
    this.followers = [];
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

  /** `name` as the chosen robot has it. */
  nameOf(name) {
    return robotName(this.name, name);
  }
}
