// System commands on /system_shell/cmd_string (std_msgs/String) and the mode indicator from
// /system_shell/system_mode (std_msgs/String: gmapping, navigation, busy); the answer to
// `version` comes latched on /system_shell/version. Reboot and shutdown ask first.
/* global ROSLIB */
import { confirmAction } from './dialogs.js';
import { log } from './log.js';
import { TOPICS } from './names.js';

const MODE_LABELS = { gmapping: 'mapping', navigation: 'navigation', busy: 'switching…' };

export class Shell {
  constructor({ ros }) {
    this.cmd = new ROSLIB.Topic({ ros, name: TOPICS.shellCommand, messageType: 'std_msgs/String' });
    this.pill = document.getElementById('mode');
    this.buttons = [...document.querySelectorAll('#shell [data-cmd]')];
    for (const b of this.buttons) b.addEventListener('click', () => this.run(b));
    new ROSLIB.Topic({ ros, name: TOPICS.systemMode, messageType: 'std_msgs/String' })
      .subscribe((msg) => this.showMode(msg.data));
    this.version = document.getElementById('version');
    this.versionAsked = false;
    new ROSLIB.Topic({ ros, name: TOPICS.version, messageType: 'std_msgs/String' })
      .subscribe((msg) => this.showVersion(msg.data));
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
    this.cmd.publish(new ROSLIB.Message({ data: command }));
    log('info', `command sent: ${command}`);
  }

  showMode(mode) {
    const value = String(mode || '').trim();
    if (value === this.pill.dataset.mode) return;
    this.pill.dataset.mode = value || 'unknown';
    this.pill.querySelector('.value').textContent = MODE_LABELS[value] || value || 'unknown';
    for (const b of this.buttons) b.classList.toggle('current', b.dataset.cmd === value);
    log('info', `system mode: ${value}`);
  }
}
