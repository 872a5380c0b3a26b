// System commands on /system_shell/cmd_string (std_msgs/String) and the mode indicator from
// /system_shell/system_mode (std_msgs/String: gmapping, navigation, busy); the answer to
// `version` comes latched on /system_shell/version. Reboot and shutdown ask first. On a fleet
// server, those of the robot chosen in the fleet panel (currentrobot.js).
/* global ROSLIB */
import { CurrentRobot } from './currentrobot.js';
import { confirmAction } from './dialogs.js';
import { log } from './log.js';
import { TOPICS } from './names.js';

const MODE_LABELS = { gmapping: 'mapping', navigation: 'navigation', busy: 'switching…' };

export class Shell {
  constructor({ ros, stores, robot = new CurrentRobot() }) {
    this.cmd = () => robot.publisher(ros, TOPICS.shellCommand, 'std_msgs/String');
    this.pill = document.getElementById('mode');
    this.buttons = [...document.querySelectorAll('#shell [data-cmd]')];
    for (const b of this.buttons) b.addEventListener('click', () => this.run(b));
    stores.follow(robot, TOPICS.systemMode, (msg) => this.showMode(msg.data), () => this.showMode(''));
    this.version = document.getElementById('version');
    this.versionAsked = false;
    stores.follow(robot, TOPICS.version, (msg) => this.showVersion(msg.data));
  }

  showVersion(text) {
    this.version.textContent = text;
    if (this.versionAsked) log('info', `version: ${text}`);
    this.versionAsked = false;
  }

  async run(button) {
    const command = button.dataset.cmd;
    if (button.dataset.confirm && !(await confirmAction(button.dataset.confirm, button.textContent))) {
      return;
    }
    this.send(command);
  }

  send(command) {
    if (command === 'version') this.versionAsked = true;
    this.cmd().publish(new ROSLIB.Message({ data: command }));
    log('info', `command sent: ${command}`);
  }

  showMode(mode) {
    const value = String(mode || '').trim();
    if (value === this.pill.dataset.mode) return;
    this.pill.dataset.mode = value || 'unknown';
    this.pill.querySelector('.value').textContent = MODE_LABELS[value] || value || 'unknown';
    for (const b of this.buttons) b.classList.toggle('current', b.dataset.cmd === value);
    if (value) log('info', `system mode: ${MODE_LABELS[value] || value}`);
  }
}
